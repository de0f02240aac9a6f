"""The paper's torque optimisation: a null-space acceleration that brings the
joint torques closest to the middle of their ranges."""

from __future__ import annotations

import numpy as np

from ..checks import weight_matrix_root
from ..errors import InvalidInput, NoRedundancy
from ..linalg import LeastSquares
from ..robot import Robot, TaskTerms
from .base import NullSpaceFunction, NullSpaceResolver
from .options import Option, vector_or_matrix
from .registry import register_resolver
from .stacks import least_squares

__all__ = ["NullSpaceTorque", "WeightedNullSpaceTorque", "torque_midpoint"]


def torque_midpoint(robot: Robot) -> np.ndarray:
    r""":math:`(\tau^+ + \tau^-)/2` [N·m], zero for unbounded joints."""
    bounded = np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)
    upper = np.where(bounded, robot.torque_upper, 0.0)
    lower = np.where(bounded, robot.torque_lower, 0.0)
    return 0.5 * (upper + lower)


@register_resolver
class NullSpaceTorque(NullSpaceResolver):
    r"""Unweighted null-space torque optimisation, Eq. (28), Eq. (29), Eq. (30), Eq. (31), Eq. (36).

    With :math:`\tilde\tau = H J^\dagger(\ddot x - \dot J\dot q) + \dot q\cdot C\cdot\dot q + g`,
    Eq. (28), it picks the null-space motion that minimises Eq. (29),

    .. math::

        \Big\|\tau - \frac{\tau^+ + \tau^-}{2}\Big\|^2, \qquad
        \tau = \tilde\tau + H Z y,

    that is Eq. (30), :math:`\|H Z y - (\hat\tau^+ + \hat\tau^-)/2\|^2` with
    :math:`(\hat\tau^+ + \hat\tau^-)/2 = (\tau^+ + \tau^-)/2 - \tilde\tau`: a
    least-squares problem in :math:`y` whose matrix :math:`HZ` has full
    column rank n − m. Its solution is Eq. (31), computed without forming
    :math:`[H(I - J^\dagger J)]^\dagger`, whose rank n − m a loose
    pseudoinverse cutoff would get wrong; the torque is then Eq. (36).
    """

    name = "null-space"
    equations = (28, 29, 30, 31, 36)
    needs_redundancy = True

    def objective_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)

        def torque_distance(terms: TaskTerms, torque):
            return float(np.sum((torque - midpoint) ** 2))  # Eq. (29)

        return torque_distance

    def stack_null_space_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)

        def coordinates(terms, null_space_basis, particular):
            # offset (τ⁺ + τ⁻)/2 − H J⁺r − b; y minimises ‖H Z y − offset‖, Eq. (31)
            offset = midpoint - np.einsum("bij,bj->bi", terms.inertia, particular) - terms.bias_torque
            return least_squares(terms.inertia @ null_space_basis, offset)

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        midpoint = torque_midpoint(robot)
        least_squares = LeastSquares(robot.nv, robot.redundancy)

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia = terms.inertia
            inertia_basis = inertia.dot(null_space_basis)
            # Eq. (28), Eq. (30): (τ̂⁺ + τ̂⁻)/2 = (τ⁺ + τ⁻)/2 − τ̃.
            torque_offset = midpoint - inertia.dot(particular) - terms.bias_torque
            return least_squares(inertia_basis, torque_offset)  # Eq. (31), the minimiser of Eq. (29)

        return coordinates


@register_resolver
class WeightedNullSpaceTorque(NullSpaceResolver):
    r"""Null-space torque optimisation weighted by torque range, Eq. (32), Eq. (33), Eq. (37).

    Minimises Eq. (32), :math:`(\tau - \tau_{mid})^\top W (\tau - \tau_{mid})`, over the
    torques that realise the task (solution Eq. (33), torque Eq. (37)), with by default

    .. math::

        W = \mathrm{diag}\big(1/(\tau_i^+ - \tau_i^-)^2\big)

    (zero weight for an unbounded joint). A user weight is a vector (the
    diagonal of W) or a symmetric positive semi-definite n×n matrix.
    """

    name = "weighted-null-space"
    equations = (32, 33, 37)
    needs_redundancy = True
    options = (
        Option(
            name="weight",
            kind="vector (n) or symmetric n×n matrix",
            unit="1/(N·m)²",
            default=None,
            meaning="W of the criterion (τ − τ_mid)ᵀW(τ − τ_mid): its diagonal, or the whole matrix",
            convert=vector_or_matrix,
            default_text="1/(τ⁺−τ⁻)², Eq. (33)",
        ),
    )

    def objective_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)

        def weighted_torque_distance(terms: TaskTerms, torque):
            weighted = root * (torque - midpoint) if root.ndim == 1 else root @ (torque - midpoint)
            return float(weighted @ weighted)  # Eq. (32)

        return weighted_torque_distance

    @property
    def needs_torque_limits(self) -> bool:
        return self.weight is None

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if self.weight is None and not np.isfinite(robot.torque_upper - robot.torque_lower).any():
            raise NoRedundancy(
                f"resolver '{self.name}' weights torques by their range, but robot '{robot.name}' has no "
                "finite torque limit; give torque limits or a weight matrix"
            )
        self.weight_root(robot)

    def weight_root(self, robot: Robot) -> np.ndarray:
        r"""A square root :math:`S` with :math:`S^\top S = W` (a vector when W is diagonal)."""
        if self.weight is None:
            torque_range = robot.torque_upper - robot.torque_lower
            return np.where(np.isfinite(torque_range), 1.0 / torque_range, 0.0)
        weight, n = self.weight, robot.nv
        if weight.size and np.isfinite(weight).all() and not weight.any():
            # W = 0 leaves no criterion: every torque would be optimal, and the step would fall back to pinv.
            raise InvalidInput(
                f"weight {weight.tolist()} is zero for every joint, which leaves no torque to minimise; "
                "give at least one positive weight"
            )
        return weight_matrix_root(weight, n)

    def stack_null_space_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)

        def coordinates(terms, null_space_basis, particular):
            # y minimises ‖S (H Z y − offset)‖, S² = W, Eq. (33)
            offset = midpoint - np.einsum("bij,bj->bi", terms.inertia, particular) - terms.bias_torque
            inertia_basis = terms.inertia @ null_space_basis
            if root.ndim == 1:
                return least_squares(root[None, :, None] * inertia_basis, root * offset)
            return least_squares(root @ inertia_basis, np.einsum("ij,bj->bi", root, offset))

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)
        least_squares = LeastSquares(root.shape[0], robot.redundancy)
        diagonal = root.ndim == 1
        root_column = root[:, None] if diagonal else None

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia = terms.inertia
            inertia_basis = inertia.dot(null_space_basis)
            torque_offset = midpoint - inertia.dot(particular) - terms.bias_torque  # Eq. (28), Eq. (30)
            # Eq. (33): y = [W½ H Z]⁺ W½ (τ̂⁺ + τ̂⁻)/2, the minimiser of Eq. (32).
            if diagonal:
                return least_squares(root_column * inertia_basis, root * torque_offset)
            return least_squares(root.dot(inertia_basis), root.dot(torque_offset))

        return coordinates
