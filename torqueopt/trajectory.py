r"""Tip trajectories.

:class:`StraightLine` is the paper's movement (Section 3): a rest-to-rest
straight line with constant tangential acceleration :math:`a` over the first
half of the duration :math:`T` and the same deceleration over the second,

.. math::

    s(t) = \begin{cases} \tfrac12 a t^2 & 0 \le t \le T/2 \\
    \tfrac14 a T^2 - \tfrac12 a (T - t)^2 & T/2 < t \le T \end{cases}

so the path is :math:`a T^2/4` long and the peak speed is :math:`aT/2`.
After :math:`T` the reference rests at the end point, with zero acceleration from T on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .checks import positive_number
from .errors import InvalidInput

__all__ = ["StraightLine", "Reference"]


@dataclass(frozen=True)
class Reference:
    """Reference samples: arrays of shape (len(t), d) or (d,) for a scalar t.

    Attributes:
        position: [m]. velocity: [m/s]. acceleration: [m/s²].
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


@dataclass(frozen=True)
class StraightLine:
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
        try:
            direction = np.asarray(self.direction, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InvalidInput(f"direction {self.direction!r} is not a vector of numbers") from None
        if direction.size not in (2, 3) or not np.isfinite(direction).all():
            raise InvalidInput(f"direction {direction.tolist()} must be 2 or 3 finite numbers")
        norm = float(np.linalg.norm(direction))
        if norm == 0.0:
            raise InvalidInput(f"direction {direction.tolist()} is zero; give a non-zero direction")
        positive_number(self.accel, "accel", "m/s²")
        positive_number(self.duration, "duration", "s")
        object.__setattr__(self, "direction", direction / norm)
        object.__setattr__(self, "accel", float(self.accel))
        object.__setattr__(self, "duration", float(self.duration))
        if self.start is not None:
            start = np.asarray(self.start, dtype=float).reshape(-1)
            if start.shape != direction.shape or not np.isfinite(start).all():
                raise InvalidInput(f"start {start.tolist()} must be {direction.size} finite numbers like the direction")
            object.__setattr__(self, "start", start)

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
        return self._start() + self.length * self.direction

    def anchored(self, start) -> StraightLine:
        """The same movement starting at ``start``."""
        return replace(self, start=np.asarray(start, dtype=float))

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
        start = self._start()
        position = start + np.multiply.outer(arc, self.direction)
        return Reference(
            position=position,
            velocity=np.multiply.outer(speed, self.direction),
            acceleration=np.multiply.outer(tangential, self.direction),
        )

    def _start(self) -> np.ndarray:
        if self.start is None:
            raise InvalidInput("this StraightLine has no start point; use anchored(start) or let simulate anchor it")
        return self.start
