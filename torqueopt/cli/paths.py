"""``--path`` and its options: the trajectory a command follows (``torqueopt run``, ``torqueopt optimize``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInput
from ..settings import Settings, numbers, positive, setting, whole
from ..trajectory import Circle, MinimumJerkLine, StraightLine, Trajectory, WaypointPath

__all__ = ["PATHS", "PathSettings"]

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


def _path_kind(text: str, name: str) -> str:
    kind, colon, file_name = text.partition(":")
    if (
        kind not in ("line", "min-jerk", "circle", "csv")
        or (kind == "csv") != bool(file_name)
        or (kind != "csv" and colon)
    ):
        raise InvalidInput(f"--path: '{text}' is not a path; choose one of {', '.join(PATHS)}")
    return text


@dataclass(frozen=True)
class PathSettings(Settings):
    """``--path`` and the options of each kind of path: the trajectory the tip follows (:meth:`trajectory`)."""

    TITLE = "movement"

    path: str = setting(
        "line",
        "tip path: line (the paper's: constant acceleration, then deceleration), min-jerk (straight, "
        "minimum-jerk profile), circle (rest-to-rest, closes at the start), csv:FILE (spline through timed "
        "waypoints, columns t,x,y[,z]; a pose task also takes an orientation, columns t,x,y,z,qw,qx,qy,qz or, "
        "with --rpy, t,x,y,z,roll,pitch,yaw); default line",
        metavar="KIND",
        parse=_path_kind,
    )
    direction: tuple[float, ...] | None = setting(
        None, "line and min-jerk: direction in world axes, 2 values for xy, 3 otherwise", metavar="D", parse=numbers()
    )
    duration: float | None = setting(
        None,
        f"line, min-jerk and circle: movement duration [s] (default {DEFAULT_DURATION}); a csv path lasts until its "
        "last time",
        unit="s",
        metavar="T",
        parse=positive,
    )
    accel: float | None = setting(
        None,
        "line: tangential acceleration [m/s²] (default √2); min-jerk: length a·T²/4",
        unit="m/s²",
        metavar="A",
        parse=positive,
    )
    length: float | None = setting(
        None, "min-jerk: path length [m] (default that of the line, a·T²/4)", unit="m", metavar="L", parse=positive
    )
    radius: float | None = setting(
        None, f"circle: radius [m] (default {DEFAULT_RADIUS})", unit="m", metavar="R", parse=positive
    )
    turns: int | None = setting(None, "circle: whole turns (default 1)", metavar="N", parse=whole(1))
    normal: tuple[float, float, float] | None = setting(
        None, "circle, 3-D tasks: plane normal, 3 values (default 0,0,1)", metavar="N", parse=numbers(3)
    )
    centre: tuple[float, ...] | None = setting(
        None,
        "circle: direction from the start to the centre (default: towards the world z axis)",
        metavar="D",
        parse=numbers(),
    )
    absolute: bool = setting(
        False,
        "csv: the waypoints (and rotations) are world coordinates (default: a shape placed at the tip's "
        "start, its rotations turning the frame from its start orientation about the world axes)",
        switch="on",
    )
    rpy: bool = setting(
        False,
        "csv, pose task: the orientation columns are roll,pitch,yaw, R = Rz(yaw)·Ry(pitch)·Rx(roll), in "
        "radians (in degrees with --degrees)",
        switch="on",
    )

    def trajectory(self, degrees: bool = False) -> Trajectory:
        """The trajectory these settings describe (``degrees``: a csv path's roll, pitch, yaw in degrees);
        InvalidInput names a misplaced option."""
        kind, _, file_name = self.path.partition(":")
        for option, kinds in _APPLIES.items():
            if getattr(self, option) not in (None, False) and kind not in kinds:
                raise InvalidInput(f"--{option} applies to --path {' or '.join(kinds)}, not to --path {kind}")
        duration = DEFAULT_DURATION if self.duration is None else self.duration
        if kind in ("line", "min-jerk"):
            if self.direction is None:
                raise InvalidInput(f"--path {kind} needs --direction (e.g. --direction 1,1)")
            direction = np.array(self.direction)
            accel = math.sqrt(2.0) if self.accel is None else self.accel
            if kind == "line":
                return StraightLine(direction, accel=accel, duration=duration)
            if self.length is not None and self.accel is not None:
                raise InvalidInput("--length and --accel both set the min-jerk line's length; give one")
            length = accel * duration**2 / 4.0 if self.length is None else self.length
            return MinimumJerkLine(direction, length=length, duration=duration)
        if kind == "circle":
            radius = DEFAULT_RADIUS if self.radius is None else self.radius
            turns = 1 if self.turns is None else self.turns
            normal = None if self.normal is None else np.array(self.normal)
            centre = None if self.centre is None else np.array(self.centre)
            return Circle(radius, duration, turns=turns, normal=normal, centre_direction=centre)
        return WaypointPath.from_csv(file_name, absolute=self.absolute, rpy=self.rpy, degrees=degrees)
