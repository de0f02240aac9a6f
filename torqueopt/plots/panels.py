"""Pieces drawn on the axes of several figures: colours, joint titles, limits, events, early stops, legends, the tip path.

The helpers are shared by the figure modules of this package and are not
part of its API; :data:`RESOLVER_COLORS` is.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InvalidInput
from ..result import SimResult

__all__ = ["RESOLVER_COLORS"]

#: One colour per resolver, the same in every figure.
RESOLVER_COLORS = {
    "pinv": "tab:blue",
    "inertia-pinv": "tab:orange",
    "null-space": "tab:red",
    "weighted-null-space": "tab:green",
    # the velocity-level methods of Section 1.1
    "velocity-pinv": "black",  # drawn beside pinv (tab:blue): tab:cyan was hard to tell from it
    "gradient-projection": "tab:purple",
    "task-priority": "tab:olive",
    "obstacle-avoidance": "tab:brown",
    "extended-jacobian": "tab:pink",
    "kinetic-energy-pinv": "tab:gray",
}
_JOINT_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")
_EVENT_COLORS = ("tab:purple", "0.25", "tab:olive")


#: The most characters a panel title's line holds at 10 pt on a 9 in wide figure before it is wrapped.
TITLE_CHARACTERS = 90


def _nonempty(results: Sequence[SimResult]) -> list[SimResult]:
    results = list(results)
    if not results:
        raise InvalidInput("no runs to plot: give at least one SimResult")
    return results


def _color(result: SimResult) -> str:
    return RESOLVER_COLORS.get(result.resolver, "tab:purple")


def _joint_title(result: SimResult, joint: int, peak_by_run=None) -> str:
    limit = result.torque_upper[joint]
    limit_text = f"limit ±{limit:g} {result.joint_unit(joint, 'torque')}" if np.isfinite(limit) else "no torque limit"
    text = f"{result.joint_names[joint]} ({limit_text})"
    if peak_by_run:
        # One line per few runs: a title of six runs' peaks ran past the figure's right edge.
        lines, line = [], text + ";  peak |τ|: "
        for index, (name, peak) in enumerate(peak_by_run):
            entry = f"{name} {peak:.3g}" + ("," if index < len(peak_by_run) - 1 else "")
            if len(line) + len(entry) > TITLE_CHARACTERS and not line.endswith(": "):
                lines.append(line.rstrip())
                line = ""
            line += entry + " "
        text = "\n".join([*lines, line.rstrip()])
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
    return "".join(f"\n{note}" for note in notes)  # a line each: two ran off a 7-joint arm's figure


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
    # The reduced SVD: its right factor is all that is read; the full one builds an N×N left factor.
    _, spread, axes = np.linalg.svd(reference - origin, full_matrices=False)
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
            _draw_track(ax, along, across * 1e3, result, single)
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
            _draw_track(ax, tip[:, 0], tip[:, 1], result, single)
        ax.set_aspect("equal", adjustable="datalim")
        unit = "[m]" if linear == 2 else "direction of the movement's plane [m]"
        ax.set_xlabel(f"tip {names[0]} {unit}".replace("tip first", "tip, first"))
        ax.set_ylabel(f"tip {names[1]} {unit}".replace("tip second", "tip, second"))
        ax.set_title("tip path" if linear == 2 else "tip path in the plane of the movement", fontsize=9, loc="left")
    ax.plot([], [], "o", color="k", ms=4, label="start")
    ax.plot([], [], "x", color="0.3", ms=7, label="end of run")
    ax.grid(alpha=0.3)


def _draw_track(ax, horizontal, vertical, result: SimResult, single: bool) -> None:
    """One run's tip track, its start (a black dot) and its end (a cross in the run's colour)."""
    color = "tab:red" if single else _color(result)
    ax.plot(horizontal, vertical, color=color, lw=1.2, label="tip" if single else f"{result.resolver} tip")
    if len(result.t):
        ax.plot(horizontal[0], vertical[0], "o", color="k", ms=4)
        ax.plot(horizontal[-1], vertical[-1], "x", color=color, ms=7)


def _joint_lines(ax, result: SimResult, values, lw: float, label: str = "{name}") -> None:
    """One line per joint of ``values`` (rows × joints) against the run's time, in the joint's colour."""
    for joint, name in enumerate(result.joint_names):
        color = _JOINT_COLORS[joint % len(_JOINT_COLORS)]
        ax.plot(result.t, values[:, joint], color=color, lw=lw, label=label.format(name=name))
