r"""Obstacle avoidance through the null space (Maciejewski & Klein, 1985), Eqs. (12)-(13)."""

from __future__ import annotations

import numpy as np

from ...errors import InvalidInput
from ...linalg import DEFAULT_SINGULAR_TOLERANCE
from ...robot import Robot
from ...tasks import FrameTask, Kinematics, ObstacleTask, pseudoinverse
from .base import VelocityResolver, pseudoinverse_solver

__all__ = ["ObstacleAvoidance", "activation"]


def activation(clearance: float, influence: float, critical: float) -> float:
    r"""Maciejewski & Klein's homogeneous-term gain :math:`\alpha_h(d)`: 0 beyond ``influence`` [m],
    1 within ``critical`` [m], a smooth (C¹) cubic step between."""
    if clearance >= influence:
        return 0.0
    if clearance <= critical:
        return 1.0
    s = (influence - clearance) / (influence - critical)
    return s * s * (3.0 - 2.0 * s)


class ObstacleAvoidance(VelocityResolver):
    r"""Resolved rate that moves the arm's closest point away from an obstacle, Eq. (13).

    .. math::

        \dot q = J^\dagger\dot x + \alpha_h(d)\,[J_o(I - J^\dagger J)]^\dagger(\dot x_o - J_o J^\dagger \dot x)

    where :math:`x_o` is the point of the arm closest to the obstacle,
    :math:`J_o` its Jacobian, :math:`\dot x_o = v_o \hat n` the repulsive
    velocity along the outward normal (:class:`torqueopt.tasks.ObstacleTask`),
    and :math:`\alpha_h(d)` (Maciejewski & Klein's gain on the homogeneous
    solution) switches the term on smoothly as the clearance d falls below
    ``influence``. Eq. (12) is the null-space vector
    :math:`\dot\phi = [J_o(I - J^\dagger J)]^\dagger(\dot x_o - J_o J^\dagger\dot x)`.

    Args:
        obstacle: an ObstacleTask, or numbers (x, y), (x, y, z) or (x, y, z, radius) [m].
        speed: repulsive speed :math:`v_o` [m/s]; the obstacle task's own by default.
        influence: clearance [m] beyond which the obstacle is ignored.
        critical: clearance [m] within which the avoidance acts fully.
    """

    name = "obstacle-avoidance"
    needs_redundancy = True

    def __init__(
        self,
        obstacle=None,
        speed: float | None = None,
        influence: float = 0.5,
        critical: float = 0.1,
        position_gain: float = 0.0,
        singular_tolerance: float = DEFAULT_SINGULAR_TOLERANCE,
    ):
        super().__init__(position_gain, singular_tolerance)
        if obstacle is None:
            raise InvalidInput("resolver 'obstacle-avoidance' needs obstacle= an ObstacleTask or x,y[,z[,radius]] [m]")
        self.obstacle = ObstacleTask.from_spec(obstacle)
        if speed is not None:
            self.obstacle = ObstacleTask(self.obstacle.center, self.obstacle.radius, speed=speed, frame=self.obstacle.frame)
        influence, critical = float(influence), float(critical)
        if not (np.isfinite(influence) and np.isfinite(critical) and 0 <= critical < influence):
            raise InvalidInput(f"need 0 <= critical < influence [m], got critical={critical!r}, influence={influence!r}")
        self.influence, self.critical = influence, critical

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.obstacle.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        decompose = pseudoinverse_solver(robot, self.singular_tolerance)
        obstacle, influence, critical = self.obstacle, self.influence, self.critical

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            particular, basis, condition = decompose(task.jacobian(kinematics), task_velocity)
            closest = obstacle.closest_point(kinematics)
            gain = activation(closest.clearance, influence, critical)
            if gain == 0.0:
                return particular, condition
            point_jacobian = obstacle.point_jacobian(kinematics, closest)
            repulsion = obstacle.speed * closest.normal  # ẋ_o
            # Eq. (12): φ̇ = [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ), with I − J⁺J = Z Zᵀ
            projector = basis.dot(basis.T)
            phi = pseudoinverse(point_jacobian.dot(projector)).dot(repulsion - point_jacobian.dot(particular))
            # Eq. (13): J⁺ẋ + α_h [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ)
            return particular + gain * phi, condition

        return rates
