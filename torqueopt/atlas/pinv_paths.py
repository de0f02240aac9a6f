r"""On the paths ``pinv`` handles: which resolvers are stable, within every limit, and save torque; across arms.

The question a user with a seven-joint arm asks of the atlas is "which
resolver, with which settings, is safe on my arm, and what does it save?".
:func:`pinv_paths_summary` answers it from one atlas's table, with the same
definitions as ``torqueopt tune``:

* the paths ``pinv`` handles, :math:`P`: those where ``pinv``'s verdict is
  ``stable`` (within the 2x-limit rule, the joints' position and velocity
  limits, on its path to 1 mm, completed) and its peak :math:`|\tau|/\tau^+`
  is at most 1;
* **stable**: the resolver's ``whiplash`` verdicts on :math:`P`, with the
  Wilson 95 % interval; it passes when the upper end is at most 1 %
  (:data:`WHIPLASH_BOUND`; with no whip at all that needs :math:`|P| \ge 381`);
* **within all limits**: the paths of :math:`P` on which its peak
  :math:`|\tau|/\tau^+` exceeds 1 or it passes a position or velocity limit
  (``first_position_limit_violation``, ``first_velocity_limit_violation``),
  with the Wilson interval; it passes when there is none (as pinv, which is
  within them on every path of :math:`P` by definition);
* **saving torque**: the median over :math:`P` of ``torque_vs_pinv`` (its peak
  :math:`|\tau|/\tau^+` over pinv's on the same path), with the
  distribution-free 95 % interval of a median (order statistics,
  ``scipy.stats.quantile_test``); it passes when the median is below 1.

The runs it loses the path on (``lost path``: more than 1 mm off, how the
bounded resolvers give way) are counted beside, but decide nothing: the
issue's bar is stability, the limits and the saving.

:func:`summarise <torqueopt.atlas.report.summarise>` stores the result in
``atlas.json`` under ``pinv_paths``; :func:`torqueopt.atlas.arms.cross_arm_table`
turns the ``atlas.json`` of several arms into one Markdown table.
"""

from __future__ import annotations

import math

import numpy as np

from .stats import wilson_interval

__all__ = [
    "BASELINE",
    "WHIPLASH_BOUND",
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
        ``{"paths": movements, "pinv_handles": |P|, "resolvers": {label: {...}}}``; per label:
        ``whips``, ``whip_rate``, ``whip_low``, ``whip_high``, ``stable``; ``over_limits`` (with
        ``over_torque``, ``over_position``, ``over_velocity``), ``over_rate``, ``over_low``, ``over_high``,
        ``within_limits``; ``median_torque_vs_pinv``, ``median_low``, ``median_high``, ``saves_torque``;
        ``lost_path``; and ``meets_bar`` (all three).
    """
    pinv = table[table["resolver"] == BASELINE].set_index("path")
    handled = pinv.index[(pinv["verdict"] == "stable") & (pinv["peak_torque_ratio"] <= 1.0)]
    out = {"paths": int(table["path"].nunique()), "pinv_handles": len(handled), "resolvers": {}}
    for label in dict.fromkeys(table["resolver"]):
        runs = table[table["resolver"] == label].set_index("path")
        on = runs.loc[runs.index.intersection(handled)]
        count = len(on)
        whips = int((on["verdict"] == "whiplash").sum())
        whip_low, whip_high = wilson_interval(whips, count)
        # A NaN peak (no applied torque) is not "within": only a number at most 1 is.
        over_torque = ~(on["peak_torque_ratio"] <= 1.0)
        over_position = on["first_position_limit_violation"].notna()
        over_velocity = on["first_velocity_limit_violation"].notna()
        over = int((over_torque | over_position | over_velocity).sum())
        over_low, over_high = wilson_interval(over, count)
        ratios = on["torque_vs_pinv"].to_numpy(dtype=float)
        ratios = ratios[np.isfinite(ratios)]
        median, low, high = median_interval(ratios)
        entry = {
            "paths": count,
            "whips": whips,
            "whip_rate": whips / count if count else math.nan,
            "whip_low": whip_low,
            "whip_high": whip_high,
            "stable": bool(count and whip_high <= WHIPLASH_BOUND),
            "over_limits": over,
            "over_torque": int(over_torque.sum()),
            "over_position": int(over_position.sum()),
            "over_velocity": int(over_velocity.sum()),
            "over_rate": over / count if count else math.nan,
            "over_low": over_low,
            "over_high": over_high,
            "within_limits": bool(count and over == 0),
            "median_torque_vs_pinv": median,
            "median_low": low,
            "median_high": high,
            "saves_torque": bool(math.isfinite(median) and median < 1.0),
            "lost_path": int((on["verdict"] == "lost path").sum()),
        }
        entry["meets_bar"] = entry["stable"] and entry["within_limits"] and entry["saves_torque"]
        out["resolvers"][label] = entry
    return out


def _percent(value: float) -> str:
    if not math.isfinite(value):
        return "–"
    text = f"{100 * value:.1f}"
    return text[:-2] if text.endswith(".0") else text


def _whips(entry: dict) -> str:
    return f"{_percent(entry['whip_rate'])} % [{_percent(entry['whip_low'])}, {_percent(entry['whip_high'])}]"


def over_text(entry: dict) -> str:
    """The share of the paths pinv handles on which a resolver leaves a limit, as the tables write it."""
    return f"{_percent(entry['over_rate'])} % [{_percent(entry['over_low'])}, {_percent(entry['over_high'])}]"


def median_text(entry: dict) -> str:
    """The median peak torque ratio against pinv and its 95 % interval, as the tables write them."""
    low, high = entry["median_low"], entry["median_high"]
    interval = f" [{low:.3g}, {high:.3g}]" if math.isfinite(low) and math.isfinite(high) else ""
    return f"{entry['median_torque_vs_pinv']:.3g}{interval}"


def pinv_paths_markdown(block: dict) -> list[str]:
    """The lines of atlas.md's section on the paths pinv handles: one row per resolver."""
    lines = [
        "## On the paths pinv handles",
        "",
        f"pinv handles {block['pinv_handles']} of {block['paths']} movements (its verdict stable and its peak "
        "|τ|/τ⁺ at most 1). On those: a resolver is stable when its whiplash rate's 95 % upper bound is at most "
        f"{WHIPLASH_BOUND:.0%}, within all limits when no run passes a torque, position or velocity limit, and "
        "saves torque when its median peak torque ratio against pinv is below 1 (95 % interval of the median). "
        "Lost path (more than 1 mm off) is counted, not judged.",
        "",
        "| resolver | whiplash [95 % CI] | outside a limit [95 % CI] (torque / position / velocity) | median peak "
        "torque vs pinv [95 % CI] | lost path | stable, within limits, saving |",
        "|---|---|---|---|---|---|",
    ]
    for label, entry in block["resolvers"].items():
        marks = "".join("yes " if entry[key] else "no " for key in ("stable", "within_limits", "saves_torque"))
        lines.append(
            f"| {label} | {_whips(entry)} | {over_text(entry)} ({entry['over_torque']} / {entry['over_position']} / "
            f"{entry['over_velocity']}) | {median_text(entry)} | {entry['lost_path']} | "
            f"{'**all three**' if entry['meets_bar'] else marks.strip().replace(' ', ', ')} |"
        )
    return lines
