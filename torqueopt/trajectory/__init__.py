"""Tip trajectories: the protocol :func:`torqueopt.simulate` takes and the built-in movements.

* :class:`StraightLine`: the paper's rest-to-rest line, constant acceleration then deceleration;
* :class:`MinimumJerkLine`: a rest-to-rest line with the quintic minimum-jerk profile;
* :class:`Circle`: a rest-to-rest circle through the start, closing on itself;
* :class:`WaypointPath`: a rest-to-rest spline through timed waypoints, e.g. from a CSV file, with the
  frame's rotations for a ``pose`` task if given (interpolated on SO(3), :mod:`.orientation`).

Each is a :class:`Trajectory`: ``sample(t)`` gives a :class:`Reference`
(position, velocity, acceleration), ``duration``, ``dimension``, ``start``
and ``anchored(start)``; every one rests after its duration.
"""

from .base import Reference, Trajectory, check_trajectory, describe, minimum_jerk
from .circle import Circle
from .lines import MinimumJerkLine, StraightLine
from .waypoints import WaypointPath

__all__ = [
    "Circle",
    "MinimumJerkLine",
    "Reference",
    "StraightLine",
    "Trajectory",
    "WaypointPath",
    "check_trajectory",
    "describe",
    "minimum_jerk",
]
