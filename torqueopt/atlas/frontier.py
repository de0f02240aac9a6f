r"""The frontier: the global optimum against every local method, and how well the stability margin predicts a whip.

:func:`global_summary` (``atlas.json``'s ``global``) compares, path by path,
each local method with the ``global-optimum`` rows of an atlas run with
``--global`` (:mod:`torqueopt.atlas.global_optimum`):

* a run is **problem-free** when its verdict is ``stable`` (no whip, not too
  demanding, on its path within 1 mm, inside the joint limits, completed) and
  its peak torque stays within the limits (``peak_torque_ratio`` ≤ 1);
* ``cost_vs_global`` and ``peak_vs_global`` are a run's ∫‖τ‖² dt and peak
  torque ratio over the global optimum's on the same path, on the paths where
  the optimiser converged (the others are counted, not compared);
* the **most successful local method** is the one problem-free on the most
  paths (ties: the lower median ``cost_vs_global``); a local method is
  **completely successful** when it is problem-free on every path on which
  the global optimum is.

:func:`margin_summary` (``atlas.json``'s ``margin``) scores the stability
margin as a predictor of the whiplash verdict: the score of a run is its
``peak_stability_margin`` (the largest margin before the instability, or over
the run), the label whether it whips; runs of every torque resolver are
pooled. The population is split by path number: the **even** paths choose
the threshold (the one that maximises TPR − FPR, Youden's J), the **odd**
paths are held out and give the ROC curve, its area (AUC, the probability
that a whipping run scores above a non-whipping one, ties counted half) and
the true and false positive rates at that threshold and at σ > 0. The median
warning time is that of the held-out whips on which the margin turned
positive before the instability.

:func:`broader_answer` writes the README's answer to the paper's broader
question from ``atlas.json`` alone; the test suite checks that the README's
paragraph is what it writes from the committed ``docs/atlas/global.json``.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from .global_optimum import GLOBAL_RESOLVER
from .stats import proportion

__all__ = ["auc", "broader_answer", "global_summary", "margin_summary", "problem_free", "roc_curve"]

#: The README's link to the full account.
ACCOUNT_PAGE = "docs/discussion/global-atlas.md"


def problem_free(rows) -> np.ndarray:
    """Per row: verdict ``stable`` and peak torque within the limits (module docstring)."""
    peak = rows["peak_torque_ratio"].to_numpy(float)
    return (rows["verdict"].to_numpy() == "stable") & (np.nan_to_num(peak, nan=np.inf) <= 1.0)


def _median(values) -> float:
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else math.nan


def global_summary(table) -> dict | None:
    """The global optimum and every local method's distance to it (module docstring); None without global rows."""
    global_rows = table[table["resolver"] == GLOBAL_RESOLVER].set_index("path")
    if not len(global_rows):
        return None
    paths = len(global_rows)
    statuses = global_rows["optimizer_status"].value_counts()
    converged = global_rows["optimizer_status"] == "converged"
    global_free = problem_free(global_rows)
    free_paths = set(global_rows.index[global_free])
    converged_paths = set(global_rows.index[converged.to_numpy()])
    verdicts = global_rows["verdict"].value_counts()
    summary = {
        "paths": paths,
        "optimizer_status": {str(k): int(v) for k, v in statuses.items()},
        "converged": int(converged.sum()),
        "not_converged": int(paths - converged.sum()),
        "problem_free": proportion(int(global_free.sum()), paths).as_dict(),
        "problem_free_converged": proportion(int((global_free & converged.to_numpy()).sum()), paths).as_dict(),
        "stable": proportion(int((global_rows["verdict"] == "stable").sum()), paths).as_dict(),
        "within_limits": proportion(int((global_rows["peak_torque_ratio"] <= 1.0).sum()), paths).as_dict(),
        "verdicts": {str(k): int(v) for k, v in verdicts.items()},
        "median_iterations": _median(global_rows["optimizer_iterations"]),
        "max_iterations": float(global_rows["optimizer_iterations"].max()),
        "max_replay_tip_error": float(global_rows["replay_tip_error"].max()),
        "median_peak_torque_ratio": _median(global_rows["peak_torque_ratio"]),
        "median_torque_vs_pinv": _median(global_rows["torque_vs_pinv"]),
    }
    local = {}
    for resolver in dict.fromkeys(table["resolver"]):
        if resolver == GLOBAL_RESOLVER:
            continue
        rows = table[table["resolver"] == resolver].set_index("path")
        free = problem_free(rows)
        on_converged = rows.index.isin(list(converged_paths))
        failed_where_global_free = int((~free & rows.index.isin(list(free_paths))).sum())
        local[resolver] = {
            "runs": len(rows),
            "problem_free": proportion(int(free.sum()), len(rows)).as_dict(),
            "whiplash": proportion(int((rows["verdict"] == "whiplash").sum()), len(rows)).as_dict(),
            "fails_where_global_is_problem_free": failed_where_global_free,
            "median_cost_vs_global": _median(rows["cost_vs_global"][on_converged]),
            "median_peak_vs_global": _median(rows["peak_vs_global"][on_converged]),
            "median_cost_vs_global_problem_free": _median(rows["cost_vs_global"][on_converged & free]),
            "cheaper_than_global": int((rows["cost_vs_global"][on_converged] < 1.0 - 1e-6).sum()),
            # The global optimum's cost over this method's, path by path (converged paths).
            "median_global_cost_share": _median(1.0 / rows["cost_vs_global"][on_converged].to_numpy(float)),
        }
    summary["local"] = local
    if local:
        best = min(
            local,
            key=lambda name: (-local[name]["problem_free"]["successes"], local[name]["median_cost_vs_global"]),
        )
        cheapest = min(local, key=lambda name: local[name]["median_cost_vs_global"])
        summary["most_successful_local"] = best
        summary["cheapest_local"] = cheapest
        summary["completely_successful"] = sorted(
            name for name, item in local.items() if item["fails_where_global_is_problem_free"] == 0
        )
        if "pinv" in local:
            summary["median_global_cost_vs_pinv"] = local["pinv"]["median_global_cost_share"]
        summary["median_global_cost_vs_most_successful"] = local[best]["median_global_cost_share"]
        summary["median_global_cost_vs_cheapest"] = local[cheapest]["median_global_cost_share"]
    return summary


def roc_curve(scores, labels) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(false positive rates, true positive rates, thresholds): "whip predicted" when score ≥ threshold, thresholds
    from +inf down through every distinct score."""
    scores, labels = np.asarray(scores, float), np.asarray(labels, bool)
    thresholds = np.r_[np.inf, np.unique(scores)[::-1]]
    positives, negatives = max(int(labels.sum()), 1), max(int((~labels).sum()), 1)
    tpr = np.array([np.count_nonzero(labels & (scores >= t)) for t in thresholds]) / positives
    fpr = np.array([np.count_nonzero(~labels & (scores >= t)) for t in thresholds]) / negatives
    return fpr, tpr, thresholds


def auc(scores, labels) -> float:
    """Area under the ROC curve, by the trapezoid rule over :func:`roc_curve` (NaN without both classes)."""
    labels = np.asarray(labels, bool)
    if labels.all() or not labels.any():
        return math.nan
    fpr, tpr, _ = roc_curve(scores, labels)
    return float(np.trapezoid(tpr, fpr))


def _rates(scores, labels, threshold) -> dict:
    predicted = scores >= threshold
    return {
        "threshold": float(threshold),
        "true_positive_rate": proportion(int((predicted & labels).sum()), int(labels.sum())).as_dict(),
        "false_positive_rate": proportion(int((predicted & ~labels).sum()), int((~labels).sum())).as_dict(),
    }


def margin_summary(table) -> dict | None:
    """How well ``peak_stability_margin`` predicts the whiplash verdict (module docstring); None without margins."""
    if "peak_stability_margin" not in table.columns:
        return None
    rows = table[np.isfinite(table["peak_stability_margin"].to_numpy(float))]
    if not len(rows):
        return None
    scores = rows["peak_stability_margin"].to_numpy(float)
    labels = (rows["verdict"] == "whiplash").to_numpy()
    held_out = (rows["path"].to_numpy() % 2) == 1
    train_scores, train_labels = scores[~held_out], labels[~held_out]
    threshold = 0.0
    if train_labels.any() and not train_labels.all():
        fpr, tpr, thresholds = roc_curve(train_scores, train_labels)
        threshold = float(thresholds[1:][np.argmax((tpr - fpr)[1:])])
    test_scores, test_labels = scores[held_out], labels[held_out]
    warnings = rows["margin_warning_time"].to_numpy(float)[held_out & labels]
    per_resolver = {}
    for resolver in dict.fromkeys(rows["resolver"]):
        chosen = (rows["resolver"] == resolver).to_numpy() & held_out
        per_resolver[resolver] = {
            "runs": int(chosen.sum()),
            "whips": int(labels[chosen].sum()),
            "auc": auc(scores[chosen], labels[chosen]),
        }
    fpr, tpr, _ = roc_curve(test_scores, test_labels)
    return {
        "held_out": "odd path numbers (the even ones chose the threshold)",
        "runs": len(rows),
        "held_out_runs": int(held_out.sum()),
        "held_out_whips": int(test_labels.sum()),
        "auc": auc(test_scores, test_labels),
        "train_auc": auc(train_scores, train_labels),
        "at_threshold": _rates(test_scores, test_labels, threshold),
        "at_zero": _rates(test_scores, test_labels, 0.0),
        "warned_whips": int(np.isfinite(warnings).sum()),
        "median_warning_time": _median(warnings),
        "median_warning_fraction": _median(
            (rows["margin_warning_time"] / rows["instability_time"]).to_numpy(float)[held_out & labels]
        ),
        "per_resolver": per_resolver,
        # The held-out curve at most 201 points (every distinct score would be thousands): enough to draw it.
        "roc": {"fpr": _thin(fpr).tolist(), "tpr": _thin(tpr).tolist()},
    }


def _thin(values: np.ndarray, count: int = 201) -> np.ndarray:
    if len(values) <= count:
        return values
    return values[np.unique(np.linspace(0, len(values) - 1, count).round().astype(int))]


def _share(item: dict) -> str:
    return f"{item['fraction']:.1%} [{item['low']:.1%}, {item['high']:.1%}]"


def _percent(item: dict) -> str:
    """A share as the README writes it: ``40 % [28, 54]`` (Wilson 95 %)."""
    return f"{item['fraction']:.0%} [{100 * item['low']:.0f}, {100 * item['high']:.0f}]".replace("%", " %")


def broader_answer(summary: dict, *, link: bool = True) -> str:
    """The README's answer to "can any local algorithm be completely successful?", written from ``atlas.json``.

    A local method is completely successful when it is problem-free (stable and within the torque limits) on
    every path on which the global optimum is; the paragraph says which, or that none is, and the costs.
    """
    frontier = summary["global"]
    config = summary["config"]
    durations = ", ".join(f"{d:g}" for d in summary["durations"])
    best = frontier["most_successful_local"]
    best_item = frontier["local"][best]
    winners = frontier["completely_successful"]
    where = (
        f"{frontier['paths']:,} random {durations} s movements of {config['robot_name']} (`torqueopt atlas --global`)"
    )
    if winners:
        names = ", ".join(f"`{name}`" for name in winners)
        answer = (
            f"Yes, on {where}: {names} {'is' if len(winners) == 1 else 'are'} problem-free (stable, within the "
            f"torque limits) on every path on which the whole-movement optimum is."
        )
    else:
        count = len(frontier["local"])
        answer = (
            f"Not on {where}: each of the {count} local methods has a problem (a whip, a torque over its limit, a "
            f"lost path) on some path where the whole-movement optimum has none."
        )
    answer += (
        f" The most successful, `{best}`, is problem-free on {_percent(best_item['problem_free'])} of the paths, the "
        f"optimum on {_percent(frontier['problem_free'])} (stable on {_percent(frontier['stable'])}: its criterion "
        f"has no torque limit). The optimum's median ∫‖τ‖² dt is {frontier['median_global_cost_vs_pinv']:.2f} of "
        f"`pinv`'s"
    )
    if best != "pinv":
        answer += f" and {frontier['median_global_cost_vs_most_successful']:.2f} of `{best}`'s"
    answer += f"; it converged on {frontier['converged']:,} paths"
    answer += f" ({frontier['not_converged']:,} did not, counted as such)." if frontier["not_converged"] else "."
    text = f"- **Can any local algorithm be completely successful?** {answer}"
    if link:  # the README's link to the full account (a report elsewhere has no such page beside it)
        text += f" ([The global optimum on every path]({ACCOUNT_PAGE}))"
    return textwrap.fill(text, width=78, subsequent_indent="  ", break_long_words=False, break_on_hyphens=False)


def _ratio(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.3g}"


def frontier_markdown(summary: dict) -> list[str]:
    """The report's section on the global optimum and every local method's distance to it."""
    frontier = summary["global"]
    statuses = ", ".join(f"{status} {count}" for status, count in frontier["optimizer_status"].items())
    verdicts = ", ".join(f"{verdict} {count}" for verdict, count in frontier["verdicts"].items())
    lines = [
        "## The global optimum against the local methods",
        "",
        (
            f"`torqueopt.optimize` on each of the {frontier['paths']:,} movements (same start, line and duration; "
            "∫‖τ‖² dt, end free, no torque bounds, warm start pinv's run), judged from the open-loop replay of its "
            f"torques. Optimiser: {statuses}; median {frontier['median_iterations']:.0f} IPOPT iterations (most "
            f"{frontier['max_iterations']:.0f}); replay "
            f"within {frontier['max_replay_tip_error'] * 1e3:.3g} mm of the path. Verdicts: {verdicts}."
        ),
        "",
        (
            f"Problem-free (verdict stable and peak torque within the limits): the global optimum on "
            f"{_share(frontier['problem_free'])} of the paths ({frontier['problem_free']['successes']}/"
            f"{frontier['paths']}; stable {_share(frontier['stable'])}, within the limits "
            f"{_share(frontier['within_limits'])}). Its median cost is "
            f"{_ratio(frontier.get('median_global_cost_vs_pinv', math.nan))} of pinv's and "
            f"{_ratio(frontier['median_global_cost_vs_most_successful'])} of the most successful local method's "
            f"(`{frontier['most_successful_local']}`); completely successful local methods (problem-free wherever the "
            f"global optimum is): {', '.join(frontier['completely_successful']) or 'none'}."
        ),
        "",
        "Per method, on the paths where the optimiser converged for the ratios (cost = ∫‖τ‖² dt over the movement, "
        "the same sum for every row):",
        "",
        "| method | problem-free | whiplash | fails where the global optimum is problem-free | median cost / global "
        "| median peak torque / global | median cost / global, its problem-free runs |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, item in frontier["local"].items():
        lines.append(
            f"| {name} | {_share(item['problem_free'])} | {_share(item['whiplash'])} | "
            f"{item['fails_where_global_is_problem_free']} | {_ratio(item['median_cost_vs_global'])} | "
            f"{_ratio(item['median_peak_vs_global'])} | {_ratio(item['median_cost_vs_global_problem_free'])} |"
        )
    lines.append(f"| {GLOBAL_RESOLVER} | {_share(frontier['problem_free'])} | - | - | 1 | 1 | 1 |")
    lines += ["", "Generated answer (the README's, without its link):", "", broader_answer(summary, link=False)]
    return lines


def margin_markdown(summary: dict) -> list[str]:
    """The report's section on the stability margin as a predictor of the whiplash verdict."""
    margin = summary["margin"]
    every = summary["config"].get("margin", {}).get("every", math.nan)
    at, zero = margin["at_threshold"], margin["at_zero"]

    def rates(item):
        return (
            f"true positives {_share(item['true_positive_rate'])}, false positives "
            f"{_share(item['false_positive_rate'])}"
        )

    lines = [
        "## The stability margin as a predictor of the whips",
        "",
        (
            f"Score: `peak_stability_margin` (σ every {every * 1e3:g} ms, before the instability on a whip, over the run "
            f"otherwise); label: the whiplash verdict; every torque resolver's runs pooled ({margin['runs']:,}). Held "
            f"out: {margin['held_out']}: {margin['held_out_runs']:,} runs, {margin['held_out_whips']} whips."
        ),
        "",
        (
            f"AUC on the held-out runs {margin['auc']:.3f} (on the even paths {margin['train_auc']:.3f}). At the "
            f"threshold chosen on the even paths, σ ≥ {at['threshold']:.3g} 1/s: {rates(at)}; at σ ≥ 0: {rates(zero)}. "
            f"The margin turned positive before {margin['warned_whips']} of the {margin['held_out_whips']} held-out "
            f"whips, a median {margin['median_warning_time']:.3g} s before the instability "
            f"({_ratio(margin['median_warning_fraction'])} of the time to it)."
        ),
        "",
        "| resolver | held-out runs | whips | AUC |",
        "|---|---|---|---|",
    ]
    for name, item in margin["per_resolver"].items():
        value = "-" if not math.isfinite(item["auc"]) else f"{item['auc']:.3f}"
        lines.append(f"| {name} | {item['runs']} | {item['whips']} | {value} |")
    return lines


def draw_margin_roc(summary: dict, path) -> str:
    """margin_roc.png: the held-out ROC curve with its AUC and the chosen threshold's point."""
    import matplotlib.pyplot as plt

    from ..io import atomic_write

    margin = summary["margin"]
    figure, axis = plt.subplots(figsize=(5.2, 4.6))
    axis.plot(
        margin["roc"]["fpr"], margin["roc"]["tpr"], color="C3", lw=1.6, label=f"held out: AUC {margin['auc']:.3f}"
    )
    for item, marker, text in (
        (margin["at_threshold"], "o", "threshold from the even paths"),
        (margin["at_zero"], "s", "σ ≥ 0"),
    ):
        axis.plot(
            item["false_positive_rate"]["fraction"],
            item["true_positive_rate"]["fraction"],
            marker,
            color="k",
            label=f"{text} ({item['threshold']:.3g} 1/s)",
        )
    axis.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls="--")
    axis.set_xlabel("false positive rate (runs that do not whip)")
    axis.set_ylabel("true positive rate (whips)")
    axis.set_title("peak stability margin as a whip predictor, odd paths", fontsize=9)
    axis.legend(fontsize=8, loc="lower right")
    axis.grid(alpha=0.3)
    figure.tight_layout()
    atomic_write(path, lambda handle: figure.savefig(handle, format="png", dpi=130))
    plt.close(figure)
    return path.name
