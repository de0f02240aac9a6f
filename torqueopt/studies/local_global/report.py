"""The local-against-global study's files: ``global.json`` (its numbers), ``global.md`` (its table) and figures."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...io import atomic_write, written_together

if TYPE_CHECKING:
    from .study import LocalGlobalStudy

__all__ = ["joint_3_range", "markdown_text", "write_local_global"]


def joint_3_range(study: LocalGlobalStudy) -> list[float] | None:
    """[lowest, highest] joint-3 angle of the long movement's global optimum [deg], None without it.

    Links 2 and 3 are in line at joint 3 = 0, where the local methods whip.
    """
    optimum = study.global_runs.get(("long", "global"))
    if optimum is None:
        return None
    angles = np.degrees(optimum.as_sim_result().joint_angles[:, 2])
    return [float(angles.min()), float(angles.max())]


def markdown_text(study: LocalGlobalStudy, figures: list[str]) -> str:
    """``global.md``: the study's rows as a table, and its figures.

    What they answer is said by the documentation's page (docs/discussion/local-global.md), from ``global.json``.
    """
    lines = [
        "# Local against global torque optimisation",
        "",
        f"Grid step of the global optima: {study.grid_step * 1e3:g} ms.",
        "",
        "| movement | method | ∫‖τ‖² dt [N²·m²·s] | ∫Σ(τᵢ/τᵢ⁺)² dt [s] | peak \\|τ\\|/limit | verdict "
        "| replay tip error [mm] |",
        "| --- | --- | ---: | ---: | ---: | --- | ---: |",
    ]
    for row in study.rows:
        cost = "—" if row.cost is None else f"{row.cost:.2f}"
        weighted = "—" if row.weighted_cost is None else f"{row.weighted_cost:.4f}"
        replay = "—" if row.replay_tip_error is None else f"{row.replay_tip_error * 1e3:.2g}"
        lines.append(
            f"| {row.movement} | {row.method} | {cost} | {weighted} | {row.peak_ratio:.3f} | {row.verdict} | {replay} |"
        )
    if study.missing_remedies:
        lines += ["", f"Not registered in this build, so not run: {', '.join(study.missing_remedies)}."]
    lines.append("")
    for figure in figures:
        lines += [f"![{figure}]({figure})", ""]
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
