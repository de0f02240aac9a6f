"""The local-against-global study in words and files: its answer to the paper's question, ``global.md``, ``global.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...io import atomic_write, written_together
from ...paper import MOVEMENTS

if TYPE_CHECKING:
    from .study import LocalGlobalStudy

__all__ = ["answer_paragraph", "markdown_text", "write_local_global"]


def answer_paragraph(study: LocalGlobalStudy) -> str:
    """One paragraph that answers the paper's question with this study's numbers."""
    local_long = [row for row in study.rows if row.movement == "long" and row.kind == "local"]
    failed = [row.method for row in local_long if not row.problem_free]
    free_local = [row for row in local_long if row.problem_free]
    best_local = min(free_local, key=lambda row: row.cost) if free_local else None
    optimum, pinv = study.row("long", "global"), study.row("long", "pinv")
    weighted, weighted_bounded = study.row("long", "global weighted"), study.row("long", "global weighted, bounded")
    gaps = []
    for movement in MOVEMENTS:
        local, best = study.row(movement, "null-space"), study.row(movement, "global")
        excess = local.cost / best.cost - 1 if local.cost is not None else math.nan
        gaps.append(
            f"{movement} {local.cost:.2f} against {best.cost:.2f} "
            + (f"(+{100 * excess:.1f} %)" if excess < 1 else f"({local.cost / best.cost:.0f} times, {local.verdict})")
            if local.cost is not None
            else f"{movement}: null-space {local.verdict} against {best.cost:.1f}"
        )
    sentences = [
        (
            f"On the paper's long movement {len(failed)} of the {len(local_long)} local methods run here fail "
            f"({', '.join(failed) if failed else 'none'}: unstable, diverged, off their path or over a torque limit)."
        ),
        (
            "Null-space, the local torque optimum, is nearly globally optimal while the movement is short and "
            f"falls behind as it grows (∫‖τ‖² dt in N²·m²·s: {'; '.join(gaps)})."
        ),
    ]
    if best_local is not None:
        sentences.append(
            f"The cheapest local method that stays problem-free on the long movement is {best_local.method} at "
            f"{best_local.cost:.1f} (pinv {pinv.cost:.1f}); the whole-movement optimum costs "
            f"{optimum.cost:.1f}, {100 * (1 - optimum.cost / best_local.cost):.0f} % less, peaks at "
            f"{optimum.peak_ratio:.2f} of a limit, and its torques replayed open loop keep the tip within "
            f"{optimum.replay_tip_error * 1e3:.1g} mm of the path."
        )
    sentences.append(
        f"Weighted by torque range, the optimum of the long movement exceeds a limit "
        f"(peak {weighted.peak_ratio:.2f}) unless the bounds are imposed, and with them it peaks at "
        f"{weighted_bounded.peak_ratio:.4f} and is "
        f"{weighted_bounded.verdict}: a quadratic criterion, local or "
        "global, does not by itself keep torques within limits."
    )
    global_rows = [row for row in study.rows if row.kind == "global"]
    clean = [row for row in global_rows if row.problem_free]
    sentences.append(
        f"{len(clean)} of the {len(global_rows)} global solutions are problem-free by the same detector "
        + (
            "(all of them). "
            if len(clean) == len(global_rows)
            else f"(not: {', '.join(f'{row.movement} {row.method}' for row in global_rows if not row.problem_free)}). "
        )
        + "So, on this arm and these paths, the global resolution is free of the whiplash that ends the "
        "local torque optimisers"
        + (
            ", and no local method comes within 20 % of its cost on the long movement; it is "
            if best_local is not None and best_local.cost > 1.2 * optimum.cost
            else "; it is "
        )
        + "a local optimum of a nonconvex problem, reached from pinv's motion, and it needs the whole path in "
        "advance and an NLP solve where a local method needs one instant."
    )
    long_optimum = study.global_runs.get(("long", "global"))
    if long_optimum is not None:
        sentences.append(alignment_sentence(long_optimum))
    return " ".join(sentences)


def alignment_sentence(optimum) -> str:
    """How near the long movement's optimum brings links 2 and 3 to the line-up that whips the local methods,
    from its joint-3 angles (links 2 and 3 are in line at joint 3 = 0)."""
    angles = np.degrees(optimum.as_sim_result().joint_angles[:, 2])
    low, high = float(angles.min()), float(angles.max())
    if low <= 0.0 <= high:
        return (
            f"The whole-movement optimum of the long movement takes joint 3 from {low:.1f}° to {high:.1f}°, "
            "through the alignment of links 2 and 3 that whips the local methods."
        )
    nearest = min(abs(low), abs(high))
    return (
        f"The whole-movement optimum of the long movement keeps joint 3 between {low:.1f}° and {high:.1f}°: "
        f"links 2 and 3 come no nearer than {nearest:.1f}° to the alignment that whips the local methods."
    )


def markdown_text(study: LocalGlobalStudy, figures: list[str]) -> str:
    """The study as Markdown (``global.md``): its table, the answer, its figures."""
    lines = [
        "# Local against global torque optimisation",
        "",
        (
            "The paper's arm, its three movements, open loop; every cost on the 1 ms grid over the applied "
            f"torques. Global optima: direct transcription with {study.grid_step * 1e3:g} ms intervals, IPOPT, "
            "start at rest at q0, end free, replayed open loop through the same RK4."
        ),
        "",
        "| movement | method | ∫‖τ‖² dt [N²·m²·s] | ∫Σ(τᵢ/τᵢ⁺)² dt [s] | peak \\|τ\\|/limit | verdict |",
        "| --- | --- | ---: | ---: | ---: | --- |",
    ]
    for row in study.rows:
        cost = "—" if row.cost is None else f"{row.cost:.2f}"
        weighted = "—" if row.weighted_cost is None else f"{row.weighted_cost:.4f}"
        verdict = row.verdict
        if row.kind == "global":
            verdict += f"; replay within {row.replay_tip_error * 1e3:.2g} mm"
        lines.append(f"| {row.movement} | {row.method} | {cost} | {weighted} | {row.peak_ratio:.3f} | {verdict} |")
    if study.missing_remedies:
        lines += ["", f"Not registered in this build, so not run: {', '.join(study.missing_remedies)}."]
    lines += ["", "## The paper's question", "", study.answer(), ""]
    for figure in figures:
        lines.append(f"![{figure}]({figure})")
        lines.append("")
    return "\n".join(lines)


def local_global_files(out_dir) -> list[Path]:
    """The files :func:`write_local_global` writes into ``out_dir``, for a command to check before the study."""
    out = Path(out_dir)
    return [out / name for name in ("global_torques_long.png", "global_arm_long.png", "global.json", "global.md")]


def write_local_global(study: LocalGlobalStudy, out_dir) -> list[Path]:
    """Write global.md, global.json and the two figures into ``out_dir``, together or not at all."""
    out = Path(out_dir)
    with written_together():
        figures = study.write_figures(out)
        summary = json.dumps(study.summary(), indent=2, default=_json_default).encode()
        markdown = study.markdown([path.name for path in figures]).encode()
        atomic_write(out / "global.json", lambda handle: handle.write(summary))
        atomic_write(out / "global.md", lambda handle: handle.write(markdown))
    return [*figures, out / "global.json", out / "global.md"]


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
