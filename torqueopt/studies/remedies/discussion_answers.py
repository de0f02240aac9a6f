"""The remedies study's answers to the Discussion's two questions: their numbers, and sentences made of them.

The sentences are the ``sentences`` of ``summary.json``'s ``remedies.answers``, kept as the file has always
had them (and printed by ``torqueopt paper``); the documentation's page (docs/discussion/remedies.md)
says the answers itself, from the numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict
from itertools import pairwise
from typing import TYPE_CHECKING

from ...paper import MOVEMENTS
from ...resolvers import get_resolver
from .measures import (
    _WITHIN,
    BOUNDED_QP,
    LEAST_SQUARES_REFERENCE,
    LINEAR_PROGRAM,
    SELF_MOTION_DAMPING,
    SWEPT_RESOLVER,
    _peak_ratio,
)

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["kinematic_term_answer", "linear_programming_answer", "percent"]


def kinematic_term_answer(study: RemediesStudy) -> dict:
    """The Discussion's first question, answered in sentences generated from the runs and the sweep."""
    sentences = []
    reference = study.sweep_reference
    null_long = study.report("long", reference)
    sentences.append(
        f"Without a kinematic term (μ = 0, {reference}) the long movement is "
        + null_long.summary
        + f" (peak |τ|/limit {_peak_ratio(study.run('long', reference)):.3g})."
    )
    result = {"sentences": sentences}
    points = [p for p in study.sweep if p.kinematic_weight > 0]
    if points:
        stable = [p for p in points if p.long_stable]
        within = [p for p in points if p.within_limits]
        if within:
            best = max(within, key=lambda p: p.short_kept)
            sentences.append(
                f"Yes on this arm: with μ = {best.kinematic_weight:g} and K_D = {best.damping:g} 1/s the long "
                f"movement stays stable and within its torque limits (peak |τ|/limit {best.long_peak_ratio:.3g}), "
                f"while the short movement keeps {kept_text(best.short_kept)} of the cut in "
                f"{study.sweep_cost_text()} that {reference} makes against pinv."
            )
        elif stable:
            best = max(stable, key=lambda p: p.short_kept)
            sentences.append(
                f"Only in part: μ = {best.kinematic_weight:g}, K_D = {best.damping:g} 1/s keeps the long movement "
                f"stable but not within its limits (peak |τ|/limit {best.long_peak_ratio:.3g}); it keeps "
                f"{kept_text(best.short_kept)} of the short movement's cut."
            )
        else:
            best = None
            sentences.append(
                f"No: none of the {len(points)} settings swept (μ in {_listing(study.kinematic_weights)}, K_D in "
                f"{_listing(study.dampings)} 1/s) keeps the long movement stable."
            )
        sentences.append(
            f"Of the {len(points)} settings with μ > 0, {len(stable)} keep the long movement stable and "
            f"{len(within)} also within its limits."
        )
        never_stable = [
            mu for mu in sorted({p.kinematic_weight for p in points})
            if not any(p.long_stable for p in points if p.kinematic_weight == mu)
        ]  # fmt: skip
        always_whips = [
            mu for mu in never_stable
            if all(p.long_instability_time is not None for p in points if p.kinematic_weight == mu)
        ]  # fmt: skip
        if always_whips:
            sentences.append(
                f"With μ = {_listing(always_whips)} every K_D swept leaves it unstable: the term must weigh "
                "enough against the torque criterion to hold the self-motion down."
            )
        others = [mu for mu in never_stable if mu not in always_whips]
        if others:
            sentences.append(
                f"With μ = {_listing(others)} no K_D swept keeps it stable: it whips or leaves its path at each."
            )
        if stable:
            kept = [p.short_kept for p in stable]
            falling = all(
                later.short_kept <= earlier.short_kept + 1e-9
                for damping in study.dampings
                for earlier, later in pairwise(sorted((p for p in points if p.damping == damping),
                                                    key=lambda p: p.kinematic_weight))
            )  # fmt: skip
            sentences.append(
                f"The stable settings keep between {kept_text(min(kept))} and {kept_text(max(kept))} of the short "
                "movement's cut"
                + (
                    "; at every K_D the share kept falls as μ grows: the more the term weighs, the less torque "
                    "the short movement saves."
                    if falling
                    else "."
                )
            )
        result.update(
            torque_weight=study.sweep_torque_weight,
            settings=len(points),
            stable_settings=len(stable),
            within_limit_settings=len(within),
            best=None if best is None else asdict(best),
        )
    else:
        sentences.append("The (μ, K_D) sweep was not run.")
    if SWEPT_RESOLVER in study.remedies:
        defaults = get_resolver(SWEPT_RESOLVER)
        long = study.run("long", SWEPT_RESOLVER)
        sentences.append(
            f"The defaults of {SWEPT_RESOLVER} (μ = {defaults.kinematic_weight:g}, K_D = {defaults.damping:g} 1/s) "
            f"keep {kept_text(study.cut_kept('short', SWEPT_RESOLVER))} of the short movement's cut"
            + (
                ""
                if study.sweep_torque_weight == "unit"
                else " (null-space's, in ∫‖τ‖²dt: the defaults use the unit weight)"
            )
            + " and leave the long "
            f"movement {study.verdict('long', SWEPT_RESOLVER)} (peak |τ|/limit {_peak_ratio(long):.3g}); the "
            f"medium movement is {study.verdict('medium', SWEPT_RESOLVER)}."
        )
    if SELF_MOTION_DAMPING in study.remedies:
        sentences.append(
            f"Self-motion damping alone (the μ → ∞ limit) leaves the long movement "
            f"{study.verdict('long', SELF_MOTION_DAMPING)} (peak |τ|/limit "
            f"{_peak_ratio(study.run('long', SELF_MOTION_DAMPING)):.3g}) but keeps "
            f"{kept_text(study.cut_kept('short', SELF_MOTION_DAMPING))} of the short movement's cut: a kinematic method, "
            "like pinv."
        )
    return result


def linear_programming_answer(study: RemediesStudy) -> dict:
    """The Discussion's second question: does the LP (minmax-torque) stay within bounds better than least squares?

    A movement counts as done within the bounds when the run completes, is stable, keeps every
    |τ|/limit ≤ 1 and realises the task at every step (no infeasible step): a resolver that
    stays within the limits by giving up the path has not done the movement.
    """
    if LINEAR_PROGRAM not in study.remedies:
        return {
            "answered": False,
            "sentences": [f"Not answered in this build: the LP resolver {LINEAR_PROGRAM} is not registered."],
        }

    def record(name: str) -> dict:
        peaks = {m: _peak_ratio(study.run(m, name)) for m in MOVEMENTS}
        infeasible = {m: study.run(m, name).infeasible_steps for m in MOVEMENTS}
        # Within the limits: every torque, on a run that completed without whipping (the path is judged
        # apart, by the infeasible steps and the tip error the next sentence gives).
        within = [
            m
            for m in MOVEMENTS
            if peaks[m] <= _WITHIN and study.run(m, name).completed and not study.report(m, name).unstable
        ]
        return {
            "peak_torque_ratio": peaks,
            "within_limits": within,
            "infeasible_steps": infeasible,
            "done_within_bounds": [m for m in within if infeasible[m] == 0 and study.stable(m, name)],
            "max_tip_error": {m: study.run(m, name).max_tip_error for m in MOVEMENTS},
        }

    def peaks_text(entry: dict) -> str:
        return ", ".join(f"{m} {entry['peak_torque_ratio'][m]:.3g}" for m in MOVEMENTS)

    records = {name: record(name) for name in (LINEAR_PROGRAM, BOUNDED_QP, LEAST_SQUARES_REFERENCE)
               if name == LEAST_SQUARES_REFERENCE or name in study.remedies}  # fmt: skip
    lp, least_squares = records[LINEAR_PROGRAM], records[LEAST_SQUARES_REFERENCE]
    total = len(MOVEMENTS)
    sentences = [
        f"{LINEAR_PROGRAM} (minimum largest normalised torque, an LP) keeps every torque within its limits on "
        f"{len(lp['within_limits'])} of {total} movements (peak |τ|/limit {peaks_text(lp)})."
    ]
    gave_up = {m: n for m, n in lp["infeasible_steps"].items() if n}
    if gave_up:
        pinv_error = max(study.run(m, "pinv").max_tip_error for m in gave_up)
        sentences.append(
            "But at "
            + ", ".join(f"{n} steps of the {m} movement" for m, n in gave_up.items())
            + " no torque within the limits realises the task, so it gives up task acceleration there: the tip "
            f"leaves the path by up to {max(lp['max_tip_error'][m] for m in gave_up) * 1e3:.3g} mm "
            f"(pinv: {pinv_error * 1e3:.3g} mm)."
        )
    compared = [
        f"{LEAST_SQUARES_REFERENCE} (least squares weighted by torque range, no bounds) on "
        f"{len(least_squares['done_within_bounds'])} ({peaks_text(least_squares)})"
    ]
    if BOUNDED_QP in records:
        qp = records[BOUNDED_QP]
        options = study.run("short", BOUNDED_QP).resolver_options or {}
        term = options.get("kinematic_weight") or 0.0
        with_term = f", with its kinematic term μ = {term:g}, K_D = {options.get('damping', 0):g} 1/s" if term else ""
        compared.append(
            f"{BOUNDED_QP} (least squares with hard bounds, a QP{with_term}) on {len(qp['done_within_bounds'])} "
            f"({peaks_text(qp)})"
        )
    sentences.append(
        f"Realising the path with every torque within its limits, the LP does {len(lp['done_within_bounds'])} of "
        f"{total} movements; " + "; ".join(compared) + "."
    )
    lead = len(lp["done_within_bounds"]) - len(least_squares["done_within_bounds"])
    if lead > 0:
        verdict = "more satisfactory than least squares for staying within the bounds on this arm"
    elif lead == 0:
        verdict = "no more satisfactory than least squares for staying within the bounds on this arm"
    else:
        verdict = "less satisfactory than least squares for staying within the bounds on this arm"
    if BOUNDED_QP in records:
        against_qp = len(lp["done_within_bounds"]) - len(records[BOUNDED_QP]["done_within_bounds"])
        verdict += (
            ", and "
            + ("more" if against_qp > 0 else "no more" if against_qp == 0 else "less")
            + " satisfactory than least squares with the bounds as constraints"
        )
    sentences.append(f"By this measure linear programming is {verdict}.")
    return {"answered": True, "sentences": sentences, **records}


def _listing(values: Sequence[float]) -> str:
    values = [f"{v:g}" for v in values]
    return values[0] if len(values) == 1 else ", ".join(values[:-1]) + " and " + values[-1]


def kept_text(share: float) -> str:
    """The share of null-space's cut a run keeps, in words: a percentage, or "none" for a run that costs more
    than pinv (a negative share, which "keeps -80 %" would misstate)."""
    if math.isfinite(share) and share < 0:
        return "none"
    return percent(share)


def percent(share: float) -> str:
    """A share as a whole percentage, with no "-0 %" for a tiny negative one."""
    return "-" if not math.isfinite(share) else f"{round(100 * share) + 0:.0f}%"
