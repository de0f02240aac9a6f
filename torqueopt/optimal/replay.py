r"""Open-loop replay of given torques through the simulation's RK4 stepper.

The torque :math:`\tau_j` is held over :math:`[t_j, t_j + \Delta t]` and the
forward dynamics (Pinocchio's ABA) are integrated by the same classical RK4
step as :func:`torqueopt.simulate` (:func:`torqueopt.integrators.rk4_stepper`,
not a second RK4 loop), without any feedback: what a robot would do if the
torques were played back to it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..integrators import rk4_stepper
from ..robot import Robot

__all__ = ["Replay", "replay_torques"]


class Replay(NamedTuple):
    """The replayed motion, one row per grid time t_0 .. t_M.

    Attributes:
        q: configurations, (M+1, nq). v: joint velocities [rad/s], (M+1, n).
        tip: task-frame origin in the world [m], (M+1, 3).
        completed: False when the state stopped being finite (rows after it are NaN).
    """

    q: np.ndarray
    v: np.ndarray
    tip: np.ndarray
    completed: bool


def replay_torques(robot: Robot, q0, v0, torques, dt: float) -> Replay:
    """Integrate ``torques`` (M×n, each held for ``dt`` [s]) from (q0, v0), open loop."""
    torques = np.asarray(torques, float)
    steps = len(torques)
    data = robot.model.createData()
    advance = rk4_stepper(robot, dt, data)
    forward_dynamics = robot.forward_dynamics_function(data)
    q_rows = np.full((steps + 1, robot.nq), np.nan)
    v_rows = np.full((steps + 1, robot.nv), np.nan)
    q, v = np.array(q0, float), np.array(v0, float)
    q_rows[0], v_rows[0] = q, v
    completed = True
    for j, tau in enumerate(torques):
        q, v = advance(q, v, tau, forward_dynamics(q, v, tau))
        if not (np.isfinite(q).all() and np.isfinite(v).all()):
            completed = False
            break
        q_rows[j + 1], v_rows[j + 1] = q, v
    tip = np.full((steps + 1, 3), np.nan)
    for j in range(steps + 1):
        if np.isfinite(q_rows[j]).all():
            tip[j] = robot.frame_placement(q_rows[j], data).translation
    return Replay(q_rows, v_rows, tip, completed)
