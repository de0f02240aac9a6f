r"""Torque minimisation in the inverse-inertia norms: τᵀH⁻¹τ and τᵀH⁻²τ.

Both criteria measure the torque by the acceleration it causes. With
:math:`\tau = H\ddot q + b` (:math:`b = \dot q\cdot C\cdot\dot q + g`, Eq. (20))
and the free (unactuated) acceleration :math:`\ddot q_0 = -H^{-1} b`,

.. math::

    \tau^\top H^{-1}\tau = (\ddot q - \ddot q_0)^\top H (\ddot q - \ddot q_0),
    \qquad
    \tau^\top H^{-2}\tau = \|\ddot q - \ddot q_0\|^2 .

The first is Gauss's principle of least constraint: the realised motion
deviates least, in the kinetic metric, from the motion the arm would make
unactuated; the task acts as the constraint. Its use for redundancy
resolution is attributed to Kazerounian & Nedungadi (1988) in
torqueopt's literature notes (not checked against the paper here).

Over the null-space coordinates of Eq. (26),
:math:`\ddot q = p + Zy` with :math:`p = J^\dagger(\ddot x - \dot J\dot q)`
and :math:`\tilde\tau = H p + b` (Eq. (28)), the minimisers are

.. math::

    \tau^\top H^{-1}\tau:\quad Z^\top H Z\, y = -Z^\top\tilde\tau,
    \qquad\qquad
    \tau^\top H^{-2}\tau:\quad y = -Z^\top H^{-1}\tilde\tau

(:math:`Z` orthonormal). Without velocity or gravity (:math:`b = 0`) the
first is the inertia-weighted pseudoinverse (Eq. (35)) and the second is
``pinv`` (Eq. (34)).
"""

from __future__ import annotations

import numpy as np

from ..linalg import LeastSquares
from ..robot import Robot, TaskTerms
from .base import NullSpaceFunction, NullSpaceResolver
from .registry import register_resolver

__all__ = ["InverseInertiaTorque", "InverseInertiaSquaredTorque"]


@register_resolver
class InverseInertiaTorque(NullSpaceResolver):
    r"""Minimum τᵀH⁻¹τ (Gauss's principle of least constraint): ZᵀHZ y = −Zᵀτ̃.

    :math:`\tau^\top H^{-1}\tau` [kg·m²/s⁴ = W/s for revolute joints] is the
    kinetic-metric distance of :math:`\ddot q` from the free acceleration
    :math:`-H^{-1}b`. With :math:`\tau = \tilde\tau + HZy` its gradient in
    :math:`y` is :math:`2(HZ)^\top H^{-1}\tau = 2Z^\top\tau`, so at the optimum the
    torque has no component in the null space of J: :math:`Z^\top\tau = 0`.
    """

    name = "inverse-inertia-torque"

    def objective_function(self, robot: Robot):
        def gauss(terms: TaskTerms, torque):
            return float(torque @ np.linalg.solve(terms.inertia, torque))  # τᵀH⁻¹τ

        return gauss

    def stack_null_space_function(self, robot: Robot):
        def coordinates(terms, null_space_basis, particular):
            # y = −(ZᵀHZ)⁻¹ Zᵀτ̃, τ̃ = H J⁺r + b (Eq. (28)); ZᵀHZ is positive definite
            reduced_inertia = np.swapaxes(null_space_basis, 1, 2) @ terms.inertia @ null_space_basis
            torque_tilde = np.einsum("bij,bj->bi", terms.inertia, particular) + terms.bias_torque
            rhs = np.einsum("bji,bj->bi", null_space_basis, torque_tilde)
            return -np.linalg.solve(reduced_inertia, rhs[..., None])[..., 0]

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        # Z^T H Z is symmetric positive definite; the SVD solve is as in inertia-pinv.
        solve = LeastSquares(robot.redundancy, robot.redundancy)

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia_basis = terms.inertia.dot(null_space_basis)
            reduced_inertia = null_space_basis.T.dot(inertia_basis)
            torque_tilde = terms.inertia.dot(particular) + terms.bias_torque  # τ̃, Eq. (28)
            return -solve(reduced_inertia, null_space_basis.T.dot(torque_tilde))

        return coordinates


@register_resolver
class InverseInertiaSquaredTorque(NullSpaceResolver):
    r"""Minimum τᵀH⁻²τ = ‖q̈ + H⁻¹b‖²: y = −Zᵀ H⁻¹ τ̃.

    :math:`\tau^\top H^{-2}\tau = \|H^{-1}\tau\|^2` [rad²/s⁴] is the squared
    Euclidean distance of :math:`\ddot q` from the free acceleration; at the
    optimum :math:`Z^\top H^{-1}\tau = 0`: the acceleration the torque causes
    has no null-space component.
    """

    name = "inverse-inertia-squared-torque"

    def objective_function(self, robot: Robot):
        def squared(terms: TaskTerms, torque):
            scaled = np.linalg.solve(terms.inertia, torque)
            return float(scaled @ scaled)  # τᵀH⁻²τ

        return squared

    def stack_null_space_function(self, robot: Robot):
        def coordinates(terms, null_space_basis, particular):
            # y = −Zᵀ H⁻¹ τ̃ (Eq. (28)'s τ̃)
            torque_tilde = np.einsum("bij,bj->bi", terms.inertia, particular) + terms.bias_torque
            inverse_inertia_torque = np.linalg.solve(terms.inertia, torque_tilde[..., None])[..., 0]
            return -np.einsum("bji,bj->bi", null_space_basis, inverse_inertia_torque)

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        solve = LeastSquares(robot.nv, robot.nv)

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            torque_tilde = terms.inertia.dot(particular) + terms.bias_torque  # τ̃, Eq. (28)
            return -null_space_basis.T.dot(solve(terms.inertia, torque_tilde))  # −Zᵀ H⁻¹ τ̃

        return coordinates
