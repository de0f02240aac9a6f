"""``torqueopt plot``: draw any saved run (torques with limits, joint velocities, tip path)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..errors import InvalidInput
from ..io import writable_path, written_together
from ..plots import DEFAULT_DPI, MAX_DPI, check_title, figure_format, parse_dpi, plot_run
from ..result import load_result
from ..whiplash import detect_whiplash
from . import EXIT_OK
from .stick import add_stick_options, check_stick_options, stick_figure_path, stick_robot, write_stick_figures

__all__ = ["add_parser"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "plot",
        help="plot a saved run: torques against limits, joint velocities, tip path against reference",
        description=(
            "Plot a run written by 'torqueopt run --out' (a .csv with its .csv.json sidecar, or a .npz): the torque "
            "of each joint with its ± limits, the joint velocities, and the tip path and error against the "
            "reference. A run that stopped early is drawn up to where it stopped, and the figure says so."
        ),
    )
    parser.add_argument("run", metavar="RUN", help="run file: .csv (with its .csv.json sidecar) or .npz")
    parser.add_argument(
        "--out",
        metavar="FIGURE",
        help="figure to write, in the format its suffix names: .png, .pdf or .svg (default: RUN with the suffix .png)",
    )
    parser.add_argument(
        "--dpi",
        default=str(DEFAULT_DPI),
        help=f"resolution of a PNG figure [dots per inch], at most {MAX_DPI} (default {DEFAULT_DPI})",
    )
    parser.add_argument("--title", help="figure title (default: robot, resolver, task and duration)")
    add_stick_options(parser)
    parser.set_defaults(handler=plot_command)


def plot_command(args: argparse.Namespace) -> int:
    out = args.out if args.out else Path(args.run).with_suffix(".png")
    figure_format(out)
    check_stick_options(args)
    dpi = parse_dpi(args.dpi)
    if args.title is not None:
        check_title(args.title)
    out = writable_path(out)
    if args.stick_figures:
        writable_path(stick_figure_path(out))
    result = load_result(args.run)
    _check_plottable(result, args.run)
    robot = stick_robot(args, result) if args.stick_figures else None
    with written_together():
        path = plot_run(result, out, title=args.title, dpi=dpi, events=_instability(result))
        sticks = None if robot is None else write_stick_figures(args, robot, result, path)
    status = "" if result.completed else f" (the run stopped early at t = {result.stop_time:.3f} s)"
    print(f"wrote {path}{status}")
    if sticks is not None:
        print(f"wrote {sticks}")
    return EXIT_OK


def _instability(result) -> dict[str, float]:
    """When the whiplash detector (its default thresholds, as ``run`` reports them) finds the run unstable."""
    report = detect_whiplash(result)
    return {"unstable by the whiplash detector": report.time} if report.unstable else {}


def _check_plottable(result, source) -> None:
    """A run with rows, and no infinite value (NaN marks a torque never applied; inf has no place on an axis)."""
    if not len(result.t):
        raise InvalidInput(f"run file '{source}' has no rows: nothing to plot")
    for values, what, unit in ((result.tau, "torque", "N·m"), (result.v, "joint velocity", "rad/s"),
                               (result.joint_angles, "joint angle", "rad")):  # fmt: skip
        infinite = np.isinf(values)
        if infinite.any():
            row, joint = np.argwhere(infinite)[0]
            raise InvalidInput(
                f"run file '{source}' holds an infinite {what} ({values[row, joint]:g} {unit} at "
                f"t = {result.t[row]:.3f} s, joint {result.joint_names[joint]}): nothing to plot"
            )
    for values, what in ((result.x, "tip position"), (result.x_ref, "reference position"), (result.t, "time")):
        if np.isinf(values).any():
            raise InvalidInput(f"run file '{source}' holds an infinite {what}: nothing to plot")
