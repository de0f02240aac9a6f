"""The Pinocchio plant: the controller's own model, classical RK4 with the torque held over the step."""

from __future__ import annotations

import numpy as np

from ..integrators import RK4, HeldTorque
from .base import register_plant

__all__ = ["PinocchioPlant"]


@register_plant("pinocchio")
class PinocchioPlant:
    """The robot's own Pinocchio model as the plant: :class:`~torqueopt.integrators.RK4` of
    :class:`~torqueopt.integrators.HeldTorque`, for one movement and for stacks.

    The resolver's joint acceleration, ABA(q, v, τ) on this very model, is
    RK4's first stage when the caller gives it (``acceleration``), which
    saves one ABA per step.

    Args:
        data: the Pinocchio data a movement's steps compute in (fresh when
            None); one plant per run, so runs in threads never share one.
        threads: OpenMP threads of ``abaInParallel`` for stacks.
    """

    def __init__(self, robot, data=None, threads: int = 1):
        self.robot = robot
        self.system = HeldTorque(robot, data, threads)
        self._dt = None
        self._one = self._stack = None

    def reset(self, dt: float | None = None) -> None:
        """Make the steppers for the control step dt [s]; nothing else to forget."""
        if dt is not None and dt != self._dt:
            self._dt = dt
            # One state's step as a bare function (one call per step); stacks' rebuilt as the batch shrinks.
            self._one, self._stack = RK4(self.system, dt).stepper((self.robot.nq,)), RK4(self.system, dt).step

    def step(self, q, v, tau, dt: float, acceleration=None) -> tuple[np.ndarray, np.ndarray]:
        """One RK4 step of dt [s] with tau [N·m] held; ``acceleration`` is ABA(q, v, tau) when known."""
        if dt != self._dt:
            self.reset(dt)
        if acceleration is None:
            acceleration = self.robot.forward_dynamics(q, v, tau, data=self.system.data)
        return self._one(q, v, tau, acceleration)

    def step_stack(self, q, v, tau, dt: float, acceleration=None, movements=None) -> tuple[np.ndarray, np.ndarray]:
        """The RK4 step on (B, ...) stacks, the later stages of the whole stack by one ``abaInParallel`` each."""
        if dt != self._dt:
            self.reset(dt)
        if acceleration is None:
            acceleration = self.system.derivative(True)(q, v, tau)
        return self._stack(q, v, tau, acceleration)

    def record(self, movement: int | None = None) -> dict:
        """The plant as the run file keeps it."""
        return {"name": "pinocchio", "integrator": "rk4", "torque": "held over each step"}
