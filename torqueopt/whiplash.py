r"""The whiplash (instability) detector: when does holding the path need runaway torque?

Hollerbach & Suh call a movement unstable when "the torques required to keep
the manipulator endpoint on the planned trajectory become extremely high"
(Section 4 of the paper): the resolver has pumped the arm's self-motion up to
high joint speeds, and when links 2 and 3 swing into line the natural
dynamics would whip the tip off the path unless the joints push back very
hard. In open loop the tip still tracks the path; the sign of the whip is the
torque it costs.

Definition
----------
Every joint gets a yardstick :math:`s_i` [N·m or N] and a demand

.. math::

    r_i(t) = \frac{|\tau_i(t)|}{s_i}, \qquad
    s_i = \begin{cases}
        k_\text{limit}\,\tau_i^{+} & \text{joint with a finite limit}\\
        k_\text{growth}\,\max_{j\ \text{unlimited}} |\tau_j(0)| & \text{joint without one}
    \end{cases}

The run is *unstable* from the first sample at which some :math:`r_i > 1`:

* a joint with a torque limit needs more than ``limit_factor`` times that
  limit (default 2: the path can only be held with twice the torque the
  actuator has). The paper's limits scale with the mass each joint swings
  (54/24/6 N·m are 1.2 m/s² times the mass moments 45/20/5 kg·m of the
  outstretched arm), so this puts every joint on the same footing;
* a joint without a limit has no such yardstick, so it is measured against
  the torque the movement started with: it trips when it needs more than
  ``growth_factor`` times the largest torque any unlimited joint needed at the
  first sample (default 8).

A movement that asks for more than ``limit_factor`` times a limit from its
very first step is reported too (it cannot be executed either); its reason
says that the excess was there from the start, not built up by a whip.

Neither default is fitted to the paper's runs. On its scenario every run the
paper calls stable peaks below 1.0 times the limits and every run it calls
unstable above 4 times them, so any ``limit_factor`` from 1 to 4 classifies
them as the paper does; 2 sits in the middle of that gap. The
``growth_factor`` of 8 was set on 360 random straight lines of the paper's
arm with other start points and directions (pinv, inertia-pinv and
null-space, 0.5 to 2 s): there, with the limits ignored, it agrees with the
``limit_factor`` = 2 verdict on 98 % of the runs.

The detector reads only the :class:`~torqueopt.result.SimResult` (torques,
limits, joint speeds, tip error), so it works for any robot, any number of
joints, runs read back from files, and runs with unbounded torque limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import positive_number
from .result import SimResult

__all__ = [
    "DEFAULT_LIMIT_FACTOR",
    "DEFAULT_GROWTH_FACTOR",
    "WhiplashReport",
    "torque_demand",
    "detect_whiplash",
]

#: A joint with a torque limit trips when it needs more than this multiple of the limit.
DEFAULT_LIMIT_FACTOR = 2.0
#: A joint without a limit trips when it needs more than this multiple of the starting torque.
DEFAULT_GROWTH_FACTOR = 8.0


@dataclass(frozen=True)
class WhiplashReport:
    """What :func:`detect_whiplash` found in a run.

    Attributes:
        unstable: True when some joint's demand exceeded its yardstick.
        time: first sample at which it did [s], None when stable.
        joint: name of the joint that tripped first, None when stable.
        criterion: ``"limit"`` (a multiple of the torque limit) or
            ``"growth"`` (a multiple of the starting torque), None when stable.
        reason: one sentence saying why, or why not.
        peak_demand: largest :math:`r_i(t)` over the run (above 1: tripped);
            nan when no joint could be judged.
        limit_factor, growth_factor: the thresholds used.
    """

    unstable: bool
    time: float | None
    joint: str | None
    criterion: str | None
    reason: str
    peak_demand: float
    limit_factor: float
    growth_factor: float


def torque_demand(
    result: SimResult,
    limit_factor: float = DEFAULT_LIMIT_FACTOR,
    growth_factor: float = DEFAULT_GROWTH_FACTOR,
) -> np.ndarray:
    r"""The demand :math:`r_i(t) = |\tau_i(t)| / s_i` of every joint at every sample, shape (N, n).

    Columns of joints that cannot be judged (no limit, and no unlimited joint
    applied torque at the first sample) are nan. See the module docstring.
    """
    limit_factor = positive_number(limit_factor, "limit_factor", hint="a multiple, such as 2")
    growth_factor = positive_number(growth_factor, "growth_factor", hint="a multiple, such as 8")
    limited = _limited(result)
    demand = np.full(result.tau.shape, np.nan)
    # torque_ratio divides by τ⁺ or |τ⁻| by the torque's sign, so asymmetric limits are right too.
    demand[:, limited] = result.torque_ratio[:, limited] / limit_factor
    if (~limited).any() and len(result.t):
        start = float(np.abs(result.tau[0, ~limited]).max())
        if start > 0.0:  # False for NaN too: a run with no torque at its start has no yardstick
            demand[:, ~limited] = np.abs(result.tau[:, ~limited]) / (growth_factor * start)
    return demand


def detect_whiplash(
    result: SimResult,
    limit_factor: float = DEFAULT_LIMIT_FACTOR,
    growth_factor: float = DEFAULT_GROWTH_FACTOR,
) -> WhiplashReport:
    """Whether and when the run went unstable, by the definition of the module docstring.

    Args:
        result: any simulated run (or one read back by :func:`torqueopt.load_result`).
        limit_factor: a joint with a torque limit trips above this multiple of it.
        growth_factor: a joint without a limit trips above this multiple of
            the torque the movement started with.

    Raises:
        InvalidInput: a factor that is not a positive finite number.
    """
    demand = torque_demand(result, limit_factor, growth_factor)
    factors = {"limit_factor": float(limit_factor), "growth_factor": float(growth_factor)}
    # A joint is judged when it has a yardstick; rows without a torque (the
    # final state) are NaN in every column and never trip.
    judged = ~np.isnan(demand).all(axis=0) if len(demand) else np.zeros(result.n, bool)
    stopped = "" if result.completed else f"; the run stopped early: {result.stop_reason}"
    if not len(result.t) or not judged.any():
        if not len(result.t):
            why = "the run has no samples"
        elif np.isnan(result.tau).all():
            why = "the run applied no torque (it stopped at its first sample)"
        else:
            why = "no joint has a torque limit and the run applies no torque at its start, so there is no yardstick"
        return WhiplashReport(False, None, None, None, f"not judged: {why}{stopped}", math.nan, **factors)

    peak_demand = float(np.nanmax(demand))
    row_demand = np.where(np.isnan(demand), -np.inf, demand).max(axis=1)
    tripped = row_demand > 1.0
    if not tripped.any():
        reason = (
            f"stable: the largest torque demand is {peak_demand:.2f} of the threshold "
            f"({_threshold_text(result, limit_factor, growth_factor)}){stopped}"
        )
        return WhiplashReport(False, None, None, None, reason, peak_demand, **factors)

    row = int(np.argmax(tripped))
    joint = int(np.nanargmax(demand[row]))
    name = result.joint_names[joint]
    torque = result.tau[row, joint]
    limit = result.torque_upper[joint] if torque >= 0 else -result.torque_lower[joint]
    time = float(result.t[row])
    if np.isfinite(limit):
        criterion = "limit"
        size = f"{torque:.4g} N·m, {abs(torque) / limit:.3g} times its limit {limit:g} N·m (threshold {limit_factor:g})"
    else:
        criterion = "growth"
        start = abs(torque) / (demand[row, joint] * growth_factor)
        size = (
            f"{torque:.4g} N·m, {abs(torque) / start:.3g} times the {start:.4g} N·m the movement started with "
            f"(threshold {growth_factor:g})"
        )
    speed = np.abs(result.v[row])
    fastest = int(np.argmax(speed))
    context = (
        "already at the first sample: the movement asks for more torque than the arm has, without any whip"
        if row == 0
        else f"with joint {result.joint_names[fastest]} turning at {speed[fastest]:.3g} rad/s "
        f"and the tip {result.tip_error[row] * 1e3:.3g} mm from its path"
    )
    reason = f"unstable from t = {time:.3f} s: joint {name} needs {size}, {context}{stopped}"
    return WhiplashReport(True, time, name, criterion, reason, peak_demand, **factors)


def _limited(result: SimResult) -> np.ndarray:
    """Per joint, True when both of its torque limits are finite."""
    return np.isfinite(result.torque_upper) & np.isfinite(result.torque_lower)


def _threshold_text(result: SimResult, limit_factor: float, growth_factor: float) -> str:
    limited = _limited(result)
    parts = []
    if limited.any():
        parts.append(f"{limit_factor:g} times the torque limit")
    if (~limited).any():
        parts.append(f"{growth_factor:g} times the starting torque for joints without a limit")
    return " and ".join(parts)
