r"""The horizon curve: how much look-ahead torque optimisation needs, from one control step to the whole movement.

Each curve is an atlas (``torqueopt atlas --global --global-bounded``) of one arm and one kind of path, with the
local methods at the left edge, ``receding-horizon`` over windows of growing length, and the whole-movement optimum
under the same torque bounds and joint limits at the right edge:

* local: ``pinv``, ``null-space`` (the paper's torque optimum, unbounded), ``damped-null-space`` (the kinematic
  remedy) and ``bounded-torque[kinematic_weight=0]`` (the paper's criterion under the torque bounds and joint
  limits: the one-step problem of the windows);
* windows: ``receding-horizon[horizon=H,replan_every=R]`` (``horizon_dt='auto'``: 10 ms knots, 5 ms before
  8 Dec 2026; the one-step window replans every step), :data:`REPLAN_EVERY` control steps between solves (see :func:`window_label`);
* the optimum: the atlas's ``global-optimum`` rows with ``--global-bounded`` (the ``shooting`` transcription under
  the torque bounds and joint limits, its default starts), which also say on which paths no motion within the
  limits exists (``infeasible for every resolver``).

Four commands:

``run CURVE --out FOLDER [--workers N] [--times ROWS.jsonl]``
    the atlas of ``CURVE`` (:data:`CURVES`) in ``FOLDER``, one path per chunk, in this process (``--workers 0``,
    the default) or on N Dask worker processes. The worker count is no setting of the atlas: any count resumes
    the same folder, and the rows do not depend on it. The chunks go out in the order of their paths, so a sweep
    stopped at any moment leaves a whole prefix of paths, and the chunks in flight (at most N) are lost; the same
    command resumes it. Stop it with Ctrl-C (``kill -INT``): with N >= 1 the workers ignore it and the sweep ends
    within seconds; in this process it ends when the IPOPT solve under way returns (a window's solve: seconds; the
    whole-movement optimum's: up to its time limit). ``--times`` appends each chunk's CPU seconds to ROWS.jsonl
    (``--workers 0``).
``time CURVE --atlas FOLDER --paths I,J --out ROWS.jsonl``
    the CPU time [s] of every method's run on the paths I, J of that atlas, one JSON line per run (resumed
    from the lines already written): the atlas's rows carry no time, so that a chunk is a deterministic function
    of its settings.
``cost --times CURVE=ROWS.jsonl ... [--methods CURVE=ROWS.jsonl ...] --json OUT.json``
    the CPU seconds per path of ``run --times``'s rows, the hours the curve's planned paths take in CPU time and on
    one and two busy cores, and (from ``time``'s rows) each method's share (:func:`run_cost`).
``summary --atlas CURVE=FOLDER ... --timing CURVE=ROWS.jsonl ... --json OUT.json --figure OUT.png``
    reads each atlas's finished prefix of paths and the timing rows, and writes per method: the problem-free
    share over all paths and over the feasible ones, the whiplash share (each with its Wilson 95 % interval),
    the median cost ∫‖τ − τ_mid‖² dt, its median ratio to the optimum's on the same path, the median peak
    torque ratio, the CPU time per control step; and the figure.

What a path costs is IPOPT's work in the windows' solves (docs/discussion/horizon.md, "What it costs";
docs/data/horizon_time.json): planar3 took 105 s of CPU a path in the mean of paths 0, 1 and 13 (21 to 192 s, at a
load of 14 to 21), so its 1,000 paths some 29 CPU hours, 15 h on two free cores (``--workers 2``). The atlas's own
work (loading, drawing the population, writing a chunk, reading the chunks on resuming) is under 0.1 s a path, the
local methods about a second, the whole-movement optimum (two starts) a few seconds, about a minute where no start
meets the limits and phase-1 runs from each. Most of the windows' work is in solves that fail: once a window finds no
motion within the limits, the run leaves the path under the fallback and every later solve of that run fails too. The
one-step window is run, not read off ``bounded-torque[kinematic_weight=0]``'s row, although it solves the same step's
problem: the window holds the tip to the path's position one step ahead where ``bounded-torque`` integrates
accelerations and drifts (1.0 to 1.3 mm over a 2 s line, past the verdicts' 1 mm), and a failed window falls back to
``bounded-torque``'s defaults (``kinematic_weight=0.5``). On the first 13 planar3 paths their verdicts differ on 4
(three drifts, one whip), while their costs agree within 0.3 % on the 5 paths with no infeasible step.

A run is *problem-free* when its verdict is ``stable`` and its peak torque within the limits
(:func:`torqueopt.atlas.frontier.problem_free`); the optimum's row is judged the same way, from the open-loop
replay of its torques.

    nice python benchmarks/horizon_curve.py run planar3 --out runs/planar3 --workers 2
    nice python benchmarks/horizon_curve.py run planar3 --out runs/planar3 --times runs/planar3-times.jsonl
    nice python benchmarks/horizon_curve.py time planar3 --atlas runs/planar3 --paths 1 --out runs/planar3-time.jsonl
    python benchmarks/horizon_curve.py cost --times planar3=runs/planar3-times.jsonl \
        --methods planar3=runs/planar3-time.jsonl --json docs/data/horizon_time.json
    python benchmarks/horizon_curve.py summary --atlas planar3=runs/planar3 --timing planar3=runs/planar3-time.jsonl \
        --json docs/data/horizon_curve.json --figure docs/horizon_curve.png
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Control steps between solves of every window longer than one step (20 ms at dt = 1 ms; see the docs page).
REPLAN_EVERY = 20
#: The local methods at the curve's left edge, by their atlas labels.
LOCAL = ("pinv", "null-space", "damped-null-space", "bounded-torque[kinematic_weight=0]")
#: The window of one control step (dt = 1 ms): one knot interval, replanned every step.
ONE_STEP = "receding-horizon[horizon=0.001]"
#: The ``resolver`` column of the optimum's rows (torqueopt.atlas.global_optimum.GLOBAL_RESOLVER).
OPTIMUM = "global-optimum"
#: Where the README's answer sits (what :func:`readme_with_answer` replaces).
ANSWER_BEGIN = "<!-- horizon-answer: generated by benchmarks/horizon_curve.py (horizon_answer) -->"
ANSWER_END = "<!-- /horizon-answer -->"
#: The docs page the README's answer links to.
PAGE = "docs/discussion/horizon.md"


@dataclass(frozen=True)
class Curve:
    """One curve: an arm, a kind of path, its duration [s], the population the issue asks for, the windows [s]."""

    name: str
    robot: str
    path: str
    duration: float
    planned_paths: int
    horizons: tuple[float, ...]
    one_step: bool = False
    seed: int = 2026

    def resolvers(self) -> list[str]:
        """The atlas's resolver labels, left to right (the optimum comes from ``--global``)."""
        return [*LOCAL, *([ONE_STEP] if self.one_step else []), *(window_label(h) for h in self.horizons)]

    def arguments(self, out, workers: int = 0) -> list[str]:
        """The ``torqueopt atlas`` arguments of this curve's sweep into ``out`` on ``workers`` Dask worker processes
        (0: in this process). The workers are no setting of the atlas: a sweep resumes with any count."""
        return [
            "--robot", self.robot, "--path", self.path, "--paths", str(self.planned_paths),
            "--durations", f"{self.duration:g}", "--seed", str(self.seed), "--resolvers", ",".join(self.resolvers()),
            "--global", "--global-bounded", "--workers", str(workers), "--chunk-size", "1", "--no-figures",
            "--no-progress", "--out", str(out),
        ]  # fmt: skip


def window_label(horizon: float) -> str:
    """The atlas label of a window of ``horizon`` seconds, replanned every :data:`REPLAN_EVERY` steps."""
    return f"receding-horizon[horizon={horizon:g},replan_every={REPLAN_EVERY}]"


#: The curves of issue 38: planar3's 2 s lines (1,000 planned); panda's 2 s lines and 1 s circles (200 each).
CURVES = {
    curve.name: curve
    for curve in (
        Curve("planar3", "planar3", "line", 2.0, 1000, (0.02, 0.05, 0.1, 0.2, 0.5, 1.0), one_step=True),
        Curve("panda-lines", "panda", "line", 2.0, 200, (0.05, 0.1, 0.2, 0.5, 1.0)),
        Curve("panda-circles", "panda", "circle", 1.0, 200, (0.05, 0.1, 0.2, 0.5, 1.0)),
    )
}


# -- the arithmetic of the summary ----------------------------------------------------------------------------------
def _pct(item: dict) -> str:
    """A share as the pages write it: ``40 % [17, 69]`` (Wilson 95 %)."""
    if not item["trials"]:
        return "-"
    return f"{item['fraction']:.0%} [{100 * item['low']:.0f}, {100 * item['high']:.0f}]".replace("%", " %")


def share(flags) -> dict:
    """k of n (``flags`` True or False per path), the fraction and its Wilson 95 % interval."""
    from torqueopt.atlas.stats import proportion

    flags = np.asarray(flags, bool)
    item = proportion(int(flags.sum()), int(flags.size)).as_dict()
    return {**item, "text": _pct(item)}


def feasible_share(flags, feasible) -> dict:
    """:func:`share` over the paths on which a motion within the limits exists (``feasible``), the others left out."""
    flags, feasible = np.asarray(flags, bool), np.asarray(feasible, bool)
    return share(flags[feasible])


def median(values) -> float | None:
    """The median of the finite values (None when there is none: the JSON's null, the page's "-")."""
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else None


def horizon_of(label: str, duration: float) -> float:
    """The look-ahead of a method [s]: 0 for a local method, the window for receding-horizon, the movement for the
    optimum."""
    if label == OPTIMUM:
        return duration
    if label.startswith("receding-horizon"):
        from torqueopt.resolvers import resolver_from_label

        return float(resolver_from_label(label).horizon)  # the label leaves out a default horizon
    return 0.0


def horizon_text(seconds: float, duration: float) -> str:
    """``local``, ``one step``, ``20 ms``, ``1 s``, ``whole movement``."""
    if seconds == 0.0:
        return "local"
    if seconds >= duration:
        return "whole movement"
    if seconds <= 1e-3 + 1e-12:
        return "one step"
    return f"{1e3 * seconds:g} ms" if seconds < 1.0 else f"{seconds:g} s"


def method_key(label: str, duration: float) -> str:
    """A short key of a method for the page's markers (no comma, no bracket): ``pinv``, ``bounded-torque``,
    ``h1ms``, ``h20ms``, ``h1s``, ``optimum``."""
    if label == OPTIMUM:
        return "optimum"
    if label.startswith("receding-horizon"):
        seconds = horizon_of(label, duration)
        return f"h{1e3 * seconds:g}ms" if seconds < 1.0 else f"h{seconds:g}s"
    return label.split("[", 1)[0]


def _normalised(label: str) -> str:
    """A method's label as the atlas writes it (options at their defaults left out)."""
    from torqueopt.resolvers import resolver_from_label

    return label if label == OPTIMUM else resolver_from_label(label).label


def _method_name(label: str, seconds: float, duration: float) -> str:
    """How the pages name a method: its label, ``window of 20 ms``, ``whole-movement optimum``."""
    if label == OPTIMUM:
        return "whole-movement optimum"
    if label.startswith("receding-horizon"):
        return f"window of {horizon_text(seconds, duration)}"
    return label


def summarise_table(table, timing=None) -> dict:
    """Per method (in the table's order): shares, costs, peaks and CPU time (module docstring).

    ``table``: the atlas rows (``results.parquet``'s columns, the global ratios added) of whole paths;
    ``timing``: rows ``{"path", "method", "cpu_seconds", "steps"}`` or None.
    """
    from torqueopt.atlas.frontier import problem_free
    from torqueopt.atlas.verdicts import INFEASIBLE

    duration = float(table["duration"].iloc[0])
    optimum = table[table["resolver"] == OPTIMUM].set_index("path").sort_index()
    paths = optimum.index.to_numpy()
    feasible = optimum["verdict"].to_numpy() != INFEASIBLE
    converged = optimum["optimizer_status"].to_numpy() == "converged"
    methods = []
    for label in dict.fromkeys(table["resolver"]):
        rows = table[table["resolver"] == label].set_index("path").reindex(paths)
        free = problem_free(rows)
        seconds = horizon_of(label, duration)
        item = {
            "key": method_key(label, duration),
            "label": label,
            "name": _method_name(label, seconds, duration),
            "kind": "optimum" if label == OPTIMUM else "window" if label.startswith("receding-horizon") else "local",
            "horizon": seconds,
            "horizon_text": horizon_text(seconds, duration),
            "runs": len(rows),
            "problem_free": share(free),
            "problem_free_of_feasible": feasible_share(free, feasible),
            "whiplash": share(rows["verdict"].to_numpy() == "whiplash"),
            "lost_path": int((rows["verdict"] == "lost path").sum()),
            "median_cost": median(rows["cost"]),
            "median_cost_vs_optimum": median(rows["cost_vs_global"].to_numpy(float)[converged]),
            "median_peak_torque_ratio": median(rows["peak_torque_ratio"]),
            "median_peak_vs_optimum": median(rows["peak_vs_global"].to_numpy(float)[converged]),
            "cpu_ms_per_step": None,
            "timed_paths": 0,
        }
        if timing:
            mine = [row for row in timing if _normalised(row["method"]) == label]
            if mine:
                item["cpu_ms_per_step"] = 1e3 * sum(r["cpu_seconds"] for r in mine) / sum(r["steps"] for r in mine)
                item["timed_paths"] = len(mine)
        methods.append(item)
    return {
        "paths": len(paths),
        "feasible_paths": int(feasible.sum()),
        "infeasible_paths": int((~feasible).sum()),
        "optimum_converged": int(converged.sum()),
        "optimum_status": {str(k): int(v) for k, v in optimum["optimizer_status"].value_counts().items()},
        "methods": methods,
        "answer": answer_of(methods),
    }


def answer_of(methods: list[dict]) -> dict:
    """Which window first matches the optimum's problem-free count, the best local method, and their shares."""
    optimum = next(m for m in methods if m["kind"] == "optimum")
    local = [m for m in methods if m["kind"] == "local"]
    windows = sorted((m for m in methods if m["kind"] == "window"), key=lambda m: m["horizon"])
    best_local = max(local, key=lambda m: m["problem_free"]["successes"]) if local else None
    matching = next(
        (m for m in windows if m["problem_free"]["successes"] >= optimum["problem_free"]["successes"]), None
    )
    return {
        "best_local": best_local["key"] if best_local else None,
        "best_local_problem_free": best_local["problem_free"]["text"] if best_local else None,
        "best_window": max(windows, key=lambda m: (m["problem_free"]["successes"], -m["horizon"]))["key"]
        if windows
        else None,
        "first_window_matching_optimum": matching["key"] if matching else None,
        "first_window_matching_optimum_text": matching["horizon_text"] if matching else None,
    }


# -- what a curve costs to run -----------------------------------------------------------------------------------
def path_seconds(chunk_rows) -> dict:
    """CPU seconds per whole path, ``{path: {"resolvers": s, "optimum": s}}``, from :func:`timed_chunks`' rows
    (one path per chunk); a path without both parts is left out, a part timed twice (a chunk redone) counts once,
    the last time."""
    parts: dict = {}
    for row in chunk_rows:
        if row["paths"] != 1:
            raise ValueError(f"a chunk of {row['paths']} paths at path {row['path']}: the curve runs one path a chunk")
        parts.setdefault(row["path"], {})[row["part"]] = row["cpu_seconds"]
    return {path: part for path, part in sorted(parts.items()) if set(part) == {"resolvers", "optimum"}}


def run_cost(curve: Curve, chunk_rows, method_rows=None, workers=(1, 2)) -> dict:
    """What ``curve`` costs: CPU seconds per path over the timed paths (mean, its 95 % interval from the standard
    error, cut at 0, median, 90th percentile, least, largest; by part), and the hours its ``planned_paths`` take at
    that mean in CPU time and in wall time on each count of ``workers`` busy cores; with ``method_rows`` (the
    ``time`` command's), each method's mean CPU seconds per path and its share of their sum."""
    seconds = path_seconds(chunk_rows)
    totals = np.array([sum(part.values()) for part in seconds.values()], float)
    if not totals.size:
        raise SystemExit(f"no path of curve {curve.name} has both its chunks timed")
    mean = float(totals.mean())
    error = float(totals.std(ddof=1) / np.sqrt(totals.size)) if totals.size > 1 else math.nan
    hours = curve.planned_paths * mean / 3600.0
    item = {
        "name": curve.name, "planned_paths": curve.planned_paths, "timed_paths": int(totals.size),
        "paths": [int(path) for path in seconds],
        "cpu_per_path": {
            "mean": mean, "low": max(mean - 1.96 * error, 0.0), "high": mean + 1.96 * error,
            "median": float(np.median(totals)), "p90": float(np.percentile(totals, 90)), "min": float(totals.min()),
            "max": float(totals.max()),
        },
        "cpu_per_path_by_part": {
            part: float(np.mean([parts[part] for parts in seconds.values()])) for part in ("resolvers", "optimum")
        },
        "mean_load": float(np.mean([row["load"] for row in chunk_rows if row["path"] in seconds])),
        "cpu_hours": hours,
        "cpu_hours_low": curve.planned_paths * max(mean - 1.96 * error, 0.0) / 3600.0,
        "cpu_hours_high": curve.planned_paths * (mean + 1.96 * error) / 3600.0,
        "hours_on": [{"workers": count, "hours": hours / count} for count in workers],
        "methods": [],
    }  # fmt: skip
    if method_rows:
        by_method: dict = {}
        for row in method_rows:
            by_method.setdefault(row["method"], []).append(row["cpu_seconds"])
        means = {label: float(np.mean(values)) for label, values in by_method.items()}
        whole = sum(means.values())
        for label, value in means.items():
            seconds_of = horizon_of(label, curve.duration)
            item["methods"].append({
                "label": label, "key": method_key(label, curve.duration),
                "name": _method_name(label, seconds_of, curve.duration), "timed_paths": len(by_method[label]),
                "cpu_seconds_per_path": value, "share": value / whole,
            })  # fmt: skip
    return item


def cost_summary(times: dict, method_times: dict | None = None, workers=(1, 2)) -> dict:
    """The JSON of what the curves cost (``times``: curve name -> :func:`timed_chunks`' files, comma-separated;
    ``method_times``: curve name -> the ``time`` command's files), with their sum in hours on each count of
    ``workers``."""

    def lines(files: str) -> list[dict]:
        return [json.loads(line) for file in files.split(",") for line in Path(file).read_text().splitlines()]

    curves = []
    for name, files in times.items():
        rows = lines(files)
        methods = (method_times or {}).get(name)
        method_rows = lines(methods) if methods else None
        curves.append(run_cost(CURVES[name], rows, method_rows, workers))
    cpu = sum(curve["cpu_hours"] for curve in curves)
    return {
        "curves": curves,
        "cpu_hours": cpu,
        "hours_on": [{"workers": count, "hours": cpu / count} for count in workers],
    }


# -- the README's answer ----------------------------------------------------------------------------------------


def horizon_answer(summary: dict) -> str:
    """The README's answer to "how much look-ahead does torque optimisation need?", written from the curve's JSON
    (its first curve, planar3's), whichever way the numbers come out, with the sample size it rests on."""
    curve = summary["curves"][0]
    methods = {m["key"]: m for m in curve["methods"]}
    answer = curve["answer"]
    optimum, best_local = methods["optimum"], methods[answer["best_local"]]
    windows = sorted((m for m in curve["methods"] if m["kind"] == "window"), key=lambda m: m["horizon"])
    shortest, longest = windows[0], windows[-1]
    where = (
        f"the first {curve['paths']:,} of {curve['planned_paths']:,} random {curve['duration']:g} s lines of "
        f"{curve['robot']}"
    )
    text = (
        f"- **How much look-ahead does it take?** On {where} (a small sample: the 95 % intervals are wide), "
        f"`receding-horizon` under the torque bounds and joint limits is problem-free on {_pct(shortest['problem_free'])}"
        f" of the paths with a window of {shortest['horizon_text']}, {_pct(longest['problem_free'])} with "
        f"{longest['horizon_text']}, the whole-movement optimum under the same limits on "
        f"{_pct(optimum['problem_free'])} and the best local method (`{best_local['label']}`) on "
        f"{_pct(best_local['problem_free'])}."
    )
    matching = answer["first_window_matching_optimum"]
    if matching is not None:
        window = methods[matching]
        ratio = window["median_cost_vs_optimum"]
        text += f" The shortest window as often problem-free as the optimum is {window['horizon_text']}" + (
            f", at {ratio:.2f} times its ∫‖τ‖² dt in the median." if ratio is not None else "."
        )
    else:
        text += f" No window up to {longest['horizon_text']} is as often problem-free as the optimum."
    text += f" ([The horizon curve]({PAGE}))"
    return textwrap.fill(text, width=78, subsequent_indent="  ", break_long_words=False, break_on_hyphens=False)


def readme_with_answer(text: str, summary: dict) -> str:
    """``text`` (the README) with its block between :data:`ANSWER_BEGIN` and :data:`ANSWER_END` written again."""
    if ANSWER_BEGIN not in text or ANSWER_END not in text:
        raise ValueError(f"the text has no '{ANSWER_BEGIN}' ... '{ANSWER_END}' block")
    before, rest = text.split(ANSWER_BEGIN, 1)
    return f"{before}{ANSWER_BEGIN}\n{horizon_answer(summary)}\n{ANSWER_END}{rest.split(ANSWER_END, 1)[1]}"


# -- the figure -------------------------------------------------------------------------------------------------
def draw_figure(summary: dict, path: Path):
    """Problem-free share (Wilson 95 % bars; open marks: of the feasible paths) and median cost over the optimum's
    against the look-ahead, one column per curve: the local methods at the left edge, the optimum at the right."""
    from torqueopt.plots.canvas import new_figure, save_figure

    curves = summary["curves"]
    fig = new_figure(4.6 * len(curves) + 0.6, 7.0)
    axes = np.array(fig.subplots(2, len(curves), squeeze=False))
    for column, curve in enumerate(curves):
        share_ax, cost_ax = axes[:, column]
        _draw_curve(share_ax, cost_ax, curve)
    fig.suptitle("How much look-ahead torque optimisation needs", fontsize=11)
    save_figure(fig, path, dpi=200)
    return fig


def _positions(curve: dict) -> dict:
    """The x position of each method: the windows at their length [s] (log scale), the local methods spread at the
    left edge, the optimum at the right."""
    windows = sorted((m for m in curve["methods"] if m["kind"] == "window"), key=lambda m: m["horizon"])
    low, high = windows[0]["horizon"], windows[-1]["horizon"]
    local = [m for m in curve["methods"] if m["kind"] == "local"]
    positions = {m["key"]: m["horizon"] for m in windows}
    for index, m in enumerate(local):
        positions[m["key"]] = low / 2.2 ** (len(local) - index)
    positions["optimum"] = high * 3.5
    return positions


_LOCAL_MARKERS = ("s", "v", "D", "^", "P")


def _leading(value: float) -> int:
    """The leading digit of a positive number."""
    return round(float(value / 10 ** np.floor(np.log10(value))))


def _tick(seconds: float) -> str:
    return "1 step" if seconds <= 1e-3 + 1e-12 else f"{1e3 * seconds:g}"


def _draw_curve(share_ax, cost_ax, curve: dict) -> None:
    from matplotlib.ticker import FuncFormatter

    positions = _positions(curve)
    methods = curve["methods"]
    windows = sorted((m for m in methods if m["kind"] == "window"), key=lambda m: m["horizon"])
    local = [m for m in methods if m["kind"] == "local"]
    optimum = next(m for m in methods if m["kind"] == "optimum")
    x = [positions[m["key"]] for m in windows]

    def bars(items, key):
        values = np.array([m[key]["fraction"] for m in items])
        low = values - np.array([m[key]["low"] for m in items])
        high = np.array([m[key]["high"] for m in items]) - values
        return 100 * values, 100 * np.vstack([low, high])

    values, errors = bars(windows, "problem_free")
    drawn = share_ax.errorbar(x, values, yerr=errors, color="tab:blue", marker="o", capsize=3, label="problem-free")
    drawn.lines[0].set_gid("problem-free")  # the figure's test finds the line by it
    feasible, _ = bars(windows, "problem_free_of_feasible")
    share_ax.plot(x, feasible, color="tab:blue", ls="--", marker="o", mfc="none", label="of the feasible paths")
    whips, whip_errors = bars(windows, "whiplash")
    share_ax.errorbar(x, whips, yerr=whip_errors, color="tab:red", marker="x", capsize=2, lw=1, elinewidth=0.6,
                      alpha=0.8, label="whiplash")  # fmt: skip
    cost_ax.plot(x, [m["median_cost_vs_optimum"] or np.nan for m in windows], color="tab:blue", marker="o")
    for marker, m in zip(_LOCAL_MARKERS, local):
        value, error = bars([m], "problem_free")
        share_ax.errorbar([positions[m["key"]]], value, yerr=error, color="0.3", marker=marker, capsize=3,
                          ls="none", label=m["label"].replace("[kinematic_weight=0]", ""))  # fmt: skip
        cost_ax.plot([positions[m["key"]]], [m["median_cost_vs_optimum"] or np.nan], color="0.3", marker=marker,
                     ls="none")  # fmt: skip
    value, error = bars([optimum], "problem_free")
    share_ax.errorbar([positions["optimum"]], value, yerr=error, color="black", marker="*", ms=10, capsize=3,
                      ls="none", label="whole-movement optimum")  # fmt: skip
    cost_ax.plot([positions["optimum"]], [1.0], color="black", marker="*", ms=10, ls="none")
    for ax in (share_ax, cost_ax):
        ax.set_xscale("log")
        ticks = [positions[m["key"]] for m in windows] + [positions["optimum"]]
        ax.set_xticks(ticks, [_tick(m["horizon"]) for m in windows] + ["whole"], fontsize=8)
        # the windows' labels sit close on the log axis (100 and 200, 500 and 1000 ms ran together): slanted
        for label in ax.get_xticklabels():
            label.set_rotation(40)
            label.set_horizontalalignment("right")
            label.set_rotation_mode("anchor")
        ax.minorticks_off()
        ax.axvspan(ax.get_xlim()[0], windows[0]["horizon"] / 1.45, color="0.93", zorder=0)
        ax.grid(alpha=0.3)
    share_ax.set_ylim(-2, 102)
    share_ax.set_ylabel("share of the paths [%]")
    share_ax.set_title(
        f"{curve['robot']}, {curve['duration']:g} s {curve['path']}s: {curve['paths']:,} of "
        f"{curve['planned_paths']:,} paths", fontsize=9,
    )  # fmt: skip
    share_ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.13), ncol=3, frameon=False)
    cost_ax.set_yscale("log")
    cost_ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    # of the minor ticks only 2 and 5 times a power of ten are labelled, so that a scale of many decades stays legible
    cost_ax.yaxis.set_minor_formatter(FuncFormatter(lambda value, _: f"{value:g}" if _leading(value) in (2, 5) else ""))
    cost_ax.axhline(1.0, color="black", lw=0.8)
    cost_ax.set_ylabel("median ∫‖τ‖² dt / the optimum's")
    cost_ax.set_xlabel("window [ms] (local methods: shaded)")


# -- the commands -----------------------------------------------------------------------------------------------
def run(curve: Curve, out: Path, workers: int = 0, times: Path | None = None) -> int:
    """The curve's atlas on ``workers`` Dask worker processes (0: in this process), resumed when ``out`` holds it
    already; with ``times``, each chunk's CPU time appended to that file (:func:`timed_chunks`)."""
    from torqueopt.cli import main as torqueopt_main

    if times is None:
        return torqueopt_main(["atlas", *curve.arguments(out, workers)])
    if workers:
        raise SystemExit("--times reads the CPU time of this process's chunks: give --workers 0")
    with timed_chunks(times):
        return torqueopt_main(["atlas", *curve.arguments(out)])


@contextlib.contextmanager
def timed_chunks(times: Path):
    """Append one JSON line to ``times`` per chunk that this process computes while the block runs: its first path,
    its part (``resolvers``: every resolver's run; ``optimum``: the whole-movement optimum), its CPU and wall
    seconds, the load average and when it finished. A benchmark's instrument around the atlas's chunk function
    (``torqueopt.atlas.sweep.chunk_output``): the chunks' rows are untouched."""
    from torqueopt.atlas import sweep
    from torqueopt.atlas.jobs import GlobalChunk

    untimed = sweep.chunk_output

    def chunk_output(job):
        began, wall = time.process_time(), time.perf_counter()
        output = untimed(job)
        row = {
            "path": int(job.movements[0].path), "paths": len(job.movements),
            "part": "optimum" if isinstance(job, GlobalChunk) else "resolvers",
            "cpu_seconds": round(time.process_time() - began, 3), "wall_seconds": round(time.perf_counter() - wall, 3),
            "load": round(os.getloadavg()[0], 2), "finished": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        }  # fmt: skip
        with times.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        return output

    sweep.chunk_output = chunk_output
    try:
        yield
    finally:
        sweep.chunk_output = untimed


def movements_of(curve: Curve, atlas_folder: Path, paths: list[int]) -> tuple:
    """(the robot, the movements ``paths`` of the curve's population), checked against the atlas's rows (start q0)."""
    import torqueopt
    from torqueopt.atlas.population import PopulationSpec, arm_reach, draw_population

    robot = torqueopt.load_robot(curve.robot)
    spec = PopulationSpec(paths=curve.planned_paths, durations=(curve.duration,), seed=curve.seed, path=curve.path)
    population = draw_population(robot, spec.sized(arm_reach(robot)[1]))
    movements = [population[index] for index in paths]
    table = atlas_rows(atlas_folder)
    for movement in movements:
        row = table[(table["path"] == movement.path) & (table["resolver"] == "pinv")]
        atlas_q0 = row[[f"q0_{i}" for i in range(1, robot.nv + 1)]].to_numpy(float)
        if len(row) != 1 or not np.array_equal(atlas_q0[0], np.asarray(movement.q0, float)):
            raise SystemExit(f"path {movement.path} of {atlas_folder} is not this curve's: run the atlas first")
    return robot, movements


def time_methods(curve: Curve, atlas_folder: Path, paths: list[int], out: Path) -> None:
    """CPU seconds of each method's run (the optimum: the atlas's global row, pinv's warm start and the replay
    included) on the movements ``paths``, one JSON line per run, resumed from ``out``."""
    import torqueopt
    from torqueopt.atlas.global_optimum import DEFAULT_GLOBAL_MAX_ITERATIONS, DEFAULT_GLOBAL_MAX_TIME, global_row
    from torqueopt.atlas.global_optimum import settings as global_settings
    from torqueopt.atlas.population import movement_trajectory
    from torqueopt.atlas.verdicts import Thresholds

    robot, movements = movements_of(curve, atlas_folder, paths)
    done = set()
    if out.exists():
        done = {(row["path"], row["method"]) for row in map(json.loads, out.read_text().splitlines())}
    optimum_settings = global_settings(DEFAULT_GLOBAL_MAX_ITERATIONS, DEFAULT_GLOBAL_MAX_TIME, bounded=True)
    with out.open("a") as rows_file:
        for movement in movements:
            trajectory = movement_trajectory(movement)
            for label in [*curve.resolvers(), OPTIMUM]:
                if (movement.path, label) in done:
                    continue
                began = time.process_time()
                if label == OPTIMUM:
                    global_row(robot, movement, dt=1e-3, thresholds=Thresholds(), settings=optimum_settings)
                else:
                    torqueopt.simulate(robot, label, trajectory, movement.q0)
                seconds = time.process_time() - began
                row = {"path": int(movement.path), "method": label, "cpu_seconds": seconds,
                       "steps": round(trajectory.duration / 1e-3)}  # fmt: skip
                rows_file.write(json.dumps(row) + "\n")
                rows_file.flush()
                print(f"path {movement.path:4d} {label:50s} cpu {seconds:8.2f} s", flush=True)


def atlas_rows(folder: Path):
    """The rows of the whole paths 0 .. P-1 of an atlas folder (finished or stopped), with the global ratios."""
    from torqueopt.atlas.prefix import prefix_rows

    return prefix_rows(folder, json.loads((folder / "atlas-config.json").read_text()))[0]


def replan_check(table, other_table) -> dict:
    """The methods of two atlases of the same curve that replan at different rates, on the paths both finished."""
    paths = min(int(table["path"].max()), int(other_table["path"].max())) + 1
    return {
        "paths": paths,
        "this": summarise_table(table[table["path"] < paths])["methods"],
        "other": summarise_table(other_table[other_table["path"] < paths])["methods"],
    }


def summary(atlases: dict, timings: dict, records: dict, others: dict | None = None) -> dict:
    """The JSON of the curves (``atlases``: curve name -> atlas folder; ``timings``: curve name -> timing rows file;
    ``records``: curve name -> how it ran, in words; ``others``: curve name -> (replan_every, the folder of the same
    curve replanned at that rate), compared on the paths both finished)."""
    curves = []
    for name, folder in atlases.items():
        curve = CURVES[name]
        timing_file = timings.get(name)
        timing = [json.loads(line) for line in Path(timing_file).read_text().splitlines()] if timing_file else None
        table = atlas_rows(Path(folder))
        item = {
            "name": name, "robot": curve.robot, "path": curve.path, "duration": curve.duration, "seed": curve.seed,
            "planned_paths": curve.planned_paths, "replan_every": REPLAN_EVERY,
            "command": "python benchmarks/horizon_curve.py run " + name + " --out FOLDER",
            "atlas_command": "torqueopt atlas " + " ".join(
                f"'{a}'" if "[" in a else a for a in curve.arguments("FOLDER")
            ),
            "ran": records.get(name, ""),
        }  # fmt: skip
        item.update(summarise_table(table, timing))
        if name in (others or {}):
            every, folder = others[name]
            item["replan_check"] = {"replan_every": every, **replan_check(table, atlas_rows(Path(folder)))}
        curves.append(item)
    return {"question": "how much look-ahead does torque optimisation need?", "curves": curves}


def _pairs(texts) -> dict:
    pairs = {}
    for text in texts or []:
        name, _, value = text.partition("=")
        if name not in CURVES or not value:
            raise SystemExit(f"'{text}' is not CURVE=VALUE with CURVE one of {', '.join(CURVES)}")
        pairs[name] = value
    return pairs


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    commands = parser.add_subparsers(dest="command", required=True)
    running = commands.add_parser("run", allow_abbrev=False, help="the curve's atlas (resumed)")
    running.add_argument("curve", choices=list(CURVES))
    running.add_argument("--out", type=Path, required=True)
    running.add_argument(
        "--workers",
        type=int,
        default=0,
        help="Dask worker processes (default 0: this process); any count resumes the same folder",
    )
    running.add_argument("--times", type=Path, metavar="ROWS.jsonl",
                         help="append each chunk's CPU time to this file (with --workers 0)")  # fmt: skip
    timing = commands.add_parser("time", allow_abbrev=False, help="CPU time per run on the first paths")
    timing.add_argument("curve", choices=list(CURVES))
    timing.add_argument("--atlas", type=Path, required=True)
    timing.add_argument("--paths", type=lambda text: [int(p) for p in text.split(",")], default=[0],
                        metavar="I,J,...", help="the paths (indices) to time (default 0)")  # fmt: skip
    timing.add_argument("--out", type=Path, required=True)
    costing = commands.add_parser("cost", allow_abbrev=False, help="CPU per path and the curves' projected hours")
    costing.add_argument("--times", action="append", required=True, metavar="CURVE=ROWS.jsonl",
                         help="run --times's rows of a curve (files: comma-separated)")  # fmt: skip
    costing.add_argument("--methods", action="append", metavar="CURVE=ROWS.jsonl", help="the time command's rows")
    costing.add_argument("--json", type=Path, required=True)
    summarising = commands.add_parser("summary", allow_abbrev=False, help="the JSON, the figure, the README")
    summarising.add_argument("--atlas", action="append", required=True, metavar="CURVE=FOLDER")
    summarising.add_argument("--timing", action="append", metavar="CURVE=ROWS.jsonl")
    summarising.add_argument("--ran", action="append", metavar="CURVE=TEXT", help="how the sweep ran, in words")
    summarising.add_argument(
        "--replan-check",
        action="append",
        metavar="CURVE=EVERY:FOLDER",
        help="the same curve's atlas replanned every EVERY steps, compared on its paths",
    )
    summarising.add_argument("--json", type=Path, required=True)
    summarising.add_argument("--figure", type=Path)
    summarising.add_argument("--readme", type=Path, help="write the README's answer block")
    arguments = parser.parse_args(argv)
    if arguments.command == "run":
        return run(CURVES[arguments.curve], arguments.out, arguments.workers, arguments.times)
    if arguments.command == "time":
        time_methods(CURVES[arguments.curve], arguments.atlas, arguments.paths, arguments.out)
        return 0
    if arguments.command == "cost":
        result = cost_summary(_pairs(arguments.times), _pairs(arguments.methods))
        arguments.json.write_text(json.dumps(result, indent=1) + "\n")
        for curve in result["curves"]:
            spread = curve["cpu_per_path"]
            print(f"{curve['name']}: {curve['timed_paths']} paths, CPU per path {spread['mean']:.1f} s "
                  f"[{spread['low']:.1f}, {spread['high']:.1f}] (median {spread['median']:.1f}, max {spread['max']:.1f}), "
                  f"{curve['planned_paths']} paths: {curve['cpu_hours']:.1f} CPU hours")  # fmt: skip
        print(f"all: {result['cpu_hours']:.1f} CPU hours; " + ", ".join(
            f"{item['hours']:.1f} h on {item['workers']} cores" for item in result["hours_on"]))  # fmt: skip
        print(f"wrote {arguments.json}")
        return 0
    others = {name: (int(text.split(":", 1)[0]), text.split(":", 1)[1]) for name, text in
              _pairs(arguments.replan_check).items()}  # fmt: skip
    result = summary(_pairs(arguments.atlas), _pairs(arguments.timing), _pairs(arguments.ran), others)
    arguments.json.write_text(json.dumps(result, indent=1, ensure_ascii=False) + "\n")
    print(f"wrote {arguments.json}")
    if arguments.figure:
        draw_figure(result, arguments.figure)
        print(f"wrote {arguments.figure}")
    if arguments.readme:
        arguments.readme.write_text(readme_with_answer(arguments.readme.read_text(), result))
        print(f"wrote {arguments.readme}")
    for curve in result["curves"]:
        print(f"{curve['name']}: {curve['paths']} paths, {curve['feasible_paths']} feasible")
        for m in curve["methods"]:
            cpu = "-" if m["cpu_ms_per_step"] is None else f"{m['cpu_ms_per_step']:.3g}"
            ratio = "-" if m["median_cost_vs_optimum"] is None else f"{m['median_cost_vs_optimum']:.3g}"
            print(f"  {m['label']:50s} free {_pct(m['problem_free']):16s} of feasible "
                  f"{_pct(m['problem_free_of_feasible']):16s} whip {_pct(m['whiplash']):14s} cost/opt {ratio:6s} "
                  f"cpu {cpu} ms/step")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
