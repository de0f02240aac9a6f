r"""Gradient projection (Liégeois, 1977), Eq. (4) of the paper."""

from __future__ import annotations

import numpy as np

from ...robot import Robot
from ...tasks import FrameTask, Kinematics
from ..options import Option, number
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import criterion_from
from .options import criterion_spec

__all__ = ["GradientProjection", "DEFAULT_GAINS"]

#: Default gain k per named criterion, chosen on the paper's long movement
#: (see the README section "Kinematic against kinetic resolution").
DEFAULT_GAINS = {"joint-limits": 10.0, "manipulability": 1.0}


class GradientProjection(VelocityResolver):
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
    needs_redundancy = True
    options = (
        Option(
            name="criterion",
            kind="'joint-limits' | 'manipulability' | callable p(joint_angles)",
            unit="",
            default="joint-limits",
            meaning="the criterion p to minimise: Eq. (5), or p = −w of Eq. (6), or your own",
            convert=criterion_spec,
        ),
        Option(
            name="k",
            kind="number >= 0",
            unit="rad²/s per unit of p",
            default=None,
            meaning="gain of the projected gradient, q̇ = J⁺ẋ − k(I − J⁺J)∂p/∂q",
            convert=number(0.0),
            default_text="10 for joint-limits, 1 for manipulability and callables",
        ),
        POSITION_GAIN_OPTION,
    )

    def __init__(self, **options):
        super().__init__(**options)
        self.objective = criterion_from(self.criterion)
        self.gain = DEFAULT_GAINS.get(getattr(self.objective, "name", ""), 1.0) if self.k is None else self.k

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.objective.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        decompose = pseudoinverse_solver(robot, self.singular_tolerance)
        criterion, k = self.objective, self.gain

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            particular, basis, condition = decompose(task.jacobian(kinematics), task_velocity)
            gradient = criterion.gradient(kinematics, task)
            # Eq. (4): J⁺ẋ + (I − J⁺J) k' ∂g/∂θ with k' = −k, and I − J⁺J = Z Zᵀ
            return particular - k * basis.dot(basis.T.dot(gradient)), condition

        return rates
