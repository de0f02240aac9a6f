r"""The robot model: a Pinocchio model, a task frame and a task kind.

At a state :math:`(q, \dot q)` a :class:`Robot` gives every term the
resolvers need, all computed by Pinocchio:

* the joint-space inertia :math:`H(q)` (CRBA), symmetric, in [kg·m²];
* the bias torques :math:`b(q,\dot q) = \dot q \cdot C \cdot \dot q + g(q)`
  (RNEA with zero acceleration), in [N·m], Eq. (20) of the paper;
* the task Jacobian :math:`J` and drift :math:`\dot J \dot q` in the
  world-aligned frame at the task frame's origin, Eq. (18).

Tasks:

``xy``
    planar tip position (m = 2), the paper's task.
``position``
    3-D position of the frame origin (m = 3).
``pose``
    position and orientation (m = 6). The orientation coordinates are the
    rotation vector :math:`\log(R R_0^\top)` of the frame's rotation relative
    to a reference rotation :math:`R_0` in world axes; their rates and
    accelerations are the world angular velocity and acceleration.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .catalog import RobotSource
from .checks import TASK_DIMENSIONS, check_task_and_frame, finite_vector, torque_limit_vector
from .units import joint_kind, joint_unit

__all__ = ["Robot", "TaskTerms", "TASK_DIMENSIONS", "check_task_and_frame"]

_TASK_ROWS = {"xy": slice(0, 2), "position": slice(0, 3), "pose": slice(0, 6)}
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_WORLD = pin.Convention.WORLD
#: Joints with one configuration coordinate that Pinocchio integrates by addition.
_EUCLIDEAN_JOINTS = frozenset(
    f"JointModel{kind}" for kind in ("RX", "RY", "RZ", "RevoluteUnaligned", "PX", "PY", "PZ", "PrismaticUnaligned")
)


class TaskTerms(NamedTuple):
    r"""Dynamic and task terms at one state (an immutable tuple, cheap to build at every step).

    Attributes:
        inertia: joint-space inertia :math:`H` (n×n) [kg·m², kg].
        bias_torque: :math:`\dot q \cdot C \cdot \dot q + g` (n) [N·m].
        jacobian: task Jacobian :math:`J` (m×n), world-aligned.
        drift: :math:`\dot J \dot q` (m), the classical task acceleration at
            zero joint acceleration [m/s², rad/s²].
        placement: pose of the task frame in the world (Pinocchio SE3).
        joint_velocity: :math:`\dot q` (n) [rad/s], the state's velocity
            (for resolvers that shape the self-motion by it).
        configuration: :math:`q` (nq), the state's configuration vector
            (for resolvers that need more of the model at this state).

    The terms a resolver gets inside :func:`torqueopt.simulate` come from
    :meth:`Robot.terms_function`: there ``inertia`` and ``bias_torque`` are
    views of the run's own Pinocchio data, valid for that step only; copy
    them to keep them.
    """

    inertia: np.ndarray
    bias_torque: np.ndarray
    jacobian: np.ndarray
    drift: np.ndarray
    placement: pin.SE3
    joint_velocity: np.ndarray
    configuration: np.ndarray

    @property
    def task_velocity(self) -> np.ndarray:
        r""":math:`J \dot q` (m) [m/s, rad/s], computed when asked for."""
        return self.jacobian.dot(self.joint_velocity)


class Robot:
    """A Pinocchio model with a task frame, a task kind and torque limits.

    Build one with :func:`torqueopt.load_robot`. Joints outside the chain that carries
    the task frame (the other arm, a gripper, a mobile base) are locked at
    their reference values, so ``nv`` counts only the joints that move the
    task frame.
    """

    def __init__(
        self,
        model: pin.Model,
        frame: str,
        task: str,
        *,
        name: str = "robot",
        source: RobotSource | None = None,
        torque_limit=None,
        gravity=True,
        locked_joints: tuple[str, ...] = (),
        full_model: pin.Model | None = None,
        locked_configuration: np.ndarray | None = None,
        default_configuration: np.ndarray | None = None,
        payload=None,
    ):
        check_task_and_frame(model, frame, task, name)
        self.model = model
        self.name = name
        self.source = source
        self.frame = frame
        self.frame_id = model.getFrameId(frame)
        self.task = task
        self.task_rows = _TASK_ROWS[task]
        self.locked_joints = tuple(locked_joints)
        self.full_model = full_model if full_model is not None else model
        self.locked_configuration = locked_configuration
        #: The :class:`~torqueopt.Payload` the task frame carries, already in ``model``'s inertias
        #: (:func:`torqueopt.load_robot` adds it); None without one.
        self.payload = payload
        self.joint_names = [model.names[j] for j in range(1, model.njoints) if model.joints[j].nv > 0]
        #: Per joint, 'revolute', 'continuous' or 'prismatic' (:func:`torqueopt.units.joint_kind`): its units.
        self.joint_kinds = [joint_kind(model.joints[j]) for j in range(1, model.njoints) if model.joints[j].nv > 0]
        #: True when every joint is revolute or prismatic with one coordinate, so
        #: that configurations add (``integrate(q, dq) == q + dq``); continuous
        #: joints, stored as (cos, sin), make it False.
        self.euclidean = all(model.joints[j].shortname() in _EUCLIDEAN_JOINTS for j in range(1, model.njoints))
        self._neutral = pin.neutral(model)
        self._default_configuration = (
            self._neutral.copy() if default_configuration is None else np.asarray(default_configuration, float)
        )
        self._set_gravity(gravity)
        self.urdf_effort_limit = np.array(model.effortLimit, dtype=float)
        self._set_torque_limit(torque_limit)

    # -- sizes --------------------------------------------------------------
    def joint_unit(self, joint: int, quantity: str) -> str:
        """The unit of ``quantity`` (``position``, ``velocity``, ``acceleration``, ``torque``) for joint ``joint``."""
        return joint_unit(self.joint_kinds[joint], quantity)

    @property
    def nq(self) -> int:
        """Size of a configuration vector (2 per continuous joint)."""
        return self.model.nq

    @property
    def nv(self) -> int:
        """Number of joint velocities n (the joints that move the task frame)."""
        return self.model.nv

    @property
    def m(self) -> int:
        """Task dimension m."""
        return TASK_DIMENSIONS[self.task]

    @property
    def redundancy(self) -> int:
        """Degree of redundancy n - m."""
        return self.nv - self.m

    # -- settings (a Robot is not changed after it is made: with_* give changed copies) --
    def _set_gravity(self, gravity) -> None:
        """Gravity on (``True``: -9.81 m/s² along world z), off, or its vector [m/s²]; only while the robot is made."""
        if gravity is True:
            vector = np.array([0.0, 0.0, -9.81])
        elif gravity is False or gravity is None:
            vector = np.zeros(3)
        else:
            vector = finite_vector(gravity, 3, "gravity")
        self.model.gravity.linear = vector

    @property
    def gravity(self) -> np.ndarray:
        """Gravity vector in world axes [m/s²]."""
        return np.array(self.model.gravity.linear)

    def with_gravity(self, gravity) -> Robot:
        """A copy of this robot (its own Pinocchio model) under ``gravity``; this robot is left as it is.

        ``gravity``: ``True`` (−9.81 m/s² along z), ``False`` or a 3-vector
        [m/s²]. The torque limits are this robot's.
        """
        copy = self._copy(self.model.copy(), self.torque_upper.copy(), gravity)
        copy.torque_lower = self.torque_lower.copy()
        return copy

    def with_torque_limit(self, torque_limit=None) -> Robot:
        """A copy of this robot with symmetric torque limits τ⁺ = −τ⁻ [N·m]; this robot is left as it is.

        ``None`` takes the URDF's effort limits; a scalar applies to every
        joint; a vector gives one limit per joint; ``inf`` marks a joint as
        unbounded. The copy shares this robot's Pinocchio model.
        """
        return self._copy(self.model, torque_limit, self.gravity)

    def _copy(self, model: pin.Model, torque_limit, gravity) -> Robot:
        return Robot(
            model,
            self.frame,
            self.task,
            name=self.name,
            source=self.source,
            torque_limit=torque_limit,
            gravity=gravity,
            locked_joints=self.locked_joints,
            full_model=self.full_model,
            locked_configuration=self.locked_configuration,
            default_configuration=self._default_configuration,
            payload=self.payload,
        )

    def _set_torque_limit(self, torque_limit=None) -> None:
        r"""Symmetric torque limits :math:`\tau^+ = -\tau^-` [N·m]; only while the robot is made.

        ``None`` takes the URDF's effort limits; a scalar applies to every
        joint; a vector gives one limit per joint. A URDF limit that is zero,
        infinite or missing means "unbounded" (recorded in
        :attr:`joints_without_torque_limit`); a limit given here must be
        positive, and ``inf`` marks a joint as unbounded on purpose.
        """
        if torque_limit is None:
            limit = self.urdf_effort_limit.copy()
            limit[~np.isfinite(limit) | (limit <= 0)] = np.inf
        else:
            limit = torque_limit_vector(self, torque_limit)
        self.torque_upper = limit
        self.torque_lower = -limit

    @property
    def torque_limit(self) -> np.ndarray:
        """Symmetric torque limit per joint [N·m]; ``inf`` where unbounded."""
        return self.torque_upper

    @property
    def joints_without_torque_limit(self) -> list[str]:
        """Joints whose torque is unbounded (no usable limit in the URDF, or set so)."""
        return [name for name, hi in zip(self.joint_names, self.torque_upper) if not np.isfinite(hi)]

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per joint, the URDF's (lower, upper) position limits [rad or m] and velocity limit [rad/s or m/s].

        ``±inf`` where there is none: continuous joints have no position
        limits, and a velocity limit of 0 (URDF's unspecified, or ``inf``) or
        beyond 1e300 (Pinocchio's "unset") means unbounded.
        """
        model = self.model
        lower, upper = np.full(self.nv, -np.inf), np.full(self.nv, np.inf)
        velocity = np.array(model.velocityLimit, dtype=float)
        velocity[~(velocity > 0) | (velocity > 1e300)] = np.inf
        for joint in range(1, model.njoints):
            description = model.joints[joint]
            if description.nq == description.nv == 1:
                lower[description.idx_v] = model.lowerPositionLimit[description.idx_q]
                upper[description.idx_v] = model.upperPositionLimit[description.idx_q]
        lower[lower < -1e300] = -np.inf
        upper[upper > 1e300] = np.inf
        return lower, upper, velocity

    # -- configurations -------------------------------------------------------
    @property
    def default_configuration(self) -> np.ndarray:
        """The SRDF reference configuration when there is one, else Pinocchio's neutral."""
        return self._default_configuration.copy()

    def configuration(self, joint_angles) -> np.ndarray:
        """Configuration vector from one coordinate per joint (angles in [rad], lengths in [m]).

        For continuous joints, whose configuration is (cos, sin), the angle is
        measured from Pinocchio's neutral configuration.
        """
        angles = finite_vector(joint_angles, self.nv, "q0", names=self.joint_names)
        return pin.integrate(self.model, self._neutral, angles)

    def joint_angles(self, configuration) -> np.ndarray:
        """Inverse of :meth:`configuration`: one coordinate per joint, for one configuration or rows of them."""
        configurations = np.asarray(configuration, float)
        if self.euclidean:
            # Every joint is revolute or prismatic: Pinocchio's difference is a subtraction.
            return configurations - self._neutral
        if configurations.ndim == 1:
            return pin.difference(self.model, self._neutral, configurations)
        return np.array([pin.difference(self.model, self._neutral, row) for row in configurations]).reshape(-1, self.nv)

    # -- dynamics -------------------------------------------------------------
    def terms(self, q: np.ndarray, v: np.ndarray) -> TaskTerms:
        """Inertia, bias torques, task Jacobian and drift at (q, v), all from Pinocchio, computed in a fresh data."""
        terms = self.terms_function()(q, v)
        return terms._replace(inertia=terms.inertia.copy(), bias_torque=terms.bias_torque.copy())

    def terms_function(self, data: pin.Data | None = None):
        """:meth:`terms` as a bare function ``(q, v) -> TaskTerms``, for inner loops.

        It computes in ``data`` (a fresh Pinocchio data when None), which it
        keeps: a run makes its own, so runs in threads never share one. Its
        ``inertia`` and ``bias_torque`` are views of that data, not copies:
        they hold the latest call's values until the data is next written
        (by this function or by any Pinocchio algorithm given the same
        data). A loop that uses them before its next call saves four numpy
        calls per step; the other fields are fresh at each call.
        """
        model, frame_id, rows = self.model, self.frame_id, self.task_rows
        data = model.createData() if data is None else data
        # Eigen never reallocates these fixed-size members, so one view serves every call.
        inertia, bias_torque = data.M, data.nle

        def terms(q: np.ndarray, v: np.ndarray) -> TaskTerms:
            pin.computeAllTerms(model, data, q, v)  # H and b of Eq. (20)
            placement = pin.updateFramePlacement(model, data, frame_id)
            jacobian6 = pin.getFrameJacobian(model, data, frame_id, _LWA)
            # computeAllTerms leaves the kinematics at zero joint acceleration, so
            # the classical acceleration of the frame is exactly J̇q̇ of Eq. (18).
            drift6 = pin.getFrameClassicalAcceleration(model, data, frame_id, _LWA).vector
            return TaskTerms(inertia, bias_torque, jacobian6[rows], drift6[rows], placement, v, q)

        return terms

    def forward_dynamics(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, data: pin.Data | None = None
    ) -> np.ndarray:
        """Joint acceleration from torque, by Pinocchio's ABA [rad/s²], computed in ``data`` (fresh when None).

        ABA runs in Pinocchio's WORLD convention: the same accelerations as
        the default LOCAL one to round-off, in fewer instructions (BENCHMARKS.md).
        """
        data = self.model.createData() if data is None else data
        return pin.aba(self.model, data, q, v, tau, _WORLD)

    def forward_dynamics_function(self, data: pin.Data | None = None):
        """:meth:`forward_dynamics` as a bare callable ``(q, v, tau) -> q̈`` computing in ``data`` (fresh when None).

        Calling it skips one Python frame per call, for inner loops.
        """
        data = self.model.createData() if data is None else data
        return partial(pin.aba, self.model, data, convention=_WORLD)

    def integrate(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Configuration reached from q by the joint displacement dq."""
        return pin.integrate(self.model, q, dq)

    def frame_placement(self, q: np.ndarray, data: pin.Data | None = None) -> pin.SE3:
        """World pose of the task frame at configuration q, computed in ``data`` (fresh when None)."""
        data = self.model.createData() if data is None else data
        pin.framesForwardKinematics(self.model, data, q)
        return data.oMf[self.frame_id].copy()

    def task_coordinates(self, placement: pin.SE3, reference_rotation: np.ndarray | None = None) -> np.ndarray:
        """Task coordinates x (m) of a frame placement; see the module docstring for ``pose``."""
        if self.task == "pose":
            reference = np.eye(3) if reference_rotation is None else reference_rotation
            return np.concatenate([placement.translation, pin.log3(placement.rotation.dot(reference.T))])
        return placement.translation[self.task_rows].copy()

    def task_position(self, q: np.ndarray, reference_rotation: np.ndarray | None = None) -> np.ndarray:
        """Task coordinates x (m) at configuration q."""
        return self.task_coordinates(self.frame_placement(q), reference_rotation)

    def __repr__(self) -> str:
        return (
            f"Robot({self.name!r}, frame={self.frame!r}, task={self.task!r}, n={self.nv}, m={self.m}, "
            f"torque_limit={self.torque_limit.tolist()})"
        )
