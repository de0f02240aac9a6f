"""Figures of simulated runs: torques against limits, joint motion, tip path, stick figures.

Every function draws one figure with matplotlib's object API on the Agg
canvas (no pyplot, no global backend switch, no window) and writes it as a
file in the format its suffix names (PNG at :data:`DEFAULT_DPI`, or vector
PDF and SVG) through :func:`torqueopt.io.atomic_write`, so a figure file is
either complete or absent. A run that stopped early is drawn up to where it stopped,
with a dashed line there and a note saying why.

matplotlib is imported inside the functions; without it they raise
:class:`torqueopt.errors.MissingDependency`.
"""

from __future__ import annotations

import os
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .errors import InvalidInput, MissingDependency
from .io import atomic_write
from .result import SimResult
from .robot import Robot

__all__ = [
    "RESOLVER_COLORS",
    "plot_torques",
    "plot_motion",
    "plot_tip_path",
    "plot_stick_strip",
    "plot_run",
    "arm_points",
    "draw_dexterity",
    "dexterity_ellipses",
]

#: One colour per resolver, the same in every figure.
RESOLVER_COLORS = {
    "pinv": "tab:blue",
    "inertia-pinv": "tab:orange",
    "null-space": "tab:red",
    "weighted-null-space": "tab:green",
    # the velocity-level methods of Section 1.1
    "velocity-pinv": "tab:cyan",
    "gradient-projection": "tab:purple",
    "task-priority": "tab:olive",
    "obstacle-avoidance": "tab:brown",
    "extended-jacobian": "tab:pink",
    "kinetic-energy-pinv": "tab:gray",
}
_JOINT_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")
_EVENT_COLORS = ("tab:purple", "0.25", "tab:olive")
#: Resolution of raster (PNG) figures [dots per inch]; PDF and SVG are vector output.
DEFAULT_DPI = 170
#: The figure formats, by file suffix: the suffix of the path names the format.
FIGURE_FORMATS = ("png", "pdf", "svg")
#: No tick label is smaller than this [pt], so a figure stays readable when printed at its size.
_MIN_TICK_POINTS = 8.0
# Above this multiple of its limit a torque panel switches to a scale that is
# linear within ±limit and logarithmic beyond, so a runaway of 100 times the
# limit and the limit itself are both readable.
_SYMLOG_ABOVE = 1.5


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
    fig = _figure(9.0, 1.2 + 2.3 * n)
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
        log_beyond = np.isfinite(limit) and peak > _SYMLOG_ABOVE * limit
        if log_beyond:
            _symlog(ax, limit, peak)
        ax.set_ylabel("torque [N·m]")
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
    return _save(fig, path)


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
    fig = _figure(9.0, 7.0)
    speed_ax, accel_ax = fig.subplots(2, 1, sharex=True)
    for joint, name in enumerate(result.joint_names):
        color = _JOINT_COLORS[joint % len(_JOINT_COLORS)]
        speed_ax.plot(result.t, result.v[:, joint], color=color, lw=1.4, label=name)
        accel_ax.plot(result.t, result.acceleration[:, joint], color=color, lw=1.4, label=name)
    speed_ax.set_ylabel("joint velocity [rad/s]")
    accel_ax.set_ylabel("joint acceleration [rad/s²]")
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
    return _save(fig, path)


def plot_tip_path(results: Sequence[SimResult], path: str | os.PathLike, *, title: str) -> Path:
    """Tip path of each run against the reference path (first two task coordinates), and tip error over time."""
    results = _nonempty(results)
    fig = _figure(11.0, 5.0)
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
    return _save(fig, path)


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
        robot: the robot the run was simulated with.
        result: the run.
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
    if not isinstance(snapshots, (int, np.integer)) or not 2 <= snapshots <= 24:
        raise InvalidInput(f"snapshots={snapshots!r} must be a whole number from 2 to 24")
    if not len(result.t):
        fig = _figure(8.0, 2.0)
        fig.text(0.5, 0.4, "no samples to draw: the run stopped before its first step", ha="center", va="center")
        _suptitle(fig, title, [result])
        return _save(fig, path)
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
    low, high = drawn.min(axis=0), drawn.max(axis=0)
    center, span = 0.5 * (low + high), 1.12 * (high - low) + 1e-3
    aspect = float(np.clip(span[1] / span[0], 0.35, 2.0))
    # Equal scales on both axes: widen the narrower range to the panel's shape.
    span = np.maximum(span, span[::-1] * np.array([1.0 / aspect, aspect]))

    # Axes placed by hand, in inches: constrained layout costs about a second per strip.
    columns = min(len(rows), 5)
    panel_rows = -(-len(rows) // columns)
    panel_width = 3.0
    panel_height = panel_width * aspect
    header, row_gap, gap, left, right = 0.95, 0.75, 0.15, 0.8, 0.2
    speed_height, bottom = 2.3, 0.55
    width = left + right + columns * panel_width + (columns - 1) * gap
    height = header + panel_rows * (panel_height + row_gap) + speed_height + bottom
    fig = _figure(width, height, constrained=False)

    def place(x, y, w, h):
        return fig.add_axes((x / width, y / height, w / width, h / height))

    ticks = _few_ticks()
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
        ax.set_xlim(center[0] - span[0] / 2, center[0] + span[0] / 2)
        ax.set_ylim(center[1] - span[1] / 2, center[1] + span[1] / 2)
        ax.set_aspect("equal")
        ax.xaxis.set_major_locator(ticks())
        ax.yaxis.set_major_locator(ticks())
        ax.text(
            0.03,
            0.95,
            f"t = {result.t[row]:.3f} s",
            transform=ax.transAxes,
            va="top",
            fontsize=9,
            bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1.5},
        )
        ax.tick_params(labelsize=7)
        if column == 0:
            ax.set_ylabel(_axis_names(robot)[1] + " [m]", fontsize=8)
        else:
            ax.set_yticklabels([])
        if index == 0:
            fig.legend(
                *ax.get_legend_handles_labels(),
                loc="upper center",
                ncol=5,
                fontsize=8,
                frameon=False,
                bbox_to_anchor=(0.5, 1.0 - 0.62 / height),
            )
        ax.set_xlabel(_axis_names(robot)[0] + " [m]", fontsize=8, labelpad=1)
    speed_ax = place(left, bottom, width - left - right, speed_height - 0.35)
    for joint, name in enumerate(result.joint_names):
        speed_ax.plot(
            result.t,
            result.v[:, joint],
            color=_JOINT_COLORS[joint % len(_JOINT_COLORS)],
            lw=1.3,
            label=f"{name} velocity",
        )
    for row in rows:
        speed_ax.axvline(result.t[row], color="0.75", lw=0.8)
    speed_ax.plot([], [], color="0.75", lw=0.8, label="snapshot times")
    _mark_events(speed_ax, events)
    _mark_stops(speed_ax, [result])
    speed_ax.set_xlabel("time [s]")
    speed_ax.set_ylabel("joint velocity [rad/s]")
    speed_ax.grid(alpha=0.3)
    speed_ax.legend(loc="upper left", fontsize=8, ncol=2)
    _suptitle(fig, title, [result], y=1.0 - 0.08 / height)
    return _save(fig, path)


def plot_run(result: SimResult, path: str | os.PathLike, *, title: str | None = None, dpi: float | None = None) -> Path:
    """Overview of any saved run: torque of each joint with its limits, joint velocities, tip path and error.

    ``path`` ends in .png, .pdf or .svg; ``dpi`` sets a PNG's resolution (default :data:`DEFAULT_DPI`).
    """
    n = result.n
    fig = _figure(13.0, max(6.0, 1.0 + 1.7 * n) + (1.8 if result.dexterity else 0.0))
    grid = fig.add_gridspec(n, 2, width_ratios=(1.3, 1.0))
    torque_axes = [fig.add_subplot(grid[joint, 0]) for joint in range(n)]
    for joint, ax in enumerate(torque_axes):
        color = _JOINT_COLORS[joint % len(_JOINT_COLORS)]
        ax.plot(result.t, result.tau[:, joint], color=color, lw=1.3, label="torque")
        _draw_limits(ax, result, joint)
        limit = result.torque_upper[joint]
        peak = float(result.peak_torque[joint])
        if np.isfinite(limit) and peak > _SYMLOG_ABOVE * limit:
            _symlog(ax, limit, peak)
        ax.set_ylabel("[N·m]", fontsize=8)
        ax.set_title(_joint_title(result, joint), fontsize=9, loc="left")
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
        _mark_stops(ax, [result])
        if joint < n - 1:
            ax.tick_params(labelbottom=False)
    torque_axes[-1].set_xlabel("time [s]")
    torque_axes[0].legend(loc="upper left", fontsize=7)
    panels = (1.0, 1.3, 0.8, 0.9) if result.dexterity else (1.0, 1.3, 0.8)
    right = grid[:, 1].subgridspec(len(panels), 1, height_ratios=panels)
    speed_ax = fig.add_subplot(right[0])
    for joint, name in enumerate(result.joint_names):
        speed_ax.plot(result.t, result.v[:, joint], color=_JOINT_COLORS[joint % len(_JOINT_COLORS)], lw=1.2, label=name)
    _mark_stops(speed_ax, [result])
    velocity_title = _draw_joint_limits(speed_ax, result)
    speed_ax.set_title("joint velocities" + velocity_title, fontsize=9, loc="left")
    speed_ax.set_xlabel("time [s]")
    speed_ax.set_ylabel("[rad/s]")
    speed_ax.legend(fontsize=7, ncol=2)
    speed_ax.grid(alpha=0.3)
    path_ax = fig.add_subplot(right[1])
    _draw_tip_path(path_ax, [result], single=True)
    path_ax.legend(fontsize=7)
    error_ax = fig.add_subplot(right[2])
    error_ax.plot(result.t, result.tip_error * 1e3, color="tab:red", lw=1.2)
    _mark_stops(error_ax, [result])
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
    return _save(fig, path, dpi)


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


# -- dexterity ----------------------------------------------------------------
_ELLIPSES = ("velocity", "acceleration")
_DEXTERITY_LINES = (
    ("manipulability", "w, Eq. (6)", "tab:blue"),
    ("min_singular_value", "σ_min(J)", "tab:green"),
    ("dynamic_manipulability", "dynamic w, Eq. (25)", "tab:red"),
)


def draw_dexterity(ax, result: SimResult) -> None:
    """Draw a run's dexterity measures on ``ax``, each relative to its value at the start (1 = unchanged).

    The legend gives each measure's start value, so the panel reads both how
    dexterity changed and where it began.
    """
    highest = 1.0
    for name, label, color in _DEXTERITY_LINES:
        values = np.asarray(result.dexterity.get(name, ()), dtype=float)
        if not values.size or not np.isfinite(values[0]) or values[0] == 0.0:
            continue
        ratio = values / values[0]
        highest = max(highest, float(np.nanmax(ratio)))
        ax.plot(result.t, ratio, color=color, lw=1.2, label=f"{label} (start {values[0]:.3g})")
    ax.axhline(1.0, color="0.6", lw=0.8, ls=":")
    _mark_stops(ax, [result])
    # Head room above the curves for the legend.
    ax.set_ylim(0.0, 1.9 * highest)
    ax.set_title("dexterity, as a ratio to its start value", fontsize=9, loc="left")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("ratio to start", fontsize=8)
    ax.legend(fontsize=7, loc="upper left", framealpha=0.85)
    ax.grid(alpha=0.3)


def dexterity_ellipses(robot: Robot, result: SimResult, rows, kind: str, basis, tips, drawn):
    r"""Outlines (points × 2, drawing coordinates) of one dexterity ellipse per snapshot row, and a legend label.

    ``kind`` ``"velocity"`` draws :math:`\{J\dot q : \|\dot q\| \le 1\}`, ``"acceleration"``
    Yoshikawa's :math:`\{J\tilde H^{-1}\hat\tau : \|\hat\tau\| \le 1\}` (Eq. (24)), projected
    on the drawing plane (``basis``, 2×3; the xy task is drawn as it is) and
    centred at the tip. One scale serves every snapshot, chosen so that the
    largest semi-axis is a quarter of the drawing's extent (``drawn``); the
    label says how many drawing metres one unit [m/s or m/s²] is. An entry
    is None where the ellipse is undefined (no torque limits).
    """
    from .dexterity import dexterity

    mappings = []
    for row in rows:
        measured = dexterity(robot, result.joint_angles[row])
        ellipsoid = measured.velocity_ellipsoid if kind == "velocity" else measured.acceleration_ellipsoid
        if ellipsoid is None:
            mappings.append(None)
            continue
        axes = ellipsoid.semi_axes
        mappings.append(axes if axes.shape[0] == 2 else basis @ axes)
    largest = max((float(np.linalg.svd(m, compute_uv=False)[0]) for m in mappings if m is not None), default=0.0)
    extent = float(np.ptp(drawn, axis=0).max()) or 1.0
    scale = 0.25 * extent / largest if largest > 0 else 0.0
    angle = np.linspace(0.0, 2.0 * np.pi, 73)
    circle = np.stack([np.cos(angle), np.sin(angle)])
    outlines = []
    for mapping, tip in zip(mappings, tips):
        if mapping is None:
            outlines.append(None)
            continue
        left, values, _ = np.linalg.svd(mapping, full_matrices=False)
        outlines.append(tip + (scale * (left[:, :2] * values[:2]) @ circle).T)
    if kind == "velocity":
        label = f"velocity ellipse, ‖q̇‖ ≤ 1 rad/s (1 m/s drawn as {scale:.3g} m)"
    else:
        label = f"acceleration ellipse at rest, Eq. (24) (1 m/s² drawn as {scale:.3g} m)"
    return outlines, label


# -- helpers ------------------------------------------------------------------
def _figure(width: float, height: float, constrained: bool = True):
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingDependency("plotting needs matplotlib: pip install matplotlib") from None
    return Figure(figsize=(width, height), layout="constrained" if constrained else None)


def _few_ticks():
    from matplotlib.ticker import MaxNLocator

    return lambda: MaxNLocator(nbins=3)


def _symlog(ax, linthresh: float, peak: float) -> None:
    """Linear within ±linthresh (the limit), logarithmic beyond, with ticks a reader can tell apart.

    Ticks at 0, ±limit and, beyond it, at 1, 2 and 5 times each decade up to
    the peak; a tick less than a factor 1.95 above the limit (or above the
    tick below it) is left out, so that no two labels overlap (100 over 54).
    """
    from matplotlib.ticker import FixedLocator, NullLocator, StrMethodFormatter

    ax.set_yscale("symlog", linthresh=linthresh, linscale=1.0)
    candidates = [
        step * 10.0**k
        for k in range(int(np.floor(np.log10(linthresh))), int(np.floor(np.log10(peak))) + 2)
        for step in (1.0, 2.0, 5.0)
    ]
    beyond = []
    last = linthresh
    for value in sorted(candidates):
        if value >= 1.95 * last and value <= 1.3 * peak:
            beyond.append(value)
            last = value
    ticks = sorted({0.0, linthresh, -linthresh, *beyond, *(-v for v in beyond)})
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(StrMethodFormatter("{x:g}"))
    ax.yaxis.set_minor_locator(NullLocator())


def figure_format(path: str | os.PathLike) -> str:
    """The format a figure path names by its suffix (``png``, ``pdf`` or ``svg``), or InvalidInput."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FIGURE_FORMATS:
        shown = f"'.{suffix}'" if suffix else "no suffix"
        raise InvalidInput(
            f"figure '{path}' has {shown}; give a name ending in {', '.join('.' + f for f in FIGURE_FORMATS)}"
        )
    return suffix


def _save(fig, path: str | os.PathLike, dpi: float | None = None) -> Path:
    """Write ``fig`` in the format its suffix names (PNG at ``dpi``, default :data:`DEFAULT_DPI`; PDF, SVG)."""
    path = Path(path)
    fmt = figure_format(path)
    for ax in fig.axes:
        for label in (*ax.get_xticklabels(), *ax.get_yticklabels()):
            if label.get_fontsize() < _MIN_TICK_POINTS:
                label.set_fontsize(_MIN_TICK_POINTS)
    resolution = DEFAULT_DPI if dpi is None else dpi
    atomic_write(path, lambda handle: fig.savefig(handle, format=fmt, dpi=resolution))
    return path


def _nonempty(results: Sequence[SimResult]) -> list[SimResult]:
    results = list(results)
    if not results:
        raise InvalidInput("no runs to plot: give at least one SimResult")
    return results


def _color(result: SimResult) -> str:
    return RESOLVER_COLORS.get(result.resolver, "tab:purple")


def _joint_title(result: SimResult, joint: int, peak_by_run=None) -> str:
    limit = result.torque_upper[joint]
    limit_text = f"limit ±{limit:g} N·m" if np.isfinite(limit) else "no torque limit"
    text = f"{result.joint_names[joint]} ({limit_text})"
    if peak_by_run:
        text += ";  peak |τ|: " + ", ".join(f"{name} {peak:.3g}" for name, peak in peak_by_run)
    return text


def _draw_limits(ax, result: SimResult, joint: int) -> None:
    upper, lower = result.torque_upper[joint], result.torque_lower[joint]
    if np.isfinite(upper):
        ax.axhline(upper, color="k", ls="--", lw=1.0, label="± torque limit")
    if np.isfinite(lower):
        ax.axhline(lower, color="k", ls="--", lw=1.0)


def _mark_events(ax, events: Mapping[str, float] | None) -> None:
    for index, (label, when) in enumerate((events or {}).items()):
        ax.axvline(
            when, color=_EVENT_COLORS[index % len(_EVENT_COLORS)], ls="--", lw=1.1, label=f"{label} ({when:.3f} s)"
        )


def _draw_joint_limits(ax, result: SimResult) -> str:
    """On a joint-velocity panel: the ±velocity limit of each joint that came within half of it (dotted, in its
    colour), and a line where a joint first left its position or velocity limits; returns a title suffix."""
    peaks = np.nanmax(np.abs(result.v), axis=0) if len(result.t) else np.zeros(result.n)
    limits = result.velocity_limit
    drawn = False
    for joint, (peak, limit) in enumerate(zip(peaks, limits)):
        if np.isfinite(limit) and peak > 0.5 * limit:
            color = _JOINT_COLORS[joint % len(_JOINT_COLORS)]
            for sign in (1.0, -1.0):
                ax.axhline(sign * limit, color=color, ls=":", lw=1.2)
            drawn = True
    if drawn:
        ax.plot([], [], color="0.3", ls=":", lw=1.2, label="± velocity limit")
    notes = []
    for kind, violation, color in (
        ("position", result.first_position_violation, "tab:purple"),
        ("velocity", result.first_velocity_violation, "tab:olive"),
    ):
        if violation is not None:
            time, joint, _, _ = violation
            ax.axvline(time, color=color, ls="--", lw=1.1, label=f"{joint} leaves its {kind} limit")
            notes.append(f"{kind} limit left at {time:.3f} s ({joint})")
    return "\n" + "; ".join(notes) if notes else ""


def _mark_stops(ax, results: Sequence[SimResult]) -> None:
    for result in results:
        if not result.completed and result.stop_time is not None:
            ax.axvline(result.stop_time, color="k", ls="-.", lw=1.2, label=f"{result.resolver} stopped early")


def _legend_once(fig, axes) -> None:
    """One legend for the figure, with every distinct label of its axes."""
    seen = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, handle)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="outside lower center", ncol=min(4, len(seen)), fontsize=8)


def _suptitle(fig, title: str, results: Sequence[SimResult], y: float | None = None) -> None:
    notes = [
        f"{r.resolver} STOPPED EARLY at t = {r.stop_time:.3f} s: {r.stop_reason} (drawn up to there)"
        for r in results
        if not r.completed
    ]
    where = {} if y is None else {"y": y, "va": "top"}
    # About 8 characters per inch of figure width at this font size.
    width = max(40, int(8.5 * fig.get_figwidth()))
    lines = [wrapped for text in (title, *notes) for wrapped in textwrap.wrap(text, width)]
    fig.suptitle("\n".join(lines), fontsize=11 if not notes else 10, **where)


def _draw_tip_path(ax, results: Sequence[SimResult], single: bool = False) -> None:
    r"""Where the tip went, drawn so that millimetres of deviation show beside metres of movement.

    A straight reference (its points span one direction :math:`u`): the
    deviation across the line [mm] against the distance along it [m], the
    reference being the zero line; signed (to the left of :math:`u`) for
    planar tasks, the distance from the line for 3-D ones. A curved reference
    (a circle, waypoints): tip and reference projected onto the plane of the
    movement (the two principal directions of the reference points; x-y for
    planar tasks), which for a 3-D task is the view that shows the motion.
    """
    linear = min(results[0].m, 3)
    reference = results[0].x_ref[:, :linear]
    origin = reference[0]
    _, spread, axes = np.linalg.svd(reference - origin, full_matrices=True)
    straight = spread.size < 2 or spread[1] <= 1e-9 * max(spread[0], 1e-300)
    if straight:
        direction = axes[0] if spread.size and spread[0] > 0 else np.eye(linear)[0]
        if (reference[-1] - origin) @ direction < 0:
            direction = -direction  # distances along the line grow from its start
        normal = np.array([-direction[1], direction[0]]) if linear == 2 else None
        ax.axhline(0.0, color="0.5", ls="--", lw=1.5, label="reference path")
        for result in results:
            offset = result.x[:, :linear] - origin
            along = offset @ direction
            if normal is not None:
                across = offset @ normal
            else:
                across = np.linalg.norm(offset - np.outer(along, direction), axis=1)
            color = "tab:red" if single else _color(result)
            label = "tip" if single else f"{result.resolver} tip"
            ax.plot(along, across * 1e3, color=color, lw=1.2, label=label)
            if len(result.t):
                ax.plot(along[0], across[0] * 1e3, "o", color="k", ms=4)
                ax.plot(along[-1], across[-1] * 1e3, "x", color=color, ms=7)
        ax.set_xlabel("distance along the reference line [m]")
        ax.set_ylabel("deviation across it [mm]" if normal is not None else "distance from it [mm]")
        ax.set_title(
            "tip deviation from the straight reference path"
            + (" (signed, + to its left)" if normal is not None else ""),
            fontsize=9,
            loc="left",
        )
    else:
        basis = np.eye(linear)[:2] if linear == 2 else axes[:2]
        names = ("x", "y") if linear == 2 else ("first", "second")
        projected = (reference - origin) @ basis.T
        ax.plot(projected[:, 0], projected[:, 1], color="0.5", ls="--", lw=1.5, label="reference path")
        for result in results:
            tip = (result.x[:, :linear] - origin) @ basis.T
            color = "tab:red" if single else _color(result)
            ax.plot(tip[:, 0], tip[:, 1], color=color, lw=1.2, label="tip" if single else f"{result.resolver} tip")
            if len(result.t):
                ax.plot(*tip[0], "o", color="k", ms=4)
                ax.plot(*tip[-1], "x", color=color, ms=7)
        ax.set_aspect("equal", adjustable="datalim")
        unit = "[m]" if linear == 2 else "direction of the movement's plane [m]"
        ax.set_xlabel(f"tip {names[0]} {unit}".replace("tip first", "tip, first"))
        ax.set_ylabel(f"tip {names[1]} {unit}".replace("tip second", "tip, second"))
        ax.set_title("tip path" if linear == 2 else "tip path in the plane of the movement", fontsize=9, loc="left")
    ax.plot([], [], "o", color="k", ms=4, label="start")
    ax.plot([], [], "x", color="0.3", ms=7, label="end of run")
    ax.grid(alpha=0.3)


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
