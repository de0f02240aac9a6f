r"""Gradient projection (Liégeois, 1977), Eq. (4) of the paper."""

from __future__ import annotations

import numpy as np

from ...errors import InvalidInput
from ...linalg import DEFAULT_SINGULAR_TOLERANCE
from ...robot import Robot
from ...tasks import FrameTask, Kinematics
from .base import VelocityResolver, pseudoinverse_solver
from .criteria import criterion_from

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

    def __init__(self, criterion="joint-limits", k: float | None = None, position_gain: float = 0.0, singular_tolerance: float = DEFAULT_SINGULAR_TOLERANCE):
        super().__init__(position_gain, singular_tolerance)
        self.criterion = criterion_from(criterion)
        k = DEFAULT_GAINS.get(getattr(self.criterion, "name", ""), 1.0) if k is None else k
        try:
            k = float(k)
        except (TypeError, ValueError):
            raise InvalidInput(f"gradient-projection gain k={k!r} is not a number") from None
        if not (np.isfinite(k) and k >= 0):
            raise InvalidInput(f"gradient-projection gain k={k!r} must be a finite number >= 0")
        self.k = k

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.criterion.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        decompose = pseudoinverse_solver(robot, self.singular_tolerance)
        criterion, k = self.criterion, self.k

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            particular, basis, condition = decompose(task.jacobian(kinematics), task_velocity)
            gradient = criterion.gradient(kinematics, task)
            # Eq. (4): J⁺ẋ + (I − J⁺J) k' ∂g/∂θ with k' = −k, and I − J⁺J = Z Zᵀ
            return particular - k * basis.dot(basis.T.dot(gradient)), condition

        return rates
