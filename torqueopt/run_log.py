"""A run's log, its stop rules and the :class:`~torqueopt.result.SimResult` made from it, for every loop.

Every stepping loop (the held-torque loop of :func:`torqueopt.simulate`, the
batch of :func:`torqueopt.batch.simulate_batch`, the kinematic loop of
:func:`torqueopt.kinematic.simulate_kinematic`) builds its results with
:func:`build_result`, the one place a :class:`SimResult` of a run is made;
:func:`run_result` is the same from a log of per-step tuples
(q, v, q̈, τ, x, σmin/σmax). :class:`StopRules` holds the divergence
ceilings and words every stop (torque, speed, joint rates, a resolver that
cannot go on), the same for every loop.

The reference is sampled a block of steps at a time (:class:`ReferenceBlocks`)
and the logs grow as the run goes, so a run's memory follows the steps it
takes, not the duration it was asked for. :func:`logged_row_bytes` is what
one logged step costs in memory, for the step budget checked before a run
starts.
"""

from __future__ import annotations

import sys

import numpy as np

from .dexterity import dexterity_along
from .result import SimResult, joint_limits_record
from .robot import Robot
from .trajectory import Trajectory, describe

__all__ = [
    "REFERENCE_BLOCK",
    "ReferenceBlocks",
    "StopRules",
    "build_result",
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

    ``times`` and ``reference_position`` cover at least the logged rows; the
    result keeps their first ``len(log)`` rows (see :func:`build_result`).
    ``limiting``: per infeasible row, the bounds its answer lay on (a bounded
    resolver's ``Resolution.limiting``).
    """
    n = robot.nv
    q_log, v_log, acceleration_log, torque_log, x_log, inverse_condition_log = log_columns(
        log, (robot.nq, n, n, n, robot.m)
    )
    return build_result(
        robot,
        resolver,
        q=q_log,
        v=v_log,
        acceleration=acceleration_log,
        tau=torque_log,
        x=x_log,
        jacobian_inverse_condition=inverse_condition_log,
        times=times,
        reference_position=reference_position,
        dt=dt,
        duration=duration,
        stop_reason=stop_reason,
        stop_time=stop_time,
        trajectory=describe(trajectory),
        task_error=task_error,
        infeasible=infeasible,
        limiting=limiting,
        dexterity=dexterity,
        plant=plant,
    )


def build_result(
    robot: Robot,
    resolver,
    *,
    q: np.ndarray,
    v: np.ndarray,
    acceleration: np.ndarray,
    tau: np.ndarray,
    x: np.ndarray,
    jacobian_inverse_condition: np.ndarray,
    times: np.ndarray,
    reference_position: np.ndarray,
    dt: float,
    duration: float,
    stop_reason: str | None,
    stop_time: float | None,
    trajectory: dict,
    task_error: np.ndarray,
    infeasible: np.ndarray,
    limiting: dict[int, str] | None = None,
    dexterity: bool = False,
    joint_limits: dict | None = None,
    resolver_options: dict | None = None,
    plant: dict | None = None,
) -> SimResult:
    """The one place a run's :class:`SimResult` is made, from its recorded rows (arrays the result owns).

    ``q`` … ``jacobian_inverse_condition`` hold one row per recorded step;
    ``times`` and ``reference_position`` cover at least those rows (the
    result copies their first rows). ``trajectory`` is the description
    (:func:`torqueopt.trajectory.describe`); ``joint_limits`` and
    ``resolver_options`` may be given once for many results of one batch;
    ``plant`` is the plant's record (:meth:`torqueopt.plants.Plant.record`).
    """
    recorded = q.shape[0]
    return SimResult(
        robot=robot.name,
        frame=robot.frame,
        task=robot.task,
        resolver=resolver.name,
        resolver_options=resolver.settings_for_file() if resolver_options is None else resolver_options,
        joint_names=list(robot.joint_names),
        dt=dt,
        t=times[:recorded].copy(),
        q=q,
        joint_angles=robot.joint_angles(q).reshape(recorded, robot.nv),
        v=v,
        acceleration=acceleration,
        tau=tau,
        x=x,
        x_ref=reference_position[:recorded].copy(),
        jacobian_inverse_condition=jacobian_inverse_condition,
        torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(),
        duration=duration,
        stop_reason=stop_reason,
        stop_time=stop_time,
        trajectory=trajectory,
        task_error=task_error,
        infeasible=infeasible,
        limiting=limiting or None,
        dexterity=dexterity_along(robot, q) if dexterity else None,
        joint_limits=joint_limits_record(*robot.joint_limits) if joint_limits is None else joint_limits,
        plant=plant,
    )


#: Steps of reference sampled at a time: a run holds about this many rows of reference, whatever its duration.
REFERENCE_BLOCK = 4096


class ReferenceBlocks:
    """The task reference (:func:`task_reference`) on the grid t_i = ``spacing`` · i, i = 0 … ``last``, by blocks.

    :meth:`block` samples rows ``start`` … ``start + size - 1`` (fewer at the
    end), so a loop that stops early never samples, nor holds, the rest of a
    long requested duration. :meth:`positions` joins the position rows
    sampled so far, for the result.
    """

    def __init__(self, robot: Robot, trajectory: Trajectory, spacing: float, last: int, size: int = REFERENCE_BLOCK):
        self.robot, self.trajectory, self.spacing, self.last, self.size = robot, trajectory, spacing, last, size
        self._positions: list[np.ndarray] = []

    def block(self, start: int):
        """(times, sample) of the rows from ``start``: ``times`` a list of floats, ``sample`` the reference rows."""
        indices = np.arange(start, min(start + self.size, self.last + 1))
        times = self.spacing * indices
        sample = task_reference(self.robot, self.trajectory, times)
        self._positions.append(sample.position)
        return times, sample

    def positions(self) -> np.ndarray:
        """The position rows of every block sampled so far, in order."""
        if not self._positions:
            return np.empty((0, self.robot.m))
        return np.concatenate(self._positions) if len(self._positions) > 1 else self._positions[0]


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


class StopRules:
    r"""The stops every loop applies, and their messages, for one robot and one pair of ceilings.

    ``torque_ceiling`` (per joint, [N·m]) and ``speed_ceiling`` ([rad/s]) are
    those of :func:`stop_ceilings`: a loop's one test per vector and step is
    all(|value| <= ceiling), which also fails inf and NaN; the wording comes
    from the methods here only once a test failed.
    """

    def __init__(self, robot: Robot, max_torque_ratio: float, max_joint_speed: float):
        self.robot, self.max_torque_ratio, self.max_joint_speed = robot, max_torque_ratio, max_joint_speed
        self.torque_ceiling, self.speed_ceiling = stop_ceilings(robot, max_torque_ratio, max_joint_speed)

    def torques_over(self, torque: np.ndarray) -> np.ndarray:
        """Per row of a (B, n) stack: True where a torque fails its ceiling (or is not finite)."""
        return ~(np.abs(torque) <= self.torque_ceiling).all(axis=1)

    def speeds_over(self, velocity: np.ndarray) -> np.ndarray:
        """Per row of a (B, n) stack: True where a joint speed fails the ceiling (or is not finite)."""
        return ~(np.abs(velocity) <= self.speed_ceiling).all(axis=1)

    def torque(self, tau: np.ndarray, t: float) -> str:
        """Why torques that failed the ceiling at time t [s] end the run."""
        return torque_stop_reason(self.robot, tau, self.max_torque_ratio, t)

    def speed(self, v: np.ndarray, t: float, dt: float) -> str:
        """Why velocities that failed the ceiling after the step from t to t + dt [s] end the run."""
        return speed_stop_reason(self.robot, v, self.max_joint_speed, t, dt)

    def rates(self, velocity: np.ndarray, t: float) -> str:
        """Why joint rates a velocity-level method gave at time t [s] end the run (they failed the ceiling)."""
        if not np.isfinite(velocity).all():
            return f"joint rates became non-finite at t = {t:.4f} s"
        joint = int(np.argmax(np.abs(velocity)))
        return (
            f"speed of joint {self.robot.joint_names[joint]} reached {velocity[joint]:.4g} rad/s, beyond "
            f"{self.max_joint_speed:g} rad/s, at t = {t:.4f} s"
        )

    @staticmethod
    def unresolved(error, t: float) -> str:
        """Why a resolver that could not resolve the state at t [s] ends the run (``error``: its exception or message)."""
        return f"{error} at t = {t:.4f} s"

    @staticmethod
    def unresolved_during_step(error, t: float) -> str:
        """Why a velocity-level method undefined at a stage of the step from t [s] ends the run."""
        return f"{error} during the step from t = {t:.4f} s"
