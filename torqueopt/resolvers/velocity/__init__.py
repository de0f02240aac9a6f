"""Velocity-level (kinematic) resolvers: the methods of Section 1.1 of the paper.

======================= =============================================================================
name                    method (equations of the paper)
======================= =============================================================================
``velocity-pinv``       resolved rate with the pseudoinverse, Eq. (1), Eq. (2), Eq. (3)
``gradient-projection`` Liégeois's gradient projection, Eq. (4), criteria Eq. (5), Eq. (6)
``task-priority``       Hanafusa, Yoshikawa & Nakamura, Eq. (7), Eq. (8), Eq. (9), Eq. (10), Eq. (11)
``obstacle-avoidance``  Maciejewski & Klein, Eq. (12), Eq. (13)
``extended-jacobian``   Baillieul, Eq. (14), Eq. (15), n − m = 1
``kinetic-energy-pinv`` weighted pseudoinverse with W = H, Eq. (16), Eq. (17)
======================= =============================================================================
"""

from .base import VelocityResolver, VelocityStack
from .criteria import (
    CallableCriterion,
    Criterion,
    JointLimits,
    Manipulability,
    PostureDistance,
    criterion_from,
    manipulability,
)
from .extended_jacobian import (
    ExtendedJacobian,
    null_vector,
    signed_cofactors,
    signed_cofactors_rate,
)
from .gradient_projection import GradientProjection
from .obstacle_avoidance import ObstacleAvoidance
from .pseudoinverse import KineticEnergyPseudoInverse, VelocityPseudoInverse
from .task_priority import TaskPriority

__all__ = [
    "VelocityResolver",
    "VelocityStack",
    "VelocityPseudoInverse",
    "GradientProjection",
    "TaskPriority",
    "ObstacleAvoidance",
    "ExtendedJacobian",
    "KineticEnergyPseudoInverse",
    "Criterion",
    "JointLimits",
    "Manipulability",
    "PostureDistance",
    "CallableCriterion",
    "criterion_from",
    "manipulability",
    "null_vector",
    "signed_cofactors",
    "signed_cofactors_rate",
    "VELOCITY_RESOLVERS",
]

VELOCITY_RESOLVERS = (
    VelocityPseudoInverse,
    GradientProjection,
    TaskPriority,
    ObstacleAvoidance,
    ExtendedJacobian,
    KineticEnergyPseudoInverse,
)
