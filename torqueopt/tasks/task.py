r"""The base of every task: something of the arm whose coordinates, Jacobian and drift Pinocchio gives.

A task of dimension :math:`m` has coordinates :math:`x(q)` (m values), a
Jacobian :math:`J(q) = \partial x / \partial q` in world-aligned axes, so that
:math:`\dot x = J \dot q` (Eq. (1) of the paper), and a drift
:math:`\dot J \dot q`, so that :math:`\ddot x = J\ddot q + \dot J\dot q`
(Eq. (18)). A task may carry a target and a gain [1/s]; its desired rate is
then :math:`\dot x_d = k\,(x^* - x)` [m/s, rad/s], the low-priority
:math:`\dot x_l` of Eq. (8) or a regulation task.

Tasks read a :class:`Kinematics`, which runs Pinocchio's kinematics once per
configuration for all of them (as pink's tasks read one ``Configuration``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from functools import cache

import numpy as np
import pinocchio as pin

from ..checks import finite_numbers, non_negative_number
from ..errors import InvalidInput

__all__ = ["Kinematics", "PerConfiguration", "Task"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class Kinematics:
    """Pinocchio kinematics of one robot at one configuration, computed once and read by every task.

    It owns its own Pinocchio ``Data``, so it never disturbs the robot's.
    Call :meth:`update` with a configuration (and, for drifts, a velocity)
    before reading.
    """

    def __init__(self, robot):
        self.robot = robot
        self.model = robot.model
        self.data = robot.model.createData()
        self.q: np.ndarray | None = None
        self.v: np.ndarray | None = None
        #: How many times :meth:`update` ran: what was computed at one value of it holds while it stays.
        self.revision = 0
        self._hessians_ready = False
        self._zero = np.zeros(robot.model.nv)
        # Views of frames' translations in data.oMf, which Pinocchio never reallocates (eigenpy's SE3.translation
        # is a view into it): read after each update without a boost.python SE3 per read.
        self._translations: dict[int, np.ndarray] = {}
        self._joint_origins: np.ndarray | None = None
        self._world_jacobians: tuple[np.ndarray, np.ndarray] | None = None

    def update(self, q: np.ndarray, v: np.ndarray | None = None) -> Kinematics:
        """Placements and joint Jacobians at q; with v, also the velocities that drifts need."""
        model, data = self.model, self.data
        if v is not None:
            # Accelerations at zero q̈, so a frame's classical acceleration is J̇q̇.
            pin.forwardKinematics(model, data, q, v, self._zero)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        self.q, self.v = q, v
        self.revision += 1
        self._hessians_ready = False
        return self

    @property
    def nv(self) -> int:
        return self.model.nv

    def frame_placement(self, frame_id: int) -> pin.SE3:
        """World pose of a frame (a copy)."""
        return self.data.oMf[frame_id].copy()

    def frame_position(self, frame_id: int) -> np.ndarray:
        """World position of a frame's origin (3 values, a copy) [m]: ``frame_placement(frame_id).translation``."""
        return self.frame_position_view(frame_id).copy()

    def frame_position_view(self, frame_id: int) -> np.ndarray:
        """World position of a frame's origin [m] as a read-only view into Pinocchio's data: it holds the position
        at the latest :meth:`update` (:meth:`frame_position` is a copy)."""
        translation = self._translations.get(frame_id)
        if translation is None:
            translation = self._translations[frame_id] = self.data.oMf[frame_id].translation
            translation.setflags(write=False)
        return translation

    def joint_origins(self) -> np.ndarray:
        """World positions of every joint's origin [m], (njoints, 3), row j joint j's (row 0 the universe's): one
        read-only strided view of the translations of Pinocchio's ``data.oMi``, which hold the positions at the
        latest :meth:`update` (not a copy; ``translations_view``, made once)."""
        if self._joint_origins is None:
            self._joint_origins = translations_view(self.data.oMi, 0, len(self.data.oMi))
        return self._joint_origins

    def world_jacobians(self) -> np.ndarray:
        r"""Every joint's Jacobian columns in Pinocchio's WORLD frame (6×n, linear rows first): column k maps
        :math:`\dot q_k` to the spatial velocity :math:`(v_O, \omega)` of joint k's body taken at the world origin, so a
        point p on a body moves at :math:`v_O + \omega\times p` summed over the columns of the joints that move
        that body. A read-only view of Pinocchio's ``data.J`` (not a copy), which holds them at the latest
        :meth:`update`."""
        return self._world_views()[0]

    def world_jacobian_rates(self, v: np.ndarray) -> np.ndarray:
        r""":math:`\dot J` (6×n) of :meth:`world_jacobians` along joint velocity v, from Pinocchio's
        ``computeJointJacobiansTimeVariation`` at the configuration of the last :meth:`update`: a read-only view of
        ``data.dJ`` (not a copy), which holds it until the next call."""
        pin.computeJointJacobiansTimeVariation(self.model, self.data, self.q, v)
        return self._world_views()[1]

    def _world_views(self) -> tuple[np.ndarray, np.ndarray]:
        if self._world_jacobians is None:
            # eigenpy returns Data's own matrices as views into them, which Pinocchio never reallocates
            views = self.data.J, self.data.dJ
            for view in views:
                view.setflags(write=False)
            self._world_jacobians = views
        return self._world_jacobians

    def frame_jacobian(self, frame_id: int) -> np.ndarray:
        """6×n Jacobian of a frame at its origin, world-aligned axes (linear rows first)."""
        return pin.getFrameJacobian(self.model, self.data, frame_id, _LWA)

    def frame_drift(self, frame_id: int) -> np.ndarray:
        r""":math:`\dot J\dot q` of a frame (6 values, classical acceleration at zero q̈, world-aligned)."""
        if self.v is None:
            raise InvalidInput("a task drift J̇q̇ needs the joint velocity: call Kinematics.update(q, v)")
        return pin.getFrameClassicalAcceleration(self.model, self.data, frame_id, _LWA).vector

    def frame_jacobian_time_variation(self, frame_id: int, v: np.ndarray) -> np.ndarray:
        r""":math:`\dot J` (6×n) of a frame's Jacobian (:meth:`frame_jacobian`) moving at joint velocity v, world-aligned.

        From Pinocchio's ``computeJointJacobiansTimeVariation`` at the
        configuration of the last :meth:`update`, so
        :math:`\dot J v` is the frame's classical acceleration at zero q̈
        (:meth:`frame_drift`); the tests hold it to a central difference of
        :meth:`frame_jacobian` along v.
        """
        pin.computeJointJacobiansTimeVariation(self.model, self.data, self.q, v)
        return pin.getFrameJacobianTimeVariation(self.model, self.data, frame_id, _LWA)

    def jacobian_time_variations(self, v: np.ndarray, frame_ids=(), joint_ids=()):
        r""":math:`\dot J` (6×n, world-aligned) of several frames (:meth:`frame_jacobian_time_variation`) and joints
        (at the joint's origin) moving at joint velocity v, from one ``computeJointJacobiansTimeVariation`` for all
        of them: (the frames' list, the joints' list)."""
        model, data = self.model, self.data
        pin.computeJointJacobiansTimeVariation(model, data, self.q, v)
        frames = [pin.getFrameJacobianTimeVariation(model, data, frame_id, _LWA) for frame_id in frame_ids]
        return frames, [pin.getJointJacobianTimeVariation(model, data, joint_id, _LWA) for joint_id in joint_ids]

    def frame_jacobian_derivative(self, frame_id: int) -> np.ndarray:
        r"""Derivatives of the frame Jacobian: array D (6, n, n) with
        :math:`D[:, i, k] = \partial J_{:,i} / \partial q_k`, from Pinocchio's kinematic Hessian.

        ``pin.getFrameKinematicHessian`` returns Eigen's column-major tensor
        through a row-major view; it is read here in Fortran order (its memory
        as (n, n, 6) in C order, transposed: the same view as
        ``reshape(-1).reshape((6, n, n), order="F")``, in two calls instead of
        four), which the tests hold to central differences of :meth:`frame_jacobian`.
        """
        if not self._hessians_ready:
            pin.computeJointKinematicHessians(self.model, self.data)
            self._hessians_ready = True
        n = self.model.nv
        return pin.getFrameKinematicHessian(self.model, self.data, frame_id, _LWA).reshape(n, n, 6).T

    def frame_jacobian_derivative_rows(self, frame_id: int) -> np.ndarray:
        r"""The derivatives of :meth:`frame_jacobian_derivative` as Pinocchio lays them out: an (n, 6n) array
        whose row k is :math:`\partial J/\partial q_k` flattened column by column,
        :math:`[k, 6i + a] = \partial J_{a,i}/\partial q_k = D[a, i, k]` (Eigen's column-major tensor read in
        C order, no copy), so that a contraction with D is one product (the tests hold it to D)."""
        if not self._hessians_ready:
            pin.computeJointKinematicHessians(self.model, self.data)
            self._hessians_ready = True
        n = self.model.nv
        return pin.getFrameKinematicHessian(self.model, self.data, frame_id, _LWA).reshape(n, 6 * n)


def translations_view(placements, first: int, count: int) -> np.ndarray:
    """A read-only (count, 3) view of the translations of ``placements[first:first + count]`` (a Pinocchio data's
    ``oMi`` or ``oMf``), not a copy: they hold the positions at the data's latest computation.

    eigenpy returns each ``SE3.translation`` as a view into the placement's own memory, and the placements of a
    data are one contiguous vector that Pinocchio never reallocates; so one strided view reads them all, where
    reading them one by one crosses boost.python and eigenpy once each (BENCHMARKS.md). The
    layout is checked for every placement viewed when the view is made, not assumed.
    """
    first_translation = placements[first].translation
    stride = _placement_stride(placements, first, count, "translation")
    return np.lib.stride_tricks.as_strided(first_translation, shape=(count, 3), strides=(stride, 8), writeable=False)


def rotations_view(placements, first: int, count: int) -> np.ndarray:
    """A read-only (count, 3, 3) view of the rotation matrices of ``placements[first:first + count]``, not a copy:
    :func:`translations_view`'s reading of the rotations (Eigen's column-major 3×3, checked as it is)."""
    rotation = placements[first].rotation
    if rotation.strides != (8, 24):
        raise RuntimeError("Pinocchio's rotations are not column-major 3x3 matrices: cannot view them")
    stride = _placement_stride(placements, first, count, "rotation")
    return np.lib.stride_tricks.as_strided(rotation, shape=(count, 3, 3), strides=(stride, 8, 24), writeable=False)


def _placement_stride(placements, first: int, count: int, part: str) -> int:
    """The byte stride between the ``part`` (translation, rotation) of successive placements, checked for each."""
    addresses = [getattr(placements[first + index], part).__array_interface__["data"][0] for index in range(count)]
    stride = addresses[1] - addresses[0] if count > 1 else 0
    if addresses != [addresses[0] + index * stride for index in range(count)]:
        raise RuntimeError("Pinocchio's placements are not one evenly strided vector: cannot view them")
    return stride


@cache
def identity(n: int) -> np.ndarray:
    """The n×n identity, read-only, built once per n (``np.eye`` costs more than the products it enters)."""
    matrix = np.eye(n)
    matrix.setflags(write=False)
    return matrix


class PerConfiguration:
    """``function(kinematics)``, computed once per configuration: kept until the kinematics' next :meth:`Kinematics.update`.

    A velocity-level step evaluates the joint rates and then their time derivative at the same configuration;
    what both read (a pseudoinverse, a criterion's gradient, :math:`H^{-1}`) is computed by the first and
    reused by the second. A function that raises caches nothing and forgets what it held: a value is
    served only while the last call that computed anything was for this kinematics at this configuration
    (so a function may leave state elsewhere, a solver's decomposition, that its value stands for).
    """

    def __init__(self, function):
        self.function = function
        self._kinematics: Kinematics | None = None
        self._revision = -1
        self._value = None

    def __call__(self, kinematics: Kinematics):
        if kinematics.revision != self._revision or kinematics is not self._kinematics:
            self._kinematics = None
            self._value = self.function(kinematics)
            self._kinematics, self._revision = kinematics, kinematics.revision
        return self._value


class Task(ABC):
    r"""A task: coordinates :math:`x(q)`, Jacobian :math:`J`, drift :math:`\dot J\dot q`, optional target.

    Subclasses set ``dimension`` and implement :meth:`value`,
    :meth:`jacobian` and :meth:`drift`.

    Args:
        target: task coordinates to reach (``dimension`` values), or None.
        gain: rate of convergence to the target, :math:`\dot x_d = k(x^* - x)` [1/s].
    """

    dimension: int
    #: True when :meth:`jacobian_rate` and :meth:`desired_velocity_rate` hold in closed form (a task-priority
    #: resolver then takes q̈ in closed form too).
    closed_form_rates: bool = False

    def __init__(self, target=None, gain: float = 1.0):
        self.gain = non_negative_number(gain, "task gain", "1/s")
        self.target = None if target is None else self._check_target(target)

    def _check_target(self, target) -> np.ndarray:
        return finite_numbers(target, "task target", self.dimension, context=lambda: f"for {self!r}")

    def check(self, robot) -> None:
        """Raise if this task cannot be computed on ``robot`` (a missing frame, a wrong size)."""

    @abstractmethod
    def value(self, kinematics: Kinematics) -> np.ndarray:
        """Task coordinates x (``dimension`` values) [m, rad]."""

    @abstractmethod
    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        """Task Jacobian J (dimension × n), world-aligned, Eq. (1)."""

    @abstractmethod
    def drift(self, kinematics: Kinematics) -> np.ndarray:
        r""":math:`\dot J\dot q` (dimension values), Eq. (18); needs ``kinematics.update(q, v)``."""

    def error(self, kinematics: Kinematics) -> np.ndarray:
        """Target minus value (``dimension`` values); needs a target."""
        if self.target is None:
            raise InvalidInput(f"{self!r} has no target; give target= to use it as a regulation task")
        return self.target - self.value(kinematics)

    def desired_velocity(self, kinematics: Kinematics) -> np.ndarray:
        r""":math:`\dot x_d = k (x^* - x)` [m/s, rad/s], zero without a target."""
        if self.target is None:
            return np.zeros(self.dimension)
        return self.gain * self.error(kinematics)

    def jacobian_rate(self, kinematics: Kinematics, v: np.ndarray) -> np.ndarray:
        r""":math:`\dot J` (dimension × n) at the kinematics' configuration, moving at joint velocity v.

        Only for tasks with :attr:`closed_form_rates`."""
        raise InvalidInput(f"{self!r} has no Jacobian time variation in closed form")

    def desired_velocity_rate(self, kinematics: Kinematics, v: np.ndarray) -> np.ndarray:
        r""":math:`\frac{d}{dt}\dot x_d = -k J v` [m/s², rad/s²] along the motion at joint velocity v, zero without a target.

        Exact where :math:`\dot x = Jv` holds for the coordinates themselves (only for tasks with
        :attr:`closed_form_rates`; not a pose's rotation vector)."""
        if self.target is None:
            return np.zeros(self.dimension)
        return -self.gain * self.jacobian(kinematics).dot(v)
