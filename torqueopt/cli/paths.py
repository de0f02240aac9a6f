"""``--path`` and its options: the trajectory a command follows (``torqueopt run``)."""

from __future__ import annotations

import argparse
import math

from ..errors import InvalidInput
from ..trajectory import Circle, MinimumJerkLine, StraightLine, Trajectory, WaypointPath
from .common import parse_positive, parse_vector, parse_whole

__all__ = ["PATHS", "add_path_options", "trajectory_from_args"]

PATHS = ("line", "min-jerk", "circle", "csv:FILE")
DEFAULT_DURATION = 2.0
DEFAULT_RADIUS = 0.1

# Which --path kinds each option applies to (for a one-line error when it is given with another).
_APPLIES = {
    "direction": ("line", "min-jerk"),
    "accel": ("line", "min-jerk"),
    "length": ("min-jerk",),
    "duration": ("line", "min-jerk", "circle"),
    "radius": ("circle",),
    "turns": ("circle",),
    "normal": ("circle",),
    "centre": ("circle",),
    "absolute": ("csv",),
    "rpy": ("csv",),
}


def add_path_options(group: argparse._ArgumentGroup) -> None:
    """Add ``--path`` and the options of each kind of path to ``group``."""
    group.add_argument(
        "--path",
        default="line",
        metavar="KIND",
        help="tip path: line (the paper's: constant acceleration, then deceleration), min-jerk (straight, "
        "minimum-jerk profile), circle (rest-to-rest, closes at the start), csv:FILE (spline through timed "
        "waypoints, columns t,x,y[,z]; a pose task also takes an orientation, columns t,x,y,z,qw,qx,qy,qz or, "
        "with --rpy, t,x,y,z,roll,pitch,yaw); default line",
    )
    group.add_argument(
        "--direction", metavar="D", help="line and min-jerk: direction in world axes, 2 values for xy, 3 otherwise"
    )
    group.add_argument(
        "--duration",
        metavar="T",
        help=f"line, min-jerk and circle: movement duration [s] (default {DEFAULT_DURATION}); a csv path lasts until its last time",
    )
    group.add_argument(
        "--accel", metavar="A", help="line: tangential acceleration [m/s²] (default √2); min-jerk: length a·T²/4"
    )
    group.add_argument("--length", metavar="L", help="min-jerk: path length [m] (default that of the line, a·T²/4)")
    group.add_argument("--radius", metavar="R", help=f"circle: radius [m] (default {DEFAULT_RADIUS})")
    group.add_argument("--turns", metavar="N", help="circle: whole turns (default 1)")
    group.add_argument("--normal", metavar="N", help="circle, 3-D tasks: plane normal, 3 values (default 0,0,1)")
    group.add_argument(
        "--centre",
        metavar="D",
        help="circle: direction from the start to the centre (default: towards the world z axis)",
    )
    group.add_argument(
        "--absolute",
        action="store_true",
        default=None,
        help="csv: the waypoints (and rotations) are world coordinates (default: a shape placed at the tip's "
        "start, its rotations turning the frame from its start orientation about the world axes)",
    )
    group.add_argument(
        "--rpy",
        action="store_true",
        default=None,
        help="csv, pose task: the orientation columns are roll,pitch,yaw, R = Rz(yaw)·Ry(pitch)·Rx(roll), in "
        "radians (in degrees with --degrees)",
    )


def trajectory_from_args(args: argparse.Namespace) -> Trajectory:
    """The trajectory ``--path`` and its options describe; InvalidInput names a bad or misplaced option."""
    text = str(args.path)
    kind, colon, file_name = text.partition(":")
    if (
        kind not in ("line", "min-jerk", "circle", "csv")
        or (kind == "csv") != bool(file_name)
        or (kind != "csv" and colon)
    ):
        raise InvalidInput(f"--path: '{text}' is not a path; choose one of {', '.join(PATHS)}")
    for option, kinds in _APPLIES.items():
        if getattr(args, option, None) is not None and kind not in kinds:
            raise InvalidInput(f"--{option} applies to --path {' or '.join(kinds)}, not to --path {kind}")
    duration = DEFAULT_DURATION if args.duration is None else parse_positive(args.duration, "duration")
    if kind in ("line", "min-jerk"):
        if args.direction is None:
            raise InvalidInput(f"--path {kind} needs --direction (e.g. --direction 1,1)")
        direction = parse_vector(args.direction, "direction")
        accel = math.sqrt(2.0) if args.accel is None else parse_positive(args.accel, "accel")
        if kind == "line":
            return StraightLine(direction, accel=accel, duration=duration)
        if args.length is not None and args.accel is not None:
            raise InvalidInput("--length and --accel both set the min-jerk line's length; give one")
        length = accel * duration**2 / 4.0 if args.length is None else parse_positive(args.length, "length")
        return MinimumJerkLine(direction, length=length, duration=duration)
    if kind == "circle":
        radius = DEFAULT_RADIUS if args.radius is None else parse_positive(args.radius, "radius")
        turns = 1 if args.turns is None else parse_whole(args.turns, "turns", minimum=1)
        normal = None if args.normal is None else parse_vector(args.normal, "normal", 3)
        centre = None if args.centre is None else parse_vector(args.centre, "centre")
        return Circle(radius, duration, turns=turns, normal=normal, centre_direction=centre)
    degrees = bool(getattr(args, "degrees", False))
    return WaypointPath.from_csv(file_name, absolute=bool(args.absolute), rpy=bool(args.rpy), degrees=degrees)
