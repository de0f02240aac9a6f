"""Figures that compare runs over time: joint torques against their limits, joint motion, tip paths.

The paper's Figures 2-6 are drawn by these (:mod:`torqueopt.paper.figures`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..result import SimResult
from ..units import shared_unit
from .canvas import SYMLOG_ABOVE, new_figure, save_figure, symlog_scale
from .panels import (
    _color,
    _draw_limits,
    _draw_tip_path,
    _joint_lines,
    _joint_title,
    _legend_once,
    _mark_events,
    _mark_stops,
    _nonempty,
    _suptitle,
)

__all__ = ["plot_motion", "plot_tip_path", "plot_torques"]


def plot_torques(
    results: Sequence[SimResult],
    path: str | os.PathLike,
    *,
    title: str,
    instability_times: Mapping[str, float | None] | None = None,
) -> Path:
    """Torque of each joint against time, one panel per joint, one colour per run, ±limits dashed.

    Args:
        results: runs of the same robot to compare (labelled by their resolver).
        path: PNG to write.
        title: figure title.
        instability_times: per resolver name, when it went unstable [s]
            (drawn as a dotted line); None or missing for a stable run.
    """
    results = _nonempty(results)
    instability_times = instability_times or {}
    n = results[0].n
    fig = new_figure(9.0, 1.2 + 2.3 * n)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for joint, ax in enumerate(axes):
        limit = results[0].torque_upper[joint]
        peak = max(float(r.peak_torque[joint]) for r in results)
        for result in results:
            color = _color(result)
            ax.plot(result.t, result.tau[:, joint], color=color, lw=1.4, label=result.resolver)
            when = instability_times.get(result.resolver)
            if when is not None:
                ax.axvline(when, color=color, ls=":", lw=1.2, label=f"{result.resolver} unstable from {when:.2f} s")
        _draw_limits(ax, results[0], joint)
        _mark_stops(ax, results)
        log_beyond = np.isfinite(limit) and peak > SYMLOG_ABOVE * limit
        if log_beyond:
            symlog_scale(ax, limit, peak)
        ax.set_ylabel(f"torque [{results[0].joint_unit(joint, 'torque')}]")
        panel_title = _joint_title(results[0], joint, [(r.resolver, r.peak_torque[joint]) for r in results])
        ax.set_title(
            panel_title + ("\nscale linear within ±limit, logarithmic beyond" if log_beyond else ""),
            fontsize=10,
            loc="left",
        )
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    _legend_once(fig, axes)
    _suptitle(fig, title, results)
    return save_figure(fig, path)


def plot_motion(
    result: SimResult,
    path: str | os.PathLike,
    *,
    title: str,
    events: Mapping[str, float] | None = None,
) -> Path:
    """Joint velocities and joint accelerations of one run against time.

    Args:
        events: labelled instants to mark with vertical lines, e.g.
            ``{"links 2 and 3 aligned": 1.47}`` [s].
    """
    fig = new_figure(9.0, 7.0)
    speed_ax, accel_ax = fig.subplots(2, 1, sharex=True)
    _joint_lines(speed_ax, result, result.v, 1.4)
    _joint_lines(accel_ax, result, result.acceleration, 1.4)
    speed_ax.set_ylabel(f"joint velocity [{shared_unit(result.joint_kinds, 'velocity')}]")
    accel_ax.set_ylabel(f"joint acceleration [{shared_unit(result.joint_kinds, 'acceleration')}]")
    if not np.isfinite(result.acceleration).any():
        accel_ax.text(
            0.5,
            0.5,
            "accelerations not recorded in this run file",
            transform=accel_ax.transAxes,
            ha="center",
            va="center",
        )
    for ax in (speed_ax, accel_ax):
        _mark_events(ax, events)
        _mark_stops(ax, [result])
        ax.grid(alpha=0.3)
    speed_ax.set_title("joint velocities", fontsize=10, loc="left")
    accel_ax.set_title("joint accelerations commanded by the resolver", fontsize=10, loc="left")
    accel_ax.set_xlabel("time [s]")
    _legend_once(fig, [speed_ax, accel_ax])
    _suptitle(fig, title, [result])
    return save_figure(fig, path)


def plot_tip_path(results: Sequence[SimResult], path: str | os.PathLike, *, title: str) -> Path:
    """Tip path of each run against the reference path (first two task coordinates), and tip error over time."""
    results = _nonempty(results)
    fig = new_figure(11.0, 5.0)
    path_ax, error_ax = fig.subplots(1, 2, width_ratios=(1.1, 1.0))
    _draw_tip_path(path_ax, results)
    for result in results:
        error_ax.plot(result.t, result.tip_error * 1e3, color=_color(result), lw=1.4, label=f"{result.resolver} tip")
    _mark_stops(error_ax, results)
    error_ax.set_xlabel("time [s]")
    error_ax.set_ylabel("tip distance from reference [mm]")
    error_ax.set_title("tip error", fontsize=10, loc="left")
    error_ax.grid(alpha=0.3)
    _legend_once(fig, [path_ax, error_ax])
    _suptitle(fig, title, results)
    return save_figure(fig, path)
