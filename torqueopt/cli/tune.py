"""``torqueopt tune``: a remedy's options chosen per arm from a seeded atlas (``torqueopt.tune``)."""

from __future__ import annotations

import argparse
import re
import time
from dataclasses import dataclass

from ..settings import setting
from . import EXIT_NONE_QUALIFIES, EXIT_OK
from .atlas import AtlasRobotSettings, robot_spec
from .common import importable_from_here

__all__ = ["add_parser"]


@dataclass(frozen=True)
class TuneRobotSettings(AtlasRobotSettings):
    """The arm a tune is for (``--robot`` required)."""

    robot: str | None = setting(None, "robot name or URDF (panda, xarm7, tiago, baxter, ...)", cli_required=True)


def add_parser(subparsers) -> None:
    from ..tune import TuneSettings, default_grids_text

    parser = subparsers.add_parser(
        "tune",
        help="choose a remedy's options on an arm: the largest torque saving without whiplash or leaving a limit",
        description=(
            "Run a seeded atlas of pinv and a grid of a resolver's settings on one arm and choose the setting with "
            "the largest median torque saving against pinv among those that, on the paths pinv handles (stable, "
            "within its torque limits), whip with a Wilson 95 % upper bound of at most --whiplash-bound and stay "
            "within the torque, position and velocity limits wherever pinv does. Prints the --option flags that "
            "reproduce it; writes tune.json and tune.md (the evidence table) into --out. pinv runs first; the "
            "settings then run on the paths it handles, longest first, each dropped once it is certain to fail. Exit 4 when no setting "
            f"qualifies. Default grids: {default_grids_text()}."
        ),
    )
    TuneRobotSettings.add_arguments(parser)
    TuneSettings.add_arguments(parser)
    parser.set_defaults(handler=tune_command)


def tune_command(args: argparse.Namespace) -> int:
    from ..tune import TuneSettings, tune

    started = time.perf_counter()
    importable_from_here(args.resolver)
    given = {"robot": robot_spec(args)}
    if args.out is None:
        robot = args.robot.rsplit("/", 1)[-1].removesuffix(".urdf")  # a URDF's stem: tune-arm, not tune-arm.urdf
        given["out"] = "tune-" + re.sub(r"[^A-Za-z0-9_.-]+", "-", robot)
    result = tune(TuneSettings.from_arguments(args, **given))
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
