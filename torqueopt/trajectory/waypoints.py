r"""A tip path through timed waypoints, read from a CSV file.

The waypoints :math:`(t_k, p_k)`, :math:`t_0 = 0 < t_1 < \dots < t_K = T`,
are joined by the quintic interpolating spline (degree 5, scipy's
``make_interp_spline``) whose velocity and acceleration are zero at both
ends:

.. math::

    x(t_k) = p_k,\qquad \dot x(0) = \dot x(T) = 0,\qquad \ddot x(0) = \ddot x(T) = 0,

so the path is C⁴ (position, velocity, acceleration, jerk and snap
continuous) through its waypoints and rest to rest. With two waypoints it
is exactly the minimum-jerk line between them.

CSV format: a header row naming the columns ``t,x,y`` (planar task) or
``t,x,y,z``, then one waypoint per row: time [s] and position [m].
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..checks import finite_numbers
from ..errors import InvalidInput
from .base import Reference, Trajectory

__all__ = ["WaypointPath"]

_HEADERS = (["t", "x", "y"], ["t", "x", "y", "z"])


@dataclass(frozen=True)
class WaypointPath(Trajectory):
    """Rest-to-rest path through timed waypoints (quintic spline, zero end velocity and acceleration).

    Args:
        times: waypoint times [s], strictly increasing from 0; the last is the duration.
        points: waypoints [m], one row of 2 or 3 coordinates per time.
        start: where the first waypoint is placed [m]. The path is moved
            rigidly by ``start − points[0]``, so the waypoints give its shape;
            :func:`torqueopt.simulate` anchors it at the tip's position at q0
            when None. To follow the waypoints in world coordinates, give
            ``start=points[0]`` (``from_csv(path, absolute=True)``).
        source: where the waypoints came from (a file name), for the record.
    """

    times: np.ndarray
    points: np.ndarray
    start: np.ndarray | None = None
    source: str | None = None
    _spline: object = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        try:
            times = np.asarray(self.times, dtype=float).reshape(-1)
            points = np.asarray(self.points, dtype=float)
        except (TypeError, ValueError):
            raise InvalidInput("waypoint times and points must be numbers") from None
        if points.ndim != 2 or points.shape[1] not in (2, 3):
            raise InvalidInput(f"waypoints have shape {points.shape}; give one row of 2 or 3 coordinates per time")
        if times.size < 2:
            raise InvalidInput(f"a waypoint path needs at least 2 waypoints, got {times.size}")
        if points.shape[0] != times.size:
            raise InvalidInput(f"{times.size} waypoint times but {points.shape[0]} waypoints")
        for k in range(times.size):
            if not (np.isfinite(times[k]) and np.isfinite(points[k]).all()):
                raise InvalidInput(f"waypoint {k + 1} (t={times[k]:g} s, {points[k].tolist()}) is not finite")
        if times[0] != 0.0:
            raise InvalidInput(f"the first waypoint time is {times[0]:g} s; times count from 0")
        for k in range(1, times.size):
            if not times[k] > times[k - 1]:
                raise InvalidInput(
                    f"waypoint {k + 1} time {times[k]:g} s is not after the previous one, "
                    f"{times[k - 1]:g} s; times must increase strictly"
                )
        from scipy.interpolate import make_interp_spline

        rest = np.zeros(points.shape[1])
        at_rest = [(1, rest), (2, rest)]
        spline = make_interp_spline(times, points, k=5, bc_type=(at_rest, at_rest))
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "_spline", spline)
        if self.start is not None:
            object.__setattr__(self, "start", finite_numbers(self.start, "start", points.shape[1]))

    kind = "csv"

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def dimension(self) -> int:
        return self.points.shape[1]

    @classmethod
    def from_csv(cls, path: str | os.PathLike, absolute: bool = False) -> WaypointPath:
        """The path through the waypoints of a CSV file with columns ``t,x,y`` or ``t,x,y,z``.

        Args:
            absolute: the waypoints are world coordinates (start at the first
                one) rather than a shape placed at the tip's start.

        Raises:
            InvalidInput: the file is missing or unreadable, or a row is
                malformed (the message names the file and the row).
        """
        path = Path(path)
        if not path.is_file():
            raise InvalidInput(f"waypoint file '{path}' does not exist")
        try:
            # utf-8-sig: spreadsheets often start the file with a byte-order mark.
            with open(path, newline="", encoding="utf-8-sig") as handle:
                rows = [
                    (number, row) for number, row in enumerate(csv.reader(handle), 1) if any(c.strip() for c in row)
                ]
        except (OSError, UnicodeDecodeError, csv.Error) as error:
            raise InvalidInput(f"waypoint file '{path}' cannot be read ({error})") from None
        if not rows:
            raise InvalidInput(f"waypoint file '{path}' is empty; give a header t,x,y or t,x,y,z and waypoint rows")
        header_row, header = rows[0]
        names = [name.strip().lower() for name in header]
        if names not in _HEADERS:
            raise InvalidInput(
                f"waypoint file '{path}' row {header_row}: header {','.join(header)!r} must be t,x,y or t,x,y,z"
            )
        values = []
        for number, row in rows[1:]:
            if len(row) != len(names):
                raise InvalidInput(
                    f"waypoint file '{path}' row {number}: {len(row)} values, the header has {len(names)}"
                )
            try:
                numbers = [float(cell) for cell in row]
            except ValueError:
                raise InvalidInput(
                    f"waypoint file '{path}' row {number}: {','.join(row)!r} is not all numbers"
                ) from None
            if not all(math.isfinite(x) for x in numbers):
                raise InvalidInput(f"waypoint file '{path}' row {number}: {','.join(row)!r} has a non-finite value")
            if values and not numbers[0] > values[-1][1][0]:
                raise InvalidInput(
                    f"waypoint file '{path}' row {number}: time {numbers[0]:g} s is not after the previous "
                    f"row's {values[-1][1][0]:g} s; times must increase strictly"
                )
            if not values and numbers[0] != 0.0:
                raise InvalidInput(f"waypoint file '{path}' row {number}: the first time is {numbers[0]:g} s, not 0")
            values.append((number, numbers))
        if len(values) < 2:
            raise InvalidInput(f"waypoint file '{path}' has {len(values)} waypoint rows; give at least 2")
        table = np.array([numbers for _, numbers in values])
        points = table[:, 1:]
        return cls(table[:, 0], points, start=points[0] if absolute else None, source=str(path))

    def anchored(self, start) -> WaypointPath:
        return replace(self, start=np.asarray(start, dtype=float))

    def parameters(self) -> dict:
        return {"source": self.source, "waypoints": len(self.times)}

    def sample(self, t) -> Reference:
        start = self._require_start()
        times = np.asarray(t, dtype=float)
        clipped = np.clip(times, 0.0, self.duration)
        offset = start - self.points[0]
        moving = ((times >= 0.0) & (times <= self.duration))[..., None]
        return Reference(
            position=self._spline(clipped) + offset,
            velocity=np.where(moving, self._spline(clipped, 1), 0.0),
            acceleration=np.where(moving, self._spline(clipped, 2), 0.0),
        )
