"""``torqueopt optimize``: the torque-optimal motion for a whole straight-line movement."""

from __future__ import annotations

import argparse

from ..errors import InvalidInput
from ..io import writable_path, writable_paths
from ..optimal import (
    DEFAULT_GRID_STEP,
    DEFAULT_MAX_NONZEROS,
    ENDS,
    HESSIANS,
    TRANSCRIPTIONS,
    WEIGHTS,
    OptimalResult,
    optimize,
)
from ..optimal.whole_path import MAX_ITERATIONS, transcription_intervals
from ..progress import interrupt_deferred, progress_bar
from ..resolvers import resolver_names
from ..robot import Robot
from ..units import joint_unit
from . import EXIT_OK, EXIT_STOPPED
from .common import (
    add_robot_options,
    add_start_options,
    parse_positive,
    parse_vector,
    parse_whole,
    robot_from_args,
    start_from_args,
    torque_table,
)
from .paths import add_path_options, trajectory_from_args

__all__ = ["add_parser", "format_optimal_summary"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "optimize",
        help="whole-movement torque optimisation (direct transcription, IPOPT)",
        description=(
            "Find the joint motion that keeps the task frame on a tip path (the paper's straight line by "
            "default; --path as for run) and minimises "
            "the integral of |S(tau - tau_mid)|^2 over the whole movement, starting at rest at q0 "
            "(direct transcription, Pinocchio's analytical derivatives, IPOPT from casadi). The torques are "
            "replayed open loop through the simulation's RK4 and the cost is evaluated on the simulation "
            "grid. With --paper, run the local-against-global study on the paper's arm instead and write "
            "global.md, global.json and figures into --out DIR. Exit 0 when IPOPT converged, 3 when it "
            "stopped short (iteration or time limit, infeasible, failed): the last iterate is still "
            "written and labelled as such."
        ),
    )
    add_robot_options(parser, required=False)  # --paper needs none
    group = parser.add_argument_group("movement")
    add_start_options(group)
    add_path_options(group)
    group.add_argument(
        "--dt",
        default="0.001",
        help="simulation grid of the result, its cost and the replay [s]; must divide the duration (default 0.001)",
    )
    group = parser.add_argument_group("optimisation")
    group.add_argument(
        "--weight",
        default="identity",
        metavar="W",
        help=f"torque weight: {', '.join(WEIGHTS)} (S = diag(2/(τ⁺−τ⁻)), Eq. (33)) or the diagonal of W, one value "
        "per joint (default identity)",
    )
    group.add_argument("--end", default="rest", choices=ENDS, help="end at rest (v(T) = 0) or free (default rest)")
    group.add_argument("--torque-bounds", action="store_true", help="impose τ⁻ ≤ τ ≤ τ⁺ as hard constraints")
    group.add_argument(
        "--joint-limits", action="store_true", help="impose the URDF's joint position and velocity limits"
    )
    group.add_argument(
        "--grid-step",
        default=repr(DEFAULT_GRID_STEP),
        metavar="H",
        help=f"longest transcription interval [s] (default {DEFAULT_GRID_STEP})",
    )
    group.add_argument(
        "--warm-start",
        default="pinv",
        metavar="RESOLVER",
        help=f"resolver whose run starts the solve: {', '.join(resolver_names())}",
    )
    group.add_argument(
        "--transcription",
        default="shooting",
        choices=TRANSCRIPTIONS,
        help="direct (Pinocchio's first derivatives, --hessian) or shooting (the same program with CasADi's exact "
        "derivatives, solved from the warm start and a damped null-space run, the best kept) (default shooting)",
    )
    group.add_argument(
        "--compiled",
        action="store_true",
        help="with --transcription shooting: compile the problem's functions to C once (kept in ~/.cache/torqueopt)",
    )
    group.add_argument(
        "--hessian",
        default="auto",
        choices=HESSIANS,
        help="Hessian of the Lagrangian: gauss-newton, limited-memory (L-BFGS), or auto: Gauss-Newton, then "
        "L-BFGS from where it stopped if it did not converge (default auto)",
    )
    group.add_argument("--tolerance", default="1e-8", help="IPOPT tolerance (default 1e-8)")
    group.add_argument(
        "--max-iterations", default="500", metavar="N", help="IPOPT iteration limit of each run (default 500)"
    )
    group.add_argument(
        "--max-nonzeros",
        default=f"{DEFAULT_MAX_NONZEROS:.0e}",
        metavar="N",
        help="refuse a transcription of more than N nonzeros (constraint Jacobian and Hessian, about 280 bytes "
        f"each), counted before it is built (default {DEFAULT_MAX_NONZEROS:.0e})",
    )
    group.add_argument("--max-time", metavar="SECONDS", help="wall-time limit of the solve [s] (default none)")
    group.add_argument("--verbose", action="store_true", help="print IPOPT's iteration log")
    group.add_argument(
        "--out",
        metavar="PATH",
        help="write the run: .csv (with .csv.json and .csv.optimal.json) or .npz; with --paper, the study's folder",
    )
    group.add_argument(
        "--paper",
        action="store_true",
        help="run the local-against-global study on the paper's arm and movements instead; needs --out DIR "
        "(writes global.md, global.json and figures)",
    )
    parser.set_defaults(handler=optimize_command)


def optimize_command(args: argparse.Namespace) -> int:
    if args.paper:
        return _paper_study(args)
    if args.robot is None:
        raise InvalidInput("give --robot (or --paper --out DIR for the local-against-global study)")
    trajectory = trajectory_from_args(args)
    dt = parse_positive(args.dt, "dt")
    grid_step = parse_positive(args.grid_step, "grid-step")
    tolerance = parse_positive(args.tolerance, "tolerance")
    max_iterations = parse_whole(args.max_iterations, "max-iterations", minimum=1, maximum=MAX_ITERATIONS)
    max_time = None if args.max_time is None else parse_positive(args.max_time, "max-time")
    max_nonzeros = parse_whole(args.max_nonzeros, "max-nonzeros", minimum=1)
    robot = robot_from_args(args)
    weight = args.weight if args.weight in WEIGHTS else parse_vector(args.weight, "weight", robot.nv)
    q0 = start_from_args(args, robot)
    if args.out:
        writable_paths(OptimalResult.files(args.out))
    intervals = transcription_intervals(trajectory.duration, grid_step)
    description = (
        f"torqueopt optimize: IPOPT on {intervals:,} intervals of {trajectory.duration / intervals * 1e3:.4g} ms "
        f"(up to {max_iterations} iterations per run)"
    )
    bars = []
    interrupted: list = []

    def iteration(number: int) -> bool:
        # The bar (or its one line) starts with IPOPT's first iteration, after every check has passed.
        if not bars:
            bars.append(progress_bar(description, total=max_iterations, unit="iteration", enabled=not args.verbose))
        bars[0].n = number  # each IPOPT run counts from 0
        bars[0].refresh()
        return bool(interrupted)  # a Ctrl-C stops IPOPT at its next iteration (and any run after it at its first)

    # IPOPT runs in C++ where Python hears no Ctrl-C: it is held here, read at each iteration, and raised once the
    # solve has stopped, before any file is written.
    try:
        with interrupt_deferred() as interrupted:
            result = optimize(
                robot,
                trajectory,
                q0,
                weight=weight,
                end=args.end,
                torque_bounds=args.torque_bounds,
                joint_limits=args.joint_limits,
                dt=dt,
                grid_step=grid_step,
                warm_start=args.warm_start,
                transcription=args.transcription,
                compiled=args.compiled,
                hessian=args.hessian,
                tolerance=tolerance,
                max_iterations=max_iterations,
                max_time=max_time,
                max_nonzeros=max_nonzeros,
                verbose=args.verbose,
                progress=iteration,
            )
    finally:
        for bar in bars:
            bar.close()
    # Files first, then the summary, so that a closed stdout cannot cost a result.
    lines = []
    if args.out:
        result.to_csv(args.out)
        *files, optimal = OptimalResult.files(args.out)
        lines.append(f"wrote {', '.join(map(str, files))} and {optimal}")
    print(format_optimal_summary(robot, result))
    for line in lines:
        print(line)
    return EXIT_OK if result.optimal else EXIT_STOPPED


def _paper_study(args: argparse.Namespace) -> int:
    from ..studies import local_global

    if not args.out:
        raise InvalidInput("--paper needs --out DIR, the folder for global.md, global.json and the figures")
    out = writable_path(args.out, directory=True)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"--out '{out}' exists and is not a folder")
    writable_paths(local_global.local_global_files(out))
    study = local_global.run_local_global(progress=True)
    for path in local_global.write_local_global(study, out):
        print(f"wrote {path}")
    return EXIT_OK if study.all_optimal else EXIT_STOPPED


def format_optimal_summary(robot: Robot, result: OptimalResult) -> str:
    """A short human-readable report of an optimisation."""
    unit = "N²·m²·s" if result.weight == "identity" else "s (weighted)" if result.weight == "range" else "(user weight)"
    verdict = (
        "optimal (IPOPT converged)" if result.optimal else f"NOT OPTIMAL: {result.status} ({result.solver_message})"
    )
    lines = [
        f"{result.robot}: whole-path torque optimisation, task {result.task} at frame '{result.frame}' "
        f"(n={robot.nv}, m={robot.m}), {result.grid_intervals} intervals of {result.grid_step * 1e3:.4g} ms, "
        f"end {result.end}, weight {result.weight}"
        + (", torque bounds" if result.torque_bounds else "")
        + (", joint limits" if result.joint_limits else ""),
        f"status: {verdict}, {result.iterations} iterations ({result.hessian}), {result.solve_seconds:.2f} s",
        (
            f"cost on the {result.dt * 1e3:g} ms grid: {result.cost:.6g} {unit} "
            f"(warm start {result.warm_start}: {result.warm_start_cost:.6g})"
        ),
    ]
    for start in result.starts:
        lines.append(
            f"  start {start['warm_start']}: {start['status']} ({start['solver_message']}), {start['iterations']} "
            f"iterations, grid cost {start['grid_cost']:.6g}, {start['seconds']:.2f} s"
        )
    if result.feasibility:
        lines.append(f"  phase-1: {result.feasibility['evidence']}")
    kinds = result.joint_kinds or [None] * len(result.joint_names)
    lines += torque_table(
        result.joint_names,
        result.peak_torque,
        result.torque_upper,
        result.peak_torque_ratio,
        [joint_unit(kind, "torque") for kind in kinds],
    )
    lines.append(
        f"open-loop RK4 replay: max tip error {result.replay_tip_error * 1e3:.4g} mm "
        f"(plan between nodes: {result.plan_tip_error * 1e3:.3g} mm)"
    )
    return "\n".join(lines)
