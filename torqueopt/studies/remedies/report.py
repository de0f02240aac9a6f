"""The remedies study's section of ``summary.md``: its runs, its sweep and its answers' numbers, as tables.

What they answer is said by the documentation's page (docs/discussion/remedies.md), from ``summary.json``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from .discussion_answers import kinematic_term_answer, linear_programming_answer
from .measures import SWEPT_RESOLVER

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["answer_lines", "kept_text", "markdown_section", "percent"]


def markdown_section(study: RemediesStudy, figures: Sequence[str]) -> str:
    """The study's section of ``summary.md``."""
    lines = ["## Remedies", ""]
    if study.skipped:
        lines += [f"Not registered in this build, so not run: {', '.join(study.skipped)}.", ""]
    lines += [
        "| movement | resolver | peak \\|τ\\|/limit | C [N²·m²·s] | cut kept | verdict "
        "| max tip error [mm] | infeasible steps |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in study.entries():
        verdict = study.verdict(row["movement"], row["resolver"])
        when = verdict if verdict == "stable" else f"**{verdict}**"
        kept = "-" if row["null_space_cut_kept"] is None else kept_text(row["null_space_cut_kept"])
        lines.append(
            f"| {row['movement']} | {row['resolver']} | {row['peak_torque_ratio']:.3g} | {row['torque_cost']:.4g} "
            f"| {kept} | {when} | {row['max_tip_error'] * 1e3:.3g} | {row['infeasible_steps']} |"
        )
    lines += ["", f"### Sweep of {SWEPT_RESOLVER} (torque_weight={study.sweep_torque_weight})", ""]
    if study.sweep:
        lines += [
            "Each cell: short movement's cut kept / long movement's peak |τ|/limit (**U**: unstable; **L**: lost its "
            "path or stopped early).",
            "",
            "| μ \\ K_D [1/s] | " + " | ".join(f"{d:g}" for d in study.dampings) + " |",
            "|---|" + "---|" * len(study.dampings),
        ]
        by_setting = {(p.kinematic_weight, p.damping): p for p in study.sweep}
        for mu in study.kinematic_weights:
            cells = []
            for damping in study.dampings:
                point = by_setting[mu, damping]
                mark = "" if point.long_stable else " **U**" if point.long_instability_time is not None else " **L**"
                cells.append(f"{percent(point.short_kept)} / {point.long_peak_ratio:.3g}{mark}")
            lines.append(f"| {mu:g} | " + " | ".join(cells) + " |")
    else:
        lines.append("Not run.")
    answers = {"kinematic_term": kinematic_term_answer(study), "linear_programming": linear_programming_answer(study)}
    lines += ["", "### The answers' numbers (`remedies.answers`)", "", *answer_lines(answers)]
    if figures:
        lines += ["", "Figures:", "", *(f"- `{name}`" for name in figures)]
    return "\n".join(lines) + "\n"


def answer_lines(answers: dict) -> list[str]:
    """``remedies.answers`` of ``summary.json`` (any of its two keys) as Markdown bullets and a table."""
    lines = []
    if "kinematic_term" in answers:
        term, best = answers["kinematic_term"], answers["kinematic_term"]["best"]
        kept = term["stable_short_kept"]
        lines += [
            f"- kinematic term, sweep settings with μ > 0: {term['settings']}; long movement stable: "
            f"{term['stable_settings']}; also within its limits: {term['within_limit_settings']}",
            "- best setting: "
            + ("-" if best is None else f"μ = {best['kinematic_weight']:g}, K_D = {best['damping']:g} 1/s, short cut "
               f"kept {kept_text(best['short_kept'])}, long peak |τ|/limit {best['long_peak_ratio']:.3g}, within limits: "
               f"{_yes(best['within_limits'])}"),
            f"- μ with no stable K_D: {_values(term['never_stable_weights'])}; unstable at every K_D: "
            f"{_values(term['always_unstable_weights'])}",
            f"- short cut kept by the stable settings: {'-' if kept is None else ' to '.join(map(kept_text, kept))}; "
            f"falls as μ grows at every K_D: {_yes(term['short_kept_falls_with_weight'])}",
        ]  # fmt: skip
    if "linear_programming" in answers:
        answer = answers["linear_programming"]
        lines += ["", "| resolver | within limits | done within bounds | infeasible steps | max tip error [mm] "
                  "| LP's lead [movements] |", "|---|---|---|---|---|---|"]  # fmt: skip
        lines += [
            f"| {name} | {', '.join(entry['within_limits']) or '-'} | {', '.join(entry['done_within_bounds']) or '-'} "
            f"| {_values(entry['infeasible_steps'].values())} | {_values(entry['max_tip_error'].values(), 'mm')} "
            f"| {answer['lp_lead'].get(name, '-')} |"
            for name, entry in answer.get("resolvers", {}).items()
        ] or ["| not run: the LP is not registered | | | | | |"]
    return lines


def _values(values, spec: str = "g") -> str:
    return ", ".join(f"{1e3 * v:.3g}" if spec == "mm" else format(v, spec) for v in values) or "-"


def _yes(flag: bool | None) -> str:
    return "-" if flag is None else "yes" if flag else "no"


def kept_text(share: float) -> str:
    """The share of null-space's cut a run keeps: a percentage, or "none" for a run that costs more than pinv
    (a negative share, which "keeps -80 %" would misstate)."""
    return "none" if math.isfinite(share) and share < 0 else percent(share)


def percent(share: float) -> str:
    """A share as a whole percentage, with no "-0 %" for a tiny negative one."""
    return "-" if not math.isfinite(share) else f"{round(100 * share) + 0:.0f}%"
