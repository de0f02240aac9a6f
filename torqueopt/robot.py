r"""The robot model: a Pinocchio model, a task frame and a task kind.

At a state :math:`(q, \dot q)` a :class:`Robot` gives every term the
resolvers need, all computed by Pinocchio:

* the joint-space inertia :math:`H(q)` (CRBA), symmetric, in [kg·m²];
* the bias torques :math:`b(q,\dot q) = \dot q \cdot C \cdot \dot q + g(q)`
  (RNEA with zero acceleration), in [N·m], Eq. (20) of the paper;
* the task Jacobian :math:`J` and drift :math:`\dot J \dot q` in the
  world-aligned frame at the task frame's origin, Eq. (18).

Joint damping and friction (the URDF's ``<dynamics damping friction>``,
Pinocchio's ``model.damping`` and ``model.friction``) are modelled or not
as one setting says, ``joint_dynamics`` (:data:`JOINT_DYNAMICS`): with
``"urdf"`` the joints resist motion with the torque

.. math::

    \tau_j(\dot q) = D \dot q + F \tanh(\dot q / v_s),\qquad
    v_{s,j} = F_j\,(H^{-1})_{jj}(q_\mathrm{ref}) / \kappa,

:math:`D` the damping [N·m·s/rad], :math:`F` the friction [N·m] and
:math:`v_s` [rad/s] the velocity below which the friction fades, per joint:
below it the friction slows the joint at the rate :math:`\kappa` =
:data:`FRICTION_RATE` whatever its inertia, as MuJoCo's ``frictionloss``
does (:math:`(H^{-1})_{jj}` at the default configuration); it joins the bias torque
:math:`b` the resolvers compensate, and the forward dynamics subtract it
(:meth:`torqueopt.Robot.forward_dynamics`), so the controller's model and the
Pinocchio plant stay one model, and the torque the paper's criterion
weighs is the motor's. With ``"off"`` neither is modelled (Pinocchio's own
algorithms never read them). Why tanh, and why this :math:`v_s`:
docs/decisions/0009-joint-damping-and-friction.md.

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
from .errors import InvalidInput
from .units import joint_kind, joint_unit

__all__ = [
    "DEFAULT_JOINT_DYNAMICS",
    "FRICTION_RATE",
    "JOINT_DYNAMICS",
    "Robot",
    "TaskTerms",
    "TASK_DIMENSIONS",
    "check_joint_dynamics",
    "check_task_and_frame",
    "joint_resistance",
]

_TASK_ROWS = {"xy": slice(0, 2), "position": slice(0, 3), "pose": slice(0, 6)}
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_WORLD = pin.Convention.WORLD
#: Joints with one configuration coordinate that Pinocchio integrates by addition.
_EUCLIDEAN_JOINTS = frozenset(
    f"JointModel{kind}" for kind in ("RX", "RY", "RZ", "RevoluteUnaligned", "PX", "PY", "PZ", "PrismaticUnaligned")
)
#: The joint-dynamics settings, ``urdf`` (model the URDF's joint damping and friction) and ``off`` (neither).
JOINT_DYNAMICS = ("urdf", "off")
#: The setting a robot gets unless told, ``off``, which keeps every run of the example arms whose URDFs carry
#: damping (panda, xarm7, baxter, tiago) as it was before joint dynamics existed (decision record 0009).
DEFAULT_JOINT_DYNAMICS = "off"
#: κ [1/s] of the friction model :math:`F_j \tanh(\dot q_j / v_{s,j})`, :math:`v_{s,j} = F_j (H^{-1})_{jj} / κ`:
#: below saturation the friction slows joint j at the rate κ whatever its inertia, as MuJoCo's ``frictionloss``
#: does at its default solref (2 / (0.95 · 0.02 s) / (1 + 0.1/0.9) ≈ 94.7 /s); decision record 0009.
FRICTION_RATE = 100.0


def check_joint_dynamics(value) -> str:
    """The joint-dynamics setting ``value`` names (``urdf`` or ``off``).

    Raises:
        InvalidInput: any other value, naming it and the valid ones.
    """
    if isinstance(value, str) and value in JOINT_DYNAMICS:
        return value
    raise InvalidInput(f"joint dynamics {value!r} is not one of {', '.join(JOINT_DYNAMICS)}")


def joint_resistance(
    damping: np.ndarray, friction: np.ndarray, velocity_scale: np.ndarray, velocity: np.ndarray
) -> np.ndarray:
    r"""The torque the joints' damping and friction oppose motion with, :math:`D\dot q + F\tanh(\dot q/v_s)` [N·m].

    ``velocity`` is one state's (n) or a stack's (B, n) [rad/s]; ``damping``
    [N·m·s/rad], ``friction`` [N·m] and ``velocity_scale`` :math:`v_s`
    [rad/s] one value per joint (``Robot.friction_velocity_scale``).
    """
    return damping * velocity + friction * np.tanh(velocity / velocity_scale)


class TaskTerms(NamedTuple):
    r"""Dynamic and task terms at one state (an immutable tuple, cheap to build at every step).

    Attributes:
        inertia: joint-space inertia :math:`H` (n×n) [kg·m², kg].
        bias_torque: :math:`\dot q \cdot C \cdot \dot q + g` (n) [N·m], plus the joints'
            damping and friction :math:`\tau_j(\dot q)` when the robot models them.
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
    task frame. ``joint_dynamics`` says whether the URDF's joint damping and
    friction are modelled (see the module docstring).
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
        joint_dynamics: str = DEFAULT_JOINT_DYNAMICS,
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
        self._set_joint_dynamics(joint_dynamics)

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

    def with_joint_dynamics(self, joint_dynamics: str) -> Robot:
        """A copy of this robot that models the URDF's joint damping and friction (``"urdf"``) or not (``"off"``).

        The copy shares this robot's Pinocchio model and torque limits; this robot is left as it is.
        """
        copy = self._copy(self.model, self.torque_upper.copy(), self.gravity, joint_dynamics)
        copy.torque_lower = self.torque_lower.copy()
        return copy

    def _copy(self, model: pin.Model, torque_limit, gravity, joint_dynamics: str | None = None) -> Robot:
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
            joint_dynamics=self.joint_dynamics if joint_dynamics is None else joint_dynamics,
        )

    def _set_joint_dynamics(self, joint_dynamics: str) -> None:
        """Model the URDF's joint damping and friction, or not; only while the robot is made."""
        self.joint_dynamics = check_joint_dynamics(joint_dynamics)
        #: The URDF's joint damping [N·m·s/rad or N·s/m] and friction [N·m or N], one per joint, as written.
        self.urdf_joint_damping = np.array(self.model.damping, dtype=float)
        self.urdf_joint_friction = np.array(self.model.friction, dtype=float)
        modelled = self.joint_dynamics == "urdf"
        #: The damping D and friction F the robot models: the URDF's under ``urdf``, zeros under ``off``.
        self.joint_damping = self.urdf_joint_damping.copy() if modelled else np.zeros(self.nv)
        self.joint_friction = self.urdf_joint_friction.copy() if modelled else np.zeros(self.nv)
        #: v_s per joint [rad/s or m/s] of the friction model (see the module docstring); 1 where F = 0.
        self.friction_velocity_scale = np.ones(self.nv)
        if self.urdf_joint_friction.any():
            data = self.model.createData()
            inverse_inertia = np.diag(pin.computeMinverse(self.model, data, self._default_configuration)).copy()
            scale = self.urdf_joint_friction * inverse_inertia / FRICTION_RATE
            self.friction_velocity_scale = np.where(scale > 0, scale, 1.0)

    @property
    def urdf_has_joint_dynamics(self) -> bool:
        """True when the URDF gives some joint a nonzero damping or friction (modelled or not)."""
        return bool(self.urdf_joint_damping.any() or self.urdf_joint_friction.any())

    @property
    def models_joint_dynamics(self) -> bool:
        """True when the dynamics carry a joint damping or friction torque (``urdf``, and the URDF has some)."""
        return bool(self.joint_damping.any() or self.joint_friction.any())

    def joint_resistance(self, velocity: np.ndarray) -> np.ndarray:
        r""":math:`\tau_j(\dot q) = D\dot q + F\tanh(\dot q/v_s)` [N·m] of one velocity (n) or a stack (B, n); zeros
        when the robot does not model joint dynamics."""
        return joint_resistance(
            self.joint_damping, self.joint_friction, self.friction_velocity_scale, np.asarray(velocity, dtype=float)
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

        if not self.models_joint_dynamics:
            return terms
        resistance = self.joint_resistance

        def terms_with_joint_resistance(q: np.ndarray, v: np.ndarray) -> TaskTerms:
            # The bias the resolvers compensate is the motor's: b of Eq. (20) plus the joints' own resistance.
            found = terms(q, v)
            return found._replace(bias_torque=found.bias_torque + resistance(v))

        return terms_with_joint_resistance

    def forward_dynamics(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, data: pin.Data | None = None
    ) -> np.ndarray:
        r"""Joint acceleration from torque, by Pinocchio's ABA [rad/s²], computed in ``data`` (fresh when None).

        ABA runs in Pinocchio's WORLD convention: the same accelerations as
        the default LOCAL one to round-off, in fewer instructions (BENCHMARKS.md).
        When the robot models joint dynamics the joints' resistance
        :math:`\tau_j(\dot q)` is taken off the torque first: ABA(q, q̇, τ − τ_j(q̇)).
        """
        data = self.model.createData() if data is None else data
        if self.models_joint_dynamics:
            tau = tau - self.joint_resistance(v)
        return pin.aba(self.model, data, q, v, tau, _WORLD)

    def forward_dynamics_function(self, data: pin.Data | None = None):
        """:meth:`forward_dynamics` as a bare callable ``(q, v, tau) -> q̈`` computing in ``data`` (fresh when None).

        Calling it skips one Python frame per call, for inner loops.
        """
        model = self.model
        data = model.createData() if data is None else data
        if not self.models_joint_dynamics:
            return partial(pin.aba, model, data, convention=_WORLD)
        resistance = self.joint_resistance

        def forward_dynamics(q, v, tau):
            return pin.aba(model, data, q, v, tau - resistance(v), _WORLD)

        return forward_dynamics

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
            f"torque_limit={self.torque_limit.tolist()}, joint_dynamics={self.joint_dynamics!r})"
        )
