r"""What the remedies study runs and how it measures a run.

The remedies (:data:`REMEDIES`), the paper's runs drawn beside them
(:data:`BASELINES`), the (μ, K_D) grid of the swept blend, and the measures:
the torque cost :math:`\int \|S(\tau - \tau_{mid})\|^2 dt`, stability (the
whiplash detector's verdict on a completed run) and the peak |τ|/limit.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import InvalidInput
from ...resolvers import RESOLVERS
from ...result import SimResult
from ...whiplash import WhiplashReport

__all__ = [
    "BASELINES",
    "BOUNDED_QP",
    "DEFAULT_DAMPINGS",
    "DEFAULT_KINEMATIC_WEIGHTS",
    "LEAST_SQUARES_REFERENCE",
    "LINEAR_PROGRAM",
    "REMEDIES",
    "SELF_MOTION_DAMPING",
    "SWEEP_REFERENCES",
    "SWEPT_RESOLVER",
    "registered_remedies",
    "torque_cost",
]

#: The remedies this study runs, when registered (``bounded-torque`` and ``minmax-torque`` come from
#: the bounded resolvers; a build without them answers the LP question with "not run").
REMEDIES = (
    "damped-null-space",
    "self-motion-damping",
    "inverse-inertia-torque",
    "inverse-inertia-squared-torque",
    "bounded-torque",
    "minmax-torque",
)
#: The paper's runs drawn beside the remedies.
BASELINES = ("pinv", "null-space")
#: The least-squares method the LP is compared with (weighted by torque range, Eq. (33)).
LEAST_SQUARES_REFERENCE = "weighted-null-space"
LINEAR_PROGRAM = "minmax-torque"
BOUNDED_QP = "bounded-torque"
SELF_MOTION_DAMPING = "self-motion-damping"
#: The blend whose μ and K_D are swept.
SWEPT_RESOLVER = "damped-null-space"
#: μ values of the sweep (dimensionless, relative to ‖SHZ‖_F; 0 is null-space).
DEFAULT_KINEMATIC_WEIGHTS = (0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2.0, 5.0)
#: K_D values of the sweep [1/s].
DEFAULT_DAMPINGS = (2.0, 5.0, 10.0, 20.0, 50.0)
#: The torque weights the sweep can use, each with the paper's method it equals at μ = 0.
SWEEP_REFERENCES = {"unit": "null-space", "range": "weighted-null-space"}
_WITHIN = 1.0 + 1e-6  # peak |τ|/limit at or below this is within the limits (round-off of a bounded solver)


def registered_remedies() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(the remedies registered in this build, those that are not), each in :data:`REMEDIES` order."""
    present = tuple(name for name in REMEDIES if name in RESOLVERS)
    return present, tuple(name for name in REMEDIES if name not in RESOLVERS)


def torque_cost(result: SimResult, torque_weight: str = "unit") -> float:
    r""":math:`\int \|S(\tau - \tau_{mid})\|^2 dt` over the torques held over each step.

    ``torque_weight``: ``unit`` (S = I, [N²·m²·s]) or ``range`` (S = diag(1/(τ⁺ − τ⁻)) of
    Eq. (33), [s]; 0 for an unbounded joint). The last row of a completed run (t = T)
    starts no step, so it is left out.
    """
    bounded = np.isfinite(result.torque_upper) & np.isfinite(result.torque_lower)
    midpoint = np.where(bounded, 0.5 * (result.torque_upper + result.torque_lower), 0.0)
    if torque_weight == "unit":
        root = np.ones(result.n)
    elif torque_weight == "range":
        root = np.where(bounded, 1.0 / (result.torque_upper - result.torque_lower), 0.0)
    else:
        raise InvalidInput(f"torque weight '{torque_weight}' of a torque cost must be one of unit, range")
    applied = result.tau[:-1] if result.completed else result.tau
    return float(np.sum(np.square(root * (applied - midpoint))) * result.dt)


def _stable(result: SimResult, report: WhiplashReport) -> bool:
    return result.completed and report.stable


def _peak_ratio(result: SimResult) -> float:
    return float(result.peak_torque_ratio.max()) if len(result.t) else math.nan
