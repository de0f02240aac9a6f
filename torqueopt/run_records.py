"""What a run records and the :class:`~torqueopt.result.SimResult` made from it, for every lanes form of the engine.

Every run of the engine (:mod:`torqueopt.engine`: :func:`torqueopt.simulate`,
the batch of :func:`torqueopt.batch.simulate_batch`, the kinematic loop of
:func:`torqueopt.kinematic.simulate_kinematic`) builds its results with
:func:`build_result`, the one place a :class:`SimResult` of a run is made;
:func:`run_result` is the same from a log of per-step tuples
(q, v, q̈, τ, x, σmin/σmax). The stop rules and their messages are in
:mod:`torqueopt.stop_rules`.

The reference is sampled a block of steps at a time (:class:`ReferenceBlocks`)
and the logs grow as the run goes, so a run's memory follows the steps it
takes, not the duration it was asked for. :func:`logged_row_bytes` is what
one logged step costs in memory, for the step budget checked before a run
starts.
"""

from __future__ import annotations

import numpy as np

from .dexterity import dexterity_along
from .result import SimResult, joint_dynamics_record, joint_limits_record
from .robot import Robot
from .run_robot import robot_record
from .trajectory import Trajectory, describe

__all__ = [
    "REFERENCE_BLOCK",
    "ReferenceBlocks",
    "build_result",
    "log_columns",
    "logged_row_bytes",
    "run_result",
    "task_reference",
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
    robot_source: dict | None = None,
) -> SimResult:
    """The one place a run's :class:`SimResult` is made, from its recorded rows (arrays the result owns).

    ``q`` … ``jacobian_inverse_condition`` hold one row per recorded step;
    ``times`` and ``reference_position`` cover at least those rows (the
    result copies their first rows). ``trajectory`` is the description
    (:func:`torqueopt.trajectory.describe`); ``joint_limits``,
    ``resolver_options`` and ``robot_source`` (:func:`torqueopt.run_robot.robot_record`)
    may be given once for many results of one batch;
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
        joint_kinds=list(robot.joint_kinds),
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
        gravity=robot.gravity.tolist(),
        payload=None if robot.payload is None else robot.payload.record(),
        robot_source=robot_record(robot) if robot_source is None else robot_source,
        joint_dynamics=joint_dynamics_record(robot),
    )


#: Steps of reference sampled at a time: a run holds about this many rows of reference, whatever its duration.
REFERENCE_BLOCK = 4096


class ReferenceBlocks:
    """The task reference (:func:`task_reference`) on the grid t_i = ``spacing`` · i, i = 0 … ``last``, by blocks.

    :meth:`block` samples rows ``start`` … ``start + size - 1`` (fewer at the
    end), so a loop that stops early never samples, nor holds, the rest of a
    long requested duration. :meth:`positions` joins the position rows
    sampled so far, for the result. ``progress(row)`` is called with the block's first row as each block starts:
    a long run's progress, at no cost per step.
    """

    def __init__(
        self,
        robot: Robot,
        trajectory: Trajectory,
        spacing: float,
        last: int,
        size: int = REFERENCE_BLOCK,
        progress=None,
        start_rotation: np.ndarray | None = None,
    ):
        self.robot, self.trajectory, self.spacing, self.last, self.size = robot, trajectory, spacing, last, size
        self.progress = progress
        self.start_rotation = start_rotation
        self._positions: list[np.ndarray] = []

    def block(self, start: int):
        """(times, sample) of the rows from ``start``: ``times`` a list of floats, ``sample`` the reference rows."""
        if self.progress is not None:
            self.progress(start)
        indices = np.arange(start, min(start + self.size, self.last + 1))
        times = self.spacing * indices
        sample = task_reference(self.robot, self.trajectory, times, self.start_rotation)
        self._positions.append(sample.position)
        return times, sample

    def positions(self) -> np.ndarray:
        """The position rows of every block sampled so far, in order."""
        if not self._positions:
            return np.empty((0, self.robot.m))
        return np.concatenate(self._positions) if len(self._positions) > 1 else self._positions[0]


def task_reference(robot: Robot, trajectory: Trajectory, times: np.ndarray, start_rotation: np.ndarray | None = None):
    """The trajectory's samples embedded in the task coordinates.

    For ``pose`` the orientation rows are the trajectory's own (``sample_orientation``) about
    ``start_rotation``, the frame's rotation at q0 that the task measures from, when it is oriented;
    else zero: the start orientation held.
    """
    sample = trajectory.sample(times)
    if robot.task != "pose":
        return sample
    if getattr(trajectory, "oriented", False):
        turn = trajectory.sample_orientation(times, start_rotation)
        turning = (turn.position, turn.velocity, turn.acceleration)
    else:
        turning = (np.zeros((times.size, 3)),) * 3
    own = (sample.position, sample.velocity, sample.acceleration)
    return type(sample)(*(np.hstack(pair) for pair in zip(own, turning)))


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
