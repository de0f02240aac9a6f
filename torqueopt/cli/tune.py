"""``torqueopt tune``: a remedy's options chosen per arm from a seeded atlas (``torqueopt.tune``)."""

from __future__ import annotations

import argparse
import re
import time

from ..errors import InvalidInput
from . import EXIT_NONE_QUALIFIES, EXIT_OK
from .atlas import path_kind
from .common import parse_number, parse_positive, parse_vector, parse_whole

__all__ = ["add_parser"]


def add_parser(subparsers) -> None:
    from ..resolvers.options import label_value
    from ..tune import DEFAULT_CHUNK_SIZE, DEFAULT_GRIDS, DEFAULT_MAX_STEPS, DEFAULT_PATHS, MAX_SETTINGS

    grids = "; ".join(
        f"{name}: "
        + " x ".join(f"{option} {','.join(label_value(v) for v in values)}" for option, values in grid.items())
        for name, grid in DEFAULT_GRIDS.items()
    )
    parser = subparsers.add_parser(
        "tune",
        help="choose a remedy's options on an arm: the largest torque saving without whiplash or leaving a limit",
        description=(
            "Run a seeded atlas of pinv and a grid of a resolver's settings on one arm and choose the setting with "
            "the largest median torque saving against pinv among those that, on the paths pinv handles (stable, "
            "within its torque limits), whip with a Wilson 95 %% upper bound of at most --whiplash-bound and stay "
            "within the torque, position and velocity limits wherever pinv does. Prints the --option flags that "
            "reproduce it; writes tune.json and tune.md (the evidence table) into --out. pinv runs first; the "
            "settings then run on the paths it handles, longest first, each dropped once it is certain to fail. Exit 4 when no setting "
            f"qualifies. Default grids: {grids}."
        ),
    )
    parser.add_argument("--robot", required=True, help="robot name or URDF (panda, xarm7, tiago, baxter, ...)")
    parser.add_argument("--frame", help="task frame (default: the robot's end effector)")
    parser.add_argument("--task", help="task: xy or position (default xy for planar3, position otherwise)")
    parser.add_argument("--torque-limit", metavar="TAU", help="symmetric torque limits [N·m], one or one per joint")
    parser.add_argument("--resolver", default="damped-null-space", help="resolver to tune (default damped-null-space)")
    parser.add_argument(
        "--values",
        action="append",
        default=[],
        metavar="NAME=V1,V2,...",
        help=f"an option of the grid and its values, repeatable (replaces the default grid; at most {MAX_SETTINGS} "
        "settings in all)",
    )
    parser.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="an option held fixed in every setting, repeatable (e.g. --option torque_weight=range)",
    )
    parser.add_argument(
        "--paths", default=str(DEFAULT_PATHS), metavar="N", help=f"movements per duration (default {DEFAULT_PATHS})"
    )
    parser.add_argument(
        "--chunk-size",
        default=str(DEFAULT_CHUNK_SIZE),
        metavar="N",
        help=f"paths per chunk of the settings' runs; settings certain to fail are dropped between chunks "
        f"(default {DEFAULT_CHUNK_SIZE})",
    )
    parser.add_argument(
        "--durations", default="0.5,1,1.5,2", metavar="T,...", help="movement durations [s] (default 0.5,1,1.5,2)"
    )
    parser.add_argument("--seed", default="0", help="seed of the population (default 0)")
    parser.add_argument(
        "--out", metavar="DIR", help="output folder (default tune-ROBOT; resumed if it holds this tune)"
    )
    parser.add_argument(
        "--whiplash-bound",
        default="0.01",
        metavar="P",
        help="largest Wilson 95 %% upper bound of a qualifying whiplash rate (default 0.01)",
    )
    parser.add_argument("--path", default="line", metavar="KIND", help="line, min-jerk or circle (default line)")
    parser.add_argument(
        "--accel", metavar="A", help="acceleration [m/s²] (default: sized to the arm, √2 x reach / 3 m)"
    )
    parser.add_argument("--dt", default="0.001", help="integration step [s] (default 0.001)")
    parser.add_argument(
        "--workers", metavar="N", help="local Dask worker processes (default: the machine's cores; 0: no Dask)"
    )
    parser.add_argument(
        "--max-steps",
        default=f"{DEFAULT_MAX_STEPS:.0e}",
        metavar="N",
        help="refuse tunes of more trajectory-steps, pinv and every setting on every path (default 1e9)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.set_defaults(handler=tune_command)


def _pairs(texts: list[str], flag: str, example: str) -> dict[str, str]:
    pairs = {}
    for text in texts:
        name, separator, value = text.partition("=")
        name = name.strip()
        if not separator or not name or not value.strip():
            raise InvalidInput(f"{flag} '{text}' must be NAME=VALUE, e.g. {flag} {example}")
        if name in pairs:
            raise InvalidInput(f"{flag} {name} is given twice; give it once")
        pairs[name] = value.strip()
    return pairs


def tune_command(args: argparse.Namespace) -> int:
    from ..atlas.sweep import RobotSpec
    from ..tune import tune

    started = time.perf_counter()
    values = _pairs(args.values, "--values", "damping=5,10,20")
    grid = {name: [v.strip() for v in text.split(",")] for name, text in values.items()} or None
    if grid and any(not v for vs in grid.values() for v in vs):
        raise InvalidInput("--values: an empty value between commas; give NAME=V1,V2,...")
    options = _pairs(args.option, "--option", "torque_weight=range")
    torque_limit = (
        None if args.torque_limit is None else tuple(parse_vector(args.torque_limit, "torque-limit").tolist())
    )
    spec = RobotSpec(args.robot, frame=args.frame, task=args.task, torque_limit=torque_limit)
    out = args.out if args.out else "tune-" + re.sub(r"[^A-Za-z0-9_.-]+", "-", args.robot.rsplit("/", 1)[-1])
    result = tune(
        spec,
        args.resolver,
        grid=grid,
        options=options,
        paths=parse_whole(args.paths, "paths", 1),
        chunk_size=parse_whole(args.chunk_size, "chunk-size", 1),
        durations=tuple(parse_vector(args.durations, "durations").tolist()),
        seed=parse_whole(args.seed, "seed"),
        out=out,
        whiplash_bound=parse_number(args.whiplash_bound, "whiplash-bound"),
        workers=None if args.workers is None else parse_whole(args.workers, "workers"),
        accel=None if args.accel is None else parse_positive(args.accel, "accel"),
        path=path_kind(args.path),
        dt=parse_positive(args.dt, "dt"),
        progress=not args.no_progress,
        max_steps=parse_whole(args.max_steps, "max-steps", 1),
    )
    width = max(len(_options_text(row)) for row in result.settings) + 2
    print(f"{'setting':<{width}}{'P':>6}{'whips [95% upper]':>20}{'over limits':>13}{'saving':>9}  qualifies")
    for row in result.settings:
        upper = "-" if row["whip_high"] is None else f"{row['whip_high']:.1%}"
        saving = "-" if row["saving"] is None or row["saving"] != row["saving"] else f"{row['saving']:+.1%}"
        whips = f"{row['whips']} [{upper}]"
        print(
            f"{_options_text(row):<{width}}{row['pinv_handles']:>6}{whips:>20}"
            f"{row['over_limits']:>13}{saving:>9}  {'yes' if row['qualifies'] else 'no: ' + row['reason']}"
        )
    elapsed = time.perf_counter() - started
    if result.chosen is None:
        print(f"no setting of {result.resolver} qualifies on {result.summary['robot_name']}: see the table")
        print(f"wrote {result.out}/tune.json and tune.md in {elapsed:.1f} s")
        return EXIT_NONE_QUALIFIES
    print(f"chosen: {result.chosen['flags']}")
    print(f"wrote {result.out}/tune.json and tune.md in {elapsed:.1f} s")
    return EXIT_OK


def _options_text(row: dict) -> str:
    from ..resolvers.options import label_value

    return ", ".join(f"{k}={label_value(v)}" for k, v in row["options"].items()) or "defaults"
