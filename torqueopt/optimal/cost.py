r"""The whole-movement torque cost, evaluated the same way for every run.

.. math::

    C = \int_0^T \big\| S\,(\tau - \tau_{mid}) \big\|^2 \, dt
      \;\approx\; \sum_{j=0}^{M-1} \Delta t\, \big\| S\,(\tau_j - \tau_{mid}) \big\|^2

over the torques :math:`\tau_j` held over the steps :math:`[t_j, t_j + \Delta t]`
of the simulation grid, :math:`\tau_{mid} = (\tau^+ + \tau^-)/2` (zero for
symmetric limits and for unbounded joints). The sample at :math:`t = T`
is not an applied torque and is left out. With :math:`S = I` the cost is in
[N²·m²·s]. The torque-range weight is the square root of Eq. (33)'s weight
scaled by the half range, :math:`S = \mathrm{diag}\big(2/(\tau^+ - \tau^-)\big)`,
so that :math:`S^\top S = \mathrm{diag}(1/\tau_{limit}^2)` for symmetric limits,
as in the paper's weighted experiments; the weighted cost is in [s] (1 s per
joint held at its limit for one second). It has the same minimiser as the
``weighted-null-space`` resolver's :math:`1/(\tau^+ - \tau^-)^2`.
"""

from __future__ import annotations

import numpy as np

from ..checks import weight_matrix_root
from ..errors import InvalidInput
from ..resolvers.null_space import torque_midpoint
from ..result import SimResult
from ..robot import Robot

__all__ = ["WEIGHTS", "run_cost", "torque_cost", "weight_root"]

#: The named weights: ``identity`` (S = I) and ``range`` (S = diag(2/(τ⁺ − τ⁻)), Eq. (33)).
WEIGHTS = ("identity", "range")


def weight_root(robot: Robot, weight=None) -> np.ndarray:
    r"""The matrix :math:`S` (n×n) of the cost :math:`\|S(\tau - \tau_{mid})\|^2`.

    Args:
        weight: ``None`` or ``"identity"`` (S = I); ``"range"``
            (:math:`S = \mathrm{diag}(2/(\tau^+ - \tau^-))`, Eq. (33); every
            joint needs a finite limit); a vector of n non-negative values,
            the diagonal of :math:`W = S^\top S`; or a symmetric positive
            semi-definite n×n matrix W.
    """
    n = robot.nv
    if weight is None or (isinstance(weight, str) and weight == "identity"):
        return np.eye(n)
    if isinstance(weight, str):
        if weight != "range":
            raise InvalidInput(f"unknown weight '{weight}': choose one of {', '.join(WEIGHTS)}, a vector or a matrix")
        torque_range = robot.torque_upper - robot.torque_lower
        if not np.isfinite(torque_range).all():
            raise InvalidInput(
                f"weight 'range' divides by the torque range, but joints {', '.join(robot.joints_without_torque_limit)} "
                f"of robot '{robot.name}' have no torque limit; give torque limits or a weight vector"
            )
        return np.diag(2.0 / torque_range)  # Eq. (33): W^(1/2), scaled by the half range
    root = weight_matrix_root(weight, n, choices=WEIGHTS)
    return np.diag(root) if root.ndim == 1 else root


def torque_cost(tau, dt: float, root: np.ndarray, midpoint: np.ndarray) -> float:
    r""":math:`\sum_j \Delta t\,\|S(\tau_j - \tau_{mid})\|^2` over the rows of ``tau`` (each held for ``dt`` [s])."""
    residual = (np.asarray(tau, float) - midpoint).dot(root.T)
    return float(dt * np.sum(residual * residual))


def run_cost(result: SimResult, robot: Robot, weight=None) -> float:
    """The cost of a simulated run on its own grid: every applied torque, not the sample at t = T.

    A completed run's last row (t = T, NaN torque) is not applied. A run
    that stopped early is charged for the finite torques it recorded (the
    one that stopped it included): compare completed runs only.
    """
    applied = result.tau[:-1] if result.completed else result.tau[np.isfinite(result.tau).all(axis=1)]
    return torque_cost(applied, result.dt, weight_root(robot, weight), torque_midpoint(robot))
