r"""Gradient projection (Liégeois, 1977), Eq. (4) of the paper."""

from __future__ import annotations

import numpy as np

from ...robot import Robot
from ...tasks import FrameTask, Kinematics
from ..options import Option, number
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import criterion_from
from .options import criterion_spec

__all__ = ["GradientProjection", "CriterionGain", "CRITERION_OPTION", "DEFAULT_GAINS", "gain_option"]

#: Default gain k per named criterion, chosen on the paper's long movement
#: (see docs/discussion/kinematic.md, "Kinematic against kinetic resolution").
DEFAULT_GAINS = {"joint-limits": 10.0, "manipulability": 1.0}


#: The criterion p(q) of both gradient-projection resolvers (velocity and acceleration level).
CRITERION_OPTION = Option(
    name="criterion",
    kind="'joint-limits' | 'manipulability' | callable p(joint_angles)",
    unit="",
    default="joint-limits",
    meaning="the criterion p to minimise: Eq. (5), or p = −w of Eq. (6), or your own",
    convert=criterion_spec,
)


def gain_option(unit: str, meaning: str) -> Option:
    """The gain k of a gradient term, in ``unit``; its default depends on the criterion (:data:`DEFAULT_GAINS`)."""
    return Option(
        name="k",
        kind="number >= 0",
        unit=unit,
        default=None,
        meaning=meaning,
        convert=number(0.0),
        default_text="10 for joint-limits, 1 for manipulability and callables",
    )


class CriterionGain:
    """For resolvers with the options ``criterion`` and ``k``: the criterion object and its gain.

    Sets ``objective`` (a :class:`Criterion`) and ``gain`` (``k``, or the
    criterion's default gain), and checks the criterion against the robot.
    """

    def __init__(self, **options):
        super().__init__(**options)
        self.objective = criterion_from(self.criterion)
        self.gain = DEFAULT_GAINS.get(getattr(self.objective, "name", ""), 1.0) if self.k is None else self.k

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.objective.check(robot)


class GradientProjection(CriterionGain, VelocityResolver):
    r"""Resolved rate plus the projected gradient of a criterion p(q), Eq. (4).

    .. math::

        \dot q = J^\dagger \dot x - k\,(I - J^\dagger J)\,\frac{\partial p}{\partial q}

    Eq. (4) with its arbitrary constant equal to −k, so that k > 0 descends p:
    the self-motion lowers p at the rate
    :math:`\dot p = -k\,\|Z^\top \partial p/\partial q\|^2` while the task is
    realised exactly.

    Args:
        criterion: ``joint-limits`` (Eq. (5)), ``manipulability`` (p = −w,
            Eq. (6)), a :class:`Criterion`, or a callable ``p(joint_angles)``
            (gradient by central differences).
        k: gain [rad²/s per unit of p]; defaults to 10 for ``joint-limits``
            and 1 for ``manipulability`` and callables.
    """

    name = "gradient-projection"
    equations = (4, 5, 6)
    needs_redundancy = True
    options = (
        CRITERION_OPTION,
        gain_option("rad²/s per unit of p", "gain of the projected gradient, q̇ = J⁺ẋ − k(I − J⁺J)∂p/∂q"),
        POSITION_GAIN_OPTION,
    )

    def rate_function(self, robot: Robot, task: FrameTask):
        decompose = pseudoinverse_solver(robot, self.singular_tolerance)
        criterion, k = self.objective, self.gain

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            particular, basis, inverse_condition = decompose(task.jacobian(kinematics), task_velocity)
            gradient = criterion.gradient(kinematics, task)
            # Eq. (4): J⁺ẋ + (I − J⁺J) k' ∂g/∂θ with k' = −k, and I − J⁺J = Z Zᵀ
            return particular - k * basis.dot(basis.T.dot(gradient)), inverse_condition

        return rates
