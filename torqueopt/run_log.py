"""A run's log and the :class:`~torqueopt.result.SimResult` made from it, shared by every simulation loop.

The held-torque loop (:func:`torqueopt.simulate`) and the kinematic loop
(:func:`torqueopt.kinematic.simulate_kinematic`) log one tuple
(q, v, q̈, τ, x, σmin/σmax) per step; :func:`run_result` turns the log into
the run's result, with the reference of :func:`task_reference` on the same
grid. :func:`logged_row_bytes` is what one logged step costs in
memory, for the step budget checked before a run starts.
:func:`torque_stop_reason` and :func:`speed_stop_reason` word why a run
stopped, the same for every loop (``simulate``, the batch, the kinematic
loop's torque stop).
"""

from __future__ import annotations

import sys

import numpy as np

from .dexterity import dexterity_along
from .result import SimResult, joint_limits_record
from .robot import Robot
from .trajectory import Trajectory, describe

__all__ = [
    "log_columns",
    "logged_row_bytes",
    "run_result",
    "speed_stop_reason",
    "stop_ceilings",
    "task_reference",
    "torque_stop_reason",
]


def run_result(
    robot: Robot,
    resolver,
    log: list[tuple],
    times: np.ndarray,
    reference_position: np.ndarray,
    *,
    dt: float,
    duration: float,
    stop_reason: str | None,
    stop_time: float | None,
    trajectory,
    task_error: np.ndarray,
    infeasible: np.ndarray,
    dexterity: bool,
    limiting: dict[int, str] | None = None,
    plant: dict | None = None,
) -> SimResult:
    """The :class:`SimResult` of a run from its per-step ``log`` of (q, v, q̈, τ, x, σmin/σmax) tuples.

    ``times`` and ``reference_position`` are the run's whole grid and
    reference; the result keeps their first ``len(log)`` rows. ``limiting``: per
    infeasible row, the bounds its answer lay on (a bounded resolver's ``Resolution.limiting``). Every loop
    (held-torque and kinematic) builds its result here.
    """
    recorded = len(log)
    n = robot.nv
    q_log, v_log, acceleration_log, torque_log, x_log, inverse_condition_log = log_columns(
        log, (robot.nq, n, n, n, robot.m)
    )
    return SimResult(
        robot=robot.name,
        frame=robot.frame,
        task=robot.task,
        resolver=resolver.name,
        resolver_options=resolver.settings_for_file(),
        joint_names=list(robot.joint_names),
        dt=dt,
        t=times[:recorded].copy(),
        q=q_log,
        joint_angles=robot.joint_angles(q_log).reshape(recorded, n),
        v=v_log,
        acceleration=acceleration_log,
        tau=torque_log,
        x=x_log,
        x_ref=reference_position[:recorded].copy(),
        jacobian_inverse_condition=inverse_condition_log,
        torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(),
        duration=duration,
        stop_reason=stop_reason,
        stop_time=stop_time,
        trajectory=describe(trajectory),
        task_error=task_error,
        infeasible=infeasible,
        limiting=limiting or None,
        dexterity=dexterity_along(robot, q_log) if dexterity else None,
        joint_limits=joint_limits_record(*robot.joint_limits),
        plant=plant,
    )


def task_reference(robot: Robot, trajectory: Trajectory, times: np.ndarray):
    """The trajectory's samples embedded in the task coordinates (zero orientation rows for ``pose``)."""
    sample = trajectory.sample(times)
    if robot.task != "pose":
        return sample
    pad = np.zeros((times.size, 3))
    return type(sample)(
        position=np.hstack([sample.position, pad]),
        velocity=np.hstack([sample.velocity, pad]),
        acceleration=np.hstack([sample.acceleration, pad]),
    )


def logged_row_bytes(robot: Robot) -> int:
    """Memory one recorded step takes while a run is logged [bytes]: six arrays, their headers and a tuple."""
    floats = robot.nq + 3 * robot.nv + robot.m + 2
    return 8 * floats + 6 * 112 + 96


def log_columns(log: list[tuple], sizes: tuple[int, ...]) -> list[np.ndarray]:
    """The per-step tuples of ``log`` as arrays: one (steps × size) array per vector field, then the trailing float.

    Each vector field is joined by one ``concatenate`` (cheaper per row than
    ``np.array`` of a list of arrays).
    """
    if not log:
        return [*(np.empty((0, size)) for size in sizes), np.empty(0)]
    *vectors, scalars = zip(*log)
    arrays = [np.concatenate(column).reshape(len(log), size) for column, size in zip(vectors, sizes)]
    return [*arrays, np.array(scalars, dtype=float)]


def stop_ceilings(robot: Robot, max_torque_ratio: float, max_joint_speed: float):
    """The divergence stops' ceilings: per-joint torque [N·m] (an array) and joint speed [rad/s] (a float).

    Both are capped at the largest float, so the one test a loop makes per
    step, all(|value| <= ceiling), also fails inf and NaN (which compare
    False); the reason is worked out only then.
    """
    largest = sys.float_info.max
    return np.minimum(max_torque_ratio * robot.torque_upper, largest), min(max_joint_speed, largest)


def torque_stop_reason(robot: Robot, tau: np.ndarray, max_torque_ratio: float, t: float) -> str:
    """Why torques that failed the ceiling test end the run at time t [s]."""
    if not np.isfinite(tau).all():
        return f"torque became non-finite at t = {t:.4f} s"
    limit = robot.torque_upper
    joint = int(np.argmax(np.abs(tau) / limit))
    return (
        f"torque of joint {robot.joint_names[joint]} reached {tau[joint]:.4g} N·m, more than "
        f"{max_torque_ratio:g} times its limit {limit[joint]:g} N·m, at t = {t:.4f} s"
    )


def speed_stop_reason(robot: Robot, v: np.ndarray, max_joint_speed: float, t: float, dt: float) -> str:
    """Why joint velocities that failed the ceiling test after the step from t to t + dt [s] end the run."""
    if not np.isfinite(v).all():
        return f"state became non-finite during the step from t = {t:.4f} s"
    joint = int(np.argmax(np.abs(v)))
    return (
        f"speed of joint {robot.joint_names[joint]} reached {v[joint]:.4g} rad/s, beyond "
        f"{max_joint_speed:g} rad/s, at t = {t + dt:.4f} s"
    )
