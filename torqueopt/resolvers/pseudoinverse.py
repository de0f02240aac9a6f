"""Resolvers that use a generalised inverse alone, with no torque criterion."""

from __future__ import annotations

import numpy as np

from ..linalg import LeastSquares
from ..robot import Robot, TaskTerms
from .base import NullSpaceFunction, NullSpaceResolver, joint_acceleration_of
from .registry import register_resolver

__all__ = ["PseudoInverse", "InertiaWeightedPseudoInverse"]


@register_resolver
class PseudoInverse(NullSpaceResolver):
    r"""Unweighted pseudoinverse, Eq. (34).

    .. math::

        \tau = H J^\dagger(\ddot x - \dot J\dot q) + \dot q \cdot C \cdot \dot q + g \qquad \text{Eq. (34)}

    The joint acceleration is the minimum-norm one, :math:`\min \|\ddot q\|^2`:
    the null-space coordinates are :math:`y = 0`, so the torque line of
    :class:`~torqueopt.resolvers.base.NullSpaceResolver` computes Eq. (34).
    """

    name = "pinv"
    equations = (34,)

    def objective_function(self, robot: Robot):
        def acceleration_norm(terms: TaskTerms, torque):
            acceleration = joint_acceleration_of(terms, torque)
            return float(acceleration @ acceleration)  # ‖q̈‖², which Eq. (34) minimises

        return acceleration_norm

    def stack_null_space_function(self, robot: Robot):
        return None  # y = 0 on stacks too

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        return None


@register_resolver
class InertiaWeightedPseudoInverse(NullSpaceResolver):
    r"""Inertia-weighted pseudoinverse, Eq. (16), Eq. (19), Eq. (35).

    .. math::

        \ddot q = J_H^\dagger(\ddot x - \dot J\dot q) \quad \text{Eq. (19)}, \qquad
        J_H^\dagger = H^{-1}J^\top(J H^{-1} J^\top)^{-1} \quad \text{Eq. (16) with } W = H,

    and the torque :math:`\tau = H\ddot q + \dot q\cdot C\cdot\dot q + g`, Eq. (35),

    where :math:`\ddot q` minimises :math:`\ddot q^\top H \ddot q` over the joint
    accelerations that realise the task. In null-space coordinates,
    :math:`y = -(Z^\top H Z)^{-1} Z^\top H\, J^\dagger(\ddot x - \dot J\dot q)`.
    """

    name = "inertia-pinv"
    equations = (16, 19, 35)

    def objective_function(self, robot: Robot):
        def kinetic_metric(terms: TaskTerms, torque):
            acceleration = joint_acceleration_of(terms, torque)
            return float(acceleration @ terms.inertia @ acceleration)  # q̈ᵀHq̈, which Eq. (19) minimises

        return kinetic_metric

    def stack_null_space_function(self, robot: Robot):
        def coordinates(terms, null_space_basis, particular):
            # y = −(ZᵀHZ)⁻¹ ZᵀH J⁺r, Eq. (16), Eq. (35); ZᵀHZ is positive definite
            inertia_basis = terms.inertia @ null_space_basis
            reduced_inertia = np.swapaxes(null_space_basis, 1, 2) @ inertia_basis
            rhs = np.einsum("bji,bj->bi", inertia_basis, particular)
            return -np.linalg.solve(reduced_inertia, rhs[..., None])[..., 0]

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        # Z^T H Z is symmetric positive definite (H is, Z has full column rank),
        # so the least-squares solution is its inverse applied. Eigen's SVD
        # serves here rather than its Cholesky: no slower per step, measured
        # in simulate (BENCHMARKS.md), and no separate success check through eigenpy.
        solve = LeastSquares(robot.redundancy, robot.redundancy)

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia_basis = terms.inertia.dot(null_space_basis)
            reduced_inertia = null_space_basis.T.dot(inertia_basis)
            # Eq. (16), Eq. (19) with W = H, in null-space coordinates.
            return -solve(reduced_inertia, inertia_basis.T.dot(particular))

        return coordinates
