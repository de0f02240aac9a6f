r"""A rest-to-rest circle that starts and ends at the same point.

The tip goes round a circle of radius r through its start point
:math:`x_0`, ``turns`` times, with the phase following the minimum-jerk
profile :math:`s(\tau) = 10\tau^3 - 15\tau^4 + 6\tau^5`:

.. math::

    \varphi(t) = 2\pi N s(t/T),\qquad
    x(t) = c + r(\cos\varphi\, e_1 + \sin\varphi\, e_2),\qquad c = x_0 - r e_1,

    \dot x = r\dot\varphi(-\sin\varphi\, e_1 + \cos\varphi\, e_2),\qquad
    \ddot x = r\ddot\varphi(-\sin\varphi\, e_1 + \cos\varphi\, e_2)
              - r\dot\varphi^2(\cos\varphi\, e_1 + \sin\varphi\, e_2),

where :math:`e_1` points from the centre to the start and
:math:`e_2 = n \times e_1` (in the plane: :math:`e_1` turned by +90°), so
the tip turns counter-clockwise about the normal n. Since
:math:`\dot\varphi = \ddot\varphi = 0` at t = 0 and T, the movement is rest
to rest and closes on itself: x(T) = x(0) exactly (φ(T) = 2πN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..checks import finite_numbers, positive_number, whole_number
from ..errors import InvalidInput
from .base import Reference, Trajectory, minimum_jerk

__all__ = ["Circle"]

_DEFAULT_NORMAL = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Circle(Trajectory):
    r"""Rest-to-rest circle of ``radius`` through the start point, gone round ``turns`` times in ``duration``.

    The circle lies in the plane through the start with normal ``normal``
    (3-D tasks; the xy plane for the planar task) and its centre lies at
    ``radius`` from the start along ``centre_direction``. By default the
    centre is towards the world z axis (for an arm based at the origin: towards its
    base, so the circle stays inside a reach the start already has); where
    the start lies on that axis, towards −x.

    Args:
        radius: r [m].
        duration: T [s] for all the turns.
        turns: N, whole turns (≥ 1); the tip ends where it started.
        normal: plane normal, 3 values (normalised); (0, 0, 1) by default. Only
            for 3-D tasks: a circle with a normal is 3-D.
        centre_direction: from the start towards the centre, 2 or 3 values; its
            component along the normal is dropped. Its size fixes the dimension.
        start: start (and end) point [m]; anchored at the tip by
            :func:`torqueopt.simulate` when None. Its size (2 or 3) fixes the
            dimension when neither ``normal`` nor ``centre_direction`` does.

    Peak speed :math:`15\pi N r/(4T)`, at mid-time.
    """

    radius: float
    duration: float
    turns: int = 1
    normal: np.ndarray | None = None
    centre_direction: np.ndarray | None = None
    start: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "radius", positive_number(self.radius, "radius", "m"))
        object.__setattr__(self, "duration", positive_number(self.duration, "duration", "s"))
        object.__setattr__(self, "turns", whole_number(self.turns, "turns", minimum=1))
        dimension = None
        if self.normal is not None:
            normal = finite_numbers(self.normal, "normal", 3)
            norm = float(np.linalg.norm(normal))
            if norm == 0.0:
                raise InvalidInput("normal [0.0, 0.0, 0.0] is zero; give a non-zero plane normal")
            object.__setattr__(self, "normal", normal / norm)
            dimension = 3
        if self.centre_direction is not None:
            centre = finite_numbers(self.centre_direction, "centre_direction")
            if dimension is not None and centre.size != dimension:
                raise InvalidInput(
                    f"centre_direction {centre.tolist()} has {centre.size} values but the normal makes the circle 3-D"
                )
            if float(np.linalg.norm(self._in_plane(centre))) < 1e-9 * max(float(np.linalg.norm(centre)), 1e-300):
                raise InvalidInput(
                    f"centre_direction {centre.tolist()} is zero or along the normal; give a direction in the plane"
                )
            object.__setattr__(self, "centre_direction", centre)
            dimension = centre.size
        if self.start is not None:
            start = finite_numbers(self.start, "start")
            if dimension is not None and start.size != dimension:
                raise InvalidInput(f"start {start.tolist()} has {start.size} values but the circle is {dimension}-D")
            object.__setattr__(self, "start", start)

    kind = "circle"

    @property
    def dimension(self) -> int | None:
        if self.normal is not None:
            return 3
        if self.centre_direction is not None:
            return self.centre_direction.size
        return None if self.start is None else self.start.size

    @property
    def peak_speed(self) -> float:
        """Tip speed at mid-time, 15πNr/(4T) [m/s]."""
        return 15.0 * math.pi * self.turns * self.radius / (4.0 * self.duration)

    @property
    def centre(self) -> np.ndarray:
        """Centre of the circle [m] (needs a start)."""
        e1, _ = self.axes()
        return self._require_start() - self.radius * e1

    @property
    def end(self) -> np.ndarray:
        return self._require_start().copy()

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """(e₁, e₂): unit vectors from the centre to the start and along the start's direction of travel."""
        start = self._require_start()
        if self.centre_direction is not None:
            towards = self._in_plane(self.centre_direction)
        else:
            # Towards the world z axis: minus the start's horizontal part, in the plane.
            horizontal = start.copy()
            if horizontal.size == 3:
                horizontal[2] = 0.0
            towards = self._in_plane(-horizontal)
            if float(np.linalg.norm(towards)) < 1e-9:
                fallback = np.zeros(start.size)
                fallback[0] = -1.0
                towards = self._in_plane(fallback)
            if float(np.linalg.norm(towards)) < 1e-9:  # the normal is along x
                fallback = np.zeros(start.size)
                fallback[1] = -1.0
                towards = self._in_plane(fallback)
        e1 = -towards / np.linalg.norm(towards)
        if e1.size == 2:
            e2 = np.array([-e1[1], e1[0]])
        else:
            e2 = np.cross(self._normal3(), e1)
        return e1, e2

    def anchored(self, start) -> Circle:
        return replace(self, start=np.asarray(start, dtype=float))

    def parameters(self) -> dict:
        return {
            "radius": self.radius,
            "turns": self.turns,
            "normal": None if self.normal is None else self.normal.tolist(),
            "centre_direction": None if self.centre_direction is None else self.centre_direction.tolist(),
        }

    def sample(self, t) -> Reference:
        e1, e2 = self.axes()
        centre = self._require_start() - self.radius * e1
        s, s_dot, s_ddot = minimum_jerk(t, self.duration)
        full = 2.0 * math.pi * self.turns
        phase, rate, phase_acceleration = full * s, full * s_dot, full * s_ddot
        radial = np.multiply.outer(np.cos(phase), e1) + np.multiply.outer(np.sin(phase), e2)
        tangent = np.multiply.outer(-np.sin(phase), e1) + np.multiply.outer(np.cos(phase), e2)
        r = self.radius
        return Reference(
            position=centre + r * radial,
            velocity=r * rate[..., None] * tangent,
            acceleration=r * phase_acceleration[..., None] * tangent - r * (rate**2)[..., None] * radial,
        )

    def _normal3(self) -> np.ndarray:
        return _DEFAULT_NORMAL if self.normal is None else self.normal

    def _in_plane(self, vector: np.ndarray) -> np.ndarray:
        """``vector`` without its component along the normal (unchanged in the planar case)."""
        vector = np.asarray(vector, dtype=float)
        if vector.size == 2:
            return vector
        normal = self._normal3()
        return vector - vector.dot(normal) * normal
