r"""On the paths ``pinv`` handles: which resolvers are stable, within every limit, and save torque; across arms.

:func:`pinv_paths_summary` gives, from one atlas's table, each resolver's figures on the paths ``pinv``
handles, :math:`P` (its verdict ``stable`` and its peak :math:`|\tau|/\tau^+` at most 1), with the definitions
``torqueopt tune`` uses (:func:`handled_paths`, :func:`counts_on`): its whips with their rate's Wilson 95 %
interval (stable: the upper end at most :data:`WHIPLASH_BOUND`), its runs outside a torque, position or
velocity limit (within limits: none), and the median of ``torque_vs_pinv`` with its distribution-free 95 %
interval (saving torque: below 1). docs/discussion/atlas.md says what they mean.
:func:`summarise <torqueopt.atlas.report.summarise>` stores it in ``atlas.json`` under ``pinv_paths``.
"""

from __future__ import annotations

import math

import numpy as np

from .stats import wilson_interval

__all__ = [
    "BASELINE",
    "WHIPLASH_BOUND",
    "counts_on",
    "handled_paths",
    "median_interval",
    "median_text",
    "over_text",
    "pinv_paths_markdown",
    "pinv_paths_summary",
]

BASELINE = "pinv"
#: A resolver is stable on an arm when its whiplash rate on the paths pinv handles has a Wilson 95 % upper bound
#: at most this.
WHIPLASH_BOUND = 0.01


def handled_paths(table) -> list[int]:
    """The paths pinv handles: its verdict ``stable`` and its peak torque ratio at most 1 (``table``: an atlas's rows)."""
    pinv = table[table["resolver"] == BASELINE]
    return sorted(int(p) for p in pinv.loc[(pinv["verdict"] == "stable") & (pinv["peak_torque_ratio"] <= 1.0), "path"])


def counts_on(runs) -> dict:
    """One resolver's ``runs`` (its rows on the paths pinv handles) counted: ``whips``, ``whip_rate``, ``whip_low``,
    ``whip_high`` (Wilson 95 %), ``over_torque``, ``over_position``, ``over_velocity``, ``over_limits`` (runs
    outside any of them) and ``lost_path``."""
    count = len(runs)
    whips = int((runs["verdict"] == "whiplash").sum())
    whip_low, whip_high = wilson_interval(whips, count)
    # A NaN peak (no applied torque) is not "within": only a number at most 1 is.
    over_torque = ~(runs["peak_torque_ratio"] <= 1.0)
    over_position = runs["first_position_limit_violation"].notna()
    over_velocity = runs["first_velocity_limit_violation"].notna()
    return {
        "whips": whips,
        "whip_rate": whips / count if count else math.nan,
        "whip_low": whip_low,
        "whip_high": whip_high,
        "over_torque": int(over_torque.sum()),
        "over_position": int(over_position.sum()),
        "over_velocity": int(over_velocity.sum()),
        "over_limits": int((over_torque | over_position | over_velocity).sum()),
        "lost_path": int((runs["verdict"] == "lost path").sum()),
    }


def median_interval(values: np.ndarray) -> tuple[float, float, float]:
    """(median, low, high): the median and its distribution-free 95 % interval (order statistics)."""
    if not values.size:
        return math.nan, math.nan, math.nan
    median = float(np.median(values))
    if values.size < 6:  # fewer than 6 values cannot bracket a median at 95 %
        return median, math.nan, math.nan
    from scipy.stats import quantile_test

    interval = quantile_test(values, q=median, p=0.5).confidence_interval(confidence_level=0.95)
    return median, float(interval.low), float(interval.high)


def pinv_paths_summary(table) -> dict:
    """Each resolver's figures on the paths pinv handles (see the module docstring).

    Returns:
        ``{"paths": movements, "pinv_handles": |P|, "resolvers": {label: {...}}}``; per label: ``paths`` (how
        many of P it ran), :func:`counts_on`'s counts, ``stable``; ``over_rate``, ``over_low``, ``over_high``,
        ``within_limits``; ``median_torque_vs_pinv``, ``median_low``, ``median_high``, ``saves_torque``; and
        ``meets_bar`` (all three).
    """
    handled = handled_paths(table)
    out = {"paths": int(table["path"].nunique()), "pinv_handles": len(handled), "resolvers": {}}
    for label in dict.fromkeys(table["resolver"]):
        runs = table[table["resolver"] == label].set_index("path")
        on = runs.loc[runs.index.intersection(handled)]
        count = len(on)
        entry = {"paths": count, **counts_on(on)}
        over = entry["over_limits"]
        over_low, over_high = wilson_interval(over, count)
        ratios = on["torque_vs_pinv"].to_numpy(dtype=float)
        median, low, high = median_interval(ratios[np.isfinite(ratios)])
        entry.update(
            stable=bool(count and entry["whip_high"] <= WHIPLASH_BOUND),
            over_rate=over / count if count else math.nan,
            over_low=over_low,
            over_high=over_high,
            within_limits=bool(count and over == 0),
            median_torque_vs_pinv=median,
            median_low=low,
            median_high=high,
            saves_torque=bool(math.isfinite(median) and median < 1.0),
        )
        entry["meets_bar"] = entry["stable"] and entry["within_limits"] and entry["saves_torque"]
        out["resolvers"][label] = entry
    return out


def _percent(value: float) -> str:
    if not math.isfinite(value):
        return "–"
    text = f"{100 * value:.1f}"
    return text[:-2] if text.endswith(".0") else text


def over_text(entry: dict) -> str:
    """The share of the paths pinv handles on which a resolver leaves a limit, as the tables write it."""
    return f"{_percent(entry['over_rate'])} % [{_percent(entry['over_low'])}, {_percent(entry['over_high'])}]"


def median_text(entry: dict) -> str:
    """The median peak torque ratio against pinv and its 95 % interval, as the tables write them."""
    low, high = entry["median_low"], entry["median_high"]
    interval = f" [{low:.3g}, {high:.3g}]" if math.isfinite(low) and math.isfinite(high) else ""
    return f"{entry['median_torque_vs_pinv']:.3g}{interval}"


def pinv_paths_markdown(block: dict) -> list[str]:
    """atlas.md's table of the paths pinv handles: one row per resolver."""
    lines = [
        f"## On the {block['pinv_handles']} of {block['paths']} paths pinv handles",
        "",
        "| resolver | whiplash [95 % CI] | outside a limit [95 % CI] (torque / position / velocity) | median peak "
        "torque vs pinv [95 % CI] | lost path | stable, within limits, saving |",
        "|---|---|---|---|---|---|",
    ]
    for label, entry in block["resolvers"].items():
        marks = ", ".join("yes" if entry[key] else "no" for key in ("stable", "within_limits", "saves_torque"))
        whips = f"{_percent(entry['whip_rate'])} % [{_percent(entry['whip_low'])}, {_percent(entry['whip_high'])}]"
        lines.append(
            f"| {label} | {whips} | {over_text(entry)} ({entry['over_torque']} / {entry['over_position']} / "
            f"{entry['over_velocity']}) | {median_text(entry)} | {entry['lost_path']} | "
            f"{'**all three**' if entry['meets_bar'] else marks} |"
        )
    return lines
