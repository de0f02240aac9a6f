"""The overview figure of one run (``torqueopt plot``): torques with limits, joint velocities, tip path and error, dexterity."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..result import SimResult
from ..units import shared_unit
from .canvas import SYMLOG_ABOVE, new_figure, save_figure, symlog_scale
from .dexterity import draw_dexterity
from .panels import (
    _JOINT_COLORS,
    _draw_joint_limits,
    _draw_limits,
    _draw_tip_path,
    _joint_lines,
    _joint_title,
    _mark_events,
    _mark_stops,
    _suptitle,
)

__all__ = ["plot_run"]


def plot_run(
    result: SimResult,
    path: str | os.PathLike,
    *,
    title: str | None = None,
    dpi: float | None = None,
    events: Mapping[str, float] | None = None,
) -> Path:
    """Overview of any saved run: torque of each joint with its limits, joint velocities, tip path and error.

    ``path`` ends in .png, .pdf or .svg; ``dpi`` sets a PNG's resolution (default :data:`DEFAULT_DPI`);
    ``events`` ({label: time [s]}, e.g. when the run went unstable) are marked on the time panels.
    """
    n = result.n
    fig = new_figure(13.0, max(6.0, 1.0 + 1.7 * n) + (1.8 if result.dexterity else 0.0))
    grid = fig.add_gridspec(n, 2, width_ratios=(1.3, 1.0))
    torque_axes = [fig.add_subplot(grid[joint, 0]) for joint in range(n)]
    for joint, ax in enumerate(torque_axes):
        color = _JOINT_COLORS[joint % len(_JOINT_COLORS)]
        ax.plot(result.t, result.tau[:, joint], color=color, lw=1.3, label="torque")
        _draw_limits(ax, result, joint)
        limit = result.torque_upper[joint]
        peak = float(result.peak_torque[joint])
        if np.isfinite(limit) and peak > SYMLOG_ABOVE * limit:
            symlog_scale(ax, limit, peak)
        ax.set_ylabel(f"[{result.joint_unit(joint, 'torque')}]", fontsize=8)
        ax.set_title(_joint_title(result, joint), fontsize=9, loc="left")
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
        _mark_stops(ax, [result])
        _mark_events(ax, events)
        if joint < n - 1:
            ax.tick_params(labelbottom=False)
    torque_axes[-1].set_xlabel("time [s]")
    torque_axes[0].legend(loc="upper left", fontsize=7)
    panels = (1.0, 1.3, 0.8, 0.9) if result.dexterity else (1.0, 1.3, 0.8)
    right = grid[:, 1].subgridspec(len(panels), 1, height_ratios=panels)
    speed_ax = fig.add_subplot(right[0])
    _joint_lines(speed_ax, result, result.v, 1.2)
    _mark_stops(speed_ax, [result])
    _mark_events(speed_ax, events)
    velocity_title = _draw_joint_limits(speed_ax, result)
    speed_ax.set_title("joint velocities" + velocity_title, fontsize=9, loc="left")
    speed_ax.set_xlabel("time [s]")
    speed_ax.set_ylabel(f"[{shared_unit(result.joint_kinds, 'velocity')}]")
    # Beside the panel, not on it: seven joints' labels covered the curves they name.
    speed_ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    speed_ax.grid(alpha=0.3)
    path_ax = fig.add_subplot(right[1])
    _draw_tip_path(path_ax, [result], single=True)
    path_ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    error_ax = fig.add_subplot(right[2])
    error_ax.plot(result.t, result.tip_error * 1e3, color="tab:red", lw=1.2)
    _mark_stops(error_ax, [result])
    _mark_events(error_ax, events)
    error_ax.set_title("tip distance from reference", fontsize=9, loc="left")
    error_ax.set_xlabel("time [s]")
    error_ax.set_ylabel("[mm]")
    error_ax.grid(alpha=0.3)
    if result.max_task_error > 0 or result.infeasible_steps:
        _draw_task_shortfall(error_ax, result)
    if result.dexterity:
        draw_dexterity(fig.add_subplot(right[3]), result)
    default = (
        f"{result.robot}: resolver {result.resolver}, task {result.task} at '{result.frame}', {result.duration:g} s"
    )
    _suptitle(fig, title or default, [result])
    return save_figure(fig, path, dpi)


def _draw_task_shortfall(ax, result: SimResult) -> None:
    """On a right-hand axis: the task acceleration the resolver gave up per step, infeasible steps marked."""
    shortfall_ax = ax.twinx()
    shortfall_ax.plot(result.t, result.task_error, color="tab:purple", lw=1.0, label="task shortfall")
    infeasible = result.infeasible
    if infeasible.any():
        shortfall_ax.plot(result.t[infeasible], result.task_error[infeasible], "|", color="tab:purple", ms=6,
                          label=f"{result.infeasible_steps} infeasible steps")  # fmt: skip
    shortfall_ax.set_ylabel("‖Jq̈ + J̇q̇ − ẍ‖ [m/s²]", fontsize=8, color="tab:purple")
    shortfall_ax.tick_params(labelsize=8, colors="tab:purple")
    shortfall_ax.legend(fontsize=7, loc="upper right")
    ax.set_title("tip distance from reference; task acceleration given up (right)", fontsize=9, loc="left")
