"""The Pinocchio plant: the controller's own model, classical RK4 with the torque held over the step."""

from __future__ import annotations

import numpy as np

from ..integrators import rk4_stepper

__all__ = ["PinocchioPlant"]


class PinocchioPlant:
    """The robot's own Pinocchio model as the plant: :func:`torqueopt.integrators.rk4_stepper` per step.

    This is what :func:`torqueopt.simulate` always did; it takes the
    resolver's joint acceleration as RK4's first stage when it has it
    (``acceleration``), which saves one ABA per step.
    """

    name = "pinocchio"

    def __init__(self, robot):
        self.robot = robot
        self._steppers = {}
        self._data = robot.model.createData()

    def reset(self, dt: float | None = None) -> None:
        """Nothing to forget: the Pinocchio plant keeps no record of a run."""

    def step(self, q, v, tau, dt: float, acceleration=None) -> tuple[np.ndarray, np.ndarray]:
        """One RK4 step of dt [s] with tau [N·m] held; ``acceleration`` is ABA(q, v, tau) when known."""
        stepper = self._steppers.get(dt)
        if stepper is None:
            stepper = self._steppers[dt] = rk4_stepper(self.robot, dt, self._data)
        if acceleration is None:
            acceleration = self.robot.forward_dynamics(q, v, tau, data=self._data)
        return stepper(q, v, tau, acceleration)

    def record(self) -> dict:
        """The plant as the run file keeps it."""
        return {"name": "pinocchio", "integrator": "rk4", "torque": "held over each step"}
