r"""``bounded-torque``: the paper's torque criterion under hard torque bounds, a QP in the coordinates of Eq. (26)."""

from __future__ import annotations

import numpy as np

from ...robot import Robot, TaskTerms
from ..damping import DEFAULT_DAMPING, DEFAULT_KINEMATIC_WEIGHT, DampedNullSpaceTorque, torque_weight_root
from ..options import LARGEST_WEIGHT, Option, choice_or_vector, number
from ..registry import register_resolver
from .base import INFEASIBLE_OPTION, StackOptimum, _BoundedResolver, _solver_bounds
from .joint_limits import JOINT_ACCELERATION_LIMIT_OPTION, JOINT_LIMITS_OPTION
from .programs import _EXIT_INFEASIBLE, BoundProgram, _Program, solve_program, torque_bound_rows, with_rows

__all__ = ["TORQUE_WEIGHTS", "BoundedTorque"]

#: ``torque_weight`` names: the identity, or the torque-range weight of Eq. (33).
TORQUE_WEIGHTS = ("unit", "range")
#: The variables of the QP a step records (``Resolution.program``).
_VARIABLES = "y: null-space coordinates of Eq. (26), q̈ = p + Z y"


@register_resolver
class BoundedTorque(_BoundedResolver):
    r"""Torque optimisation with hard torque bounds, by quadratic programming.

    .. math::

        \min_y\ \|S(\tau - \tau_{mid})\|^2 + \bar\mu^2\|y + K_D Z^\top\dot q\|^2
        \quad\text{s.t.}\quad \tau = \tilde\tau + H Z y,\quad \tau^- \le \tau \le \tau^+

    with :math:`\tau_{mid} = (\tau^+ + \tau^-)/2` (Eq. (29)), :math:`S = I`
    (``torque_weight='unit'``: the criterion of ``null-space``, Eq. (29), Eq. (30), Eq. (31)),
    the torque-range weight :math:`S = \mathrm{diag}(1/(\tau^+_i - \tau^-_i))`
    of Eq. (33) (``'range'``: that of ``weighted-null-space``; zero for an
    unbounded joint), or :math:`S^2 = \mathrm{diag}(w)` for a user vector
    :math:`w` (the diagonal of the weight matrix W of Eq. (32)).
    The kinematic term is that of ``damped-null-space``, with the same
    options and defaults: :math:`\bar\mu = \mu\|SHZ\|_F` with the
    dimensionless ``kinematic_weight`` :math:`\mu` (default 0.5) and the
    self-motion damping ``damping`` :math:`K_D` (default 10 1/s). With the
    bounds inactive the answer is that of ``damped-null-space``, and with
    :math:`\mu = 0` that of ``null-space`` / ``weighted-null-space``: the
    paper's criterion under hard bounds. The Hessian
    :math:`(SHZ)^\top SHZ + \bar\mu^2 I` is positive definite whenever S
    has no zero entry or :math:`\mu > 0`.
    """

    name = "bounded-torque"
    equations = (26, 29, 33)

    options = (
        Option(
            name="torque_weight",
            kind="'unit' | 'range' | vector (n)",
            unit="1/(N·m)² for a vector",
            default="unit",
            meaning=(
                "S of the criterion ‖S(τ − τ_mid)‖²: the identity, the torque range 1/(τ⁺ − τ⁻) of Eq. (33), "
                "or S² = diag(vector), the diagonal of W"
            ),
            convert=choice_or_vector(*TORQUE_WEIGHTS),
        ),
        Option(
            name="kinematic_weight",
            kind="number in [0, 1e6]",
            unit="",
            default=DEFAULT_KINEMATIC_WEIGHT,
            meaning=(
                "μ of the kinematic term μ̄²‖y + K_D Zᵀq̇‖², μ̄ = μ‖SHZ‖_F, as in damped-null-space "
                "(0: the paper's torque criterion alone)"
            ),
            convert=number(0.0, maximum=LARGEST_WEIGHT),
        ),
        Option(
            name="damping",
            kind="number in [0, 1e6]",
            unit="1/s",
            default=DEFAULT_DAMPING,
            meaning="K_D of the kinematic term, as in damped-null-space: the self-motion velocity Zᵀq̇ is driven to 0",
            convert=number(0.0, unit="1/s", maximum=LARGEST_WEIGHT),
        ),
        INFEASIBLE_OPTION,
        JOINT_LIMITS_OPTION,
        JOINT_ACCELERATION_LIMIT_OPTION,
    )

    def weight_root(self, robot: Robot) -> np.ndarray:
        r"""The diagonal of S (n values, :math:`S^2 = W`), as ``damped-null-space`` weighs torques."""
        return torque_weight_root(self.torque_weight, robot, self.name)

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.weight_root(robot)

    def _optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int, record: bool = False):
        r = robot.redundancy
        nb = spread.size
        rows_count = nb + joint_rows_count
        root = self.weight_root(robot)[:, None]
        relative_weight2 = self.kinematic_weight**2
        damping = self.damping
        upper, lower, _ = _solver_bounds(robot, bounded)
        program = _Program(np.eye(r), np.zeros(r), np.zeros((rows_count, r)), np.ones(rows_count), -np.ones(rows_count))
        identity = np.eye(r)

        def program_at(terms: TaskTerms, basis, inertia_basis, tilde_torque, particular, joint_rows) -> BoundProgram:
            """The QP in y at this state: the criterion, the torque bounds and the rows on q̈ = p + Z y."""
            weighted_basis = root * inertia_basis
            offset = (tilde_torque - midpoint)[:, None] * root  # S(τ̃ − τ_mid), Eq. (29), Eq. (32)
            hessian = weighted_basis.T.dot(weighted_basis)
            cost = weighted_basis.T.dot(offset).reshape(-1)
            if relative_weight2:
                # μ̄² = μ²‖SHZ‖_F² = μ² trace((SHZ)ᵀSHZ), damped-null-space's normalisation.
                mu2 = relative_weight2 * hessian.trace()
                hessian = hessian + mu2 * identity
                cost = cost + mu2 * damping * basis.T.dot(terms.joint_velocity)
            # DAQP's pivot and zero tolerances are absolute: scale the criterion to a unit Hessian
            # trace (the minimiser is the same), so that range weights on large limits stay well above them.
            scale = r / hessian.trace()
            rows = torque_bound_rows(inertia_basis, tilde_torque, bounded, upper, lower, spread)
            if joint_rows_count:
                # q̈ = p + Z y within the joint limits' bounds (joint_limits.py); rows of zeros when not asked.
                rows = with_rows(
                    rows, joint_rows(particular, basis) if joint_rows is not None else _free_rows(joint_rows_count, r)
                )
            return BoundProgram(scale * hessian, scale * cost, *rows)

        def optimum(terms: TaskTerms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            y, flag = solve_program(
                program, program_at(terms, basis, inertia_basis, tilde_torque, particular, joint_rows)
            )
            if flag == _EXIT_INFEASIBLE:
                return None
            torque = tilde_torque + inertia_basis.dot(y)  # Eq. (27)
            return y, torque, program.solved(y, tilde_torque, inertia_basis, _VARIABLES) if record else None

        return optimum

    def objective_function(self, robot: Robot):
        r"""The criterion of the class docstring on the torques that realise the task,
        :math:`\|S(\tau - \tau_{mid})\|^2 + \bar\mu^2\|(I - J^+J)(\ddot q + K_D\dot q)\|^2`, that of
        ``damped-null-space`` (:math:`Z y = (I - J^+J)\ddot q` whatever the basis Z), minimised here under the
        bounds: :func:`torqueopt.testing.check_resolver` holds each answer to its KKT conditions under the
        program's constraints."""
        return DampedNullSpaceTorque.objective_function(self, robot)

    def _stack_optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int) -> StackOptimum:
        """:meth:`_optimum`'s QP for every row of a stack at once (the same numbers, row for row), solved row by row."""
        r = robot.redundancy
        rows_count = spread.size + joint_rows_count
        root = self.weight_root(robot)
        relative_weight2 = self.kinematic_weight**2
        damping = self.damping
        upper, lower, _ = _solver_bounds(robot, bounded)

        def program():
            return _Program(
                np.eye(r), np.zeros(r), np.zeros((rows_count, r)), np.ones(rows_count), -np.ones(rows_count)
            )

        def build(terms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            weighted_basis = root[:, None] * inertia_basis  # S H Z, (B, n, r)
            offset = (tilde_torque - midpoint) * root  # S(τ̃ − τ_mid), Eq. (29), Eq. (32)
            hessian = np.swapaxes(weighted_basis, 1, 2) @ weighted_basis
            cost = np.einsum("bki,bk->bi", weighted_basis, offset)
            trace = np.einsum("bii->b", hessian)
            if relative_weight2:
                # μ̄² = μ²‖SHZ‖_F², damped-null-space's normalisation.
                mu2 = relative_weight2 * trace
                hessian = hessian + mu2[:, None, None] * np.eye(r)
                cost = cost + (mu2 * damping)[:, None] * np.einsum("bki,bk->bi", basis, terms.joint_velocity)
                trace = np.einsum("bii->b", hessian)
            scale = r / trace  # a unit Hessian trace, as the single-state step
            rows = torque_bound_rows(inertia_basis, tilde_torque, bounded, upper, lower, spread)
            if joint_rows_count:
                # q̈ = p + Z y within the joint limits' bounds and the resolver's own rows.
                rows = with_rows(rows, joint_rows(particular, basis))
            return BoundProgram(
                np.ascontiguousarray(scale[:, None, None] * hessian),
                np.ascontiguousarray(scale[:, None] * cost),
                *(np.ascontiguousarray(part) for part in rows),
            )

        def solve(program, problem, row):
            y, flag = solve_program(program, problem.row(row))
            return None if flag == _EXIT_INFEASIBLE else y

        def free(problem):
            # The Hessian is positive definite (S without zeros or μ > 0, class docstring): y = −H⁻¹f, the optimum
            # wherever it meets every bound (DAQP's answer there, with no row active).
            hessian, cost, rows, row_upper, row_lower = problem
            y = -np.linalg.solve(hessian, cost[..., None])[..., 0]
            values = np.einsum("bkr,br->bk", rows, y)
            inside = ((values <= row_upper) & (values >= row_lower)).all(axis=1) & np.isfinite(y).all(axis=1)
            return y, inside

        definite = bool(relative_weight2) or bool((root != 0.0).all())
        return StackOptimum(program, build, solve, free=free if definite else None)


def _free_rows(count: int, columns: int):
    """``count`` rows that bound nothing (zero rows, infinite bounds), for a program asked without its joint limits."""
    return np.zeros((count, columns)), np.full(count, np.inf), np.full(count, -np.inf)
