r"""Obstacle avoidance through the null space (Maciejewski & Klein, 1985), Eq. (12), Eq. (13)."""

from __future__ import annotations

import numpy as np

from ...errors import InvalidInput
from ...robot import Robot
from ...tasks import (
    FrameTask,
    Kinematics,
    PerConfiguration,
    pseudoinverse_rate,
    pseudoinverse_workspace,
    undamped_pseudoinverse,
)
from ...tasks.task import identity
from ..options import Option, number
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .options import obstacle as obstacle_option

__all__ = ["ObstacleAvoidance", "activation", "activation_rate"]


def activation(clearance: float, influence: float, critical: float) -> float:
    r"""Maciejewski & Klein's homogeneous-term gain :math:`\alpha_h(d)`: 0 beyond ``influence`` [m],
    1 within ``critical`` [m], a smooth (C¹) cubic step between."""
    if clearance >= influence:
        return 0.0
    if clearance <= critical:
        return 1.0
    s = (influence - clearance) / (influence - critical)
    return s * s * (3.0 - 2.0 * s)


def activation_rate(clearance: float, influence: float, critical: float) -> float:
    r""":math:`\alpha_h'(d)` [1/m] of :func:`activation`: 0 beyond ``influence`` and within ``critical``, and
    :math:`-6s(1 - s)/(d_i - d_c)` between, with :math:`s = (d_i - d)/(d_i - d_c)`."""
    if clearance >= influence or clearance <= critical:
        return 0.0
    s = (influence - clearance) / (influence - critical)
    return -6.0 * s * (1.0 - s) / (influence - critical)


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
    equations = (12, 13)
    needs_redundancy = True
    options = (
        Option(
            name="obstacle",
            kind="ObstacleTask | x,y | x,y,z | x,y,z,radius",
            unit="m",
            default=None,
            meaning="the point or sphere obstacle (centre in world axes, radius)",
            convert=obstacle_option,
            default_text="none (required)",
        ),
        Option(
            name="speed",
            kind="number >= 0",
            unit="m/s",
            default=None,
            meaning="repulsive speed v_o of the closest point, ẋ_o = v_o n̂",
            convert=number(0.0, unit="m/s"),
            default_text="the obstacle task's (0.5)",
        ),
        Option(
            name="influence",
            kind="number > 0",
            unit="m",
            default=0.5,
            meaning="clearance beyond which the obstacle is ignored (α_h = 0)",
            convert=number(0.0, strict=True, unit="m"),
        ),
        Option(
            name="critical",
            kind="number >= 0",
            unit="m",
            default=0.1,
            meaning="clearance within which the avoidance acts fully (α_h = 1); below influence",
            convert=number(0.0, unit="m"),
        ),
        POSITION_GAIN_OPTION,
    )

    def __init__(self, **options):
        super().__init__(**options)
        if not self.critical < self.influence:
            raise InvalidInput(
                f"option critical={self.critical:g} of resolver 'obstacle-avoidance' must be below influence={self.influence:g} [m]"
            )

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if self.obstacle is None:
            raise InvalidInput(
                "resolver 'obstacle-avoidance' needs the option obstacle: an ObstacleTask or x,y[,z[,radius]] [m]"
            )
        self.obstacle.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of Eq. (13) in closed form on a position task (else None: the loop's central difference).

        With :math:`p = J^\dagger c`, :math:`N = I - J^\dagger J`, :math:`B = J_o N`,
        :math:`e = \dot x_o - J_o p` and :math:`\dot\phi = B^\dagger e` (Eq. (12)), the rates are
        :math:`p + \alpha_h\dot\phi` and

        .. math::

            \ddot q = \dot p + \dot\alpha_h\dot\phi + \alpha_h(\dot B^\dagger e + B^\dagger\dot e),\quad
            \dot p = J^\dagger(\dot c - \dot J p) + N\dot J^\top J^{\dagger\top}p,\quad
            \dot e = v_o\dot{\hat n} - \dot J_o p - J_o\dot p,\quad
            \dot B = \dot J_o N - J_o(X + X^\top),\ X = J^\dagger\dot J N,

        from :math:`\frac{d}{dt}J^\dagger = -J^\dagger\dot J J^\dagger + N\dot J^\top(JJ^\top)^{-1}` (J of full row
        rank, :math:`(JJ^\top)^{-1} = J^{\dagger\top}J^\dagger`), so that
        :math:`\dot N = -\frac{d}{dt}(J^\dagger J) = -(X + X^\top)`; :math:`\dot B^\dagger` by
        :func:`~torqueopt.tasks.pseudoinverse_rate` (B of constant rank),
        :math:`\dot\alpha_h = \alpha_h'(d)\,\hat n\cdot v_p`, and the closest point's own velocity :math:`v_p`,
        :math:`\dot{\hat n}`, :math:`\dot J_o` from :meth:`~torqueopt.tasks.ObstacleTask.point_rates`;
        :math:`\dot J` from Pinocchio's Jacobian time variation at (q, q̇). It is the derivative where the closest
        point moves smoothly; at the instant it passes from one segment to another (or onto a segment's end) the
        rates have a kink and this is the derivative on one side of it. The tests hold it to a five-point
        difference of the rates and, run for run, to the loop's central difference.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (13)'s rates and their closed-form q̈ (None for a pose task), sharing what both read at a
        configuration."""
        solver = pseudoinverse_solver(robot, self.singular_tolerance, null_space=False)
        workspace = pseudoinverse_workspace(3, robot.nv)  # of [J_o(I − J⁺J)]⁺, kept for the run
        obstacle, influence, critical = self.obstacle, self.influence, self.critical
        speed = obstacle.speed if self.speed is None else self.speed

        @PerConfiguration
        def at_configuration(kinematics: Kinematics):
            """What Eq. (13) reads at q whatever ẋ: J⁺, σmin/σmax, α_h, and J_o, ẋ_o, [J_o(I − J⁺J)]⁺ where α_h > 0;
            and for q̈ the closest point, I − J⁺J and J_o(I − J⁺J)."""
            jacobian = task.jacobian(kinematics)
            inverse, inverse_condition = solver.pseudoinverse(jacobian)  # Eq. (3) by SVD
            closest = obstacle.closest_point(kinematics)
            gain = activation(closest.clearance, influence, critical)
            projector = identity(robot.nv) - inverse.dot(jacobian)
            if gain == 0.0:
                return inverse, inverse_condition, gain, None, None, None, (closest, projector, None)
            point_jacobian = obstacle.point_jacobian(kinematics, closest)
            projected = point_jacobian.dot(projector)
            projected_inverse = undamped_pseudoinverse(projected, svd=workspace)
            return (
                inverse, inverse_condition, gain, point_jacobian, speed * closest.normal, projected_inverse,
                (closest, projector, projected),
            )  # fmt: skip

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            inverse, inverse_condition, gain, point_jacobian, repulsion, projected_inverse, _ = at_configuration(
                kinematics
            )
            particular = inverse.dot(task_velocity)  # J⁺ẋ
            if gain == 0.0:
                return particular, inverse_condition
            # Eq. (12): φ̇ = [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ), with ẋ_o = v_o n̂
            phi = projected_inverse.dot(repulsion - point_jacobian.dot(particular))
            # Eq. (13): J⁺ẋ + α_h [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ)
            return particular + gain * phi, inverse_condition

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            inverse, _, gain, point_jacobian, repulsion, projected_inverse, configuration = at_configuration(kinematics)
            closest, projector, projected = configuration
            jacobian_rate = task.jacobian_rate(kinematics, velocity)
            particular = inverse.dot(command)
            # d/dt J⁺c, with d/dt J⁺ = −J⁺J̇J⁺ + (I − J⁺J)J̇ᵀ(JJᵀ)⁻¹ for J of full row rank and (JJᵀ)⁻¹ = J⁺ᵀJ⁺
            particular_rate = inverse.dot(command_rate - jacobian_rate.dot(particular)) + projector.dot(
                jacobian_rate.T.dot(inverse.T.dot(particular))
            )
            if gain == 0.0:
                return particular_rate  # beyond the influence α_h and its rate are 0
            point_velocity, normal_rate, point_jacobian_rate = obstacle.point_rates(kinematics, closest, velocity)
            gain_rate = activation_rate(closest.clearance, influence, critical) * float(
                closest.normal.dot(point_velocity)
            )
            # Ḃ = J̇_o N + J_o Ṅ, with Ṅ = −d/dt(J⁺J) = −(X + Xᵀ), X = J⁺J̇N, from the same d/dt J⁺
            turn = inverse.dot(jacobian_rate.dot(projector))
            projected_rate = point_jacobian_rate.dot(projector) - point_jacobian.dot(turn + turn.T)
            projected_inverse_rate = pseudoinverse_rate(projected, projected_rate, projected_inverse)
            shortfall = repulsion - point_jacobian.dot(particular)  # e of Eq. (12)
            shortfall_rate = (
                speed * normal_rate - point_jacobian_rate.dot(particular) - point_jacobian.dot(particular_rate)
            )
            phi = projected_inverse.dot(shortfall)  # Eq. (12)
            phi_rate = projected_inverse_rate.dot(shortfall) + projected_inverse.dot(shortfall_rate)
            # d/dt of Eq. (13)
            return particular_rate + gain_rate * phi + gain * phi_rate

        return rates, acceleration if task.kind != "pose" else None
