"""The remedies study's section of ``summary.md``: its runs and its sweep, as tables of numbers.

What they answer is said by the documentation's page (docs/discussion/remedies.md), from ``summary.json``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from .discussion_answers import kept_text, percent
from .measures import SWEPT_RESOLVER

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["markdown_section"]


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
    if figures:
        lines += ["", "Figures:", "", *(f"- `{name}`" for name in figures)]
    return "\n".join(lines) + "\n"
