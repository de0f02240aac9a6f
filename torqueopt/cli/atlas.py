"""``torqueopt atlas``: the stability atlas, how often and where each resolver goes unstable."""

from __future__ import annotations

import argparse
import time

from ..errors import InvalidInput
from ..resolvers import resolver_names
from ..resolvers.options import split_resolver_list
from ..whiplash import DEFAULT_LIMIT_FACTOR
from . import EXIT_OK
from .common import parse_number, parse_positive, parse_vector, parse_whole

__all__ = ["add_parser"]

_PAPER_RESOLVERS = "pinv,inertia-pinv,null-space,weighted-null-space"


def add_parser(subparsers) -> None:
    from ..atlas import DEFAULT_CHUNK_SIZE, DEFAULT_KEEP_TRACES, DEFAULT_MAX_STEPS
    from ..atlas.global_optimum import DEFAULT_GLOBAL_MAX_ITERATIONS, DEFAULT_GLOBAL_MAX_TIME
    from ..atlas.margins import DEFAULT_MARGIN_EVERY
    from ..atlas.verdicts import DEFAULT_ENERGY_FACTOR, DEFAULT_PINV_FACTOR

    parser = subparsers.add_parser(
        "atlas",
        help="stability atlas: a seeded population of movements x resolvers, on a Dask cluster",
        description=(
            "Run every resolver on a seeded population of movements (the paper's straight lines by default; --path min-jerk or circle; random starts and "
            "directions, or a grid over the workspace), judge each run (the 2x-limit rule and a runaway criterion "
            "that separates whiplash from a path that is simply too demanding), and write results.parquet, "
            "atlas.md, atlas.json, figures and explorer.html (a page to explore the runs) into DIR. Runs on a local Dask cluster (one worker per core) or on "
            "--scheduler ADDRESS. Killed and started again with the same command, it resumes where it stopped."
        ),
    )
    parser.add_argument("--robot", default="planar3", help="robot name or URDF (default planar3)")
    parser.add_argument("--frame", help="task frame (default: the robot's end effector)")
    parser.add_argument("--task", help="task: xy or position (default xy for planar3, position otherwise)")
    parser.add_argument(
        "--torque-limit", metavar="TAU", help="symmetric torque limits [N·m], one value or one per joint"
    )
    parser.add_argument("--paths", required=True, metavar="N", help="movements per duration (random mode)")
    parser.add_argument(
        "--durations", default="0.5,1,1.5,2", metavar="T,...", help="movement durations [s] (default 0.5,1,1.5,2)"
    )
    parser.add_argument(
        "--resolvers",
        default=_PAPER_RESOLVERS,
        metavar="NAMES",
        help=(
            f"comma-separated resolvers, of {', '.join(resolver_names())} (default the paper's four; pinv is always "
            "run); a resolver with options as NAME[OPTION=VALUE,...], quoted for the shell, e.g. "
            "'pinv,bounded-torque,bounded-torque[joint_limits=off]': each setting is its own resolver, labelled so "
            "in every table (options: torqueopt resolvers)"
        ),
    )
    parser.add_argument(
        "--out", required=True, metavar="DIR", help="output folder (created if missing; resumed if it holds this atlas)"
    )
    parser.add_argument("--seed", default="0", help="seed of the population (default 0)")
    group = parser.add_argument_group("population")
    group.add_argument(
        "--mode", choices=("random", "grid"), default="random", help="random starts, or a grid of start points"
    )
    group.add_argument(
        "--reach-fraction", default="0.9", metavar="F", help="the whole line within F of the arm's reach (default 0.9)"
    )
    group.add_argument(
        "--min-condition", default="0.05", metavar="C", help="start Jacobian σmin/σmax at least C (default 0.05)"
    )
    group.add_argument(
        "--grid-spacing", default="0.25", metavar="M", help="grid mode: start-point spacing [m] (default 0.25)"
    )
    group.add_argument(
        "--grid-directions", default="8", metavar="K", help="grid mode: directions per start point (default 8)"
    )
    group.add_argument(
        "--path",
        default="line",
        metavar="KIND",
        help="tip paths: line (the paper's bang-bang line), min-jerk (minimum-jerk lines of random length) or "
        "circle (one turn in a random plane about a random centre); default line",
    )
    group.add_argument(
        "--length-range",
        default="0.25,1",
        metavar="LOW,HIGH",
        help="min-jerk: length, circle: circumference, uniform in LOW..HIGH times a·T²/4 (default 0.25,1)",
    )
    group.add_argument(
        "--accel",
        metavar="A",
        help="tangential acceleration a [m/s²] (default: sized to the arm, √2 x reach / 3 m: √2 on planar3)",
    )
    group.add_argument("--dt", default="0.001", help="integration step [s] (default 0.001)")
    group = parser.add_argument_group("verdicts (see torqueopt.atlas.verdicts)")
    group.add_argument(
        "--limit-factor",
        default=repr(DEFAULT_LIMIT_FACTOR),
        metavar="K",
        help="2x-limit rule: unstable above K x the limit (default 2)",
    )
    group.add_argument(
        "--pinv-factor",
        default=repr(DEFAULT_PINV_FACTOR),
        metavar="K",
        help=f"runaway above K x pinv's peak torque on the path (default {DEFAULT_PINV_FACTOR:g})",
    )
    group.add_argument(
        "--energy-factor",
        default=repr(DEFAULT_ENERGY_FACTOR),
        metavar="K",
        help=f"runaway when self-motion energy exceeds K x the task's (default {DEFAULT_ENERGY_FACTOR:g})",
    )
    group = parser.add_argument_group("execution")
    group.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a local cluster)",
    )
    group.add_argument(
        "--workers", metavar="N", help="local cluster worker processes (default: the machine's cores; 0: no Dask)"
    )
    group.add_argument(
        "--chunk-size",
        default=str(DEFAULT_CHUNK_SIZE),
        metavar="N",
        help=f"movements per chunk of work (default {DEFAULT_CHUNK_SIZE})",
    )
    group.add_argument(
        "--max-steps",
        default=f"{DEFAULT_MAX_STEPS:.0e}",
        metavar="N",
        help="refuse sweeps of more trajectory-steps (default 1e10)",
    )
    group.add_argument("--no-batch", action="store_true", help="simulate each movement alone (the reference path)")
    group.add_argument("--no-progress", action="store_true", help="no progress bar")
    group.add_argument(
        "--no-figures", action="store_true", help="skip the figures and explorer.html (no traces are kept)"
    )
    group.add_argument(
        "--keep-traces",
        default=str(DEFAULT_KEEP_TRACES),
        metavar="N",
        help=(
            f"explorer.html keeps the runs of N paths (default {DEFAULT_KEEP_TRACES}): every resolver's torque, the "
            "arm at the instability; paths where a resolver whips first, then the others, simulated again after "
            "the sweep; 0: the map only"
        ),
    )
    group = parser.add_argument_group("the global optimum and the stability margin")
    group.add_argument(
        "--global",
        dest="global_optimum",
        action="store_true",
        help=(
            "also run torqueopt.optimize on every movement: rows with resolver global-optimum (judged from the "
            "open-loop replay of its torques) and the columns cost_vs_global, peak_vs_global on every row"
        ),
    )
    group.add_argument(
        "--global-max-iterations",
        default=str(DEFAULT_GLOBAL_MAX_ITERATIONS),
        metavar="N",
        help=f"IPOPT iterations per Hessian tried, per path (default {DEFAULT_GLOBAL_MAX_ITERATIONS})",
    )
    group.add_argument(
        "--global-max-time",
        default=f"{DEFAULT_GLOBAL_MAX_TIME:g}",
        metavar="S",
        help=f"wall time of one path's solve [s] (default {DEFAULT_GLOBAL_MAX_TIME:g})",
    )
    group.add_argument(
        "--margin",
        action="store_true",
        help="record peak_stability_margin and margin_warning_time per row (the margin on a subsample of each run)",
    )
    group.add_argument(
        "--margin-every",
        default=f"{DEFAULT_MARGIN_EVERY:g}",
        metavar="S",
        help=f"time between the states whose margin is evaluated [s] (default {DEFAULT_MARGIN_EVERY:g})",
    )
    parser.set_defaults(handler=atlas_command)


def path_kind(text: str) -> str:
    """``text`` when it names a kind of path of the atlas (``--path``), else InvalidInput listing them."""
    from ..atlas.population import PATH_KINDS

    if text not in PATH_KINDS:
        raise InvalidInput(
            f"--path: '{text}' is not a kind of path for the atlas; choose one of {', '.join(PATH_KINDS)}"
        )
    return text


def atlas_command(args: argparse.Namespace) -> int:
    from ..atlas import run_atlas
    from ..atlas.sweep import RobotSpec

    started = time.perf_counter()
    durations = tuple(parse_vector(args.durations, "durations").tolist())
    resolvers = split_resolver_list(args.resolvers)
    torque_limit = (
        None if args.torque_limit is None else tuple(parse_vector(args.torque_limit, "torque-limit").tolist())
    )
    spec = RobotSpec(args.robot, frame=args.frame, task=args.task, torque_limit=torque_limit)
    result = run_atlas(
        spec,
        paths=parse_whole(args.paths, "paths", 1),
        durations=durations,
        resolvers=resolvers,
        out=args.out,
        seed=parse_whole(args.seed, "seed"),
        scheduler=args.scheduler,
        workers=None if args.workers is None else parse_whole(args.workers, "workers"),
        chunk_size=parse_whole(args.chunk_size, "chunk-size", 1),
        mode=args.mode,
        reach_fraction=parse_positive(args.reach_fraction, "reach-fraction"),
        min_condition=parse_number(args.min_condition, "min-condition"),
        grid_spacing=parse_positive(args.grid_spacing, "grid-spacing"),
        grid_directions=parse_whole(args.grid_directions, "grid-directions", 1),
        accel=None if args.accel is None else parse_positive(args.accel, "accel"),
        path=path_kind(args.path),
        length_range=tuple(parse_vector(args.length_range, "length-range", 2).tolist()),
        dt=parse_positive(args.dt, "dt"),
        limit_factor=parse_positive(args.limit_factor, "limit-factor"),
        pinv_factor=parse_positive(args.pinv_factor, "pinv-factor"),
        energy_factor=parse_positive(args.energy_factor, "energy-factor"),
        batch=not args.no_batch,
        progress=not args.no_progress,
        figures=not args.no_figures,
        max_steps=parse_whole(args.max_steps, "max-steps", 1),
        keep_traces=parse_whole(args.keep_traces, "keep-traces"),
        global_optimum=args.global_optimum,
        global_max_iterations=parse_whole(args.global_max_iterations, "global-max-iterations", 1),
        global_max_time=parse_positive(args.global_max_time, "global-max-time"),
        margin=args.margin,
        margin_every=parse_positive(args.margin_every, "margin-every"),
    )
    summary = result.summary
    width = max([22, *(len(resolver) + 2 for resolver in summary["resolvers"])])
    print(
        f"{'resolver':<{width}}"
        + "".join(f"{f'T={d:g} s':>12}" for d in summary["durations"])
        + "   (unstable by the 2x-limit rule / whiplash verdict)"
    )
    for resolver in summary["resolvers"]:
        cells = []
        for duration in summary["durations"]:
            parts = []
            for criterion in ("unstable", "whiplash"):
                item = next(
                    i
                    for i in summary["unstable_fraction"][criterion]
                    if i["resolver"] == resolver and i["duration"] == duration
                )
                parts.append(f"{item['fraction']:.0%}")
            cells.append(f"{'/'.join(parts):>12}")
        print(f"{resolver:<{width}}" + "".join(cells))
    for claim in summary["claims"]["whiplash"]:
        # These are the whiplash verdict's figures (the 2x-limit rule's are in atlas.md): the line says so.
        figure = claim["figure"].replace(" unstable", " whips")
        print(f'claim ({claim["holds"]}, by the whiplash verdict): "{claim["paper"]}": {figure}: {claim["text"]}')
    resumed = summary.get("resumed_chunks", 0)
    note = f", {resumed} chunks resumed from an earlier run" if resumed else ""
    written = (
        "results.parquet, atlas.md, atlas.json, figures and explorer.html"
        if not args.no_figures
        else ("results.parquet, atlas.md and atlas.json")
    )
    print(f"wrote {result.out}/{written} in {time.perf_counter() - started:.1f} s{note}")
    return EXIT_OK
