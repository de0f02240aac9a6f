r"""The atlas's stability-margin columns: :func:`torqueopt.stability_margin` along each run, on a subsample.

With ``--margin`` (``run_atlas(..., margin=True)``) every torque resolver's
row gets

``peak_stability_margin`` [1/s]
    the largest margin σ (the growth rate of the linearised closed-loop
    self-motion, ``torqueopt.stability``) over the sampled states before
    the instability (the row's ``instability_time``) of a run whose verdict is
    ``whiplash``, over the whole run otherwise;
``margin_warning_time`` [s]
    on a ``whiplash`` row, the instability time less the first sampled time at
    which σ was positive: how long before the whip the margin warned (0 when it
    turned positive only at the instability); NaN on a row without a whip, or
    when σ stayed at or below zero before it;
``margin_samples``
    how many states were evaluated.

The margin costs about 1.3 ms a state on planar3 for the null-space family
and 6.6 ms for ``energy-bounded-torque`` (a QP per perturbed term: 4n + 1
resolver steps a state), some 40 to 200 times one simulation step, so it is
evaluated on a subsample: the state at every ``every`` seconds (default
:data:`DEFAULT_MARGIN_EVERY`, 20 ms: 101 states on a 2 s run), from t = 0,
at the commanded task acceleration of that sample. Its cost is counted in
the atlas's up-front bound (:data:`MARGIN_STEP_EQUIVALENT` trajectory-steps a
state). The velocity-level resolvers and the global optimum have no
resolver closed loop: their margin columns are NaN.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["DEFAULT_MARGIN_EVERY", "MARGIN_STEP_EQUIVALENT", "margin_columns", "no_margin"]

#: Time between the states whose margin is evaluated [s].
DEFAULT_MARGIN_EVERY = 0.02
#: What one margin evaluation counts as in the atlas's bound on its work, in trajectory-steps.
MARGIN_STEP_EQUIVALENT = 40


def no_margin() -> dict:
    return {"peak_stability_margin": math.nan, "margin_warning_time": math.nan, "margin_samples": 0}


def margin_rows(result, every: float, until: float | None) -> np.ndarray:
    """The rows whose margin is evaluated: every ``every`` seconds from t = 0, with an applied torque, at or before
    ``until`` [s] (all rows when None)."""
    stride = max(1, round(every / result.dt))
    rows = np.arange(0, len(result.t), stride)
    rows = rows[np.isfinite(result.tau[rows]).all(axis=1)]
    if until is not None:
        rows = rows[result.t[rows] <= until + 1e-12]
    return rows


def margin_columns(robot, resolver, result, line, row: dict, every: float = DEFAULT_MARGIN_EVERY) -> dict:
    """The margin columns of one run (module docstring); ``row`` holds its verdict and instability time."""
    from ..stability import margins_along

    if getattr(resolver, "level", None) == "velocity":
        return no_margin()
    whip = row["verdict"] == "whiplash" and math.isfinite(row["instability_time"])
    rows = margin_rows(result, every, row["instability_time"] if whip else None)
    if not rows.size:
        return no_margin()
    commands = line.sample(result.t[rows]).acceleration
    if robot.task == "pose":
        commands = np.hstack([commands, np.zeros((rows.size, 3))])
    step = resolver.solver_for_run(robot, result.dt)
    margins = margins_along(robot, step, result.q[rows], result.v[rows], commands, np.ones(rows.size, dtype=bool))
    finite = np.isfinite(margins)
    peak = float(margins[finite].max()) if finite.any() else math.nan
    warning = math.nan
    if whip:
        positive = np.flatnonzero(margins > 0.0)
        if positive.size:
            warning = float(row["instability_time"] - result.t[rows[positive[0]]])
    return {"peak_stability_margin": peak, "margin_warning_time": warning, "margin_samples": int(rows.size)}
