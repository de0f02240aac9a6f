"""The remedies study's section of ``summary.md``: its table, its answers, the sweep and its figures."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ...paper import MOVEMENTS
from ...whiplash import DEFAULT_PATH_TOLERANCE
from .discussion_answers import kept_text, percent
from .measures import SWEPT_RESOLVER

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["OVERVIEW_RESOLVERS", "markdown_section", "overview_table"]


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


#: The rows of the remedies page's overview table (docs/discussion/remedies.md), in its order.
OVERVIEW_RESOLVERS = (
    "pinv",
    "null-space",
    "damped-null-space",
    "self-motion-damping",
    "inverse-inertia-torque",
    "inverse-inertia-squared-torque",
)


def overview_table(study: RemediesStudy, names: Sequence[str] = OVERVIEW_RESOLVERS) -> str:
    """The overview table of the remedies page, every number from the study's runs at 3 significant digits.

    Columns: the short movement's cut kept and peak |τ|/limit, the medium movement's peak, the long movement's
    verdict and peak; ``damped-null-space`` and ``self-motion-damping`` are labelled with their settings.
    """
    lines = [
        "| resolver | short: cut kept, peak \\|τ\\|/limit | medium: peak | long (2 s): verdict, peak |",
        "| --- | --- | --- | --- |",
    ]
    for name in names:
        options = study.run("short", name).resolver_options or {}
        label = f"`{name}`"
        if name == "damped-null-space":
            label += f" (μ = {options['kinematic_weight']:g}, K_D = {options['damping']:g} 1/s)"
        elif name == "self-motion-damping":
            label += f" (K_D = {options['damping']:g} 1/s)"
        kept = study.cut_kept("short", name)
        kept_cell = "-" if not math.isfinite(kept) else kept_text(kept).replace("%", " %")
        peaks = {movement: float(study.run(movement, name).peak_torque_ratio.max()) for movement in MOVEMENTS}
        verdict = study.verdict("long", name).replace("t = ", "")
        lines.append(
            f"| {label} | {kept_cell}, {peaks['short']:.3g} | {peaks['medium']:.3g} | {verdict}, {peaks['long']:.3g} |"
        )
    return "\n".join(lines)
