"""Stick figures of the arm: snapshots along a run, drawn from Pinocchio's forward kinematics, over its joint speeds."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..checks import whole_number
from ..errors import InvalidInput
from ..result import SimResult
from ..robot import Robot
from ..units import shared_unit
from .canvas import few_ticks, new_figure, save_figure
from .dexterity import _ELLIPSES, dexterity_ellipses
from .panels import _joint_lines, _mark_events, _mark_stops, _suptitle

__all__ = ["arm_points", "plot_stick_strip", "SNAPSHOTS_RANGE"]

#: The fewest and the most snapshots a strip may hold.
SNAPSHOTS_RANGE = (2, 24)


def plot_stick_strip(
    robot: Robot,
    result: SimResult,
    path: str | os.PathLike,
    *,
    title: str,
    snapshots: int = 8,
    events: Mapping[str, float] | None = None,
    ellipse: str | None = None,
) -> Path:
    r"""A strip of stick-figure snapshots of the arm, over a plot of its joint speeds.

    The arm is drawn from Pinocchio's forward kinematics: a segment between
    successive joint origins and on to the task frame, projected on the
    motion plane (the xy plane for the ``xy`` task, otherwise the best-fit
    plane of all drawn points). Snapshots are spaced evenly along the
    joint-space path length :math:`\int \|\dot q\|\,dt`, so they crowd where
    the joints move fast: a whip shows as a run of strongly changing poses.

    Args:
        snapshots: number of stick figures (2 to 24).
        events: labelled instants to mark on the speed plot [s].
        ellipse: draw a dexterity ellipse at the tip of every snapshot:
            ``"velocity"`` (tip velocities of unit joint speed, Eq. (6)) or
            ``"acceleration"`` (Yoshikawa's dynamic manipulability ellipsoid,
            Eq. (24)), projected on the drawing plane and scaled alike in
            every panel (see :func:`dexterity_ellipses`); None draws none.
    """
    if ellipse not in (None, *_ELLIPSES):
        raise InvalidInput(f"ellipse={ellipse!r} is not one of {', '.join(_ELLIPSES)} (or None)")
    snapshots = whole_number(snapshots, "snapshots", *SNAPSHOTS_RANGE)
    if not len(result.t):
        return _empty_strip(result, path, title)
    rows = _snapshot_rows(result, snapshots)
    points = np.array([arm_points(robot, result.joint_angles[row]) for row in rows])
    basis, origin = _plot_plane(robot, points)
    arm = (points - origin) @ basis.T
    linear = min(result.m, 3)
    tip_2d = _project_task(result.x[:, :linear], basis, origin)
    reference_2d = _project_task(result.x_ref[:, :linear], basis, origin)

    drawn = np.vstack([arm.reshape(-1, 2), reference_2d[np.isfinite(reference_2d).all(axis=1)]])
    if ellipse is not None:
        outlines, ellipse_label = dexterity_ellipses(robot, result, rows, ellipse, basis, arm[:, -1], drawn)
        drawn = np.vstack([drawn, *[outline for outline in outlines if outline is not None]])
    center, span, aspect = _view(drawn)

    # Axes placed by hand, in inches: constrained layout is slower per strip (BENCHMARKS.md, "Stick strips").
    columns = min(len(rows), 5)
    panel_rows = -(-len(rows) // columns)
    panel_width, panel_height = 3.0, 3.0 * aspect
    header, row_gap, gap, left, right = 0.95, 0.75, 0.15, 0.8, 0.2
    speed_height, bottom = 2.3, 0.55
    width = left + right + columns * panel_width + (columns - 1) * gap
    height = header + panel_rows * (panel_height + row_gap) + speed_height + bottom
    fig = new_figure(width, height, constrained=False)

    def place(x, y, w, h):
        return fig.add_axes((x / width, y / height, w / width, h / height))

    ticks = few_ticks()
    names = _axis_names(robot)
    for index, row in enumerate(rows):
        line, column = divmod(index, columns)
        top = height - header - line * (panel_height + row_gap)
        ax = place(left + column * (panel_width + gap), top - panel_height, panel_width, panel_height)
        ax.plot(reference_2d[:, 0], reference_2d[:, 1], color="0.6", ls="--", lw=1.0, label="reference path")
        ax.plot(tip_2d[: row + 1, 0], tip_2d[: row + 1, 1], color="tab:red", lw=1.0, label="tip path so far")
        ax.plot(arm[index, :, 0], arm[index, :, 1], "-o", color="k", lw=2.2, ms=3.5, label="arm (joints as dots)")
        ax.plot(arm[index, -1, 0], arm[index, -1, 1], "s", color="tab:red", ms=4, label="tip")
        if ellipse is not None and outlines[index] is not None:
            ax.fill(*outlines[index].T, color="tab:cyan", alpha=0.25, lw=1.0, ec="tab:blue", label=ellipse_label)
        _frame_snapshot(ax, center, span, ticks, f"t = {result.t[row]:.3f} s", names, column == 0)
        if index == 0:
            legend = {"loc": "upper center", "ncol": 5, "fontsize": 8, "frameon": False}
            fig.legend(*ax.get_legend_handles_labels(), **legend, bbox_to_anchor=(0.5, 1.0 - 0.62 / height))
    _draw_speeds(place(left, bottom, width - left - right, speed_height - 0.35), result, rows, events)
    _suptitle(fig, title, [result], y=1.0 - 0.08 / height)
    return save_figure(fig, path)


def _empty_strip(result: SimResult, path, title: str) -> Path:
    """The strip of a run with no rows: a line that says so."""
    fig = new_figure(8.0, 2.0)
    fig.text(0.5, 0.4, "no samples to draw: the run stopped before its first step", ha="center", va="center")
    _suptitle(fig, title, [result])
    return save_figure(fig, path)


def _view(drawn: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre, span [m] and aspect (height over width, within [0.35, 2]) of the panels around the ``drawn`` points,
    at equal scales on both axes: the narrower range is widened to the panel's shape."""
    low, high = drawn.min(axis=0), drawn.max(axis=0)
    center, span = 0.5 * (low + high), 1.12 * (high - low) + 1e-3
    aspect = float(np.clip(span[1] / span[0], 0.35, 2.0))
    return center, np.maximum(span, span[::-1] * np.array([1.0 / aspect, aspect])), aspect


def _frame_snapshot(ax, center, span, ticks, time_label: str, names: tuple[str, str], first_column: bool) -> None:
    """One snapshot's limits, equal scales, ticks, time label and axis labels (y only in the first column)."""
    ax.set_xlim(center[0] - span[0] / 2, center[0] + span[0] / 2)
    ax.set_ylim(center[1] - span[1] / 2, center[1] + span[1] / 2)
    ax.set_aspect("equal")
    ax.xaxis.set_major_locator(ticks())
    ax.yaxis.set_major_locator(ticks())
    box = {"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1.5}
    ax.text(0.03, 0.95, time_label, transform=ax.transAxes, va="top", fontsize=9, bbox=box)
    ax.tick_params(labelsize=7)
    if first_column:
        ax.set_ylabel(names[1] + " [m]", fontsize=8)
    else:
        ax.set_yticklabels([])
    ax.set_xlabel(names[0] + " [m]", fontsize=8, labelpad=1)


def _draw_speeds(speed_ax, result: SimResult, rows: list[int], events) -> None:
    """The joint speeds under the strip, with the snapshot times, the events and where the run stopped."""
    _joint_lines(speed_ax, result, result.v, 1.3, "{name} velocity")
    for row in rows:
        speed_ax.axvline(result.t[row], color="0.75", lw=0.8)
    speed_ax.plot([], [], color="0.75", lw=0.8, label="snapshot times")
    _mark_events(speed_ax, events)
    _mark_stops(speed_ax, [result])
    speed_ax.set_xlabel("time [s]")
    speed_ax.set_ylabel(f"joint velocity [{shared_unit(result.joint_kinds, 'velocity')}]")
    speed_ax.grid(alpha=0.3)
    speed_ax.legend(loc="upper left", fontsize=8, ncol=2)


def arm_points(robot: Robot, joint_angles) -> np.ndarray:
    """World positions [m] of every joint origin and then the task frame, shape (n + 1, 3), by Pinocchio's FK."""
    import pinocchio as pin

    model = robot.model
    data = model.createData()
    configuration = robot.configuration(joint_angles)
    pin.forwardKinematics(model, data, configuration)
    pin.updateFramePlacement(model, data, robot.frame_id)
    joints = [data.oMi[j].translation.copy() for j in range(1, model.njoints)]
    return np.array([*joints, data.oMf[robot.frame_id].translation.copy()])


def _snapshot_rows(result: SimResult, count: int) -> list[int]:
    """Rows spaced evenly along the joint-space path length, first and last always included."""
    rows = len(result.t)
    if rows <= count:
        return list(range(rows))
    steps = np.linalg.norm(np.diff(result.joint_angles, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    if arc[-1] <= 0.0:
        return list(np.linspace(0, rows - 1, count).round().astype(int))
    targets = np.linspace(0.0, arc[-1], count)
    chosen = np.searchsorted(arc, targets).clip(0, rows - 1)
    chosen[0], chosen[-1] = 0, rows - 1
    return sorted({int(row) for row in chosen})


def _plot_plane(robot: Robot, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two orthonormal in-plane axes (2×3) and an origin for drawing ``points`` (rows × joints × 3)."""
    if robot.task == "xy":
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.zeros(3)
    flat = points.reshape(-1, 3)
    origin = flat.mean(axis=0)
    _, _, axes = np.linalg.svd(flat - origin, full_matrices=False)
    return axes[:2], origin


def _project_task(values: np.ndarray, basis: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Task positions drawn in the same plane as the arm (the xy task is already in it)."""
    if values.shape[1] == 2:
        return values - origin[:2]
    return (values[:, :3] - origin) @ basis.T


def _axis_names(robot: Robot) -> tuple[str, str]:
    return ("x", "y") if robot.task == "xy" else ("in-plane axis 1", "in-plane axis 2")
