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

A ``pose`` task may also follow an orientation: the header
``t,x,y,z,qw,qx,qy,qz`` gives a unit quaternion (scalar first) per row, the
header ``t,x,y,z,roll,pitch,yaw`` (read with ``rpy=True``, ``--rpy``) the
angles of Pinocchio's ``rpyToMatrix``, :math:`R = R_z(\text{yaw})
R_y(\text{pitch}) R_x(\text{roll})` [rad, or degrees with ``degrees=True``].
The rotations are interpolated on SO(3) with the position's own time-scaling
(:class:`~torqueopt.trajectory.orientation.OrientationSpline`): between two
rows the frame turns by the shortest arc, so the sign of a quaternion does
not matter (q and −q are one rotation). A quaternion whose norm differs from 1
by at most :data:`~torqueopt.trajectory.waypoints.QUATERNION_NORM_TOLERANCE` (values rounded when printed) is
normalised; one farther from 1 is refused, as a sign of wrong columns.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..checks import finite_numbers
from ..errors import InvalidInput
from .base import Reference, Trajectory
from .orientation import OrientationSpline

__all__ = ["WaypointPath", "QUATERNION_NORM_TOLERANCE"]

_POSITION_HEADERS = (["t", "x", "y"], ["t", "x", "y", "z"])
_QUATERNION_HEADER = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"]
_RPY_HEADER = ["t", "x", "y", "z", "roll", "pitch", "yaw"]
_HEADERS = (*_POSITION_HEADERS, _QUATERNION_HEADER, _RPY_HEADER)
_HEADER_CHOICES = "t,x,y or t,x,y,z (position), t,x,y,z,qw,qx,qy,qz or t,x,y,z,roll,pitch,yaw (pose)"

#: How far from 1 a quaternion's norm may be and still be normalised (a file's rounding), rather than refused.
QUATERNION_NORM_TOLERANCE = 1e-3
#: Two rows' rotations within this angle [rad] of half a turn apart are refused: the shorter way round is undecided.
HALF_TURN_MARGIN = 1e-6
#: How far a given rotation matrix may be from orthonormal, det +1 (largest entry of RᵀR − I).
ROTATION_TOLERANCE = 1e-9


@dataclass(frozen=True)
class WaypointPath(Trajectory):
    r"""Rest-to-rest path through timed waypoints (quintic spline, zero end velocity and acceleration).

    Args:
        times: waypoint times [s], strictly increasing from 0; the last is the duration.
        points: waypoints [m], one row of 2 or 3 coordinates per time.
        start: where the first waypoint is placed [m]. The path is moved
            rigidly by ``start − points[0]``, so the waypoints give its shape;
            :func:`torqueopt.simulate` anchors it at the tip's position at q0
            when None. To follow the waypoints in world coordinates, give
            ``start=points[0]`` (``from_csv(path, absolute=True)``).
        source: where the waypoints came from (a file name), for the record.
        rotations: (K + 1, 3, 3) rotation matrices of the frame at the waypoints (world axes), for a ``pose``
            task, or None (the task holds its start orientation). Interpolated by
            :class:`~torqueopt.trajectory.orientation.OrientationSpline`, the shortest arc between two rows.
        rotation_start: where the first rotation is placed (world axes). The frame's rotation is
            :math:`R(t) R_0^\top B`, B = ``rotation_start``: the change since the first row, :math:`R(t) R_0^\top`
            in world axes (as the waypoints give displacements in world axes), applied to B, so the rows'
            changes give the movement; :func:`torqueopt.simulate` takes B = the frame's rotation at q0 when
            None. To follow the rotations as given, give ``rotation_start=rotations[0]``
            (``from_csv(path, absolute=True)``).
    """

    times: np.ndarray
    points: np.ndarray
    start: np.ndarray | None = None
    source: str | None = None
    rotations: np.ndarray | None = None
    rotation_start: np.ndarray | None = None
    _spline: object = field(init=False, repr=False, compare=False)
    _orientation: OrientationSpline | None = field(init=False, repr=False, compare=False)

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
        orientation = None
        if self.rotations is not None:
            if points.shape[1] != 3:
                raise InvalidInput(
                    f"waypoint rotations need 3-D waypoints (a pose task), got {points.shape[1]} coordinates"
                )
            rotations = _rotation_matrices(self.rotations, times.size, "waypoint rotations")
            _check_half_turns(rotations, times)
            object.__setattr__(self, "rotations", rotations)
            orientation = OrientationSpline(times, rotations)
            if self.rotation_start is not None:
                start = _rotation_matrices(self.rotation_start, None, "rotation_start")
                object.__setattr__(self, "rotation_start", start)
        elif self.rotation_start is not None:
            raise InvalidInput("rotation_start places the waypoint rotations, and this path has none; give rotations")
        object.__setattr__(self, "_orientation", orientation)

    kind = "csv"

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def dimension(self) -> int:
        return self.points.shape[1]

    @classmethod
    def from_csv(
        cls, path: str | os.PathLike, absolute: bool = False, rpy: bool = False, degrees: bool = False
    ) -> WaypointPath:
        """The path through the waypoints of a CSV file (columns in the module docstring).

        Args:
            absolute: the waypoints are world coordinates (start at the first
                one) rather than a shape placed at the tip's start; so are the
                rotations, when the file has them.
            rpy: the file's orientation columns are ``roll,pitch,yaw`` (``--rpy``).
            degrees: the roll, pitch and yaw are in degrees (with ``rpy``).

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
            raise InvalidInput(f"waypoint file '{path}' is empty; give a header {_HEADER_CHOICES} and waypoint rows")
        header_row, header = rows[0]
        names = [name.strip().lower() for name in header]
        if names not in _HEADERS:
            raise InvalidInput(
                f"waypoint file '{path}' row {header_row}: header {','.join(header)!r} must be {_HEADER_CHOICES}"
            )
        if names == _RPY_HEADER and not rpy:
            raise InvalidInput(
                f"waypoint file '{path}' row {header_row}: roll,pitch,yaw columns are read with --rpy (rpy=True); "
                "give it, or quaternion columns qw,qx,qy,qz"
            )
        if rpy and names != _RPY_HEADER:
            raise InvalidInput(
                f"waypoint file '{path}' row {header_row}: --rpy (rpy=True) reads roll,pitch,yaw columns, but the "
                f"header is {','.join(header)!r}; give the header {','.join(_RPY_HEADER)}"
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
                raise InvalidInput(
                    f"waypoint file '{path}' row {number}: {','.join(row)!r} has a non-finite value; give finite numbers"
                )
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
        points = table[:, 1:4]
        rotations = None
        if names == _QUATERNION_HEADER:
            rotations = _quaternion_rotations(table[:, 4:], [number for number, _ in values], path)
        elif names == _RPY_HEADER:
            angles = np.radians(table[:, 4:]) if degrees else table[:, 4:]
            rotations = np.array([pin.rpy.rpyToMatrix(*row) for row in angles])
        try:
            return cls(
                table[:, 0],
                points,
                start=points[0] if absolute else None,
                source=str(path),
                rotations=rotations,
                rotation_start=rotations[0] if absolute and rotations is not None else None,
            )
        except InvalidInput as error:
            raise InvalidInput(f"waypoint file '{path}': {error}") from None

    def anchored(self, start) -> WaypointPath:
        return replace(self, start=np.asarray(start, dtype=float))

    def parameters(self) -> dict:
        if self.rotations is None:
            return {"source": self.source, "waypoints": len(self.times)}
        placed = "relative" if self.rotation_start is None else "absolute"
        return {"source": self.source, "waypoints": len(self.times), "orientation": placed}

    @property
    def oriented(self) -> bool:
        """True when the path carries rotations (for a ``pose`` task)."""
        return self.rotations is not None

    def sample_orientation(self, t, start_rotation) -> Reference:
        r"""The orientation rows of a ``pose`` task's reference at time(s) t [s], world axes.

        Args:
            start_rotation: :math:`R_s`, the frame's rotation at q0, about which the pose task measures its
                rotation vector (:class:`~torqueopt.tasks.FrameTask`); the path's first rotation is placed
                there unless ``rotation_start`` places it.

        Returns:
            A :class:`~torqueopt.Reference` whose ``position`` is :math:`\log(R_{ref}(t) R_s^\top)` [rad], ``velocity``
            the angular velocity [rad/s] and ``acceleration`` the angular acceleration [rad/s²] of
            :math:`R_{ref}(t) = R(t) R_0^\top B` with :math:`B` the placement of the first rotation
            (``rotation_start``, else :math:`R_s`): right-multiplying by a constant leaves both rates as the
            interpolant's (:class:`~torqueopt.trajectory.orientation.OrientationSpline`).
        """
        if self._orientation is None:
            raise InvalidInput("this waypoint path has no rotations; give rotations= (or quaternion columns)")
        sample = self._orientation.sample(t)
        # R_ref R_sᵀ = R(t) · R_0ᵀ B R_sᵀ, the constant on the right made once; R_0ᵀ when B = R_s
        if self.rotation_start is None:
            offset = self.rotations[0].T
        elif start_rotation is None:
            raise InvalidInput(
                "a waypoint path with rotation_start (absolute rotations) needs the frame's start rotation to "
                "measure its rotations from; give start_rotation"
            )
        else:
            offset = self.rotations[0].T.dot(self.rotation_start).dot(np.asarray(start_rotation, float).T)
        rotation = sample.rotation.reshape(-1, 3, 3)
        vectors = np.array([pin.log3(turn.dot(offset)) for turn in rotation]).reshape(sample.angular_velocity.shape)
        return Reference(position=vectors, velocity=sample.angular_velocity, acceleration=sample.angular_acceleration)

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


def _quaternion_rotations(quaternions: np.ndarray, rows: list[int], path) -> np.ndarray:
    """Rotation matrices of the rows' quaternions (w, x, y, z), normalised within the tolerance, else refused."""
    rotations = []
    for number, quaternion in zip(rows, quaternions):
        norm = float(np.linalg.norm(quaternion))
        if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
            values = ",".join(f"{value:g}" for value in quaternion)
            raise InvalidInput(
                f"waypoint file '{path}' row {number}: quaternion qw,qx,qy,qz = {values} has norm {norm:.6g}; "
                f"give a unit quaternion, scalar first (a norm within {QUATERNION_NORM_TOLERANCE:g} of 1 is normalised)"
            )
        w, x, y, z = quaternion / norm
        rotations.append(pin.Quaternion(w, x, y, z).toRotationMatrix())
    return np.array(rotations)


def _rotation_matrices(rotations, count: int | None, name: str) -> np.ndarray:
    """``rotations`` as (count, 3, 3) rotation matrices (one 3×3 when count is None), or InvalidInput naming the bad one."""
    shape = (3, 3) if count is None else (count, 3, 3)
    try:
        matrices = np.asarray(rotations, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} must be numbers, 3×3 rotation matrices") from None
    if matrices.shape != shape:
        raise InvalidInput(f"{name} have shape {matrices.shape}; give {shape}, one rotation matrix per waypoint")
    for index, matrix in enumerate(matrices.reshape(-1, 3, 3)):
        where = "" if count is None else f" {index + 1}"
        if not np.isfinite(matrix).all():
            raise InvalidInput(f"{name}{where} {matrix.tolist()} is not finite")
        deviation = float(np.abs(matrix.T.dot(matrix) - np.eye(3)).max())
        if deviation > ROTATION_TOLERANCE or np.linalg.det(matrix) < 0.0:
            raise InvalidInput(
                f"{name}{where} {np.round(matrix, 6).tolist()} is not a rotation (RᵀR − I up to {deviation:.3g}, "
                f"det {np.linalg.det(matrix):.3g}); give an orthonormal matrix of determinant +1"
            )
    return matrices.copy()


def _check_half_turns(rotations: np.ndarray, times: np.ndarray) -> None:
    """InvalidInput when two consecutive rotations are half a turn apart: the shortest arc is not unique."""
    for k in range(1, len(rotations)):
        angle = float(np.linalg.norm(pin.log3(rotations[k - 1].T.dot(rotations[k]))))
        if angle > math.pi - HALF_TURN_MARGIN:
            raise InvalidInput(
                f"waypoint rotations at t={times[k - 1]:g} s and t={times[k]:g} s are {math.degrees(angle):.6g}° "
                "apart, half a turn: which way round is undecided; add a waypoint between them"
            )
