r"""The stability margin: growth rate of the linearised closed-loop self-motion at one state.

A torque resolver closes the loop :math:`\ddot q = F(q, \dot q)`: at each
state it maps the task acceleration :math:`\ddot x` (held fixed here, the
paper's open loop) to a torque, and the arm's forward dynamics turn that
torque into :math:`\ddot q`. Linearised about a state, the state
:math:`s = (q, \dot q)` obeys :math:`\delta\dot s = A\,\delta s` with

.. math::

    A = \begin{bmatrix} 0 & I \\ \partial\ddot q/\partial q & \partial\ddot q/\partial\dot q \end{bmatrix},
    \qquad
    \frac{\partial\ddot q}{\partial s} = \frac{\partial\,\mathrm{ABA}}{\partial s}
        + H^{-1}\,\frac{\partial\tau}{\partial s},

the first part Pinocchio's analytical ABA derivatives
(``computeABADerivatives``, whose :math:`\partial\ddot q/\partial\tau` is
:math:`H^{-1}`), the second the resolver's torque through the terms it reads,

.. math::

    \frac{\partial\tau}{\partial s_i} = \sum_{\text{term}} \frac{\partial\tau}{\partial\,\text{term}}
        \frac{\partial\,\text{term}}{\partial s_i},

with every term's derivative analytical from Pinocchio: :math:`\partial H/\partial q_k`
and :math:`\partial b/\partial s` from ``computeRNEADerivatives`` (with the joints' damping and friction
:math:`\partial\tau_j/\partial\dot q` when the robot models them, which the plant's ABA then takes off),
:math:`\partial J/\partial q_k` from ``getFrameVelocityDerivatives`` and the
drift :math:`\dot J\dot q` (the classical acceleration, :math:`a + \omega\times v`)
from ``getFrameAccelerationDerivatives``. The resolver itself is any
registered step (a QP, an SVD-based pseudoinverse), so its dependence on the
terms is taken as a central difference of the step along each term
perturbation :math:`\partial\,\text{term}/\partial s_i` (the configuration
moved with it, for resolvers that read the model at it).

The self-motion is what the tip does not see: the state changes
:math:`\delta s` that keep the tip's position and velocity,
:math:`J\delta q = 0` and :math:`\partial(J\dot q)/\partial q\,\delta q + J\delta\dot q = 0`,
a subspace of dimension 2(n − m) with an orthonormal basis B. The margin is

.. math::

    \sigma = \max \operatorname{Re}\lambda(B^\top A B) \quad [1/\mathrm{s}],

positive when the linearised self-motion grows (at the rate σ), negative
when it decays. The tip's own error directions are left out: open loop they
are a double integrator (eigenvalues 0) whatever the resolver does.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .checks import configuration_vector, finite_vector, positive_number, velocity_vector
from .errors import InvalidInput
from .resolvers import Resolver, get_resolver
from .robot import Robot

__all__ = ["Linearisation", "linearise", "margins_along", "stability_margin", "DEFAULT_DIFFERENCE_STEP"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: Relative step of the central difference of the resolver along each term perturbation.
DEFAULT_DIFFERENCE_STEP = 1e-6


class Linearisation(NamedTuple):
    r"""The closed loop linearised at one state.

    Attributes:
        state_jacobian: A (2n × 2n) [1/s, 1/s²], of :math:`\delta(\dot q, \ddot q)` against :math:`\delta(q, \dot q)`.
        self_motion_basis: B (2n × 2(n − m)), orthonormal, the state changes that keep the tip's position and velocity.
        eigenvalues: of :math:`B^\top A B` [1/s], largest real part first.
        margin: their largest real part σ [1/s].
    """

    state_jacobian: np.ndarray
    self_motion_basis: np.ndarray
    eigenvalues: np.ndarray
    margin: float


def _rotated(rotation, local_ds, value_world, angular_jacobian):
    r"""Derivatives of :math:`R\,u` (u a 6-vector in the frame's LOCAL axes) from those of u, along the 2n directions.

    :math:`\partial(Ru)/\partial q_k = R\,\partial u/\partial q_k + J_{\omega,k}\times(Ru)`: the frame turns with
    q at the world angular velocity :math:`J_{\omega,k}` per unit :math:`q_k`; q̇ does not turn it.
    """
    n = angular_jacobian.shape[1]
    result = np.vstack([rotation.dot(local_ds[:3]), rotation.dot(local_ds[3:])])
    result[:3, :n] += np.cross(angular_jacobian.T, value_world[:3]).T
    result[3:, :n] += np.cross(angular_jacobian.T, value_world[3:]).T
    return result


def _resistance_dv(robot: Robot, v: np.ndarray) -> np.ndarray:
    r""":math:`\partial\tau_j/\partial\dot q = D + F\,\mathrm{sech}^2(\dot q/v_s)/v_s` (diagonal, n×n), zero when the
    robot does not model joint dynamics."""
    scale = robot.friction_velocity_scale
    return np.diag(robot.joint_damping + robot.joint_friction * (1.0 - np.tanh(v / scale) ** 2) / scale)


def _term_derivatives(robot: Robot, q: np.ndarray, v: np.ndarray):
    """The derivatives of H, b, J, J̇q̇ and J q̇ along each of the 2n state directions (q first, then q̇).

    Pinocchio's frame derivatives are taken in the LOCAL frame and turned into
    the task's LOCAL_WORLD_ALIGNED convention by :func:`_rotated`.
    """
    model, data = robot.model, robot.model.createData()
    n, rows, frame, m = robot.nv, robot.task_rows, robot.frame_id, robot.m
    zero = np.zeros(n)
    bias_dq, bias_dv, _ = pin.computeRNEADerivatives(model, data, q, v, zero)
    if robot.models_joint_dynamics:
        bias_dv = bias_dv + _resistance_dv(robot, v)
    bias_ds = np.hstack([bias_dq, bias_dv])
    gravity_dq = pin.computeRNEADerivatives(model, data, q, zero, zero)[0].copy()
    jacobian_world = pin.computeFrameJacobian(model, data, q, frame, _LWA)
    rotation = data.oMf[frame].rotation.copy()
    angular_jacobian = jacobian_world[3:]
    inertia_ds = np.zeros((n, n, 2 * n))  # [i, j, k] = ∂H_ij/∂s_k
    jacobian_ds = np.zeros((m, n, 2 * n))  # [i, j, k] = ∂J_ij/∂s_k
    for j in range(n):
        unit = np.zeros(n)
        unit[j] = 1.0
        # RNEA(q, 0, e_j) = H e_j + g: its q-derivative less gravity's is ∂(H e_j)/∂q.
        inertia_ds[:, j, :n] = pin.computeRNEADerivatives(model, data, q, zero, unit)[0] - gravity_dq
        # The frame velocity at q̇ = e_j is J e_j: its q-derivative is ∂(J e_j)/∂q.
        pin.computeForwardKinematicsDerivatives(model, data, q, unit, zero)
        local_dq = pin.getFrameVelocityDerivatives(model, data, frame, pin.ReferenceFrame.LOCAL)[0]
        jacobian_ds[:, j, :n] = _rotated(rotation, local_dq, jacobian_world[:, j], angular_jacobian)[rows]
    # The drift is the classical acceleration at q̈ = 0: a + ω × v (linear part), in the LOCAL frame first.
    pin.computeForwardKinematicsDerivatives(model, data, q, v, zero)
    velocity_dq, acceleration_dq, acceleration_dv, _ = (
        np.array(part) for part in pin.getFrameAccelerationDerivatives(model, data, frame, pin.ReferenceFrame.LOCAL)
    )
    velocity_ds = np.hstack([velocity_dq, pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL)])
    local = pin.getFrameVelocity(model, data, frame, pin.ReferenceFrame.LOCAL)
    classical_ds = np.hstack([acceleration_dq, acceleration_dv])
    classical_ds[:3] += np.cross(velocity_ds[3:].T, local.linear).T + np.cross(local.angular, velocity_ds[:3].T).T
    classical = pin.getFrameClassicalAcceleration(model, data, frame, pin.ReferenceFrame.LOCAL).vector
    drift_world = np.r_[rotation.dot(classical[:3]), rotation.dot(classical[3:])]
    drift_ds = _rotated(rotation, classical_ds, drift_world, angular_jacobian)
    velocity_world = np.r_[rotation.dot(local.linear), rotation.dot(local.angular)]
    task_velocity_ds = _rotated(rotation, velocity_ds, velocity_world, angular_jacobian)
    return inertia_ds, bias_ds, jacobian_ds, drift_ds[rows], task_velocity_ds[rows]


def linearise(
    robot: Robot,
    resolver: str | Resolver,
    q,
    v,
    task_acceleration,
    *,
    resolver_options: dict | None = None,
    difference_step: float = DEFAULT_DIFFERENCE_STEP,
) -> Linearisation:
    """The closed loop of ``resolver`` linearised at (q, v) with ``task_acceleration`` held (module docstring).

    Args:
        q: configuration vector (nq); v: joint velocities (n) [rad/s];
        task_acceleration: ẍ (m) [m/s², rad/s²].
        resolver_options: the resolver's options when ``resolver`` is a name.
        difference_step: relative step of the central difference of the resolver along the terms' derivatives.
    """
    resolver = get_resolver(resolver, **(resolver_options or {}))
    resolver.check(robot)
    if robot.nv <= robot.m:
        raise InvalidInput(f"robot '{robot.name}' with task '{robot.task}' has no self-motion (n = m = {robot.m})")
    q = configuration_vector(robot, q)
    v = velocity_vector(robot, v)
    command = finite_vector(task_acceleration, robot.m, f"task acceleration for task '{robot.task}'")
    difference_step = positive_number(difference_step, "difference_step")
    return _linearise(robot, resolver.solver(robot), q, v, command, difference_step)


def _linearise(robot: Robot, step, q, v, command, difference_step) -> Linearisation:
    """:func:`~torqueopt.stability.linearise` with the resolver's step already built and the inputs checked."""
    model, data = robot.model, robot.model.createData()
    n = robot.nv
    terms = robot.terms(q, v)
    resolution = step(terms, command)
    inertia_ds, bias_ds, jacobian_ds, drift_ds, velocity_ds = _term_derivatives(robot, q, v)
    # The plant: ∂ABA/∂q, ∂ABA/∂q̇ and ∂ABA/∂τ = H⁻¹ at the resolver's torque, less the joints' resistance.
    resists = robot.models_joint_dynamics
    applied = resolution.torque - robot.joint_resistance(v) if resists else resolution.torque
    aba_dq, aba_dv, inverse_inertia = (np.array(part) for part in pin.computeABADerivatives(model, data, q, v, applied))
    inverse_inertia = np.triu(inverse_inertia) + np.triu(inverse_inertia, 1).T
    if resists:
        aba_dv -= inverse_inertia.dot(_resistance_dv(robot, v))
    torque_ds = np.empty((n, 2 * n))
    for i in range(2 * n):
        direction = np.zeros(2 * n)
        direction[i] = 1.0
        h = difference_step * (1.0 + (np.abs(q).max() if i < n else np.abs(v).max()))
        sides = []
        for sign in (1.0, -1.0):
            shifted = terms._replace(
                inertia=terms.inertia + sign * h * inertia_ds[:, :, i],
                bias_torque=terms.bias_torque + sign * h * bias_ds[:, i],
                jacobian=terms.jacobian + sign * h * jacobian_ds[:, :, i],
                drift=terms.drift + sign * h * drift_ds[:, i],
                joint_velocity=v + sign * h * direction[n:],
                configuration=pin.integrate(model, q, sign * h * direction[:n]),
            )
            sides.append(step(shifted, command).torque)
        torque_ds[:, i] = (sides[0] - sides[1]) / (2 * h)
    acceleration_ds = np.hstack([aba_dq, aba_dv]) + inverse_inertia.dot(torque_ds)
    state_jacobian = np.block([[np.zeros((n, n)), np.eye(n)], [acceleration_ds]])
    # The tip's position and velocity: δx = J δq, δẋ = ∂(J q̇)/∂q δq + J δq̇.
    task_ds = np.block([[terms.jacobian, np.zeros_like(terms.jacobian)], [velocity_ds]])
    basis = np.linalg.svd(task_ds)[2][2 * robot.m :].T
    eigenvalues = np.linalg.eigvals(basis.T.dot(state_jacobian).dot(basis))
    eigenvalues = eigenvalues[np.argsort(-eigenvalues.real, kind="stable")]
    return Linearisation(state_jacobian, basis, eigenvalues, float(eigenvalues[0].real))


def margins_along(robot: Robot, step, configurations, velocities, commands, applied) -> np.ndarray:
    """σ [1/s] at each row of a run (NaN where ``applied`` is False: no torque was applied from that row).

    ``step`` is the resolver's step as the run used it; ``commands`` the task accelerations it was given.
    Within the self-motion subspace a task-space feedback's own dependence on the state is zero (it reads
    only the tip's position and velocity), so the commands as applied give the closed loop's margin.
    """
    margins = np.full(len(configurations), np.nan)
    for row in np.flatnonzero(applied):
        margins[row] = _linearise(
            robot, step, configurations[row], velocities[row], commands[row], DEFAULT_DIFFERENCE_STEP
        ).margin
    return margins


def stability_margin(
    robot: Robot,
    resolver: str | Resolver,
    q,
    v,
    task_acceleration,
    *,
    resolver_options: dict | None = None,
    difference_step: float = DEFAULT_DIFFERENCE_STEP,
) -> float:
    """The growth rate σ [1/s] of the linearised closed-loop self-motion at (q, v) (see :func:`~torqueopt.stability.linearise`).

    Positive: a small self-motion grows like exp(σ t) under ``resolver``; negative: it decays.
    """
    return linearise(
        robot, resolver, q, v, task_acceleration, resolver_options=resolver_options, difference_step=difference_step
    ).margin
