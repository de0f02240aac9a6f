r"""Acceleration-level forms of the Section 1.1 methods, as torque resolvers.

Differentiating Eq. (2) gives the acceleration-level resolution the
literature uses to put the kinematic methods into the dynamics (De Luca,
Oriolo & Siciliano 1992; Hsu, Hauser & Sastry 1989):

.. math::

    \ddot q = J^\dagger(\ddot x - \dot J\dot q) + (I - J^\dagger J)\,\ddot\phi,
    \qquad \tau = H\ddot q + \dot q\cdot C\cdot\dot q + g \quad\text{Eq. (26), Eq. (20)},

with a null-space acceleration :math:`\ddot\phi` that, unlike Eq. (2)'s
velocity, must also damp the self-motion it builds up, since nothing else
does at this level.

``gradient-projection-acceleration``
    :math:`\ddot\phi = -k\,\partial p/\partial q - k_d\dot q`: Liégeois's
    gradient (Eq. (4), criteria Eq. (5), Eq. (6)) as a null-space acceleration,
    with self-motion damping :math:`k_d` [1/s].
``task-priority-acceleration``
    Eq. (11) at the acceleration level: the lower-priority task's
    acceleration :math:`\ddot x_l = k_p(x_l^* - x_l) - k_d\dot x_l` is
    realised, as far as the null space of the robot's task allows, by
    :math:`\ddot\phi = [J_l Z]^\dagger(\ddot x_l - \dot J_l\dot q - J_l J^\dagger(\ddot x - \dot J\dot q))`,
    in the coordinates of an orthonormal null-space basis Z.

The inertia-weighted acceleration form of ``kinetic-energy-pinv`` (Eq. (16),
W = H) is Khatib's Eq. (19), the existing ``inertia-pinv``. Both resolvers
here realise the robot's task exactly.
"""

from __future__ import annotations

import numpy as np

from ..robot import Robot, TaskTerms
from ..tasks import FrameTask, Kinematics, PostureTask, TaskStack, pseudoinverse
from .base import NullSpaceFunction, NullSpaceResolver
from .options import LARGEST_WEIGHT, Option, number
from .registry import register_resolver
from .velocity.gradient_projection import CRITERION_OPTION, CriterionGain, gain_option
from .velocity.options import task_stack

__all__ = ["GradientProjectionAcceleration", "TaskPriorityAcceleration"]

_DAMPING = Option(
    name="damping",
    kind="number in [0, 1e6]",
    unit="1/s",
    default=5.0,
    meaning="self-motion damping k_d: the null-space acceleration includes −k_d q̇",
    convert=number(0.0, unit="1/s", maximum=LARGEST_WEIGHT),
)


@register_resolver
class GradientProjectionAcceleration(CriterionGain, NullSpaceResolver):
    r"""Gradient projection at the acceleration level: q̈ = J⁺(ẍ − J̇q̇) − (I − J⁺J)(k ∂p/∂q + k_d q̇).

    The acceleration-level twin of ``gradient-projection`` (Eq. (4)); p is
    ``joint-limits`` (Eq. (5)), ``manipulability`` (p = −w, Eq. (6)) or a
    callable, its gradient from Pinocchio as there. In null-space coordinates
    :math:`y = -Z^\top(k\,\partial p/\partial q + k_d\dot q)`.
    """

    name = "gradient-projection-acceleration"
    equations = (4, 5, 6)
    needs_redundancy = True
    options = (
        CRITERION_OPTION,
        gain_option("rad²/s² per unit of p", "gain of the gradient acceleration −k ∂p/∂q"),
        _DAMPING,
    )

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        kinematics = Kinematics(robot)
        task = FrameTask.of_robot(robot)
        criterion, k, damping = self.objective, self.gain, self.damping

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            kinematics.update(terms.configuration)
            gradient = criterion.gradient(kinematics, task)
            # Eq. (4) as a null-space acceleration, with the self-motion damped
            return -null_space_basis.T.dot(k * gradient + damping * terms.joint_velocity)

        return coordinates


@register_resolver
class TaskPriorityAcceleration(NullSpaceResolver):
    r"""Task priority at the acceleration level (Eq. (11) differentiated): the robot's task exactly, a lower one in its null space.

    The lower-priority task (a Task with a target; a posture task toward
    the robot's default configuration when none is given) is driven by
    :math:`\ddot x_l = k_p(x_l^* - x_l) - k_d J_l\dot q`, realised in the
    least-squares sense within the null space of J.
    """

    name = "task-priority-acceleration"
    equations = (11,)
    needs_redundancy = True
    options = (
        Option(
            name="secondary",
            kind="Task | FRAME:x,y[,z] | 'posture'",
            unit="m",
            default=None,
            meaning="the lower-priority task, driven to its target",
            convert=task_stack,
            default_text="posture: every joint toward the robot's default configuration",
        ),
        Option(
            name="stiffness",
            kind="number >= 0",
            unit="1/s²",
            default=25.0,
            meaning="k_p of the lower task's acceleration k_p(x* − x) − k_d ẋ",
            convert=number(0.0, unit="1/s²"),
        ),
        Option(
            name="damping",
            kind="number in [0, 1e6]",
            unit="1/s",
            default=10.0,
            meaning="k_d of the lower task's acceleration (10 with k_p = 25: critically damped)",
            convert=number(0.0, unit="1/s", maximum=LARGEST_WEIGHT),
        ),
    )

    def __init__(self, **options):
        super().__init__(**options)
        self.stack = TaskStack([PostureTask()]) if self.secondary is None else self.secondary

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.stack.check(robot)

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        self.stack.check(robot)
        kinematics = Kinematics(robot)
        tasks = list(self.stack)
        stiffness, damping = self.stiffness, self.damping

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            kinematics.update(terms.configuration, terms.joint_velocity)
            jacobians, accelerations = [], []
            for lower in tasks:
                jacobian = lower.jacobian(kinematics)
                desired = stiffness * lower.error(kinematics) - damping * jacobian.dot(terms.joint_velocity)
                jacobians.append(jacobian)
                # the lower task's acceleration left after the particular solution: ẍ_l − J̇_l q̇ − J_l J⁺(ẍ − J̇q̇)
                accelerations.append(desired - lower.drift(kinematics) - jacobian.dot(particular))
            stacked = np.vstack(jacobians)
            # Eq. (11) in the null-space coordinates: [J_l Z]⁺(...)
            return pseudoinverse(stacked.dot(null_space_basis)).dot(np.concatenate(accelerations))

        return coordinates
