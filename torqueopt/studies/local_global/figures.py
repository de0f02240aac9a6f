"""The local-against-global study's figures: the long movement's torques, local against global, and the optimum's arm."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...result import SimResult

if TYPE_CHECKING:
    from .study import LocalGlobalStudy

__all__ = ["plot_long_torques", "write_figures"]


def write_figures(study: LocalGlobalStudy, out_dir: Path, figure_format: str = "png") -> list[Path]:
    """``global_torques_long`` and ``global_arm_long`` (the optimum's stick figures) in ``out_dir``, as ``figure_format``."""
    from ... import plots

    out = Path(out_dir)
    torques = plot_long_torques(study, out / f"global_torques_long.{figure_format}")
    strip = plots.plot_stick_strip(
        study.robot,
        _labelled(study.global_runs["long", "global"].as_sim_result(), "global"),
        out / f"global_arm_long.{figure_format}",
        title="Long movement: the whole-movement torque optimum (unweighted, end free)",
    )
    return [torques, strip]


#: (method, colour, line style) of the long-movement torque figure, drawn when run.
_FIGURE_LINES = (
    ("pinv", "tab:blue", "-"),
    ("null-space", "tab:red", "-"),
    ("damped-null-space", "tab:orange", "-"),
    ("bounded-torque", "tab:brown", ":"),  # dotted: on this path it coincides with damped-null-space
    ("global", "black", "-"),
    ("global weighted, bounded", "tab:green", "--"),
)


def plot_long_torques(study: LocalGlobalStudy, path: Path) -> Path:
    """The long movement's torques, one panel per joint: local resolvers against the global optima.

    The axes span ±1.6 times each limit; a run that leaves them (null-space's
    whiplash) is marked where the detector trips.
    """
    from ...plots.canvas import new_figure, save_figure

    limits = np.asarray(study.scenario.torque_limit, float)
    fig = new_figure(9.0, 7.5)
    axes = fig.subplots(len(limits), 1, sharex=True)
    for joint, ax in enumerate(axes):
        for method, colour, style in _FIGURE_LINES:
            if ("long", method) in study.local_runs:
                run = study.local_runs["long", method]
            elif ("long", method) in study.global_runs:
                run = study.global_runs["long", method]
            else:
                continue
            ax.plot(run.t[:-1], run.tau[:-1, joint], color=colour, linestyle=style, linewidth=1.4, label=method)
            row = study.row("long", method)
            if row.unstable and joint == 0:
                ax.axvline(row.unstable_time, color=colour, linestyle=":", linewidth=1.0)
        for sign in (1.0, -1.0):
            ax.axhline(sign * limits[joint], color="0.3", linestyle="--", linewidth=0.8)
        ax.set_ylim(-1.6 * limits[joint], 1.6 * limits[joint])
        ax.set_ylabel(f"τ{joint + 1} [N·m]")
        ax.set_title(f"joint {joint + 1} (limit ±{limits[joint]:g} N·m)", fontsize=10, loc="left")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    unstable = [row for row in study.rows if row.movement == "long" and row.kind == "local" and row.unstable]
    note = "; ".join(
        f"{row.method} unstable from {row.unstable_time:.2f} s (dotted), leaves the axes"
        for row in unstable
        if any(row.method == line[0] for line in _FIGURE_LINES)
    )
    fig.suptitle(
        "Long movement (2 s): local resolvers against the whole-movement optimum" + (f"\n{note}" if note else "")
    )
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 6), fontsize=9)
    return save_figure(fig, path)


def _labelled(result: SimResult, label: str) -> SimResult:
    result.resolver = label
    return result
