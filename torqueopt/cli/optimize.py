"""``torqueopt optimize``: the torque-optimal motion for a whole straight-line movement."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

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
from ..settings import Settings, group, numbers, positive, positive_in, setting, time_step, whole, whole_at_least
from . import EXIT_OK, EXIT_STOPPED
from .common import OptionalRobotSettings, RestStartSettings, sized, torque_table
from .paths import PathSettings

__all__ = ["OptimizeSettings", "add_parser", "format_optimal_summary"]


def _weight(text: str, name: str) -> str | tuple[float, ...]:
    return text if text in WEIGHTS else numbers()(text, name)


@dataclass(frozen=True)
class SolverSettings(Settings):
    """The keywords of :func:`torqueopt.optimize` the command line gives, at the same defaults (a test holds
    them to its signature); ``weight`` a name or the diagonal's numbers, checked against the arm when it loads."""

    TITLE = "optimisation"

    dt: float = time_step(
        "simulation grid of the result, its cost and the replay [s]; must divide the duration (default 0.001)",
        section="movement",
    )
    weight: str | tuple[float, ...] = setting(
        "identity",
        f"torque weight: {', '.join(WEIGHTS)} (S = diag(2/(τ⁺−τ⁻)), Eq. (33)) or the diagonal of W, one value "
        "per joint (default identity)",
        metavar="W",
        parse=_weight,
    )
    end: str = setting("rest", "end at rest (v(T) = 0) or free (default rest)", choices=ENDS)
    torque_bounds: bool = setting(False, "impose τ⁻ ≤ τ ≤ τ⁺ as hard constraints", switch="on")
    joint_limits: bool = setting(False, "impose the URDF's joint position and velocity limits", switch="on")
    grid_step: float = setting(
        DEFAULT_GRID_STEP,
        f"longest transcription interval [s] (default {DEFAULT_GRID_STEP})",
        unit="s",
        check=positive_in("s"),
        parse=positive,
        metavar="H",
    )
    warm_start: str = setting(
        "pinv", lambda: f"resolver whose run starts the solve: {', '.join(resolver_names())}", metavar="RESOLVER"
    )
    transcription: str = setting(
        "shooting",
        "direct (Pinocchio's first derivatives, --hessian) or shooting (the same program with CasADi's exact "
        "derivatives, solved from the warm start and a damped null-space run, the best kept) (default shooting)",
        choices=TRANSCRIPTIONS,
    )
    compiled: bool = setting(
        False,
        "with --transcription shooting: compile the problem's functions to C once (kept in ~/.cache/torqueopt)",
        switch="on",
    )
    hessian: str = setting(
        "auto",
        "Hessian of the Lagrangian: gauss-newton, limited-memory (L-BFGS), or auto: Gauss-Newton, then "
        "L-BFGS from where it stopped if it did not converge (default auto)",
        choices=HESSIANS,
    )
    tolerance: float = setting(1e-8, "IPOPT tolerance (default 1e-8)", check=positive_in(), parse=positive)
    max_iterations: int = setting(
        500,
        "IPOPT iteration limit of each run (default 500)",
        check=whole_at_least(1, MAX_ITERATIONS),
        parse=whole(1, MAX_ITERATIONS),
        metavar="N",
    )
    max_nonzeros: int = setting(
        DEFAULT_MAX_NONZEROS,
        "refuse a transcription of more than N nonzeros (constraint Jacobian and Hessian, about 280 bytes "
        f"each), counted before it is built (default {DEFAULT_MAX_NONZEROS:.0e})",
        check=whole_at_least(1),
        parse=whole(1),
        metavar="N",
    )
    max_time: float | None = setting(
        None,
        "wall-time limit [s]: of each IPOPT run, and no start begins once it is spent (shooting); of the whole "
        "solve (direct) (default none)",
        unit="s",
        parse=positive,
        metavar="SECONDS",
    )
    verbose: bool = setting(False, "print IPOPT's iteration log", switch="on")


@dataclass(frozen=True)
class OptimizeSettings(Settings):
    """Every setting of ``torqueopt optimize``."""

    TITLE = "optimisation"

    model: OptionalRobotSettings = group(OptionalRobotSettings)
    start: RestStartSettings = group(RestStartSettings)
    tip_path: PathSettings = group(PathSettings)
    solver: SolverSettings = group(SolverSettings)
    out: str | None = setting(
        None,
        "write the run: .csv (with .csv.json and .csv.optimal.json) or .npz; with --paper, the study's folder",
        metavar="PATH",
    )
    paper: bool = setting(
        False,
        "run the local-against-global study on the paper's arm and movements instead; needs --out DIR "
        "(writes global.md, global.json and figures)",
        switch="on",
    )


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "optimize",
        help="whole-movement torque optimisation (multiple shooting, IPOPT)",
        description=(
            "Find the joint motion that keeps the task frame on a tip path (the paper's straight line by "
            "default; --path as for run) and minimises "
            "the integral of |S(tau - tau_mid)|^2 over the whole movement, starting at rest at q0 "
            "(multiple shooting with CasADi's exact derivatives, or --transcription direct, IPOPT). The torques are "
            "replayed open loop through the simulation's RK4 and the cost is evaluated on the simulation "
            "grid. With --paper, run the local-against-global study on the paper's arm instead and write "
            "global.md, global.json and figures into --out DIR. Exit 0 when IPOPT converged, 3 when it "
            "stopped short (iteration or time limit, infeasible, failed): the last iterate is still "
            "written and labelled as such."
        ),
    )
    OptimizeSettings.add_arguments(parser)
    parser.set_defaults(handler=optimize_command)


def optimize_command(args: argparse.Namespace) -> int:
    settings = OptimizeSettings.from_arguments(args)
    if settings.paper:
        return _paper_study(settings.out)
    if settings.model.robot is None:
        raise InvalidInput("give --robot (or --paper --out DIR for the local-against-global study)")
    trajectory = settings.tip_path.trajectory(settings.start.degrees)
    robot = settings.model.load("optimize")
    solver = settings.solver.as_keywords()
    if solver["weight"] not in WEIGHTS:
        solver["weight"] = sized(solver["weight"], "weight", robot.nv)
    q0 = settings.start.configuration(robot)
    if settings.out:
        writable_paths(OptimalResult.files(settings.out))
    intervals = transcription_intervals(trajectory.duration, solver["grid_step"])
    max_iterations = solver["max_iterations"]
    description = (
        f"torqueopt optimize: IPOPT on {intervals:,} intervals of {trajectory.duration / intervals * 1e3:.4g} ms "
        f"(up to {max_iterations} iterations per run)"
    )
    bars = []
    interrupted: list = []

    def iteration(number: int) -> bool:
        # The bar (or its one line) starts with IPOPT's first iteration, after every check has passed.
        if not bars:
            bars.append(
                progress_bar(description, total=max_iterations, unit="iteration", enabled=not solver["verbose"])
            )
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
                **solver,
                progress=iteration,
            )
    finally:
        for bar in bars:
            bar.close()
    # Files first, then the summary, so that a closed stdout cannot cost a result.
    lines = []
    if settings.out:
        result.to_csv(settings.out)
        *files, optimal = OptimalResult.files(settings.out)
        lines.append(f"wrote {', '.join(map(str, files))} and {optimal}")
    print(format_optimal_summary(robot, result))
    for line in lines:
        print(line)
    return EXIT_OK if result.optimal else EXIT_STOPPED


def _paper_study(folder: str | None) -> int:
    from ..studies import local_global

    if not folder:
        raise InvalidInput("--paper needs --out DIR, the folder for global.md, global.json and the figures")
    out = writable_path(folder, directory=True)
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
    lines += torque_table(result)
    lines.append(
        f"open-loop RK4 replay: max tip error {result.replay_tip_error * 1e3:.4g} mm "
        f"(plan between nodes: {result.plan_tip_error * 1e3:.3g} mm)"
    )
    return "\n".join(lines)
