r"""The trajectory protocol: what :func:`torqueopt.simulate` asks of a tip reference.

A trajectory is an object with

* ``sample(t) -> Reference``: position [m], velocity [m/s] and acceleration
  [m/s²] of the tip at a scalar time or an array of times [s];
* ``duration``: the time T [s] after which it rests at its end point (zero
  velocity and acceleration for every t ≥ T, and for t < 0 it rests at its start);
* ``dimension``: 2 for the planar ``xy`` task, 3 for ``position``/``pose``,
  or None when it takes the size of the start it is anchored at;
* ``start``: its start point [m], or None;
* ``anchored(start)``: the same movement starting at ``start``; ``simulate``
  anchors a trajectory with no start at the tip's position at q0.

A trajectory for a ``pose`` task may also give the frame's rotation: then
``oriented`` is True and ``sample_orientation(t, start_rotation)`` gives the
orientation rows of the task's reference, a :class:`~torqueopt.Reference` of the rotation
vector about the frame's start rotation [rad], the angular velocity [rad/s] and
acceleration [rad/s²] in world axes (:class:`~torqueopt.WaypointPath`
with rotations). Without it a ``pose`` task holds its start orientation.

:class:`Trajectory` is the abstract base that the built-in ones derive from
and that gives them :meth:`~Trajectory.describe` (what a result file records)
and :attr:`~Trajectory.end`. Any object with the five members above works
with ``simulate``; :func:`check_trajectory` says which member is missing.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInput

__all__ = ["Reference", "Trajectory", "check_trajectory", "minimum_jerk"]

_MEMBERS = ("sample", "duration", "dimension", "start", "anchored")


@dataclass(frozen=True)
class Reference:
    """Reference samples: arrays of shape (len(t), d) or (d,) for a scalar t.

    Attributes:
        position: [m]. velocity: [m/s]. acceleration: [m/s²].
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


class Trajectory(ABC):
    """Abstract base of the tip trajectories (see the module docstring for the protocol)."""

    #: Time T [s] at which the movement ends; it rests from then on.
    duration: float
    #: Start point [m], or None until anchored.
    start: np.ndarray | None

    @property
    @abstractmethod
    def dimension(self) -> int | None:
        """Number of position coordinates (2 or 3), None when the start decides it."""

    @abstractmethod
    def sample(self, t) -> Reference:
        """Reference position, velocity and acceleration at time(s) t [s]."""

    @abstractmethod
    def anchored(self, start) -> Trajectory:
        """The same movement starting at ``start`` [m]."""

    @abstractmethod
    def parameters(self) -> dict:
        """The constructor's arguments as JSON-ready values (without the start)."""

    @property
    def oriented(self) -> bool:
        """True when the trajectory also gives the frame's rotation (``sample_orientation``, for ``pose``)."""
        return False

    @property
    def kind(self) -> str:
        """A short name of the trajectory family, as ``torqueopt run --path`` spells it."""
        return type(self).__name__

    @property
    def end(self) -> np.ndarray:
        """End point [m] (needs a start)."""
        return np.asarray(self.sample(self.duration).position)

    def describe(self) -> dict:
        """What a result file records about the trajectory: kind, parameters, start, duration."""
        return {
            "kind": self.kind,
            **self.parameters(),
            "duration": self.duration,
            "start": None if self.start is None else np.asarray(self.start, float).tolist(),
        }

    def _require_start(self) -> np.ndarray:
        if self.start is None:
            raise InvalidInput(
                f"this {type(self).__name__} has no start point; use anchored(start) or let simulate anchor it"
            )
        return self.start


def check_trajectory(trajectory) -> None:
    """InvalidInput unless ``trajectory`` has every member of the protocol."""
    missing = [name for name in _MEMBERS if not hasattr(trajectory, name)]
    if missing:
        raise InvalidInput(
            f"trajectory {type(trajectory).__name__} lacks {', '.join(missing)}; give a torqueopt Trajectory "
            "(StraightLine, MinimumJerkLine, Circle, WaypointPath) or an object with "
            f"{', '.join(_MEMBERS)}"
        )


def describe(trajectory) -> dict:
    """:meth:`Trajectory.describe` for a built-in trajectory, the class name and duration for any other."""
    if isinstance(trajectory, Trajectory):
        return trajectory.describe()
    start = getattr(trajectory, "start", None)
    return {
        "kind": type(trajectory).__name__,
        "duration": float(trajectory.duration),
        "start": None if start is None else np.asarray(start, float).tolist(),
    }


def minimum_jerk(times, duration: float):
    r"""The rest-to-rest minimum-jerk profile and its first two time derivatives.

    With :math:`\tau = t/T` clipped to [0, 1],

    .. math::

        s = 10\tau^3 - 15\tau^4 + 6\tau^5,\qquad
        \dot s = \frac{30}{T}\tau^2(1-\tau)^2,\qquad
        \ddot s = \frac{60}{T^2}\tau(1-\tau)(1-2\tau),

    so s rises from 0 to 1 with zero velocity and acceleration at both ends
    (Flash & Hogan, 1985). Outside [0, T] it rests (ṡ = s̈ = 0).

    Returns:
        (s, ṡ [1/s], s̈ [1/s²]), arrays shaped like ``times``.
    """
    tau = np.clip(np.asarray(times, dtype=float) / duration, 0.0, 1.0)
    s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
    s_dot = 30.0 * tau**2 * (1.0 - tau) ** 2 / duration
    s_ddot = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / duration**2
    return s, s_dot, s_ddot
