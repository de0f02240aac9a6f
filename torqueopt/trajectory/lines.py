r"""Rest-to-rest straight lines: the paper's bang-bang line and the minimum-jerk line.

:class:`StraightLine` is the paper's movement (Section 3): constant
tangential acceleration :math:`a` over the first half of the duration
:math:`T` and the same deceleration over the second,

.. math::

    s(t) = \begin{cases} \tfrac12 a t^2 & 0 \le t \le T/2 \\
    \tfrac14 a T^2 - \tfrac12 a (T - t)^2 & T/2 < t \le T \end{cases}

so the path is :math:`a T^2/4` long and the peak speed is :math:`aT/2`.
After :math:`T` the reference rests at the end point, with zero
acceleration from T on.

:class:`MinimumJerkLine` covers a length :math:`L` with the quintic
:math:`s(t) = L(10\tau^3 - 15\tau^4 + 6\tau^5)`, :math:`\tau = t/T`: its
velocity and acceleration are continuous and zero at both ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..checks import finite_numbers, positive_number
from ..errors import InvalidInput
from .base import Reference, Trajectory, minimum_jerk

__all__ = ["MinimumJerkLine", "StraightLine"]


def _unit_direction(direction) -> np.ndarray:
    vector = finite_numbers(direction, "direction")
    largest = float(np.abs(vector).max()) if vector.size else 0.0
    if largest == 0.0:
        raise InvalidInput(f"direction {vector.tolist()} is zero; give a non-zero direction")
    scaled = vector / largest  # ‖(1e308, 1e308)‖ overflows to inf, and the direction would become zero
    return scaled / float(np.linalg.norm(scaled))


def _start_like(start, direction: np.ndarray) -> np.ndarray | None:
    if start is None:
        return None
    return finite_numbers(start, "start", direction.size, context="like the direction")


@dataclass(frozen=True)
class StraightLine(Trajectory):
    """Rest-to-rest straight line along ``direction`` (normalised), the paper's movement.

    Args:
        direction: 2 values for the ``xy`` task, 3 for ``position``/``pose``
            (world axes); any non-zero length, it is normalised.
        accel: tangential acceleration magnitude [m/s²], √2 in the paper.
        duration: total time T [s].
        start: start point [m]; :func:`torqueopt.simulate` anchors it at the
            tip's position at q0 when it is None.
    """

    direction: np.ndarray
    accel: float = math.sqrt(2.0)
    duration: float = 2.0
    start: np.ndarray | None = None

    def __post_init__(self):
        direction = _unit_direction(self.direction)
        positive_number(self.accel, "accel", "m/s²")
        positive_number(self.duration, "duration", "s")
        object.__setattr__(self, "direction", direction)
        object.__setattr__(self, "accel", float(self.accel))
        object.__setattr__(self, "duration", float(self.duration))
        object.__setattr__(self, "start", _start_like(self.start, direction))

    kind = "line"

    @property
    def dimension(self) -> int:
        return self.direction.size

    @property
    def length(self) -> float:
        """Path length a·T²/4 [m]."""
        return self.accel * self.duration**2 / 4.0

    @property
    def peak_speed(self) -> float:
        """Speed at mid-path a·T/2 [m/s]."""
        return self.accel * self.duration / 2.0

    @property
    def end(self) -> np.ndarray:
        """End point [m] (needs a start)."""
        return self._require_start() + self.length * self.direction

    def anchored(self, start) -> StraightLine:
        """The same movement starting at ``start``."""
        return replace(self, start=np.asarray(start, dtype=float))

    def parameters(self) -> dict:
        return {"direction": self.direction.tolist(), "accel": self.accel, "length": self.length}

    def sample(self, t) -> Reference:
        """Reference position, velocity and acceleration at time(s) t [s]."""
        times = np.asarray(t, dtype=float)
        a, total = self.accel, self.duration
        half = 0.5 * total
        tc = np.clip(times, 0.0, total)
        first = tc <= half
        arc = np.where(first, 0.5 * a * tc**2, self.length - 0.5 * a * (total - tc) ** 2)
        speed = np.where(first, a * tc, a * (total - tc))
        # The step that starts at T/2 belongs to the deceleration half.
        tangential = np.where(tc < half, a, -a)
        tangential = np.where((times < 0.0) | (times >= total), 0.0, tangential)
        speed = np.where((times < 0.0) | (times > total), 0.0, speed)
        start = self._require_start()
        position = start + np.multiply.outer(arc, self.direction)
        return Reference(
            position=position,
            velocity=np.multiply.outer(speed, self.direction),
            acceleration=np.multiply.outer(tangential, self.direction),
        )


@dataclass(frozen=True)
class MinimumJerkLine(Trajectory):
    r"""Rest-to-rest straight line of length L along ``direction`` with the minimum-jerk profile.

    .. math::

        x(t) = x_0 + L\,s(t)\,\hat d,\qquad s = 10\tau^3 - 15\tau^4 + 6\tau^5,\quad \tau = t/T,

    peak speed :math:`15L/(8T)` at mid-path, peak acceleration
    :math:`10\sqrt3 L/(3T^2) \approx 5.77\,L/T^2` at
    :math:`\tau = (3 \mp \sqrt3)/6`; velocity and acceleration are zero at
    t = 0 and t = T, so the torque has no jump at either end (the paper's
    line has one, of size H J⁺ a).

    Args:
        direction: 2 values for the ``xy`` task, 3 for ``position``/``pose``; normalised.
        length: path length L [m]; √2 m by default, the length of the paper's
            long movement (a = √2 m/s², T = 2 s).
        duration: total time T [s].
        start: start point [m]; anchored at the tip by :func:`torqueopt.simulate` when None.
    """

    direction: np.ndarray
    length: float = math.sqrt(2.0)
    duration: float = 2.0
    start: np.ndarray | None = None

    def __post_init__(self):
        direction = _unit_direction(self.direction)
        positive_number(self.length, "length", "m")
        positive_number(self.duration, "duration", "s")
        object.__setattr__(self, "direction", direction)
        object.__setattr__(self, "length", float(self.length))
        object.__setattr__(self, "duration", float(self.duration))
        object.__setattr__(self, "start", _start_like(self.start, direction))

    kind = "min-jerk"

    @property
    def dimension(self) -> int:
        return self.direction.size

    @property
    def peak_speed(self) -> float:
        """Speed at mid-path 15 L / (8 T) [m/s]."""
        return 15.0 * self.length / (8.0 * self.duration)

    @property
    def peak_acceleration(self) -> float:
        """Largest tangential acceleration 10√3 L / (3 T²) [m/s²]."""
        return 10.0 * math.sqrt(3.0) * self.length / (3.0 * self.duration**2)

    def anchored(self, start) -> MinimumJerkLine:
        return replace(self, start=np.asarray(start, dtype=float))

    def parameters(self) -> dict:
        return {"direction": self.direction.tolist(), "length": self.length}

    def sample(self, t) -> Reference:
        start = self._require_start()
        s, s_dot, s_ddot = minimum_jerk(t, self.duration)
        step = self.length * self.direction
        return Reference(
            position=start + np.multiply.outer(s, step),
            velocity=np.multiply.outer(s_dot, step),
            acceleration=np.multiply.outer(s_ddot, step),
        )
