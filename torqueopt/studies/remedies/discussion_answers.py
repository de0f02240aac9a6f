"""The numbers with which the remedies study answers the Discussion's two questions.

They are ``remedies.answers`` of ``summary.json``; docs/discussion/remedies.md says the answers in words,
reading these numbers (``torqueopt.pages``). Shares are fractions (1: all of null-space's cut), peaks are
|τ|/limit, tip errors metres, μ dimensionless and K_D in 1/s.
"""

from __future__ import annotations

from dataclasses import asdict
from itertools import pairwise
from typing import TYPE_CHECKING

from ...paper import MOVEMENTS
from .measures import _WITHIN, BOUNDED_QP, LEAST_SQUARES_REFERENCE, LINEAR_PROGRAM, _peak_ratio

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["kinematic_term_answer", "linear_programming_answer"]


def kinematic_term_answer(study: RemediesStudy) -> dict:
    """Can a kinematic term stop the whiplash? The sweep's settings with μ > 0, counted and picked out.

    ``reference``: the paper's method the blend equals at μ = 0; ``settings``, ``stable_settings``,
    ``within_limit_settings``: how many of them there are, keep the long movement stable, and also within its
    torque limits; ``best``: the setting that keeps the most of the short movement's cut among those within
    the limits, or else among the stable ones (its ``within_limits`` says which), None when none is stable;
    ``never_stable_weights``: the μ at which no K_D swept keeps the long movement stable, and
    ``always_unstable_weights`` those of them at which the whiplash detector trips at every K_D (the others
    lose the path at some); ``stable_short_kept``: [least, most] share of the short movement's cut a stable
    setting keeps (None when none is stable); ``short_kept_falls_with_weight``: at every K_D the share kept
    falls or stays as μ grows (None without a sweep).
    """
    points = [p for p in study.sweep if p.kinematic_weight > 0]
    stable = [p for p in points if p.long_stable]
    within = [p for p in points if p.within_limits]
    best = max(within or stable, key=lambda p: p.short_kept) if stable else None
    weights = sorted({p.kinematic_weight for p in points})
    never_stable = [mu for mu in weights if not any(p.long_stable for p in points if p.kinematic_weight == mu)]
    always_unstable = [
        mu for mu in never_stable
        if all(p.long_instability_time is not None for p in points if p.kinematic_weight == mu)
    ]  # fmt: skip
    by_weight = [
        sorted((p for p in points if p.damping == d), key=lambda p: p.kinematic_weight) for d in study.dampings
    ]
    return {
        "reference": study.sweep_reference,
        "torque_weight": study.sweep_torque_weight,
        "settings": len(points),
        "stable_settings": len(stable),
        "within_limit_settings": len(within),
        "best": None if best is None else {**asdict(best), "within_limits": best.within_limits},
        "never_stable_weights": never_stable,
        "always_unstable_weights": always_unstable,
        "stable_short_kept": [min(p.short_kept for p in stable), max(p.short_kept for p in stable)] if stable else None,
        "short_kept_falls_with_weight": all(
            later.short_kept <= earlier.short_kept + 1e-9 for row in by_weight for earlier, later in pairwise(row)
        )
        if points
        else None,
    }


def linear_programming_answer(study: RemediesStudy) -> dict:
    """Does the LP (minmax-torque) stay within the bounds better than least squares? Each one's movements, judged.

    ``resolvers``, per resolver (the LP, the bounded QP when registered, least squares weighted by torque range):
    ``peak_torque_ratio``, ``infeasible_steps`` (steps where no torque within the limits realises the task)
    and ``max_tip_error`` [m] per movement; ``within_limits``: the movements that completed without whipping
    with every |τ|/limit ≤ 1; ``done_within_bounds``: those of them that also realise the task at every step
    and are stable (a resolver that stays within the limits by giving up the path has not done the
    movement). ``lp_lead``: the movements the LP does within the bounds minus those each other one does.
    ``answered`` is False when the LP is not registered in this build.
    """
    if LINEAR_PROGRAM not in study.remedies:
        return {"answered": False}

    def record(name: str) -> dict:
        runs = {m: study.run(m, name) for m in MOVEMENTS}
        peaks = {m: _peak_ratio(run) for m, run in runs.items()}
        within = [
            m for m in MOVEMENTS if peaks[m] <= _WITHIN and runs[m].completed and not study.report(m, name).unstable
        ]
        return {
            "peak_torque_ratio": peaks,
            "within_limits": within,
            "infeasible_steps": {m: run.infeasible_steps for m, run in runs.items()},
            "done_within_bounds": [m for m in within if runs[m].infeasible_steps == 0 and study.stable(m, name)],
            "max_tip_error": {m: run.max_tip_error for m, run in runs.items()},
        }

    records = {name: record(name) for name in (LINEAR_PROGRAM, BOUNDED_QP, LEAST_SQUARES_REFERENCE)
               if name == LEAST_SQUARES_REFERENCE or name in study.remedies}  # fmt: skip
    done = {name: len(entry["done_within_bounds"]) for name, entry in records.items()}
    lead = {name: done[LINEAR_PROGRAM] - count for name, count in done.items() if name != LINEAR_PROGRAM}
    return {"answered": True, "lp_lead": lead, "resolvers": records}
