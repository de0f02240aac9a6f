r"""The paper's four resolvers and the four remedies on stacks of movements: one step for a whole batch.

:func:`batched_step` returns the step :func:`torqueopt.batch.simulate_batch`
takes for its resolver: the formulas of :mod:`torqueopt.resolvers` (the
paper's Eq. (16), Eq. (20), Eq. (26), Eq. (28), Eq. (31), Eq. (33), Eq. (35);
the remedies of :mod:`torqueopt.resolvers.damping` and
:mod:`torqueopt.resolvers.inverse_inertia`) on (B, ...)
stacks, held by the tests to each resolver's own step through ``simulate``.
The task-space factorisation behind them (:math:`J^\dagger r`, a null-space
basis, σmin/σmax) is :func:`complete_qr`, or :func:`two_rows` in closed form
for two task rows on two or three joints.
"""

from __future__ import annotations

import numpy as np

from .forest import stacked_cross
from .linalg import inverse_condition_number_of
from .resolvers import Resolver
from .resolvers.damping import DampedNullSpaceTorque, SelfMotionDamping
from .resolvers.inverse_inertia import InverseInertiaSquaredTorque, InverseInertiaTorque
from .resolvers.null_space import NullSpaceTorque, WeightedNullSpaceTorque, torque_midpoint
from .resolvers.pseudoinverse import InertiaWeightedPseudoInverse, PseudoInverse
from .robot import Robot

__all__ = ["BATCHED_RESOLVERS", "batched_step", "complete_qr", "two_rows"]

#: Resolver classes whose step has a batched twin here (exact classes: a subclass may change the step).
BATCHED_RESOLVERS = (
    PseudoInverse,
    InertiaWeightedPseudoInverse,
    NullSpaceTorque,
    WeightedNullSpaceTorque,
    DampedNullSpaceTorque,
    SelfMotionDamping,
    InverseInertiaTorque,
    InverseInertiaSquaredTorque,
)


def complete_qr(J: np.ndarray, residual: np.ndarray, redundant: bool):
    r"""``(J⁺r, Z, σ_min/σ_max)`` per row of a (B, m, n) stack, from the complete QR of :math:`J^\top`.

    :math:`J^\top = QR`: the first m columns of Q span the row space of J, the
    rest (Z, orthonormal) its null space, and :math:`J^\dagger r = Q_m R^{-\top} r`
    is the minimum-norm solution of :math:`J\ddot q = r`. The inverse condition comes
    from the eigenvalues of the m×m :math:`JJ^\top` (σ² of J), half the cost of an SVD of R
    per row; squaring costs accuracy, a relative error of about :math:`\varepsilon/(\sigma_{min}/\sigma_{max})^2`
    (2e-4 at the cutoff 1e-6, which it only has to decide). Rows with a singular J get a finite, unused answer.
    """
    m = J.shape[1]
    squared = np.linalg.eigvalsh(J @ np.swapaxes(J, 1, 2))  # σ² of J, smallest first
    inverse_condition = inverse_condition_number_of(np.sqrt(np.maximum(squared[:, ::-1], 0.0)))
    orthogonal, triangular = np.linalg.qr(np.swapaxes(J, 1, 2), mode="complete")
    upper = triangular[:, :m, :]
    upper = np.where((inverse_condition < 1e-12)[:, None, None], np.eye(m), upper)
    particular = np.einsum(
        "bij,bj->bi", orthogonal[:, :, :m], np.linalg.solve(np.swapaxes(upper, 1, 2), residual[..., None])[..., 0]
    )
    return particular, orthogonal[:, :, m:] if redundant else None, inverse_condition


def two_rows(J: np.ndarray, residual: np.ndarray, redundant: bool):
    r""":func:`complete_qr` for two-row Jacobians of two or three joints (the planar arm's xy task), in closed form.

    Gram-Schmidt with one re-orthogonalisation gives the row-space basis
    :math:`q_1, q_2` and :math:`R = \begin{pmatrix} r_{11} & r_{12}\\ 0 & r_{22}\end{pmatrix}`
    (:math:`J^\top = [q_1\ q_2] R`) to working accuracy; :math:`J^\dagger r = q_1 y_1 + q_2 y_2`
    with :math:`R^\top y = r`; for three joints the null space is spanned by
    :math:`z = q_1\times q_2`. The singular values of R are those of J:
    :math:`\sigma_{max}^2 = (s + \sqrt{s^2 - 4d^2})/2` with
    :math:`s = \|R\|_F^2`, :math:`d = r_{11}r_{22}`, and :math:`\sigma_{min} = d/\sigma_{max}`.
    Equal to the QR path to round-off, without a LAPACK call per row.
    """
    first, second = J[:, 0], J[:, 1]
    r11 = np.sqrt(np.einsum("bi,bi->b", first, first))
    safe11 = np.where(r11 > 0.0, r11, 1.0)
    q1 = first / safe11[:, None]
    r12 = np.einsum("bi,bi->b", q1, second)
    u = second - r12[:, None] * q1
    u -= np.einsum("bi,bi->b", q1, u)[:, None] * q1  # twice is enough: orthogonal to working accuracy
    r22 = np.sqrt(np.einsum("bi,bi->b", u, u))
    safe22 = np.where(r22 > 0.0, r22, 1.0)
    q2 = u / safe22[:, None]
    y1 = residual[:, 0] / safe11
    y2 = (residual[:, 1] - r12 * y1) / safe22
    particular = q1 * y1[:, None] + q2 * y2[:, None]
    frobenius = r11 * r11 + r12 * r12 + r22 * r22
    determinant = r11 * r22
    # σ_min/σ_max = d/σ_max² = 2d / (s + √(s² − 4d²)); 0 for a zero J (s = 0).
    denominator = frobenius + np.sqrt(np.maximum(frobenius * frobenius - 4.0 * determinant * determinant, 0.0))
    inverse_condition = np.divide(
        2.0 * determinant, denominator, out=np.zeros_like(denominator), where=denominator > 0.0
    )
    if not (redundant and J.shape[2] == 3):
        return particular, None, inverse_condition
    basis = stacked_cross(q1, q2)[:, :, None]  # z = q1 × q2, (B, 3, 1), unit: q1 ⊥ q2
    return particular, basis, inverse_condition


def batched_step(robot: Robot, resolver: Resolver):
    r"""The resolver's step on (B, ...) stacks: ``(H, b, J, J̇q̇, ẍ) -> (τ, q̈, σ_min/σ_max, singular, Z)``.

    Same equations as the resolver's own step (:meth:`Resolver.solver`):
    :math:`\ddot q = J^\dagger(\ddot x - \dot J\dot q) + Z y` (Eq. (26)),
    :math:`\tau = H\ddot q + b`, with y as each resolver chooses it.
    Rows whose Jacobian is singular (σ_min/σ_max below the resolver's
    cutoff) are flagged; their outputs are not used.
    """
    n, m = robot.nv, robot.m
    tolerance = resolver.singular_tolerance
    kind = type(resolver)
    midpoint = torque_midpoint(robot)
    root = resolver.weight_root(robot) if kind in (WeightedNullSpaceTorque, DampedNullSpaceTorque) else None
    kinematic_weight = resolver.kinematic_weight if kind is DampedNullSpaceTorque else 0.0
    damping = getattr(resolver, "damping", 0.0)
    redundant = n > m

    def least_squares(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Minimum-norm least squares per row, rank cutoff 1e-12 relative (as linalg.LeastSquares)."""
        if matrix.shape[2] == 1:
            # One column a: y = aᵀb / aᵀa, or 0 for a zero column (the minimum-norm answer).
            column = matrix[:, :, 0]
            norm2 = np.einsum("bi,bi->b", column, column)
            safe = np.where(norm2 > 0.0, norm2, 1.0)
            return np.where(norm2 > 0.0, np.einsum("bi,bi->b", column, rhs) / safe, 0.0)[:, None]
        u, s, vt = np.linalg.svd(matrix, full_matrices=False)
        keep = s > 1e-12 * s[:, :1]
        inverse = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
        projected = np.einsum("bji,bj->bi", u, rhs) * inverse
        return np.einsum("bji,bj->bi", vt, projected)

    factor = two_rows if m == 2 and n in (2, 3) else complete_qr

    def step(H, b, J, drift, command, v):
        # Eq. (26)'s particular solution J⁺(ẍ − J̇q̇), a null-space basis Z and σ_min/σ_max of J.
        particular, basis, inverse_condition = factor(J, command - drift, redundant)
        singular = ~(inverse_condition >= tolerance)
        acceleration = particular
        if redundant and kind is not PseudoInverse:
            inertia_basis = H @ basis  # H Z
            if kind is InertiaWeightedPseudoInverse:
                # y = −(ZᵀHZ)⁻¹ ZᵀH J⁺r, Eq. (16), Eq. (35); ZᵀHZ is positive definite
                reduced = np.swapaxes(basis, 1, 2) @ inertia_basis
                rhs = np.einsum("bji,bj->bi", inertia_basis, particular)
                y = -np.linalg.solve(reduced, rhs[..., None])[..., 0]
            elif kind is SelfMotionDamping:
                y = -damping * np.einsum("bji,bj->bi", basis, v)  # y = −K_D Zᵀq̇
            elif kind is InverseInertiaTorque:
                # y = −(ZᵀHZ)⁻¹ Zᵀτ̃, τ̃ = H J⁺r + b (Eq. (28)); ZᵀHZ is positive definite
                reduced = np.swapaxes(basis, 1, 2) @ inertia_basis
                torque_tilde = np.einsum("bij,bj->bi", H, particular) + b
                y = -np.linalg.solve(reduced, np.einsum("bji,bj->bi", basis, torque_tilde)[..., None])[..., 0]
            elif kind is InverseInertiaSquaredTorque:
                # y = −Zᵀ H⁻¹ τ̃ (Eq. (28)'s τ̃)
                torque_tilde = np.einsum("bij,bj->bi", H, particular) + b
                y = -np.einsum("bji,bj->bi", basis, np.linalg.solve(H, torque_tilde[..., None])[..., 0])
            else:
                # offset (τ⁺ + τ⁻)/2 − H J⁺r − b; y minimises ‖W½ (H Z y − offset)‖, Eq. (31), Eq. (33)
                offset = midpoint - np.einsum("bij,bj->bi", H, particular) - b
                if root is None:
                    y = least_squares(inertia_basis, offset)
                elif root.ndim == 1:
                    weighted = root[None, :, None] * inertia_basis
                    if kinematic_weight:
                        # damped-null-space: [SHZ; μ̄I] y ≈ [S(τ_mid − τ̃); −μ̄K_D Zᵀq̇], μ̄ = μ‖SHZ‖_F
                        weight = kinematic_weight * np.sqrt(np.einsum("bij,bij->b", weighted, weighted))
                        stacked = np.concatenate([weighted, weight[:, None, None] * np.eye(n - m)], axis=1)
                        kinematic = (-damping * weight)[:, None] * np.einsum("bji,bj->bi", basis, v)
                        y = least_squares(stacked, np.concatenate([root * offset, kinematic], axis=1))
                    else:
                        y = least_squares(weighted, root * offset)
                else:
                    y = least_squares(root @ inertia_basis, np.einsum("ij,bj->bi", root, offset))
            acceleration = particular + np.einsum("bij,bj->bi", basis, y)
        torque = np.einsum("bij,bj->bi", H, acceleration) + b  # Eq. (20)
        return torque, acceleration, inverse_condition, singular, basis

    return step
