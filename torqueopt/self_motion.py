r"""The kinetic energy of the self-motion, :math:`E_N`, and its exact rate along the dynamics.

For a state :math:`(q, \dot q)` with inertia :math:`H` and task Jacobian
:math:`J` (full rank m < n), the least kinetic energy of any joint motion with
the tip velocity :math:`\dot x = J\dot q` is
:math:`E_x = \tfrac12\dot x^\top\Lambda\dot x`, :math:`\Lambda = (J H^{-1} J^\top)^{-1}`,
reached at :math:`u = H^{-1}J^\top\Lambda J\dot q` (the inertia-weighted
pseudoinverse velocity, Eq. (16) with W = H, Eq. (17)). What is left,

.. math::

    w = \dot q - u = Z (Z^\top H Z)^{-1} Z^\top H \dot q,\qquad
    E_N = \tfrac12\dot q^\top H\dot q - E_x = \tfrac12 w^\top H w
        = \tfrac12 s^\top (Z^\top H Z)^{-1} s,\quad s = Z^\top H\dot q,

is the self-motion: :math:`J w = 0`, and :math:`u^\top H w = 0` (the two parts
are H-orthogonal, so their energies add). Z is any orthonormal basis of the
null space of J; :math:`E_N` and :math:`w` do not depend on which.

Its rate along any motion, :math:`\dot E_N = dE_N/dt`, follows from
:math:`E_N = \tfrac12\dot q^\top M\dot q` with :math:`M = H - J^\top\Lambda J`
(:math:`M\dot q = H w`):

.. math::

    \dot E_N = \dot q^\top M \ddot q + \tfrac12\dot q^\top\dot M\dot q,\qquad
    \dot M = \dot H - \dot J^\top\Lambda J - J^\top\Lambda\dot J - J^\top\dot\Lambda J,\qquad
    \dot\Lambda = -\Lambda\,(\dot J H^{-1}J^\top + J H^{-1}\dot J^\top - J H^{-1}\dot H H^{-1}J^\top)\,\Lambda,

where :math:`\dot H = \sum_k \partial H/\partial q_k\,\dot q_k` and
:math:`\dot J = \sum_k \partial J/\partial q_k\,\dot q_k` are the changes of H
and J with q along :math:`\dot q`. With :math:`f = \Lambda J\dot q`
(:math:`J^\top f = H u`, so :math:`f = J^{+\top} H u`) every term reduces to

.. math::

    \dot E_N = (H w)^\top \ddot q + \underbrace{(u + \tfrac12 w)^\top \dot H w
        - f^\top \dot J w}_{c(q,\dot q)} .

No term vanishes by the choice of definition: the basis Z drops out of
:math:`E_N` altogether (so how it turns with q contributes nothing), while
:math:`\dot H` and :math:`\dot J` enter through c, which is zero only when
the self-motion is (w = 0). The rate is affine in :math:`\ddot q`, with the
coefficient :math:`H w`; on :math:`\ddot q = p + Z y` (Eq. (26)) it is affine
in the null-space coordinates y with the coefficient :math:`Z^\top H w = s`.
:math:`\dot H = C + C^\top` with Pinocchio's Coriolis matrix C (whose
:math:`\dot H - 2C` is skew), and :math:`\dot J` is Pinocchio's frame
Jacobian time variation in the task's frame convention.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .robot import Robot

__all__ = ["SelfMotion", "self_motion", "self_motion_energy", "self_motion_energy_by_solve", "SelfMotionRate"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class SelfMotion(NamedTuple):
    r"""The self-motion part of a joint velocity.

    Attributes:
        velocity: :math:`w`, the self-motion velocity (n) [rad/s]; :math:`Jw = 0`.
        energy: :math:`E_N = \tfrac12 w^\top H w` [J].
        kinetic_energy: :math:`\tfrac12\dot q^\top H\dot q` [J], of which :math:`E_N` is a part.
    """

    velocity: np.ndarray
    energy: float
    kinetic_energy: float


def self_motion(inertia: np.ndarray, null_space_basis: np.ndarray, joint_velocity: np.ndarray) -> SelfMotion:
    r"""The self-motion :math:`w` and its kinetic energy :math:`E_N` of the module docstring at one state.

    Args:
        inertia: H (n × n) [kg·m²].
        null_space_basis: Z, an orthonormal basis of the null space of the task Jacobian (n × r).
        joint_velocity: :math:`\dot q` (n) [rad/s].
    """
    momentum = inertia.dot(joint_velocity)  # H q̇
    kinetic = 0.5 * float(joint_velocity.dot(momentum))
    projected = null_space_basis.T.dot(momentum)  # s = Zᵀ H q̇
    reduced = null_space_basis.T.dot(inertia).dot(null_space_basis)  # Zᵀ H Z
    coordinates = np.linalg.solve(reduced, projected)
    energy = 0.5 * float(projected.dot(coordinates))
    return SelfMotion(null_space_basis.dot(coordinates), min(max(energy, 0.0), kinetic), kinetic)


def self_motion_energy(inertia: np.ndarray, velocity: np.ndarray, *, jacobian=None, null_space_basis=None):
    r"""Kinetic energy :math:`T = \tfrac12\dot q^\top H\dot q` and its self-motion part :math:`E_N` [J], per row of
    stacks H (B, n, n), :math:`\dot q` (B, n).

    :math:`E_N` is the kinetic energy the joints carry beyond the least that
    gives the tip its velocity :math:`\dot x = J\dot q`:
    :math:`E_N = T - \tfrac12\dot x^\top\Lambda\dot x` with the task-space
    inertia :math:`\Lambda = (J H^{-1} J^\top)^{-1}` (from ``jacobian``, (B, m, n)).
    With an orthonormal ``null_space_basis`` Z of J instead ((B, n, n − m)), the
    same figure without inverting H: the least energy is reached at
    :math:`\dot q - Z\alpha`, :math:`\alpha = (Z^\top HZ)^{-1}Z^\top H\dot q`, so
    :math:`E_N = \tfrac12 w^\top (Z^\top H Z)^{-1} w` with :math:`w = Z^\top H\dot q`
    (0 when J has no null space: give ``null_space_basis=None`` and no ``jacobian``).
    The stacked form of :func:`self_motion`'s energy, for loops over many
    states. Kept at or above 0 (and, from Z, at or below T) against round-off. A matrix of a stack that is exactly
    singular is solved through its pseudoinverse.

    With a basis of two or more columns, T and :math:`E_N` come from one symmetric
    (r+1)×(r+1) matrix per row,

    .. math::

        M = [Z\ \dot q]^\top H\, [Z\ \dot q]
          = \begin{pmatrix} Z^\top H Z & w \\ w^\top & 2T \end{pmatrix},

    whose r pivots of symmetric elimination (on the batch axis, no LAPACK call per
    row) leave :math:`-w^\top (Z^\top HZ)^{-1} w = -2E_N` where the corner was set
    to 0: two stacked products and r broadcast updates in place of the three
    contractions, the two products of :math:`Z^\top HZ` and the per-row solve of
    :func:`self_motion_energy_by_solve`, the readable reference the tests hold it to.
    """
    if jacobian is not None:
        kinetic = 0.5 * np.einsum("bi,bij,bj->b", velocity, inertia, velocity)
        tip_velocity = np.einsum("bij,bj->bi", jacobian, velocity)
        inverse_inertia_jt = np.linalg.solve(inertia, np.swapaxes(jacobian, 1, 2))  # H⁻¹Jᵀ, (B, n, m)
        task_inverse_inertia = jacobian @ inverse_inertia_jt  # Λ⁻¹ = J H⁻¹ Jᵀ
        task_energy = 0.5 * np.einsum("bi,bi->b", tip_velocity, _solve(task_inverse_inertia, tip_velocity))
        return kinetic, np.maximum(kinetic - task_energy, 0.0)
    if null_space_basis is not None and null_space_basis.shape[2] > 1:
        return _energies_by_elimination(inertia, velocity, null_space_basis)
    return self_motion_energy_by_solve(inertia, velocity, null_space_basis)


def self_motion_energy_by_solve(inertia: np.ndarray, velocity: np.ndarray, null_space_basis=None):
    r""":func:`self_motion_energy` from a basis Z (or None) as the formulas read: :math:`H\dot q`, T,
    :math:`w = Z^\top H\dot q`, :math:`Z^\top HZ` and its solve per row by LAPACK; the reference of the
    elimination :func:`self_motion_energy` uses for bases of two or more columns."""
    momentum = np.einsum("bij,bj->bi", inertia, velocity)  # H q̇
    kinetic = 0.5 * np.einsum("bi,bi->b", velocity, momentum)
    if null_space_basis is None:
        return kinetic, np.zeros_like(kinetic)
    projected = np.einsum("bji,bj->bi", null_space_basis, momentum)  # w = Zᵀ H q̇
    reduced = np.swapaxes(null_space_basis, 1, 2) @ inertia @ null_space_basis  # Zᵀ H Z
    if reduced.shape[1] == 1:
        energy = 0.5 * projected[:, 0] ** 2 / reduced[:, 0, 0]
    else:
        energy = 0.5 * np.einsum("bi,bi->b", projected, _solve(reduced, projected))
    return kinetic, np.clip(energy, 0.0, kinetic)


def _energies_by_elimination(inertia: np.ndarray, velocity: np.ndarray, basis: np.ndarray):
    """(T, E_N) per row from M = [Z q̇]ᵀ H [Z q̇] by r pivots of symmetric elimination (see
    :func:`self_motion_energy`); rows with a pivot that is not positive (Zᵀ H Z not positive definite to working
    accuracy) by :func:`self_motion_energy_by_solve`."""
    count, n, r = basis.shape
    stacked = np.empty((count, n, r + 1))
    stacked[:, :, :r] = basis
    stacked[:, :, r] = velocity
    # [[ZᵀHZ, w], [wᵀ, q̇ᵀHq̇]] laid out batch-last, (r + 1, r + 1, B), for the updates on the batch axis
    gram = np.ascontiguousarray((np.swapaxes(stacked, 1, 2) @ (inertia @ stacked)).transpose(1, 2, 0))
    kinetic = 0.5 * gram[r, r]  # T = ½ q̇ᵀHq̇
    gram[r, r] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):  # a zero pivot's row is redone below
        for k in range(r):  # after pivot k, the trailing block is its Schur complement
            gram[k + 1 :, k + 1 :] -= gram[k + 1 :, k, None] * (gram[k, k + 1 :] / gram[k, k])
        energy = np.clip(-0.5 * gram[r, r], 0.0, kinetic)  # the corner is −wᵀ(ZᵀHZ)⁻¹w = −2 E_N
    pivots = np.diagonal(gram[:r, :r]).min(axis=1)
    if not (pivots > 0.0).all():
        rows = ~(pivots > 0.0)
        kinetic[rows], energy[rows] = self_motion_energy_by_solve(inertia[rows], velocity[rows], basis[rows])
    return kinetic, energy


def _solve(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """x with A x = b per row of stacks A (B, k, k), b (B, k); through the pseudoinverse when the stack holds an
    exactly singular A."""
    try:
        return np.linalg.solve(matrices, vectors[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return (np.linalg.pinv(matrices) @ vectors[..., None])[..., 0]


class SelfMotionRate:
    r"""The rate :math:`\dot E_N = (Hw)^\top\ddot q + c(q, \dot q)` of the module docstring, on one robot.

    Holds its own Pinocchio data (the Coriolis matrix and the Jacobian's time
    variation are computed there, never in the data a run's terms are views of).
    """

    def __init__(self, robot: Robot):
        self._model = robot.model
        self._data = robot.model.createData()
        self._frame_id = robot.frame_id
        self._rows = robot.task_rows

    def __call__(self, configuration, joint_velocity, inertia, jacobian, null_space_basis):
        """``(SelfMotion, Hw, c)``: E_N and w, the coefficient Hw (n) [N·m·s] of q̈ and c [W] in Ė_N = (Hw)ᵀq̈ + c."""
        part = self_motion(inertia, null_space_basis, joint_velocity)
        w = part.velocity
        model, data = self._model, self._data
        coriolis = pin.computeCoriolisMatrix(model, data, configuration, joint_velocity)
        inertia_rate_w = coriolis.dot(w) + coriolis.T.dot(w)  # Ḣ w, Ḣ = C + Cᵀ
        pin.computeJointJacobiansTimeVariation(model, data, configuration, joint_velocity)
        jacobian_rate = pin.getFrameJacobianTimeVariation(model, data, self._frame_id, _LWA)[self._rows]
        u = joint_velocity - w
        # f = Λ J q̇ solves Jᵀ f = H u; J has full row rank, so f = (J Jᵀ)⁻¹ J H u.
        force = np.linalg.solve(jacobian.dot(jacobian.T), jacobian.dot(inertia.dot(u)))
        constant = float((u + 0.5 * w).dot(inertia_rate_w) - force.dot(jacobian_rate.dot(w)))
        return part, inertia.dot(w), constant

    def stacked(self, configurations, joint_velocities, inertia, jacobian, null_space_basis):
        """``(E_N, Hw, c)`` of calling it for each row of stacks: q (B, nq), q̇ (B, n), H (B, n, n),
        J (B, m, n) and Z (B, n, r); E_N and c (B,), Hw (B, n). The Pinocchio calls (C, J̇) row by row, the
        rest on the stacks."""
        v = joint_velocities
        momentum = np.einsum("bij,bj->bi", inertia, v)  # H q̇
        kinetic = 0.5 * np.einsum("bi,bi->b", v, momentum)
        projected = np.einsum("bji,bj->bi", null_space_basis, momentum)  # s = Zᵀ H q̇
        reduced = np.swapaxes(null_space_basis, 1, 2) @ inertia @ null_space_basis  # Zᵀ H Z
        coordinates = np.linalg.solve(reduced, projected[..., None])[..., 0]
        energy = np.minimum(np.maximum(0.5 * np.einsum("bi,bi->b", projected, coordinates), 0.0), kinetic)
        w = np.einsum("bij,bj->bi", null_space_basis, coordinates)
        model, data, frame, rows = self._model, self._data, self._frame_id, self._rows
        inertia_rate_w = np.empty_like(w)
        jacobian_rate_w = np.empty((w.shape[0], jacobian.shape[1]))
        for row in range(w.shape[0]):
            q, qdot, w_row = configurations[row], v[row], w[row]
            coriolis = pin.computeCoriolisMatrix(model, data, q, qdot)
            inertia_rate_w[row] = coriolis.dot(w_row) + coriolis.T.dot(w_row)  # Ḣ w, Ḣ = C + Cᵀ
            pin.computeJointJacobiansTimeVariation(model, data, q, qdot)
            jacobian_rate_w[row] = pin.getFrameJacobianTimeVariation(model, data, frame, _LWA)[rows].dot(w_row)
        u = v - w
        # f = Λ J q̇ solves Jᵀ f = H u; J has full row rank, so f = (J Jᵀ)⁻¹ J H u.
        task_momentum = np.einsum("bij,bj->bi", jacobian, np.einsum("bij,bj->bi", inertia, u))
        force = np.linalg.solve(jacobian @ np.swapaxes(jacobian, 1, 2), task_momentum[..., None])[..., 0]
        constant = np.einsum("bi,bi->b", u + 0.5 * w, inertia_rate_w) - np.einsum("bi,bi->b", force, jacobian_rate_w)
        return energy, np.einsum("bij,bj->bi", inertia, w), constant
