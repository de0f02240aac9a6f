r"""The bar a local resolver with a stability guarantee is held to, measured on an atlas's rows.

``energy-bounded-torque`` claims a bounded self-motion. On a population of
movements it is asked for four things against ``pinv`` (the baseline, run
beside it on the same paths); :func:`guarantee_summary` measures each from
the rows:

* **no whip**: its ``whiplash`` verdicts, with the Wilson 95 % interval,
  whose upper end must be below :data:`WHIP_BOUND` (0.1 %; with no whip at
  all that needs :func:`least_paths` = 3,838 movements);
* **within the torque limits wherever pinv is**: on the paths where
  ``pinv``'s peak :math:`|\tau|/\tau^+` is at most 1, its own must be too
  (counted on those paths, and on the paths ``pinv`` *handles*, stable as
  well: :func:`torqueopt.atlas.pinv_paths.pinv_paths_summary`);
* **saving torque**: the median of ``torque_vs_pinv`` (its peak
  :math:`|\tau|/\tau^+` over pinv's on the same path) at or below
  :data:`TORQUE_BOUND` (0.95), with the distribution-free 95 % interval of
  the median; reported on every path, per duration and on the paths pinv
  handles, where pinv is within its limits and the ratio does not profit
  from pinv going over them;
* and, counted beside (they decide nothing but say what the resolver gave
  up): the runs that lost their path (verdict ``lost path``: the tip more
  than 1 mm off the line, how a bounded resolver gives way), on every path
  and on those pinv handles; the runs with infeasible steps (the task
  acceleration scaled down); and the runs whose largest self-motion energy
  ``peak_self_motion_energy`` went above the resolver's own bound E_max
  (its option ``energy_limit``), by more than 0.1 % and by more than 1 %.

:func:`guarantee_markdown` writes the measured figures as the page's
tables; ``python -m torqueopt.atlas.guarantee FOLDER [RESOLVER]`` prints
them for the atlas in FOLDER (its ``results.parquet`` and
``atlas-config.json``, or ``atlas.json``) and writes ``guarantee.json``
beside them.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from .pinv_paths import median_interval
from .stats import proportion

__all__ = ["TORQUE_BOUND", "WHIP_BOUND", "guarantee_markdown", "guarantee_summary", "least_paths"]

BASELINE = "pinv"
#: The whiplash rate's Wilson 95 % upper bound must be below this.
WHIP_BOUND = 0.001
#: The median peak torque ratio against pinv must be at or below this.
TORQUE_BOUND = 0.95


def least_paths(bound: float = WHIP_BOUND) -> int:
    """The fewest runs without a whip whose Wilson 95 % upper bound is below ``bound``: z²(1 − b)/b, rounded up."""
    z = 1.959963984540054
    return math.floor(z * z * (1.0 - bound) / bound) + 1


def _median(values) -> dict:
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    median, low, high = median_interval(values)
    return {"median": median, "low": low, "high": high, "runs": int(values.size)}


def _energy_limit(config: dict, resolver: str) -> float:
    for item in config.get("resolvers", []):
        if item.get("label", item.get("name")) == resolver:
            return float(item.get("options", {}).get("energy_limit", math.nan))
    return math.nan


def _figures(rows, pinv, energy_limit: float) -> dict:
    """The measured figures of ``rows`` (one resolver's, indexed by path), against ``pinv`` on the same paths."""
    pinv = pinv.loc[rows.index]
    pinv_within = (pinv["peak_torque_ratio"] <= 1.0).to_numpy()
    handled = pinv_within & (pinv["verdict"] == "stable").to_numpy()
    within = (rows["peak_torque_ratio"] <= 1.0).to_numpy()
    lost = (rows["verdict"] == "lost path").to_numpy()
    infeasible = (rows["infeasible_steps"] > 0).to_numpy()
    energy = rows["peak_self_motion_energy"].to_numpy(float)
    ratios = rows["torque_vs_pinv"].to_numpy(float)
    return {
        "runs": len(rows),
        "whiplash": proportion(int((rows["verdict"] == "whiplash").sum()), len(rows)).as_dict(),
        "pinv_whiplash": int((pinv["verdict"] == "whiplash").sum()),
        "verdicts": {str(k): int(v) for k, v in rows["verdict"].value_counts().items()},
        "pinv_within_torque_limits": int(pinv_within.sum()),
        "within_torque_limits_where_pinv_is": int((within & pinv_within).sum()),
        "largest_peak_where_pinv_within": float(np.nanmax(rows["peak_torque_ratio"].to_numpy(float)[pinv_within]))
        if pinv_within.any()
        else math.nan,
        "within_torque_limits": int(within.sum()),
        "pinv_handles": int(handled.sum()),
        "within_torque_limits_where_pinv_handles": int((within & handled).sum()),
        "torque_vs_pinv": _median(ratios),
        "torque_vs_pinv_where_pinv_handles": _median(ratios[handled]),
        "torque_vs_pinv_where_pinv_over": _median(ratios[~pinv_within]),
        "lost_path": int(lost.sum()),
        "lost_path_where_pinv_handles": int((lost & handled).sum()),
        "pinv_lost_path": int((pinv["verdict"] == "lost path").sum()),
        "kept_path": int((rows["max_tip_error"] <= 1e-3).sum()),
        "infeasible_runs": int(infeasible.sum()),
        "infeasible_steps": int(rows["infeasible_steps"].sum()),
        "steps": int(rows["steps"].sum()),
        "lost_path_with_infeasible_steps": int((lost & infeasible).sum()),
        "energy_limit": energy_limit,
        "above_energy_limit": int((energy > energy_limit * (1.0 + 1e-3)).sum()),
        "above_energy_limit_1pc": int((energy > energy_limit * 1.01).sum()),
        "above_energy_limit_with_infeasible_steps": int(((energy > energy_limit * (1.0 + 1e-3)) & infeasible).sum()),
        "largest_energy": float(np.nanmax(energy)) if np.isfinite(energy).any() else math.nan,
        "median_largest_tip_error": float(np.nanmedian(rows["max_tip_error"].to_numpy(float))),
    }


def guarantee_summary(table, config: dict, resolver: str = "energy-bounded-torque") -> dict:
    """The bar's figures for ``resolver`` (module docstring), on every path and per duration.

    Args:
        table: an atlas's rows (``results.parquet``) with ``resolver`` and ``pinv`` on the same paths.
        config: its ``atlas-config.json`` (the resolver's ``energy_limit``).

    Returns:
        ``{"resolver", "all": figures, "durations": {T: figures}, "bar": {...}}``; ``bar`` says for each of the
        three demands the measured value and whether it is met.
    """
    pinv = table[table["resolver"] == BASELINE].set_index("path")
    rows = table[table["resolver"] == resolver].set_index("path")
    if not len(rows) or not len(pinv):
        raise ValueError(f"the table needs rows of both '{resolver}' and '{BASELINE}'")
    limit = _energy_limit(config, resolver)
    every = _figures(rows, pinv, limit)
    durations = {
        f"{duration:g}": _figures(rows[rows["duration"] == duration], pinv, limit)
        for duration in sorted(set(rows["duration"]))
    }
    bar = {
        "no_whip": every["whiplash"]["successes"] == 0 and every["whiplash"]["high"] < WHIP_BOUND,
        "within_torque_limits_where_pinv_is": every["within_torque_limits_where_pinv_is"]
        == every["pinv_within_torque_limits"],
        "saves_torque": every["torque_vs_pinv"]["median"] <= TORQUE_BOUND,
    }
    bar["met"] = all(bar.values())
    return {
        "resolver": resolver,
        "whip_bound": WHIP_BOUND,
        "torque_bound": TORQUE_BOUND,
        "least_paths": least_paths(),
        "all": every,
        "durations": durations,
        "bar": bar,
    }


def _share(item: dict) -> str:
    return f"{item['successes']:,} of {item['trials']:,}, {100 * item['fraction']:.2f} % [{100 * item['low']:.3f}, {100 * item['high']:.3f}]"


def _ratio(item: dict) -> str:
    if not math.isfinite(item["median"]):
        return "-"
    if not math.isfinite(item["low"]):
        return f"{item['median']:.3f}"
    return f"{item['median']:.3f} [{item['low']:.3f}, {item['high']:.3f}]"


def guarantee_markdown(summary: dict) -> list[str]:
    """Two tables: the bar against the measured figures, and the figures per duration."""
    every, bar = summary["all"], summary["bar"]

    def met(flag: bool) -> str:
        return "**met**" if flag else "**missed**"

    lines = [
        "| the bar | measured | |",
        "| --- | --- | --- |",
        (
            f"| whiplash on none, 95 % Wilson upper bound under {100 * summary['whip_bound']:g} % | whiplash "
            f"{_share(every['whiplash'])} (`pinv`: {every['pinv_whiplash']:,}) | {met(bar['no_whip'])} |"
        ),
        (
            f"| within the torque limits wherever `pinv` is | {every['within_torque_limits_where_pinv_is']:,} of "
            f"{every['pinv_within_torque_limits']:,} (largest peak \\|τ\\|/limit there "
            f"{every['largest_peak_where_pinv_within']:.4f}); on the {every['pinv_handles']:,} paths `pinv` handles "
            f"{every['within_torque_limits_where_pinv_handles']:,} | {met(bar['within_torque_limits_where_pinv_is'])} |"
        ),
        (
            f"| median peak torque ratio against `pinv` at or below {summary['torque_bound']:g} | "
            f"{_ratio(every['torque_vs_pinv'])} on all {every['torque_vs_pinv']['runs']:,}; "
            f"{_ratio(every['torque_vs_pinv_where_pinv_handles'])} on the paths `pinv` handles; "
            f"{_ratio(every['torque_vs_pinv_where_pinv_over'])} where `pinv` is over a limit | "
            f"{met(bar['saves_torque'])} |"
        ),
        (
            f"| (counted) lost path: tip more than 1 mm off the line | {every['lost_path']:,} of {every['runs']:,} "
            f"({every['lost_path_where_pinv_handles']:,} of the {every['pinv_handles']:,} paths `pinv` handles; "
            f"`pinv` {every['pinv_lost_path']:,}); {every['lost_path_with_infeasible_steps']:,} of them with "
            f"infeasible steps | |"
        ),
        (
            f"| (counted) E_N above E_max = {every['energy_limit']:g} J | {every['above_energy_limit']:,} runs by more "
            f"than 0.1 %, {every['above_energy_limit_1pc']:,} by more than 1 % (largest {every['largest_energy']:.3g} "
            f"J); {every['above_energy_limit_with_infeasible_steps']:,} of the first with infeasible steps | |"
        ),
        (
            f"| (counted) infeasible steps (task acceleration scaled down) | on {every['infeasible_runs']:,} runs, "
            f"{every['infeasible_steps']:,} of {every['steps']:,} steps "
            f"({100 * every['infeasible_steps'] / max(every['steps'], 1):.1f} %) | |"
        ),
        "",
        "| T | runs | whiplash [95 %] | within the torque limits where `pinv` is | median peak vs `pinv` "
        "(all; where `pinv` handles) | lost path (all; where `pinv` handles) | E_N > E_max (0.1 %) | runs with "
        "infeasible steps |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for duration, item in summary["durations"].items():
        whip = item["whiplash"]
        lines.append(
            f"| {duration} s | {item['runs']:,} | {whip['successes']} [{100 * whip['low']:.2f}, "
            f"{100 * whip['high']:.2f} %] | {item['within_torque_limits_where_pinv_is']:,} of "
            f"{item['pinv_within_torque_limits']:,} | {item['torque_vs_pinv']['median']:.3f}; "
            f"{item['torque_vs_pinv_where_pinv_handles']['median']:.3f} | {item['lost_path']:,}; "
            f"{item['lost_path_where_pinv_handles']:,} of {item['pinv_handles']:,} | {item['above_energy_limit']:,} | "
            f"{item['infeasible_runs']:,} |"
        )
    return lines


def main(argv=None) -> int:
    """``python -m torqueopt.atlas.guarantee FOLDER [RESOLVER]``: print the tables, write FOLDER/guarantee.json."""
    import pandas

    from ..io import json_text

    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) not in (1, 2):
        print("usage: python -m torqueopt.atlas.guarantee FOLDER [RESOLVER]", file=sys.stderr)
        return 2
    folder = Path(args[0])
    table = pandas.read_parquet(folder / "results.parquet")
    if (folder / "atlas-config.json").is_file():
        config = json.loads((folder / "atlas-config.json").read_text())
    else:  # a docs folder keeps atlas.json, which holds the config
        config = json.loads((folder / "atlas.json").read_text())["config"]
    summary = guarantee_summary(table, config, *args[1:])
    text = json_text(summary)
    (folder / "guarantee.json").write_text(text + "\n")
    print("\n".join(guarantee_markdown(summary)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
