r"""The inverse dynamics and the task frame's position as CasADi expressions, generated from the Pinocchio model.

Pinocchio's ``pin`` wheel has no ``pinocchio.casadi``; the whole-movement
problem of :mod:`torqueopt.optimal.shooting` needs the torque and the task as
expressions CasADi can differentiate twice. This module writes them down from
the model's numbers (``model.jointPlacements``, ``model.inertias``, the
joints' axes, ``model.gravity``, ``model.armature``) with the recursive
Newton-Euler algorithm of the textbook (Featherstone, *Rigid Body Dynamics
Algorithms*, Table 5.1), in Pinocchio's conventions: motion and force vectors
as (linear, angular), expressed in each joint's frame; the base accelerates
at :math:`-g` so gravity enters through the forward pass.

.. math::

    {}^{\lambda}M_i &= M^{placement}_i\, M_J(q_i), \quad
        v_i = {}^{\lambda}M_i^{-1} v_{\lambda} + S_i \dot q_i, \quad
        a_i = {}^{\lambda}M_i^{-1} a_{\lambda} + S_i \ddot q_i + v_i \times S_i \dot q_i, \\
    f_i &= I_i a_i + v_i \times^* I_i v_i, \quad
        \tau_i = S_i^\top f_i + \text{armature}_i\, \ddot q_i, \quad
        f_{\lambda} \mathrel{+}= {}^{\lambda}M_i f_i .

This is the one twin of Pinocchio the package keeps: ``tests/test_optimal_symbolic.py``
holds it to ``pin.rnea`` and to Pinocchio's frame placement at 1e-12 on every
arm. The reason for a twin rather than Pinocchio's analytical derivatives
through callbacks is measured in docs/decisions/0001-rnea-in-casadi.md.

Joints: revolute (about x, y, z or any axis), continuous (its configuration
is (cos θ, sin θ)), prismatic (along x, y, z or any axis); fixed joints are
merged by Pinocchio when the URDF is read.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pinocchio as pin

from ..errors import InvalidInput, MissingDependency

__all__ = ["SUPPORTED_JOINTS", "configuration_expression", "model_digest", "symbolic_dynamics"]

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
#: Pinocchio joint models the generator knows: revolute, continuous ("RUB", unbounded) and prismatic.
SUPPORTED_JOINTS = (
    *(f"JointModel{kind}{axis}" for kind in ("R", "RUB", "P") for axis in "XYZ"),
    "JointModelRevoluteUnaligned",
    "JointModelRevoluteUnboundedUnaligned",
    "JointModelPrismaticUnaligned",
)


def _casadi():
    try:
        import casadi
    except ImportError:
        raise MissingDependency("the shooting transcription needs casadi: pip install casadi") from None
    return casadi


def _unaligned_axis(joint) -> np.ndarray:
    """The axis of an unaligned joint: ``model.joints[i]`` is Pinocchio's generic JointModel, whose axis only the
    concrete model it ``extract()``s has."""
    return np.array((joint if hasattr(joint, "axis") else joint.extract()).axis, float)


def _joint_kind(joint) -> tuple[str, np.ndarray]:
    """('revolute' | 'continuous' | 'prismatic', unit axis in the joint frame) of a Pinocchio joint model."""
    name = joint.shortname()
    if name not in SUPPORTED_JOINTS:
        raise InvalidInput(
            f"joint model '{name}' is not supported by the symbolic dynamics; supported: {', '.join(SUPPORTED_JOINTS)}"
        )
    if name.endswith("Unaligned"):
        axis = _unaligned_axis(joint)
        kind = {"Revolute": "revolute", "RevoluteUnbounded": "continuous", "Prismatic": "prismatic"}[
            name[len("JointModel") : -len("Unaligned")]
        ]
        return kind, axis / np.linalg.norm(axis)
    kind = {"R": "revolute", "RUB": "continuous", "P": "prismatic"}[name[len("JointModel") : -1]]
    return kind, np.array(_AXES[name[-1]])


def _rotation(casadi, axis: np.ndarray, cosine, sine):
    """Rodrigues' rotation about the unit ``axis`` by the angle of (cosine, sine)."""
    skew = casadi.DM([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    outer = casadi.DM(np.outer(axis, axis))
    return cosine * casadi.DM.eye(3) + sine * skew + (1.0 - cosine) * outer


def configuration_expression(model: pin.Model, angles):
    """Pinocchio's ``integrate(model, neutral(model), angles)`` as a CasADi expression (nq×1).

    One angle (or length) per joint, as :meth:`torqueopt.Robot.configuration`
    takes them: a revolute or prismatic joint's configuration is its angle
    (their neutral is 0), a continuous joint's is (cos θ, sin θ).
    """
    casadi = _casadi()
    entries = [None] * model.nq
    for joint in range(1, model.njoints):
        kind, _ = _joint_kind(model.joints[joint])
        iq, iv = model.joints[joint].idx_q, model.joints[joint].idx_v
        if kind == "continuous":
            entries[iq], entries[iq + 1] = casadi.cos(angles[iv]), casadi.sin(angles[iv])
        else:
            entries[iq] = angles[iv]
    return casadi.vertcat(*entries)


def model_digest(model: pin.Model, frame_id: int | None = None) -> str:
    """A hex digest of every number the expressions are made of (for a cache of compiled code)."""
    digest = hashlib.sha256()
    for joint in range(1, model.njoints):
        digest.update(model.joints[joint].shortname().encode())
        if model.joints[joint].shortname().endswith("Unaligned"):
            digest.update(_unaligned_axis(model.joints[joint]).tobytes())
        digest.update(np.int64(model.parents[joint]).tobytes())
        digest.update(np.asarray(model.jointPlacements[joint].homogeneous, float).tobytes())
        inertia = model.inertias[joint]
        digest.update(np.asarray([inertia.mass, *inertia.lever, *inertia.inertia.reshape(-1)], float).tobytes())
    digest.update(np.asarray(model.gravity.linear, float).tobytes())
    digest.update(np.asarray(model.armature, float).tobytes())
    if frame_id is not None:
        frame = model.frames[frame_id]
        digest.update(np.int64(frame.parentJoint).tobytes())
        digest.update(np.asarray(frame.placement.homogeneous, float).tobytes())
    return digest.hexdigest()


def symbolic_dynamics(model: pin.Model, frame_id: int, q, v, a):
    r"""τ = RNEA(q, v, a) and the frame's placement (rotation, position) in the world, as CasADi expressions.

    Args:
        model: a serial or branched Pinocchio model of the joints of :data:`SUPPORTED_JOINTS`.
        frame_id: the task frame's index in ``model.frames``.
        q, v, a: CasADi column vectors (SX or MX) of sizes nq, nv, nv.

    Returns:
        (tau, rotation, position): nv×1 [N·m], 3×3, 3×1 [m] expressions.
    """
    casadi = _casadi()
    count = model.njoints
    rotations, translations = [None] * count, [None] * count  # parent ← joint i
    world_rotations, world_translations = [None] * count, [None] * count
    linear_velocity, angular_velocity = [None] * count, [None] * count
    linear_acceleration, angular_acceleration = [None] * count, [None] * count
    motion_subspace = [None] * count
    zero = casadi.DM.zeros(3, 1)
    world_rotations[0], world_translations[0] = casadi.DM.eye(3), zero
    linear_velocity[0], angular_velocity[0] = zero, zero
    linear_acceleration[0], angular_acceleration[0] = -casadi.DM(np.array(model.gravity.linear)), zero
    forces_linear, forces_angular = [None] * count, [None] * count
    for joint in range(1, count):
        kind, axis = _joint_kind(model.joints[joint])
        iq, iv = model.joints[joint].idx_q, model.joints[joint].idx_v
        axis_dm = casadi.DM(axis)
        if kind == "prismatic":
            joint_rotation, joint_translation = casadi.DM.eye(3), axis_dm * q[iq]
            subspace = (axis_dm, zero)
        else:
            cosine, sine = (casadi.cos(q[iq]), casadi.sin(q[iq])) if kind == "revolute" else (q[iq], q[iq + 1])
            joint_rotation, joint_translation = _rotation(casadi, axis, cosine, sine), zero
            subspace = (zero, axis_dm)
        placement = model.jointPlacements[joint]
        rotation = casadi.DM(placement.rotation) @ joint_rotation
        translation = casadi.DM(placement.translation) + casadi.DM(placement.rotation) @ joint_translation
        rotations[joint], translations[joint] = rotation, translation
        parent = model.parents[joint]
        world_rotations[joint] = world_rotations[parent] @ rotation
        world_translations[joint] = world_translations[parent] + world_rotations[parent] @ translation
        # Motion of the parent expressed in this joint's frame: M⁻¹ (v_lin, v_ang) = (Rᵀ(v_lin − p × v_ang), Rᵀ v_ang).
        angular_parent = rotation.T @ angular_velocity[parent]
        linear_parent = rotation.T @ (linear_velocity[parent] - casadi.cross(translation, angular_velocity[parent]))
        joint_linear, joint_angular = subspace[0] * v[iv], subspace[1] * v[iv]
        linear_velocity[joint] = linear_parent + joint_linear
        angular_velocity[joint] = angular_parent + joint_angular
        # v × (S q̇) = (ω × ν_J + ν × ω_J, ω × ω_J)
        omega, nu = angular_velocity[joint], linear_velocity[joint]
        linear_acceleration[joint] = (
            rotation.T @ (linear_acceleration[parent] - casadi.cross(translation, angular_acceleration[parent]))
            + subspace[0] * a[iv]
            + casadi.cross(omega, joint_linear)
            + casadi.cross(nu, joint_angular)
        )
        angular_acceleration[joint] = (
            rotation.T @ angular_acceleration[parent] + subspace[1] * a[iv] + casadi.cross(omega, joint_angular)
        )
        inertia = model.inertias[joint]
        mass, lever, rotational = inertia.mass, casadi.DM(np.array(inertia.lever)), casadi.DM(inertia.inertia)

        def inertia_times(linear, angular, mass=mass, lever=lever, rotational=rotational):
            """I (linear, angular) for the spatial inertia (m, c, I_c): f = m(ν − c × ω), n = I_c ω + c × f."""
            force = mass * (linear - casadi.cross(lever, angular))
            return force, rotational @ angular + casadi.cross(lever, force)

        momentum_linear, momentum_angular = inertia_times(nu, omega)
        force_linear, force_angular = inertia_times(linear_acceleration[joint], angular_acceleration[joint])
        # v ×* h = (ω × h_lin, ω × h_ang + ν × h_lin)
        forces_linear[joint] = force_linear + casadi.cross(omega, momentum_linear)
        forces_angular[joint] = (
            force_angular + casadi.cross(omega, momentum_angular) + casadi.cross(nu, momentum_linear)
        )
        motion_subspace[joint] = subspace
    torques = [None] * model.nv
    for joint in range(count - 1, 0, -1):
        subspace, iv = motion_subspace[joint], model.joints[joint].idx_v
        torques[iv] = (
            casadi.dot(subspace[0], forces_linear[joint])
            + casadi.dot(subspace[1], forces_angular[joint])
            + float(model.armature[iv]) * a[iv]
        )
        parent = model.parents[joint]
        if parent > 0:
            # M f = (R f_lin, R f_ang + p × R f_lin), into the parent's frame
            rotated = rotations[joint] @ forces_linear[joint]
            forces_linear[parent] = forces_linear[parent] + rotated
            forces_angular[parent] = (
                forces_angular[parent]
                + rotations[joint] @ forces_angular[joint]
                + casadi.cross(translations[joint], rotated)
            )
    frame = model.frames[frame_id]
    parent = frame.parentJoint
    frame_rotation = world_rotations[parent] @ casadi.DM(frame.placement.rotation)
    frame_position = world_translations[parent] + world_rotations[parent] @ casadi.DM(frame.placement.translation)
    return casadi.vertcat(*torques), frame_rotation, frame_position
