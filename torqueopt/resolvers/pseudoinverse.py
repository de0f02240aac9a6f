"""Resolvers that use a generalised inverse alone, with no torque criterion."""

from __future__ import annotations

from ..linalg import LeastSquares
from ..robot import Robot, TaskTerms
from .base import NullSpaceResolver

__all__ = ["PseudoInverse", "InertiaWeightedPseudoInverse"]


class PseudoInverse(NullSpaceResolver):
    r"""Unweighted pseudoinverse, Eq. (34) of the paper.

    .. math::

        \tau = H J^\dagger(\ddot x - \dot J\dot q) + \dot q \cdot C \cdot \dot q + g

    The joint acceleration is the minimum-norm one, :math:`\min \|\ddot q\|^2`.
    """

    name = "pinv"

    def null_space_solver(self, robot: Robot):
        return None


class InertiaWeightedPseudoInverse(NullSpaceResolver):
    r"""Inertia-weighted pseudoinverse, Eqs. (16), (19), (35) of the paper.

    .. math::

        \ddot q = J_H^\dagger(\ddot x - \dot J\dot q), \qquad
        J_H^\dagger = H^{-1}J^\top(J H^{-1} J^\top)^{-1}

    which minimises :math:`\ddot q^\top H \ddot q` over the joint
    accelerations that realise the task. In null-space coordinates,
    :math:`y = -(Z^\top H Z)^{-1} Z^\top H\, J^\dagger(\ddot x - \dot J\dot q)`.
    """

    name = "inertia-pinv"

    def null_space_solver(self, robot: Robot):
        # Z^T H Z is symmetric positive definite (H is, Z has full column rank),
        # so the least-squares solution is its inverse applied. Eigen's SVD
        # serves here rather than its Cholesky: no slower per step, measured
        # in simulate (BENCHMARKS.md), and no separate success check through eigenpy.
        solve = LeastSquares(robot.redundancy, robot.redundancy)

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia_basis = terms.inertia.dot(null_space_basis)
            reduced_inertia = null_space_basis.T.dot(inertia_basis)
            return -solve(reduced_inertia, inertia_basis.T.dot(particular))

        return coordinates
