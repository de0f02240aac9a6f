r"""``minmax-torque``: the paper's linear programming on the largest normalised torque, in the coordinates of Eq. (26)."""

from __future__ import annotations

import numpy as np

from ...robot import Robot, TaskTerms
from ..registry import register_resolver
from .base import INFEASIBLE_OPTION, StackOptimum, _BoundedResolver
from .joint_limits import JOINT_ACCELERATION_LIMIT_OPTION, JOINT_LIMITS_OPTION
from .programs import (
    _EXIT_OPTIMAL,
    BOUND_MARGIN,
    BoundProgram,
    _MinMax,
    _Program,
    _RangeBasis,
    minmax_torque_rows,
    solve_program,
)

__all__ = ["MinMaxTorque"]


@register_resolver
class MinMaxTorque(_BoundedResolver):
    r"""The paper's suggestion (Discussion): linear programming on the largest normalised torque.

    .. math::

        \min_y\ \max_i \frac{|\tau_i - \tau_{mid,i}|}{\tau^+_i - \tau^-_i}
        \quad\text{s.t.}\quad \tau = \tilde\tau + H Z y \quad\text{(Eq. (27), Eq. (28))}

    as the LP :math:`\min_{y,t} t` with :math:`\pm(\tau_i - \tau_{mid,i}) \le t(\tau^+_i - \tau^-_i)`
    over the joints with finite limits (an unbounded joint has no range to
    normalise by and is left out of the max; its torque is free). The
    optimum :math:`t^*` is the utilisation: every torque is within its bounds
    iff :math:`t^* \le 1/2` (:data:`~torqueopt.resolvers.bounded.programs.FEASIBILITY_TOLERANCE` allowed). When
    :math:`t^* > 1/2` no torque within bounds realises the task and the
    ``infeasible`` policy applies (``exceed`` keeps the LP's torque, the
    least largest normalised excess, and flags the step).
    """

    name = "minmax-torque"
    equations = (26, 28)
    options = (INFEASIBLE_OPTION, JOINT_LIMITS_OPTION, JOINT_ACCELERATION_LIMIT_OPTION)

    def _optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int, record: bool = False):
        minmax = _MinMax(bounded, spread, midpoint, robot.redundancy, joint_rows_count)
        ceiling = 0.5 - BOUND_MARGIN  # the LP's t may exceed its true value by DAQP's tolerance
        range_basis = _RangeBasis(robot.nv, robot.redundancy)

        def optimum(terms: TaskTerms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            range_rows = range_basis(inertia_basis)
            # τ = τ̃ + U z gives q̈ = p + H⁻¹U z: the joint limits' rows in z.
            extra = joint_rows(particular, np.linalg.solve(terms.inertia, range_rows)) if joint_rows else None
            z, utilisation = minmax(range_rows, tilde_torque, extra)
            if utilisation is None or utilisation > ceiling:
                return None
            y = range_basis.coordinates(range_rows.dot(z))
            torque = tilde_torque + inertia_basis.dot(y)  # Eq. (27)
            return y, torque, minmax.solved(z, utilisation, tilde_torque, range_rows) if record else None

        return optimum

    def _stack_optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int) -> StackOptimum:
        r""":meth:`_optimum`'s LP for every row of a stack at once, solved row by row.

        The range basis is the Q of the thin QR :math:`HZ = QR` (any
        orthonormal basis of the range serves; the single-state step takes
        the SVD's U), so :math:`y = R^{-1}z`.
        """
        r, nb = robot.redundancy, spread.size
        ceiling = 0.5 - BOUND_MARGIN  # the LP's t may exceed its true value by DAQP's tolerance
        inverse_spread = 1.0 / spread
        middle = midpoint[bounded]
        total = 2 * nb + joint_rows_count
        sign = np.r_[-np.ones(nb), np.ones(nb)][:, None]

        def program():
            rows = np.hstack([np.zeros((total, r)), np.r_[sign[:, 0], np.zeros(joint_rows_count)][:, None]])
            upper = np.r_[np.zeros(nb), np.full(nb + joint_rows_count, np.inf)]
            lower = np.r_[np.full(nb, -np.inf), np.zeros(nb), np.full(joint_rows_count, -np.inf)]
            return _Program(np.zeros((r + 1, r + 1)), np.r_[np.zeros(r), 1.0], rows, upper, lower, linear=True)

        def build(terms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            count = inertia_basis.shape[0]
            range_rows, triangular = np.linalg.qr(inertia_basis)  # U (B, n, r) and R: HZ = U R
            rows = np.zeros((count, total, r + 1))
            upper = np.empty((count, total))
            lower = np.empty((count, total))
            # Row i: (U_i z − t) <= −c_i and (U_i z + t) >= −c_i, c_i = τ̃_i − τ_mid,i, divided by the range.
            scaled, centre = minmax_torque_rows(range_rows, tilde_torque, bounded, middle, inverse_spread)
            rows[:, :nb, :r], rows[:, nb : 2 * nb, :r] = scaled, scaled
            rows[:, : 2 * nb, r] = sign[:, 0]
            upper[:, :nb], lower[:, :nb] = centre, -np.inf
            upper[:, nb : 2 * nb], lower[:, nb : 2 * nb] = np.inf, centre
            if joint_rows_count:
                # τ = τ̃ + U z gives q̈ = p + H⁻¹U z: the joint limits' rows in z.
                extra_rows, upper[:, 2 * nb :], lower[:, 2 * nb :] = joint_rows(
                    particular, np.linalg.solve(terms.inertia, range_rows)
                )
                rows[:, 2 * nb :, :r] = extra_rows
            return BoundProgram(None, None, rows, upper, lower), triangular

        def solve(program, problem, row):
            x, flag = solve_program(program, problem[0].row(row))
            if flag != _EXIT_OPTIMAL or x[r] > ceiling:
                return None
            return x[:r]

        def coordinates(problem, rows, solutions):
            triangular = problem[1][rows]
            return np.linalg.solve(triangular, solutions[..., None])[..., 0]  # R y = z: H Z y = U z

        return StackOptimum(program, build, solve, coordinates)
