"""``torqueopt plot --stick-figures``: stick figures of a saved run, with dexterity ellipses."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..checks import parse_vector
from ..errors import InvalidInput
from ..payload import Payload
from ..plots import plot_stick_strip
from ..plots.stick import SNAPSHOTS_RANGE
from ..result import SimResult
from ..robot import Robot
from ..run_robot import robot_of_run
from .common import OptionalRobotSettings

__all__ = ["add_stick_options", "check_stick_options", "stick_figure_path", "stick_robot", "write_stick_figures"]

#: The stick figures' defaults: a velocity ellipse at the tip, 8 snapshots.
DEFAULT_ELLIPSE = "velocity"
DEFAULT_SNAPSHOTS = 8

ELLIPSES = ("velocity", "acceleration", "none")


def add_stick_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("stick figures")
    group.add_argument(
        "--stick-figures",
        action="store_true",
        help="also draw stick figures of the arm with a dexterity ellipse at the tip, into OUT-stick.png",
    )
    group.add_argument(
        "--ellipse",
        choices=ELLIPSES,
        default=None,
        help="with --stick-figures: velocity (J q̇, ‖q̇‖ ≤ 1), acceleration (Eq. (24), torque-normalised) or none "
        "(default velocity)",
    )
    group.add_argument(
        "--snapshots",
        type=_snapshots,
        default=None,
        help=f"with --stick-figures: how many ({SNAPSHOTS_RANGE[0]} to {SNAPSHOTS_RANGE[1]}, default 8)",
    )
    OptionalRobotSettings.add_arguments(parser)
    # The run records its robot: --robot and the options beside it only override.
    for action in parser._actions:
        if action.dest == "robot":
            action.help = "robot the run was simulated with (default: the name the run records) " + action.help


def write_stick_figures(args: argparse.Namespace, robot: Robot, result: SimResult, figure: Path) -> Path:
    """Draw the stick figures of ``result`` beside ``figure`` (as ``<stem>-stick.png``)."""
    path = stick_figure_path(figure)
    chosen = args.ellipse or DEFAULT_ELLIPSE
    ellipse = None if chosen == "none" else chosen
    title = f"{result.robot}: resolver {result.resolver}, {len(result.t)} rows" + (
        f", {ellipse} ellipses" if ellipse else ""
    )
    return plot_stick_strip(
        robot, result, path, title=title, snapshots=args.snapshots or DEFAULT_SNAPSHOTS, ellipse=ellipse
    )


def check_stick_options(args: argparse.Namespace) -> None:
    """--ellipse and --snapshots shape the stick figures: given without --stick-figures they would do nothing."""
    if args.stick_figures:
        return
    for option, value in (("--ellipse", args.ellipse), ("--snapshots", args.snapshots)):
        if value is not None:
            raise InvalidInput(f"{option} {value} shapes the stick figures, which are not drawn: add --stick-figures")


def stick_figure_path(figure) -> Path:
    """Where the stick figures beside ``figure`` go: ``<stem>-stick.png``."""
    figure = Path(figure)
    return figure.with_name(f"{figure.stem}-stick.png")


def stick_robot(args: argparse.Namespace, result: SimResult) -> Robot:
    """The robot named on the command line, or else the one the run records, with the run's torque limits and payload."""
    if args.torque_limit is not None:
        torque_limit = parse_vector(args.torque_limit, "torque-limit")
    else:
        torque_limit = result.torque_upper if np.isfinite(result.torque_upper).all() else None
    model = OptionalRobotSettings.from_arguments(args)
    # The payload changes H, so the acceleration ellipses: the run's own unless the options name another.
    payload = model.payload
    if payload is None and result.payload is not None and (args.robot is None or args.robot == result.robot):
        payload = Payload(**result.payload)
    return robot_of_run(
        result,
        args.robot,
        frame=args.frame,
        task=args.task,
        lock=list(model.lock) or None,
        torque_limit=torque_limit,
        gravity=model.gravity,
        payload=payload,
    )


def _snapshots(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not SNAPSHOTS_RANGE[0] <= count <= SNAPSHOTS_RANGE[1]:
        raise argparse.ArgumentTypeError(f"{text} must be from {SNAPSHOTS_RANGE[0]} to {SNAPSHOTS_RANGE[1]}")
    return count
