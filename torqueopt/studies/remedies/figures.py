"""The remedies study's figures: the long movement's torques of every remedy, and the (μ, K_D) trade-off."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .measures import BASELINES, SELF_MOTION_DAMPING, SWEPT_RESOLVER, _peak_ratio

if TYPE_CHECKING:
    from .study import RemediesStudy

__all__ = ["plot_long_torques", "plot_tradeoff"]


def plot_long_torques(study: RemediesStudy, path: Path) -> Path:
    """One panel per resolver (pinv, null-space, each remedy): every joint's τ/τ⁺ on the long movement."""
    from ...plots.canvas import new_figure, save_figure, symlog_scale

    names = (*BASELINES, *study.remedies)
    fig = new_figure(9.0, 1.0 + 1.9 * len(names))
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        result, report = study.run("long", name), study.report("long", name)
        limit = np.where(np.isfinite(result.torque_upper), result.torque_upper, np.nan)
        ratio = result.tau / limit
        for joint, joint_name in enumerate(result.joint_names):
            ax.plot(result.t, ratio[:, joint], lw=1.3, label=joint_name)
        for level in (1.0, -1.0):
            ax.axhline(level, color="k", ls="--", lw=0.9)
        peak = _peak_ratio(result)
        if peak > 1.5:
            symlog_scale(ax, 1.0, peak)
        else:
            ax.set_ylim(-1.6, 1.6)
        if report.unstable:
            ax.axvline(report.time, color="k", ls=":", lw=1.2)
        state = study.verdict("long", name)
        extra = (
            f", {result.infeasible_steps} infeasible steps (tip off the path by up to {result.max_tip_error * 1e3:.3g} mm)"
            if result.infeasible_steps
            else ""
        )
        ax.set_title(f"{name}: {state}, peak |τ|/limit {peak:.3g}{extra}", fontsize=10, loc="left")
        ax.set_ylabel("τ / τ⁺")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8, ncol=len(study.run("long", "pinv").joint_names))
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(
        f"Long movement ({study.paper.scenario.durations[-1]:g} s): each joint's torque over its limit\n"
        "dashed: ±limit; dotted: instability; logarithmic beyond ±1 where a run exceeds 1.5",
        fontsize=11,
    )
    return save_figure(fig, path)


def plot_tradeoff(study: RemediesStudy, path: Path) -> Path:
    """The sweep in two panels, one line per K_D, filled circles stable, crosses unstable, triangles neither (the
    long movement lost its path or stopped early).

    Left: the trade-off itself, the share of the short movement's cut given up
    (x, log; μ = 0 gives up nothing and sits at the left edge) against the long
    movement's peak |τ|/limit (y, log). Right: that peak against μ.
    """
    from ...plots.canvas import new_figure, save_figure

    fig = new_figure(12.0, 5.4)
    trade, by_weight = fig.subplots(1, 2, width_ratios=[3, 2])
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")
    given_up = [100 * (1 - p.short_kept) for p in study.sweep]
    floor = 0.5 * min([g for g in given_up if g > 0] or [1e-3])

    def shown(kept: float) -> float:
        return max(100 * (1 - kept), floor)

    positive = sorted({p.kinematic_weight for p in study.sweep if p.kinematic_weight > 0})
    for index, damping in enumerate(study.dampings):
        points = sorted((p for p in study.sweep if p.damping == damping), key=lambda p: p.kinematic_weight)
        color = colors[index % len(colors)]
        x = [shown(p.short_kept) for p in points]
        y = [p.long_peak_ratio for p in points]
        trade.plot(x, y, color=color, lw=1.2, label=f"K_D = {damping:g} 1/s")
        swept = [p for p in points if p.kinematic_weight > 0]
        by_weight.plot([p.kinematic_weight for p in swept], [p.long_peak_ratio for p in swept], color=color, lw=1.2,
                       label=f"K_D = {damping:g} 1/s")  # fmt: skip
        for p, xi, yi in zip(points, x, y):
            # Stable, unstable (the whiplash detector's), or neither: a run that lost its path or stopped early.
            marker = "o" if p.long_stable else ("x" if p.long_instability_time is not None else "v")
            style = {"marker": marker, "color": color, "ms": 6, "mfc": color if p.long_stable else "none"}
            trade.plot(xi, yi, **style)
            if p.kinematic_weight > 0:
                by_weight.plot(p.kinematic_weight, yi, **style)
    for mu in positive:
        points = [p for p in study.sweep if p.kinematic_weight == mu]
        top = max(points, key=lambda p: p.long_peak_ratio)
        if top.long_peak_ratio < 1.5:
            continue  # those near the limit line crowd each other; the right panel shows every μ
        trade.annotate(f"μ={mu:g}", (shown(top.short_kept), top.long_peak_ratio), textcoords="offset points",
                       xytext=(3, 5), fontsize=8, color="0.3")  # fmt: skip
    references = [("pinv", "s"), (study.sweep_reference, "D")]
    if SELF_MOTION_DAMPING in study.remedies:
        references.append((SELF_MOTION_DAMPING, "^"))
    if SWEPT_RESOLVER in study.remedies:
        references.append((SWEPT_RESOLVER, "*"))
    for name, marker in references:
        label = f"{name} (defaults)" if name == SWEPT_RESOLVER else name
        trade.plot(shown(study.cut_kept("short", name, study.sweep_torque_weight)), _peak_ratio(study.run("long", name)), marker=marker, ms=12,
                   color="k", mfc="gold" if marker == "*" else "none", ls="none", label=label)  # fmt: skip
    for ax in (trade, by_weight):
        ax.axhline(1.0, color="k", ls="--", lw=0.9, label="torque limit")
        ax.axhline(study.paper.limit_factor, color="tab:red", ls=":", lw=1.0,
                   label=f"unstable above {study.paper.limit_factor:g} × limit")  # fmt: skip
        ax.set_yscale("log")
        ax.set_ylabel("long movement (2 s): peak |τ|/limit")
        ax.grid(alpha=0.3, which="both")
    trade.set_xscale("log")
    trade.set_xlabel(
        f"short movement: share of {study.sweep_reference}'s torque cut given up [%] (μ = 0 drawn at {floor:.2g} %)"
    )
    trade.set_title("Torque saving against stability (o stable, x unstable, ▽ lost its path or stopped)", fontsize=10,
                    loc="left")  # fmt: skip
    trade.legend(fontsize=8, loc="upper right")
    by_weight.set_xscale("log")
    by_weight.set_xlabel("kinematic weight μ (relative to ‖SHZ‖_F)")
    by_weight.set_title("Long-movement peak against μ", fontsize=10, loc="left")
    fig.suptitle(
        f"{SWEPT_RESOLVER} (torque_weight={study.sweep_torque_weight}) on the paper's arm as μ and K_D vary",
        fontsize=11,
    )
    return save_figure(fig, path)
