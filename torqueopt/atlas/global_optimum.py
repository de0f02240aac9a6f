r"""The atlas's ``global-optimum`` rows: :func:`torqueopt.optimize` on every movement of the population.

With ``--global`` (``run_atlas(..., global_optimum=True)``) each movement is
also solved as a whole: :func:`torqueopt.optimize` on the same start, line
and duration, with the settings below, warm-started from the movement's own
``pinv`` run. Its row is judged like every resolver's, from the **open-loop
replay** of the optimal torques (the torque held over each 1 ms step,
integrated by the simulation's RK4 with no feedback, as a robot would play
them back): the verdict, the peak torque ratio, the first limit violation and
``max_tip_error`` (the replay's tip error, also in ``replay_tip_error``) are
those of the replay, by :func:`torqueopt.atlas.verdicts.run_row`.

Settings (recorded in ``atlas-config.json``):

* the criterion is ``optimize``'s default, :math:`\int_0^T \|\tau - \tau_{mid}\|^2 dt`
  (S = I; :math:`\tau_{mid} = 0` for symmetric limits), with no hard torque
  bounds and no joint limits: the global counterpart of the paper's local
  criterion, which the local resolvers minimise instant by instant;
* ``end="free"``: the arm need not be at rest at T, so every local run that
  tracks the line is a candidate of the same problem, and the optimum's cost
  is a lower bound of theirs (when the solver finds the global optimum: it is
  a local optimum of a nonconvex problem, found from pinv's motion);
* the ``direct`` transcription (``optimize``'s default when the committed
  1,000-path atlas was made; ``shooting`` is now, decision 0010), kept so
  that an atlas resumes and reproduces;
* the work is bounded per path: ``max_iterations`` IPOPT iterations per
  Hessian tried and ``max_time`` seconds of solve in all (the default
  ``hessian="auto"``: Gauss-Newton, then L-BFGS from its last iterate), and
  the transcription's size is checked before the sweep starts
  (:func:`check_transcription`).

With ``--global-bounded`` (``global_bounded=True``) the whole-movement problem
is solved under the torque bounds and the URDF's joint limits, by the
``shooting`` transcription from its default starts (pinv's run first),
compiled to C once per robot and duration; a path
on which it finds that no motion within the limits exists (``optimizer_status``
``infeasible``: the phase-1 problem's least excess over the limits is positive,
or IPOPT declared every start infeasible) has the verdict ``infeasible for
every resolver`` (``torqueopt.atlas.verdicts.INFEASIBLE``), with the
solver's evidence in ``optimizer_evidence`` and the least excess in
``optimizer_excess`` (NaN where no phase-1 ran), and ``infeasible_path`` marks
every row of that path. The report gives the problem-free shares over the
feasible paths beside the raw ones (:func:`torqueopt.atlas.frontier.global_summary`).

A path where the solver does not converge keeps its row: ``optimizer_status``
says how it ended (``acceptable``, ``iteration limit``, ``time limit``,
``infeasible``, ``failed``), and the row is the last iterate's replay, judged
the same way. Only ``converged`` rows enter the ``*_vs_global`` ratios
(:func:`add_global_ratios`); the others are counted in the report.

A chunk of global rows is deterministic (the same movements give the same
rows: the solve's wall time is not a column, its iterations are), except that
a path which reaches ``max_time`` stops at a load-dependent iterate: its
status says ``time limit``.
"""

from __future__ import annotations

import json

import numpy as np

from ..checks import check_rigid_joints
from ..optimal import optimize, run_cost
from ..optimal.whole_path import (
    DEFAULT_GRID_STEP,
    DEFAULT_MAX_NONZEROS,
    _check_size,
    transcription_intervals,
)
from ..resolvers import get_resolver
from ..result import SimResult, joint_limits_record
from ..simulate import DEFAULT_MAX_JOINT_SPEED, DEFAULT_MAX_TORQUE_RATIO, simulate
from ..stop_rules import StopRules
from .jobs import GlobalChunk, worker_robot
from .population import Movement, movement_trajectory
from .rows import movement_columns, path_columns, peak_applied_ratio, start_columns
from .verdicts import INFEASIBLE, Thresholds, run_row, self_motion_energy

__all__ = [
    "DEFAULT_GLOBAL_CHUNK_SIZE",
    "DEFAULT_GLOBAL_MAX_ITERATIONS",
    "DEFAULT_GLOBAL_MAX_TIME",
    "GLOBAL_END",
    "GLOBAL_RESOLVER",
    "add_global_ratios",
    "check_transcription",
    "global_row",
    "infeasibility_evidence",
    "run_global_chunk",
]

#: The ``resolver`` column of the global rows.
GLOBAL_RESOLVER = "global-optimum"
#: How the optimised movement ends (see the module docstring).
GLOBAL_END = "free"
#: IPOPT iterations per Hessian tried, per path.
DEFAULT_GLOBAL_MAX_ITERATIONS = 500
#: The most wall time of one path's solve [s], a guard against a hang far above the ~1.4 s a 2 s planar3 path takes
#: on a quiet core (a loaded machine takes longer; the iterations are the budget that does not depend on the load).
DEFAULT_GLOBAL_MAX_TIME = 600.0
#: Movements per chunk of global rows (a solve takes ~1.4 s on a 2 s planar3 path: chunks of ~10 s).
DEFAULT_GLOBAL_CHUNK_SIZE = 8


def check_transcription(
    robot, durations, max_nonzeros: int = DEFAULT_MAX_NONZEROS, torque_bounds: bool = False
) -> None:
    """Refuse, before anything runs, a duration whose transcription is larger than ``optimize`` accepts, and a
    robot whose joint damping and friction the optimum's dynamics do not model."""
    check_rigid_joints(robot)
    for duration in durations:
        intervals = transcription_intervals(duration, DEFAULT_GRID_STEP)
        _check_size(robot, duration, DEFAULT_GRID_STEP, intervals, torque_bounds, max_nonzeros)


def global_row(robot, movement: Movement, *, dt: float, thresholds: Thresholds, settings: dict) -> tuple[dict, float]:
    """(the ``global-optimum`` columns of one movement without the movement's own, pinv's peak torque ratio)."""
    line = movement_trajectory(movement)
    pinv_run = simulate(robot, get_resolver("pinv"), line, movement.q0, dt=dt)
    pinv_peak = peak_applied_ratio(pinv_run)
    bounded = "transcription" in settings  # --global-bounded; the settings of an atlas without it have no such key
    limits = {"torque_bounds": settings["torque_bounds"], "joint_limits": settings["joint_limits"]}
    solved = optimize(
        robot,
        line,
        movement.q0,
        end=settings["end"],
        dt=dt,
        grid_step=settings["grid_step"],
        warm_start=pinv_run,
        max_iterations=settings["max_iterations"],
        max_time=settings["max_time"],
        # Without --global-bounded the rows are the direct transcription's, optimize's default when the committed
        # atlas was made (its config records no transcription): kept, so that it resumes and reproduces.
        **(
            {**limits, "transcription": "shooting", "compiled": settings["compiled"]}
            if bounded
            else {"transcription": "direct"}
        ),
    )
    replayed = replay_result(robot, solved)
    kinetic, self_energy = self_motion_energy(robot, replayed)
    row = run_row(replayed, kinetic, self_energy, pinv_peak, thresholds)
    row.update(
        {
            "cost": run_cost(replayed, robot),
            "optimizer_status": solved.status,
            "optimizer_iterations": int(solved.iterations),
            "optimizer_cost": float(solved.cost),
            "replay_tip_error": float(solved.replay_tip_error),
        }
    )
    if bounded:
        if solved.status == "infeasible":
            row["verdict"] = INFEASIBLE
        row["optimizer_evidence"] = infeasibility_evidence(solved)
        row["optimizer_excess"] = float(solved.feasibility.get("excess", np.nan))
    return row, pinv_peak


def infeasibility_evidence(solved) -> str:
    """Why an ``OptimalResult`` is ``infeasible``, in one line (empty when it is not): the phase-1 problem's least
    excess over the limits and the limits it reaches, or IPOPT's word on every start."""
    if solved.status != "infeasible":
        return ""
    feasibility = solved.feasibility
    if feasibility.get("proves_infeasible"):
        return "phase-1: " + feasibility["evidence"]
    said = ", ".join(f"{start['warm_start']}: {start['solver_message']}" for start in solved.starts)
    return f"IPOPT declared every start infeasible ({said or solved.solver_message})" + (
        f"; phase-1: {feasibility['evidence']}" if feasibility else ""
    )


def replay_result(robot, solved) -> SimResult:
    """The open-loop replay of an ``OptimalResult``'s torques as a :class:`~torqueopt.SimResult`.

    The replay stops where a simulation of the same movement would: at the
    first state whose joint speed fails ``simulate``'s divergence ceiling
    (``DEFAULT_MAX_JOINT_SPEED``, or a state that is not finite). As in
    ``simulate``, the rows end at the state before it (its torque applied), and
    the run is marked as stopped (``stop_reason``, ``stop_time``: the time of
    the state that failed) in the words of a simulation's speed stop.
    """
    from ..optimal import replay_torques

    applied = solved.tau[:-1]
    replay = replay_torques(robot, solved.q[0], np.zeros(robot.nv), applied, solved.dt)
    rules = StopRules(robot, DEFAULT_MAX_TORQUE_RATIO, DEFAULT_MAX_JOINT_SPEED)
    with np.errstate(invalid="ignore", over="ignore"):
        diverged = rules.speeds_over(replay.v) | ~np.isfinite(replay.q).all(axis=1)
    count = int(np.argmax(diverged)) if diverged.any() else len(diverged)
    data = robot.model.createData()
    q, v = replay.q[:count], replay.v[:count]
    tau = np.vstack([applied, np.full((1, robot.nv), np.nan)])[:count]
    x = replay.tip[:count][:, robot.task_rows]
    condition = np.array([_inverse_condition(robot, data, row) for row in q])
    stop_reason, stop_time = None, None
    if count < len(diverged):  # the start (at rest, finite) never fails, so count >= 1
        step_start = float(solved.t[count - 1])
        stop_reason = "open-loop replay of the optimal torques: " + rules.speed(replay.v[count], step_start, solved.dt)
        stop_time = float(solved.t[count])
    lower, upper, velocity = robot.joint_limits
    return SimResult(
        robot=robot.name,
        frame=robot.frame,
        task=robot.task,
        resolver=GLOBAL_RESOLVER,
        joint_names=list(robot.joint_names),
        joint_kinds=list(robot.joint_kinds),
        dt=solved.dt,
        t=solved.t[:count],
        q=q,
        joint_angles=robot.joint_angles(q).reshape(count, robot.nv),
        v=v,
        acceleration=solved.acceleration[:count],
        tau=tau,
        x=x,
        x_ref=solved.x_ref[:count],
        jacobian_inverse_condition=condition,
        torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(),
        duration=solved.duration,
        stop_reason=stop_reason,
        stop_time=stop_time,
        trajectory=solved.trajectory,
        joint_limits=joint_limits_record(lower, upper, velocity),
    )


def _inverse_condition(robot, data, q) -> float:
    import pinocchio as pin

    from ..linalg import inverse_condition_number

    jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    return float(inverse_condition_number(jacobian[robot.task_rows]))


def run_global_chunk(job: GlobalChunk) -> list[dict]:
    """The ``global-optimum`` rows of one chunk of movements."""
    robot = worker_robot(job.robot)
    rows = []
    for movement in job.movements:
        row = movement_columns(movement, GLOBAL_RESOLVER)
        row["resolver_options"] = json.dumps(job.settings, sort_keys=True)
        columns, pinv_peak = global_row(robot, movement, dt=job.dt, thresholds=job.thresholds, settings=job.settings)
        row.update(columns)
        row.update(start_columns(movement))
        row.update(path_columns(movement))
        row["pinv_peak_torque_ratio"] = pinv_peak
        row["batched"] = False
        rows.append(row)
    return rows


def add_global_ratios(table):
    """``table`` with ``cost_vs_global`` and ``peak_vs_global``: each row's cost and peak torque ratio over those of
    the converged global optimum on the same path (NaN where the path's optimiser did not converge; 1 on its own row);
    under ``--global-bounded`` (an ``optimizer_excess`` column), ``infeasible_path`` on every row: its path's global row
    has the verdict ``infeasible for every resolver``.
    """
    if "optimizer_excess" in table.columns:
        infeasible = table.loc[(table["resolver"] == GLOBAL_RESOLVER) & (table["verdict"] == INFEASIBLE), "path"]
        table = table.assign(infeasible_path=table["path"].isin(set(infeasible)))
    rows = table[(table["resolver"] == GLOBAL_RESOLVER) & (table["optimizer_status"] == "converged")]
    cost = table["path"].map(rows.set_index("path")["cost"])
    peak = table["path"].map(rows.set_index("path")["peak_torque_ratio"])
    with np.errstate(divide="ignore", invalid="ignore"):
        return table.assign(
            cost_vs_global=table["cost"].to_numpy(float) / cost.to_numpy(float),
            peak_vs_global=table["peak_torque_ratio"].to_numpy(float) / peak.to_numpy(float),
        )


def settings(max_iterations: int, max_time: float, bounded: bool = False) -> dict:
    """The global rows' settings as atlas-config.json records them (``bounded``: torque bounds and joint limits,
    the shooting transcription; only then the key ``transcription``, so that an atlas without it keeps its
    fingerprint)."""
    recorded = {
        "end": GLOBAL_END,
        "weight": "identity",
        "torque_bounds": bool(bounded),
        "joint_limits": bool(bounded),
        "grid_step": DEFAULT_GRID_STEP,
        "warm_start": "pinv",
        "max_iterations": int(max_iterations),
        "max_time": float(max_time),
    }
    if bounded:
        # compiled to C once per robot and duration (cached on disk; CasADi's virtual machine without a compiler):
        # a panda solve took 2.6 s compiled against 8.1 s in the virtual machine (decision 0001)
        recorded.update({"transcription": "shooting", "compiled": True})
    return recorded
