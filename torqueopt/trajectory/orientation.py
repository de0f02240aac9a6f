r"""An orientation path through timed rotations, interpolated on SO(3) with the position spline's time-scaling.

The rotations :math:`R_0, \dots, R_K` (world axes) at the times :math:`t_0 = 0 < \dots < t_K = T` are joined
by the product of their increments, each advanced by its own cumulative weight:

.. math::

    R(t) = R_0 \exp(S_1(t)\,\phi_1) \exp(S_2(t)\,\phi_2) \cdots \exp(S_K(t)\,\phi_K),
    \qquad \phi_k = \log(R_{k-1}^\top R_k),

where :math:`\phi_k` is the shortest arc from one waypoint to the next (in the frame of :math:`R_{k-1}`,
angle at most π) and :math:`S_k(t)` is the position spline's own weight of the step
:math:`p_k - p_{k-1}`: the quintic interpolating spline (:class:`~torqueopt.WaypointPath`), zero
velocity and acceleration at both ends, through the values 0 at :math:`t_j < t_k` and 1 at
:math:`t_j \ge t_k`, so that the position spline is :math:`p_0 + \sum_k S_k(t)(p_k - p_{k-1})`. Hence
:math:`R(t_j) = R_j` at every waypoint, :math:`R` is as smooth as the position spline (C⁴) and rests at both
ends, and with two waypoints it is the geodesic from :math:`R_0` to :math:`R_1` on the minimum-jerk profile,
the same as the position's line.

Each factor turns about a fixed axis, so the world angular velocity and acceleration follow exactly by the
product rule: with :math:`P_k = R_0 \prod_{i \le k} \exp(S_i\phi_i)` and the world axis
:math:`u_k = P_{k-1}\phi_k`,

.. math::

    \omega_k = \omega_{k-1} + \dot S_k u_k,\qquad
    \dot\omega_k = \dot\omega_{k-1} + \ddot S_k u_k + \dot S_k\, \omega_{k-1}\times u_k,

since :math:`\dot u_k = \omega_{k-1} \times u_k`; :math:`\omega = \omega_K` and :math:`\dot\omega = \dot\omega_K`
are the derivatives of the interpolant itself, not of an approximation of it. ``exp`` and ``log`` are
Pinocchio's ``exp3`` and ``log3``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

__all__ = ["OrientationSample", "OrientationSpline", "cumulative_weights", "rotation_error"]


class OrientationSample(NamedTuple):
    """Samples of an orientation path at N times, world axes.

    Attributes:
        rotation: (N, 3, 3) rotation matrices.
        angular_velocity: (N, 3) [rad/s].
        angular_acceleration: (N, 3) [rad/s²].
    """

    rotation: np.ndarray
    angular_velocity: np.ndarray
    angular_acceleration: np.ndarray


def cumulative_weights(times: np.ndarray):
    r"""The spline whose component k − 1 is :math:`S_k(t)`, the weight of the k-th waypoint step (module docstring).

    It interpolates the K + 1 rows of a staircase (row j has ones in its first j columns) with the
    position spline's construction: degree 5, zero first and second derivatives at both ends.
    """
    from scipy.interpolate import make_interp_spline

    count = times.size - 1
    staircase = np.tril(np.ones((count + 1, count)), -1)
    rest = np.zeros(count)
    at_rest = [(1, rest), (2, rest)]
    return make_interp_spline(times, staircase, k=5, bc_type=(at_rest, at_rest))


class OrientationSpline:
    """The orientation path through ``rotations`` at ``times`` (see the module docstring).

    Args:
        times: waypoint times [s], strictly increasing from 0 (checked by the caller).
        rotations: (K + 1, 3, 3) rotation matrices, world axes.
    """

    def __init__(self, times: np.ndarray, rotations: np.ndarray):
        self.times = times
        self.rotations = rotations
        self.duration = float(times[-1])
        #: The shortest arcs φ_k = log3(R_{k-1}ᵀ R_k) [rad], one row per step.
        self.increments = np.array([pin.log3(before.T.dot(after)) for before, after in zip(rotations, rotations[1:])])
        self._weights = cumulative_weights(times)

    def sample(self, t) -> OrientationSample:
        """R(t), ω(t) and ω̇(t) at the times ``t`` [s] (a scalar or an array); rests outside [0, T]."""
        times = np.asarray(t, dtype=float)
        flat = times.reshape(-1)
        clipped = np.clip(flat, 0.0, self.duration)
        moving = ((flat >= 0.0) & (flat <= self.duration))[:, None]
        weight = self._weights(clipped)
        weight_rate = np.where(moving, self._weights(clipped, 1), 0.0)
        weight_acceleration = np.where(moving, self._weights(clipped, 2), 0.0)
        count = flat.size
        rotation = np.repeat(self.rotations[0][None], count, axis=0)
        velocity = np.zeros((count, 3))
        acceleration = np.zeros((count, 3))
        exp3 = pin.exp3
        for k, increment in enumerate(self.increments):
            axis = rotation.dot(increment)  # u_k = P_{k-1} φ_k, world axes
            rate = weight_rate[:, k, None]
            acceleration += weight_acceleration[:, k, None] * axis + rate * np.cross(velocity, axis)
            velocity += rate * axis
            factors = np.array([exp3(s * increment) for s in weight[:, k]])
            rotation = np.matmul(rotation, factors)
        shape = times.shape
        return OrientationSample(
            rotation.reshape(*shape, 3, 3), velocity.reshape(*shape, 3), acceleration.reshape(*shape, 3)
        )


def rotation_error(reference_vector: np.ndarray, rotation: np.ndarray, base_rotation: np.ndarray) -> np.ndarray:
    r""":math:`\log(R_{ref} R^\top)` [rad], world axes: the rotation vector that turns ``rotation`` R onto
    :math:`R_{ref} = \exp(r_{ref}) R_0`, given by its rotation vector ``reference_vector`` about ``base_rotation``
    :math:`R_0` (a ``pose`` task's reference rows); its norm is the angle between the two rotations."""
    return pin.log3(pin.exp3(reference_vector).dot(base_rotation).dot(rotation.T))
