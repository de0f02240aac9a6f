"""The remedies study's section of ``summary.md``: its table, its answers, the sweep and its figures."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ...whiplash import DEFAULT_PATH_TOLERANCE
from .discussion_answers import kept_text, percent
from .measures import SWEPT_RESOLVER

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["markdown_section"]


def markdown_section(study: RemediesStudy, figures: Sequence[str]) -> str:
    """The study's section of ``summary.md``."""
    lines = [
        "## Remedies for the whiplash (the Discussion's questions)",
        "",
        (
            "Every registered remedy on the three movements, beside pinv and null-space. Torque cost "
            "C = ∫‖τ − τ_mid‖² dt over the applied torques; *cut kept*: (C_pinv − C)/(C_pinv − C_null-space), "
            "the share of null-space's reduction against pinv a remedy keeps; verdict: the whiplash detector "
            f"above, which also calls a run whose tip leaves its path by more than {DEFAULT_PATH_TOLERANCE * 1e3:g} mm "
            "*lost path*, never stable."
        ),
    ]
    if study.skipped:
        lines += ["", f"Not registered in this build, so not run: {', '.join(study.skipped)}."]
    lines += [
        "",
        (
            "| movement | resolver | peak \\|τ\\|/limit | C [N²·m²·s] | cut kept | verdict "
            "| max tip error [mm] | infeasible steps |"
        ),
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
    lines += [
        "",
        "### Can the local criterion be weighted with a kinematic term to avoid high velocity buildup?",
        "",
    ]
    lines += study.kinematic_term_answer()["sentences"]
    lines += ["", "### Would linear programming rather than least squares be more satisfactory?", ""]
    lines += study.linear_programming_answer()["sentences"]
    if study.sweep:
        lines += [
            "",
            f"### The sweep of {SWEPT_RESOLVER} (torque_weight={study.sweep_torque_weight})",
            "",
            (
                f"Each cell: share of {study.sweep_reference}'s cut in {study.sweep_cost_text()} on the short "
                "movement kept / peak |τ|/limit on the long movement (**U**: unstable)."
            ),
            "",
            "| μ \\ K_D [1/s] | " + " | ".join(f"{d:g}" for d in study.dampings) + " |",
            "|---|" + "---|" * len(study.dampings),
        ]
        by_setting = {(p.kinematic_weight, p.damping): p for p in study.sweep}
        for mu in study.kinematic_weights:
            cells = []
            for damping in study.dampings:
                point = by_setting[mu, damping]
                mark = "" if point.long_stable else " **U**"
                cells.append(f"{percent(point.short_kept)} / {point.long_peak_ratio:.3g}{mark}")
            lines.append(f"| {mu:g} | " + " | ".join(cells) + " |")
    descriptions = {
        "remedies_long": "torques of every remedy on the long movement beside pinv and null-space, as |τ|/limit",
        "remedies_tradeoff": "the trade-off: short-movement cut kept against long-movement peak torque, over μ and K_D",
    }
    shown = [f"- `{name}`: {descriptions[Path(name).stem]}" for name in figures if Path(name).stem in descriptions]
    if shown:
        lines += ["", "Figures:", "", *shown]
    return "\n".join(lines) + "\n"
