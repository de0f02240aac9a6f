r"""``torqueopt.optimize``: the torque-optimal joint motion for a whole movement.

It finds the joint trajectory that keeps the task frame on the reference
path and minimises

.. math:: \int_0^T \|S(\tau - \tau_{mid})\|^2\, dt

starting at rest at :math:`q_0` (the global counterpart of the paper's
local, instant-by-instant criterion, Eq. (29), Eq. (30), Eq. (31), Eq. (32), Eq. (33)). Steps:

1. a local resolver's run (``pinv`` by default) on the simulation grid,
   sampled at the nodes, is the warm start;
2. the program of :mod:`torqueopt.optimal.transcription` (held acceleration
   over intervals of ``grid_step``, ≤ 5 ms by default) is solved by IPOPT:
   by default with CasADi's exact derivatives from several starts, the best
   kept (``transcription="shooting"``, :mod:`torqueopt.optimal.shooting`);
   with ``transcription="direct"``, with Pinocchio's first derivatives and a
   Gauss-Newton or L-BFGS Hessian from the one start
   (:mod:`torqueopt.optimal.ipopt`). Decision 0010 (docs/decisions) has the
   measurement behind the default;
3. the planned motion (piecewise quadratic, exactly as transcribed) is
   mapped to the simulation grid: the torque held over each step
   :math:`[t_j, t_j + \Delta t]` is the inverse dynamics (RNEA) of the plan
   at the step's midpoint, which equals the step's mean torque to
   :math:`O(\Delta t^2)`;
4. those torques are replayed open loop through the simulation's RK4
   (:func:`torqueopt.optimal.replay.replay_torques`): the largest tip
   deviation is ``replay_tip_error``; the cost is recomputed on the
   simulation grid (:func:`torqueopt.optimal.cost.torque_cost`), exactly as
   :func:`torqueopt.optimal.run_cost` charges a local run.

The result says how the solve ended (``status``): only ``converged`` is an
optimum; anything else is the last iterate, reported as such.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import replace

import numpy as np
import pinocchio as pin

from ..checks import (
    check_rigid_joints,
    configuration_vector,
    positive_number,
    step_count,
    trajectory_dimension,
    whole_number,
)
from ..errors import InvalidInput
from ..resolvers import Resolver, get_resolver
from ..resolvers.null_space import torque_midpoint
from ..result import SimResult
from ..robot import Robot
from ..run_robot import robot_record
from ..simulate import simulate
from ..trajectory import check_trajectory, describe
from .branches import branch_starts
from .cost import torque_cost, weight_root
from .ipopt import solve_transcription
from .replay import replay_torques
from .result import OptimalResult
from .shooting import ShootingTranscription, least_excess, solve_shooting
from .transcription import Transcription

__all__ = [
    "DEFAULT_GRID_STEP",
    "DEFAULT_MAX_NONZEROS",
    "ENDS",
    "DEFAULT_STARTS",
    "DEFAULT_TRANSCRIPTION",
    "HESSIANS",
    "OptimalResult",
    "TRANSCRIPTIONS",
    "optimize",
    "transcription_intervals",
]

#: How the movement may end: at rest (v(T) = 0) or with any joint velocity.
ENDS = ("rest", "free")
#: Hessians of the Lagrangian: ``auto`` tries Gauss-Newton, then L-BFGS from where it stopped.
HESSIANS = ("auto", "gauss-newton", "limited-memory")
#: The most IPOPT iterations a run may take (IPOPT's own counter is a 32-bit int: 2**31 failed inside casadi).
MAX_ITERATIONS = 100_000
#: What ``auto`` tries, in order, and the statuses after which a second try cannot help.
_AUTO = ("gauss-newton", "limited-memory")
_FINAL = ("converged", "infeasible", "time limit")
#: How the whole movement is transcribed: Pinocchio's derivatives with a Gauss-Newton or L-BFGS
#: Hessian (``direct``), or CasADi's exact derivatives over the same program (``shooting``).
TRANSCRIPTIONS = ("direct", "shooting")
#: ``optimize``'s transcription (decision 0010: on the planar3 atlas's 1,000 unbounded 2 s lines it converged on
#: every path, ``direct`` on 945).
DEFAULT_TRANSCRIPTION = "shooting"
#: The warm starts of the ``shooting`` transcription after ``warm_start``: a damped null-space run,
#: whose self-motion differs from pinv's, so a second local optimum can be found.
DEFAULT_STARTS = ("pinv", "damped-null-space")
#: Longest interval of the transcription grid [s].
DEFAULT_GRID_STEP = 0.005
#: Largest transcription (nonzeros of the constraint Jacobian and the Hessian) optimize builds unless told
#: otherwise: measured on planar3, each nonzero costs the solve about 280 bytes, so about 1.4 GB.
DEFAULT_MAX_NONZEROS = 5_000_000


def transcription_intervals(duration: float, grid_step: float) -> int:
    """The even number N of intervals with h = T/N <= grid_step (a Python int: it may be huge before the check)."""
    ratio = duration / (2.0 * grid_step)
    if not math.isfinite(ratio):
        raise InvalidInput(
            f"grid_step={grid_step!r} s is too small: the duration {duration:g} s has no finite count of its intervals"
        )
    return 2 * max(1, math.ceil(ratio - 1e-9))  # a step longer than T/2 still leaves two intervals


def _check_size(robot: Robot, duration, grid_step, intervals: int, torque_bounds: bool, max_nonzeros: int) -> None:
    """Refuse, before any array is made, a transcription of more than ``max_nonzeros`` nonzeros."""
    size = Transcription.count(robot, intervals, torque_bounds=torque_bounds)
    if size.nonzeros <= max_nonzeros:
        return
    per_interval = size.nonzeros // intervals
    most = 2 * (max_nonzeros // per_interval // 2)  # the most intervals within the bound (even)
    if most >= 2:
        step = duration / most
        scale = 10.0 ** (math.floor(math.log10(step)) - 2)
        remedy = f"give a grid_step of at least {math.ceil(step / scale) * scale:.3g} s, or raise max_nonzeros"
    else:
        remedy = f"raise max_nonzeros to at least {2 * per_interval} (two intervals)"
    count = f"{intervals:,}" if intervals < 1e15 else f"{intervals:.3g}"
    raise InvalidInput(
        f"the transcription of {count} intervals of {duration / intervals:.3g} s would have {size.variables:.3g} "
        f"variables and {size.nonzeros:.3g} nonzeros (constraint Jacobian {size.jacobian_nonzeros:.3g}, Hessian "
        f"{size.hessian_nonzeros:.3g}), more than max_nonzeros={max_nonzeros:.3g}: {remedy} (--max-nonzeros)"
    )


def optimize(
    robot: Robot,
    trajectory,
    q0,
    *,
    weight=None,
    end: str = "rest",
    torque_bounds: bool = False,
    joint_limits: bool = False,
    dt: float = 1e-3,
    grid_step: float = DEFAULT_GRID_STEP,
    warm_start: str | Resolver | SimResult = "pinv",
    transcription: str = DEFAULT_TRANSCRIPTION,
    starts=None,
    compiled: bool = False,
    hessian: str = "auto",
    tolerance: float = 1e-8,
    max_iterations: int = 500,
    max_time: float | None = None,
    max_nonzeros: int = DEFAULT_MAX_NONZEROS,
    verbose: bool = False,
    progress=None,
) -> OptimalResult:
    r"""The joint motion that tracks ``trajectory`` and minimises :math:`\int\|S(\tau - \tau_{mid})\|^2 dt`.

    Args:
        robot: from :func:`torqueopt.load_robot`; revolute/prismatic joints (continuous ones too
            with ``shooting``), task ``xy`` or ``position``.
        trajectory: the tip reference (anchored at the tip's position at q0
            when it has no start), e.g. :class:`torqueopt.StraightLine`.
        q0: start configuration (configuration vector or one angle per joint); the arm starts at rest.
        weight: ``None``/``"identity"`` (S = I), ``"range"`` (Eq. (33),
            S = diag(2/(τ⁺ − τ⁻))), a vector (diagonal of W) or a matrix W;
            see :func:`torqueopt.optimal.weight_root`.
        end: ``rest`` (v(T) = 0) or ``free``.
        torque_bounds: impose τ⁻ ≤ τ ≤ τ⁺ at every interval (joints with finite limits).
        joint_limits: impose the URDF's position and velocity limits at every node.
        dt: the simulation grid [s] on which the result, its cost and the replay are given.
        grid_step: the longest transcription interval [s]; the grid has an even number N of
            intervals, h = T/N ≤ grid_step.
        warm_start: a resolver (name or object) whose simulated run starts the solve, or a SimResult.
        transcription: ``shooting`` (the default; ``torqueopt.optimal.shooting``: CasADi's exact
            derivatives, the Lagrangian's Hessian included, solved from each of ``starts``) or
            ``direct`` (``torqueopt.optimal.transcription``: the same program with Pinocchio's first
            derivatives and the Hessian of ``hessian``, from ``warm_start`` alone).
        starts: ``shooting`` only: the warm starts to solve from, each as ``warm_start``;
            default ``DEFAULT_STARTS`` (``warm_start`` first). The best converged optimum is
            returned (the lowest cost; these are local optima of the whole-movement problem and
            different starts may reach different ones); every start's status, iterations and
            cost are in ``result.starts``. Where no start ends within the limits, the phase-1
            problem (``torqueopt.optimal.shooting.least_excess``), solved from a ``bounded-torque``
            run, from starts on other self-motion branches (under joint limits) and from each
            start's last point, either gives one more start (``phase-1 from <start>``) or is
            the evidence that no motion within them exists (status ``infeasible``, in
            ``result.feasibility``).
        compiled: ``shooting`` only: generate the NLP's functions as C and compile them once
            (kept in ``torqueopt.optimal.shooting.cache_directory``); without a C compiler
            CasADi's virtual machine evaluates them.
        hessian: ``direct`` only (``shooting`` accepts ``auto`` alone): ``gauss-newton`` (the block
            Gauss-Newton matrix of the cost), ``limited-memory`` (IPOPT's L-BFGS), or ``auto`` (the
            default): Gauss-Newton, and when it ends short of
            convergence (acceptable level, iteration limit, failure) L-BFGS from its last iterate.
            Measured: Gauss-Newton converges where L-BFGS stalls on panda; L-BFGS converges where
            Gauss-Newton stops at "acceptable" with active torque bounds on the planar arm.
        tolerance: IPOPT's tolerance on the scaled KKT error.
        max_iterations, max_time: bounds on the work (iterations of each IPOPT run; wall time [s]
            of all of them with ``direct``; with ``shooting``, of each run, and no start begins once
            max_time is spent: a limit that shrank from run to run would build a solver per run).
        max_nonzeros: refuse a transcription with more nonzeros than this in its
            constraint Jacobian and Hessian together (counted before anything is
            built, ``Transcription.count``; about 280 bytes each).
        verbose: print IPOPT's log.
        progress: called with the iteration number at each IPOPT iteration
            (0 at the start of each run), e.g. to move a progress bar.

    Raises:
        InvalidInput: a bad option, robot or task (one line naming the value and the valid ones).
    """
    if end not in ENDS:
        raise InvalidInput(f"end '{end}' is not one of {', '.join(ENDS)}")
    if transcription not in TRANSCRIPTIONS:
        raise InvalidInput(f"transcription '{transcription}' is not one of {', '.join(TRANSCRIPTIONS)}")
    if hessian not in HESSIANS:
        raise InvalidInput(f"hessian '{hessian}' is not one of {', '.join(HESSIANS)}")
    if transcription == "shooting" and hessian != "auto":
        # before decision 0010 the default was 'direct': a caller that names a Hessian meant that one
        raise InvalidInput(
            f"transcription 'shooting' uses the exact Hessian: give hessian 'auto', or transcription 'direct' for "
            f"hessian '{hessian}' (shooting is the default)"
        )
    dt = positive_number(dt, "dt", "s")
    grid_step = positive_number(grid_step, "grid_step", "s")
    tolerance = positive_number(tolerance, "tolerance")
    if max_time is not None:
        max_time = positive_number(max_time, "max_time", "s")
    max_iterations = whole_number(max_iterations, "max_iterations", minimum=1, maximum=MAX_ITERATIONS)
    max_nonzeros = whole_number(max_nonzeros, "max_nonzeros", minimum=1)
    if robot.m > robot.nv:
        raise InvalidInput(
            f"task '{robot.task}' has m={robot.m} coordinates but robot '{robot.name}' has n={robot.nv} joints"
        )
    check_rigid_joints(robot)
    check_trajectory(trajectory)
    duration = positive_number(trajectory.duration, "duration", "s")
    if dt > duration or grid_step > duration:
        raise InvalidInput(f"dt={dt} s and grid_step={grid_step} s must not exceed the duration {duration} s")
    steps = step_count(duration, dt)
    root = weight_root(robot, weight)
    weight_name = weight if isinstance(weight, str) else ("identity" if weight is None else "user")
    midpoint = torque_midpoint(robot)
    q_start = configuration_vector(robot, q0)
    linear_dimension = trajectory_dimension(robot, trajectory)
    if trajectory.start is None:
        trajectory = trajectory.anchored(robot.task_position(q_start)[:linear_dimension])

    intervals = transcription_intervals(duration, grid_step)
    _check_size(robot, duration, grid_step, intervals, torque_bounds, max_nonzeros)
    nodes = np.linspace(0.0, duration, intervals + 1)
    problem = (ShootingTranscription if transcription == "shooting" else Transcription)(
        robot,
        duration,
        intervals,
        trajectory.sample(nodes).position,
        q_start,
        root,
        midpoint,
        end_at_rest=end == "rest",
        torque_bounds=torque_bounds,
        joint_limits=joint_limits,
    )
    times = dt * np.arange(steps + 1)
    if transcription == "shooting":
        chosen, attempts, tried, feasibility = _solve_from_starts(
            problem,
            robot,
            trajectory,
            q_start,
            dt,
            warm_start,
            starts,
            tolerance,
            max_iterations,
            max_time,
            compiled,
            verbose,
            progress,
        )
        start_run, start_name, solved = chosen
        spent = sum(record["seconds"] for record in tried) + (feasibility[0].seconds if feasibility else 0.0)
    else:
        tried, feasibility = [], None
        start_run, start_name = _start_run(robot, trajectory, q_start, dt, warm_start)
        w0 = _warm_start(problem, start_run)
        attempts, start, spent = [], w0, 0.0
        for name in _AUTO if hessian == "auto" else (hessian,):
            remaining = None if max_time is None else max_time - spent
            if remaining is not None and remaining <= 0.0:
                break
            solved = solve_transcription(
                problem,
                start,
                hessian=name,
                tolerance=tolerance,
                max_iterations=max_iterations,
                max_time=remaining,
                verbose=verbose,
                on_iteration=progress,
            )
            attempts.append((name, solved))
            spent += solved.seconds
            if solved.status in _FINAL:
                break
            start = solved.w
    hessians_used = ", then ".join(name for name, _ in attempts)
    messages = ", then ".join(attempt.message for _, attempt in attempts)
    plan = _on_grid(problem, solved.w, times)
    applied = plan["tau"]
    replay = replay_torques(robot, q_start, np.zeros(robot.nv), applied, dt)
    reference = trajectory.sample(times).position
    linear = min(robot.m, 3)
    replay_x = replay.tip[:, robot.task_rows]
    replay_error = np.linalg.norm(replay_x[:, :linear] - reference[:, :linear], axis=1)
    plan_error = np.linalg.norm(plan["x"][:, :linear] - reference[:, :linear], axis=1)
    start_cost = (
        torque_cost(start_run.tau[:steps], dt, root, midpoint)  # rows 0..M-1: every applied torque
        if start_run is not None
        and start_run.completed
        and len(start_run.t) == steps + 1
        and math.isclose(start_run.dt, dt)
        else float("nan")
    )
    return OptimalResult(
        robot=robot.name,
        frame=robot.frame,
        task=robot.task,
        joint_names=list(robot.joint_names),
        joint_kinds=list(robot.joint_kinds),
        robot_source=robot_record(robot),
        dt=dt,
        t=times,
        q=plan["q"],
        joint_angles=robot.joint_angles(plan["q"]).reshape(len(times), robot.nv),
        v=plan["v"],
        acceleration=plan["a"],
        tau=np.vstack([applied, np.full((1, robot.nv), np.nan)]),
        x=plan["x"],
        x_ref=reference,
        replay_x=replay_x,
        torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(),
        duration=duration,
        cost=torque_cost(applied, dt, root, midpoint),
        grid_cost=solved.objective,
        weight=weight_name,
        status=solved.status,
        solver_message=messages,
        iterations=sum(attempt.iterations for _, attempt in attempts),
        solve_seconds=spent,
        replay_tip_error=float(np.nanmax(replay_error)) if replay.completed else float("inf"),
        plan_tip_error=float(plan_error.max()),
        constraint_violation=solved.constraint_violation,
        grid_step=problem.h,
        grid_intervals=intervals,
        end=end,
        torque_bounds=bool(torque_bounds),
        joint_limits=bool(joint_limits),
        trajectory=describe(trajectory),
        hessian=hessians_used,
        warm_start=start_name,
        warm_start_cost=start_cost,
        transcription=transcription,
        starts=tried,
        feasibility=_feasibility_record(*feasibility) if feasibility is not None else {},
        solution={"problem": problem, "w": solved.w, "lam_g": solved.lam_g, "lam_x": solved.lam_x},
    )


def _start_run(robot, trajectory, q_start, dt, warm_start) -> tuple[SimResult, str]:
    """The run a warm start is taken from, and its name."""
    if isinstance(warm_start, SimResult):
        return warm_start, warm_start.resolver
    resolver = get_resolver(warm_start)
    return simulate(robot, resolver, trajectory, q_start, dt=dt), resolver.name


#: The name of the start taken from the phase-1 problem's motion within the limits (``result.starts``).
PHASE_ONE = "phase-1"
#: IPOPT's return when ``progress`` asked it to stop (``torqueopt optimize`` on Ctrl-C): no other start, no phase-1.
_STOPPED = "User_Requested_Stop"
#: The start tried first by phase-1 when no start ended within the limits: ``bounded-torque`` keeps the torque bounds
#: and (its default ``joint_limits=on``, off where the problem has none) the joint limits at every step where it can, so its run is near a motion within
#: them where pinv's and damped-null-space's drift to a joint limit (panda line 3 of the population: phase-1 found a
#: least excess of 0.146 from both, a motion within every limit from this run).
LIMITED_START = "bounded-torque"
#: How many other self-motion branches (:func:`~torqueopt.optimal.branches.branch_starts`) phase-1 starts from after
#: the limited start, under joint limits.
BRANCH_STARTS = 4
#: The order of preference of a start's outcome when no start converged.
_PREFERENCE = ("converged", "acceptable", "iteration limit", "time limit", "failed", "infeasible")


def _solve_from_starts(
    problem,
    robot,
    trajectory,
    q_start,
    dt,
    warm_start,
    starts,
    tolerance,
    max_iterations,
    max_time,
    compiled,
    verbose,
    progress,
):
    """Solve the shooting program from every start; the best (status, then cost) and every start's record.

    When no start ends within the limits (``converged`` or ``acceptable``), the phase-1 problem
    (:func:`~torqueopt.optimal.shooting.least_excess`) is solved from a run of :data:`LIMITED_START` (which
    keeps within the limits where it can), under joint limits from :data:`BRANCH_STARTS` starts on other
    self-motion branches (:func:`~torqueopt.optimal.branches.branch_starts`), then from each start's last point, nearest first, until one
    finds a motion within every limit: that motion is one more start (``phase-1 from <start>``), solved
    like the others; else the least excess of those that ended at a local minimum (``converged`` or
    ``acceptable``), when positive, makes the status ``infeasible`` (whatever IPOPT said).

    Returns ((run, name, SolverOutput) of the best, [("exact", SolverOutput)], [record per start],
    (the least phase-1 :class:`~torqueopt.optimal.shooting.Feasibility`, [(start, Feasibility)]) or None).
    """
    if starts is None:
        # a run or a resolver named like a default start is that start: it is not solved from twice
        first = warm_start.resolver if isinstance(warm_start, SimResult) else getattr(warm_start, "name", warm_start)
        # without redundancy one motion follows the path: a null-space start has no self-motion to differ by
        others = DEFAULT_STARTS if robot.nv > robot.m else ()
        starts = (warm_start, *(name for name in others if name != first))
    elif isinstance(starts, (str, Resolver, SimResult)):
        starts = (starts,)
    if not len(starts):
        raise InvalidInput("starts is empty: give at least one resolver name, e.g. ('pinv',)")
    outcomes, records, spent = [], [], 0.0
    solve = functools.partial(
        solve_shooting,
        problem,
        tolerance=tolerance,
        max_iterations=max_iterations,
        compiled=compiled,
        verbose=verbose,
        on_iteration=progress,
    )
    # Each IPOPT run gets the whole max_time, and none starts once it is spent: IPOPT's time limit is an option of
    # the built solver, and a limit that shrank from run to run would build (and keep) a solver per run.
    for start in starts:
        if max_time is not None and spent >= max_time:
            break
        run, name = _start_run(robot, trajectory, q_start, dt, start)
        solved = solve(_warm_start(problem, run), max_time=max_time)
        spent += solved.seconds
        outcomes.append((run, name, solved))
        records.append(_start_record(name, solved))
        if solved.message == _STOPPED:
            break
    feasibility, tries = None, []
    stopped = outcomes[-1][2].message == _STOPPED
    if not stopped and not any(outcome[2].status in ("converged", "acceptable") for outcome in outcomes):
        # No start reached a point within the limits: phase-1 from each start's last point, nearest first, until one
        # finds a motion within the limits; the least excess found is the evidence (different starts reach
        # different local minima: panda line 13 of the population, 0.21 from pinv's and 0.02 from a damped run's).
        # IPOPT's own iterates from a start may wander off a motion within the limits (panda line 3: infeasible
        # from the limited run itself), so phase-1 goes first from that run too.
        points = [
            (run, name, solved.w)
            for run, name, solved in sorted(outcomes, key=lambda outcome: outcome[2].constraint_violation)
        ]
        limited = _limited_start(problem, robot)
        if limited is not None and (max_time is None or spent < max_time):
            run, _ = _start_run(robot, trajectory, q_start, dt, limited)
            # then, where joint limits may cut q0's self-motion branch, the other branches, which no run from q0
            # reaches (panda line 13); they have no run of their own
            count = BRANCH_STARTS if problem.joint_limits else 0
            branches = ((None, name, w) for name, w in branch_starts(problem, count))  # made when reached
            points = itertools.chain([(run, limited.label, _warm_start(problem, run))], branches, points)
        for run, name, point in points:
            if tries and max_time is not None and spent >= max_time:
                break
            found = least_excess(problem, point, tolerance=tolerance, max_iterations=max_iterations, max_time=max_time)
            spent += found.seconds
            tries.append((run, name, found))
            if found.answered and not found.proves_infeasible:
                break
        answered = [entry for entry in tries if entry[2].answered]
        run, name, feasibility = min(answered, key=lambda entry: entry[2].excess) if answered else tries[0]
        feasibility = replace(feasibility, seconds=sum(entry[2].seconds for entry in tries))
        if feasibility.answered and not feasibility.proves_infeasible:
            solved = solve(feasibility.w, max_time=max_time)
            outcomes.append((run, f"{PHASE_ONE} from {name}", solved))
            records.append(_start_record(f"{PHASE_ONE} from {name}", solved))
    best = min(
        outcomes,
        key=lambda outcome: (
            _PREFERENCE.index(outcome[2].status),
            outcome[2].constraint_violation if outcome[2].status not in ("converged", "acceptable") else 0.0,
            outcome[2].objective,
        ),
    )
    if feasibility is not None and feasibility.proves_infeasible:
        best = (best[0], best[1], replace(best[2], status="infeasible"))
    elif feasibility is not None and feasibility.answered and best[2].status == "infeasible":
        best = (best[0], best[1], replace(best[2], status="failed"))  # phase-1 met every limit: not infeasible
    if feasibility is not None:
        feasibility = (feasibility, name, [(start, found) for _, start, found in tries])
    return best, [("exact", best[2])], records, feasibility


def _limited_start(problem, robot) -> Resolver | None:
    """:data:`LIMITED_START` with the problem's joint limits, or None where it cannot run (no finite torque limit, no
    redundancy) or the problem has no limit to keep."""
    if not (problem.torque_bounds or problem.joint_limits) or robot.nv <= robot.m:
        return None
    if not (np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)).any():
        return None
    return get_resolver(LIMITED_START, joint_limits="on" if problem.joint_limits else "off")


def _feasibility_record(feasibility, name: str, tries) -> dict:
    """``OptimalResult.feasibility``: the least excess found (its record, from the start ``name``) and each phase-1
    solve's, by start."""
    record = {**feasibility.record(), "from": name}
    record["tries"] = [
        {"from": name, "status": found.status, "excess": found.excess, "iterations": found.iterations}
        for name, found in tries
    ]
    return record


def _start_record(name: str, solved) -> dict:
    """What ``OptimalResult.starts`` keeps of one start's solve."""
    return {
        "warm_start": name,
        "status": solved.status,
        "solver_message": solved.message,
        "iterations": solved.iterations,
        "grid_cost": solved.objective,
        "constraint_violation": solved.constraint_violation,
        "seconds": solved.seconds,
    }


def _warm_start(problem: Transcription, run: SimResult) -> np.ndarray:
    """A decision vector from a run: its q and v interpolated at the nodes, a from successive v.

    A run that stopped early is held at its last state for the rest of the movement.
    """
    if not len(run.t):
        raise InvalidInput("the warm-start run has no rows")
    nodes = problem.times
    q = np.column_stack([np.interp(nodes, run.t, column) for column in problem.angles(run.q).T])
    v = np.column_stack([np.interp(nodes, run.t, column) for column in run.v.T])
    beyond = nodes > run.t[-1]
    v[beyond] = 0.0
    acceleration = (v[1:] - v[:-1]) / problem.h
    return problem.join(q, v, acceleration)


def _on_grid(problem: Transcription, w: np.ndarray, times: np.ndarray) -> dict:
    """The planned motion at ``times`` and the RNEA torque at each step's midpoint (the formula of the module docstring)."""
    q_nodes, v_nodes, a_nodes = problem.split(w)
    model, data, robot = problem.model, problem.data, problem.robot
    h, last = problem.h, problem.intervals - 1

    def state(t):
        k = min(int(t // h), last)
        s = t - k * h
        return q_nodes[k] + s * v_nodes[k] + 0.5 * s * s * a_nodes[k], v_nodes[k] + s * a_nodes[k], a_nodes[k]

    rows = [state(t) for t in times]
    q = problem.configurations(np.array([row[0] for row in rows]))
    v = np.array([row[1] for row in rows])
    a = np.array([row[2] for row in rows])
    step = times[1] - times[0]
    torques = np.empty((len(times) - 1, problem.n))
    for row, t in enumerate(times[:-1]):
        angles, velocity, acceleration = state(t + 0.5 * step)
        torques[row] = pin.rnea(model, data, problem.configurations(angles), velocity, acceleration)
    tips = np.array([robot.frame_placement(row, data).translation[robot.task_rows] for row in q])
    return {"q": q, "v": v, "a": a, "tau": torques, "x": tips}
