"""Dexterity in figures: the panel of a run's dexterity measures and the velocity and acceleration ellipses at the tip."""

from __future__ import annotations

import numpy as np

from ..result import SimResult
from ..robot import Robot
from .panels import _mark_stops

__all__ = ["dexterity_ellipses", "draw_dexterity"]

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
    ax.set_ylim(0.0, 1.1 * highest)
    ax.set_title("dexterity, as a ratio to its start value", fontsize=9, loc="left")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("ratio to start", fontsize=8)
    # Beside the panel, not on it: on a run that loses dexterity the curves fill the panel (a circle's run).
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
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
    from ..dexterity import dexterity

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
