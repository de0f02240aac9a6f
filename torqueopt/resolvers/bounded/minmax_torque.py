r"""``minmax-torque``: the paper's linear programming on the largest normalised torque, in the coordinates of Eq. (26)."""

from __future__ import annotations

import numpy as np

from ...robot import Robot, TaskTerms
from .base import INFEASIBLE_OPTION, _BoundedResolver
from .joint_limits import JOINT_ACCELERATION_LIMIT_OPTION, JOINT_LIMITS_OPTION
from .programs import BOUND_MARGIN, _MinMax, _RangeBasis

__all__ = ["MinMaxTorque"]


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

    def _optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int):
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
            return y, tilde_torque + inertia_basis.dot(y)

        return optimum
