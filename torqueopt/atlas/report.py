"""The atlas's summary (atlas.json, atlas.md) and figures."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..io import atomic_write
from ..units import shared_unit
from .frontier import draw_margin_roc, frontier_markdown, global_summary, margin_markdown, margin_summary
from .global_optimum import GLOBAL_RESOLVER
from .pinv_paths import pinv_paths_markdown, pinv_paths_summary
from .stats import CRITERIA, claims, proportion, unstable_fractions
from .verdicts import INFEASIBLE, VERDICT_COLOURS, VERDICTS

__all__ = ["summarise", "write_figures", "write_markdown"]

_PAPER_RESOLVERS = ("pinv", "inertia-pinv", "null-space", "weighted-null-space")
_SHORT_CRITERIA = {"unstable": "2x-limit rule", "whiplash": "whiplash verdict (2x-limit rule and a runaway)"}


def summarise(table, config: dict) -> dict:
    """Settings, counts, unstable fractions and claims per criterion, verdicts and whip locations per resolver."""
    resolvers = list(dict.fromkeys(table["resolver"]))
    verdicts = {}
    whips = {}
    for resolver in resolvers:
        rows = table[table["resolver"] == resolver]
        verdicts[resolver] = {verdict: int((rows["verdict"] == verdict).sum()) for verdict in _verdicts(table)}
        whipped = rows[rows["verdict"] == "whiplash"]
        if len(whipped):
            aligned = whipped["aligned_joint"].value_counts()
            whips[resolver] = {
                "count": len(whipped),
                "aligned_joint": {str(k): int(v) for k, v in aligned.items()},
                "median_aligned_angle_deg": float(np.degrees(np.median(np.abs(whipped["aligned_angle"])))),
                "median_whip_speed": float(whipped["whip_speed"].median()),
                "median_instability_time_fraction": float((whipped["instability_time"] / whipped["duration"]).median()),
            }
            if config.get("joint_kinds"):  # an arm with a slider; else rad/s, and atlas.json as it was
                whips[resolver]["whip_speed_unit"] = _speed_unit(whipped["whip_speed_joint"], config)
    torque = {}
    for resolver in resolvers:
        rows = table[table["resolver"] == resolver]
        ratio = rows["torque_vs_pinv"].to_numpy(dtype=float)
        ratio = ratio[np.isfinite(ratio)]
        torque[resolver] = {
            "median_torque_vs_pinv": float(np.median(ratio)) if ratio.size else math.nan,
            "share_below_pinv": proportion(int((ratio < 1.0).sum()), int(ratio.size)).as_dict(),
        }
    summary = {
        "config": config,
        "rows": len(table),
        "paths": int(table["path"].nunique()),
        "resolvers": resolvers,
        "durations": sorted(float(d) for d in set(table["duration"])),
        "criteria": CRITERIA,
        "unstable_fraction": {criterion: unstable_fractions(table, criterion) for criterion in CRITERIA},
        "claims": {criterion: claims(table, criterion) for criterion in CRITERIA},
        "verdicts": verdicts,
        "whips": whips,
        "torque": torque,
        "pinv_paths": pinv_paths_summary(table),
    }
    # With --global and --margin: the frontier and the margin's record as a predictor (torqueopt.atlas.frontier).
    frontier, margins = global_summary(table), margin_summary(table)
    if frontier is not None:
        summary["global"] = frontier
    if margins is not None:
        summary["margin"] = margins
    return summary


def _speed_unit(joints, config: dict) -> str:
    """The unit of the whipped joints' speeds: rad/s, m/s on a slider, both when the whips were on both kinds."""
    kinds = dict(zip(config["joint_names"], config.get("joint_kinds") or [None] * len(config["joint_names"])))
    return shared_unit([kinds.get(joint) for joint in dict.fromkeys(joints)], "velocity")


def _model_text(robot: dict) -> str:
    """The robot's payload and gravity, when the atlas gave them (nothing for the URDF as it is)."""
    parts = []
    payload = robot.get("payload")
    if payload:
        position = ", ".join(f"{x:g}" for x in payload["position"])
        parts.append(f"a payload of {payload['mass']:g} kg at ({position}) m in the task frame")
    if isinstance(robot.get("gravity"), list):
        parts.append(f"gravity ({', '.join(f'{g:g}' for g in robot['gravity'])}) m/s²")
    return f" Model: {'; '.join(parts)}." if parts else ""


def _plant_text(config: dict) -> str:
    """What the torques acted on: the robot's own model (no ``plant`` in the config), or the plant it names."""
    plant = config.get("plant")
    if plant is None:
        return (
            "open loop: held-torque RK4 for the torque resolvers, RK4 on the joint velocities with inverse-dynamics "
            "torques for the velocity-level ones."
        )
    options = ", ".join(f"{key}={value}" for key, value in plant["options"].items())
    return f"the torques acting on the {plant['name']} plant" + (f" ({options})." if options else ".")


def _verdicts(table) -> tuple:
    """The verdicts counted: all of them, but ``infeasible for every resolver`` only where a path has it."""
    present = bool((table["verdict"] == INFEASIBLE).any())
    return tuple(verdict for verdict in VERDICTS if verdict != INFEASIBLE or present)


def write_markdown(summary: dict) -> str:
    config = summary["config"]
    population = config["population"]
    lines = [
        f"# Stability atlas: {config['robot_name']} ({config['task']} task)",
        "",
        (
            f"{summary['paths']} movements x {len(summary['resolvers'])} resolvers = {summary['rows']} runs; "
            f"durations {', '.join(f'{d:g}' for d in summary['durations'])} s; population `{population['mode']}` "
            f"(seed {population['seed']}, reach fraction {population['reach_fraction']:g}, "
            f"min start condition {population['min_condition']:g}); {_path_text(population, config)}, "
            f"dt {config['dt'] * 1e3:g} ms, {_plant_text(config)}{_model_text(config['robot'])}"
        ),
        (
            f"Thresholds: 2x-limit rule at {config['thresholds']['limit_factor']:g} x the limit; runaway when the torque "
            f"exceeds {config['thresholds']['pinv_factor']:g} x pinv's on the same path or the self-motion energy "
            f"exceeds {config['thresholds']['energy_factor']:g} x the task's. Intervals: Wilson 95 %."
        ),
        "",
    ]
    for criterion, description in summary["criteria"].items():
        lines += [f"## Unstable fraction by duration: {description}", ""]
        durations = summary["durations"]
        lines.append("| resolver | " + " | ".join(f"T = {d:g} s" for d in durations) + " |")
        lines.append("|---|" + "---|" * len(durations))
        by_resolver = {}
        for item in summary["unstable_fraction"][criterion]:
            by_resolver.setdefault(item["resolver"], {})[item["duration"]] = item
        for resolver, cells in by_resolver.items():
            texts = []
            for d in durations:
                cell = cells.get(d)
                texts.append(
                    "-"
                    if cell is None or not cell["trials"]
                    else f"{cell['fraction']:.0%} [{cell['low']:.0%}, {cell['high']:.0%}] ({cell['successes']}/{cell['trials']})"
                )
            lines.append(f"| {resolver} | " + " | ".join(texts) + " |")
        lines += [
            "",
            f"### The paper's claims ({criterion})",
            "",
            "| the paper | the atlas | figure | holds? |",
            "|---|---|---|---|",
        ]
        for claim in summary["claims"][criterion]:
            lines.append(
                f'| "{claim["paper"]}" | {claim["figure"]} | {claim["text"]} | {claim["holds"]} ({claim["rule"]}) |'
            )
        lines.append("")
    shown = [verdict for verdict in VERDICTS if any(verdict in counts for counts in summary["verdicts"].values())]
    lines += [
        "## Verdicts per resolver",
        "",
        "| resolver | " + " | ".join(shown) + " | median peak torque vs pinv |",
        "|---|" + "---|" * (len(shown) + 1),
    ]
    for resolver, counts in summary["verdicts"].items():
        median = summary["torque"][resolver]["median_torque_vs_pinv"]
        lines.append(f"| {resolver} | " + " | ".join(str(counts.get(v, 0)) for v in shown) + f" | {median:.3g} |")
    if summary.get("pinv_paths"):
        lines += ["", *pinv_paths_markdown(summary["pinv_paths"])]
    if summary["whips"]:
        lines += [
            "",
            "## Where the whips happened",
            "",
            "| resolver | whips | joint nearest aligned at the instability (whips) | its median \\|angle\\| "
            "| median top joint speed | median instability time / duration |",
            "|---|---|---|---|---|---|",
        ]
        for resolver, whip in summary["whips"].items():
            joints = ", ".join(f"{joint} {count}" for joint, count in whip["aligned_joint"].items())
            lines.append(
                f"| {resolver} | {whip['count']} | {joints} | {whip['median_aligned_angle_deg']:.1f}° | "
                f"{whip['median_whip_speed']:.3g} {whip.get('whip_speed_unit', 'rad/s')} | "
                f"{whip['median_instability_time_fraction']:.0%} |"
            )
    if "global" in summary:
        lines += ["", *frontier_markdown(summary)]
    if "margin" in summary:
        lines += ["", *margin_markdown(summary)]
    figures = summary.get("figures") or {}
    if figures:
        lines += ["", "## Figures", ""] + [f"- {title}: `{name}`" for title, name in figures.items()]
    lines += ["", "Columns of `results.parquet`: see `torqueopt.atlas.verdicts` (docstring) and the docs.", ""]
    return "\n".join(lines)


def _path_text(population: dict, config: dict) -> str:
    """The path kind and its parameters, as the report's header says them."""
    kind, accel = population.get("path", "line"), population["accel"]
    if config.get("accel_from_reach"):
        accel_text = f"{accel:.4g} m/s² (this arm's default: √2 m/s² x reach {config['reach']:.3g} m / 3 m)"
    else:
        accel_text = f"{accel:.4g} m/s²"
    low, high = population.get("length_range", (0.25, 1.0))
    fractions = f"{low:g} to {high:g} of a·T²/4" if low != high else f"{low:g} of a·T²/4"
    if kind == "min-jerk":
        return f"path `min-jerk` (minimum-jerk lines, length uniform in {fractions}, a = {accel_text})"
    if kind == "circle":
        return (
            f"path `circle` (one minimum-jerk turn in a random plane about a random centre, circumference uniform "
            f"in {fractions}, a = {accel_text})"
        )
    return f"path `line` (the paper's bang-bang line), acceleration {accel_text}"


def write_figures(table, summary: dict, out: Path, robot) -> dict:
    """Draw the figures into ``out``; returns {title: file name}."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    resolvers = summary["resolvers"]
    # Ten resolvers or fewer: the default cycle; more (every setting of every resolver): tab20, so none repeats.
    colours = {
        resolver: f"C{i}" if len(resolvers) <= 10 else plt.get_cmap("tab20")(i % 20)
        for i, resolver in enumerate(resolvers)
    }
    made = {"unstable fraction against duration": _draw_fractions(summary, colours, out / "unstable_fraction.png")}
    if "start_2" in table.columns and "start_3" not in table.columns:  # planar tasks
        made["workspace map of start points by verdict"] = _draw_workspace(
            table, summary, robot, out / "workspace_map.png"
        )
    made["histogram of instability times"] = _draw_instability_times(table, colours, out / "instability_time.png")
    made["torque reduction against instability rate"] = _draw_tradeoff(table, summary, colours, out / "tradeoff.png")
    if "margin" in summary:
        made["ROC of the stability margin as a whip predictor, held-out paths"] = draw_margin_roc(
            summary, out / "margin_roc.png"
        )
    return made


def _bars(share: dict) -> np.ndarray:
    """The error bar of a share's Wilson interval, (2, 1) below and above."""
    return np.clip([[share["fraction"] - share["low"]], [share["high"] - share["fraction"]]], 0.0, None)


def _draw_fractions(summary: dict, colours: dict, path: Path) -> str:
    """Unstable fraction against duration, per resolver, with Wilson intervals, for both criteria."""
    import matplotlib.pyplot as plt

    resolvers = summary["resolvers"]
    figure, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for axis, criterion in zip(axes, summary["criteria"]):
        items = summary["unstable_fraction"][criterion]
        for offset, resolver in enumerate(resolvers):
            cells = [item for item in items if item["resolver"] == resolver and item["trials"]]
            shift = (offset - (len(resolvers) - 1) / 2) * 0.012 * (max(summary["durations"]) or 1)
            axis.errorbar(
                np.array([c["duration"] for c in cells]) + shift, [c["fraction"] for c in cells],
                yerr=np.hstack([_bars(c) for c in cells]) if cells else None, marker="o", capsize=3, label=resolver,
                color=colours[resolver],
            )  # fmt: skip
        axis.set_title(_SHORT_CRITERIA.get(criterion, criterion), fontsize=9)
        axis.set_xlabel("movement duration T [s]")
        axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
    axes[0].set_ylabel("unstable fraction (Wilson 95 % interval)")
    axes[0].legend(fontsize=8)
    figure.tight_layout()
    return _save(figure, path)


def _draw_workspace(table, summary: dict, robot, path: Path) -> str:
    """Start points coloured by verdict at the longest duration, one panel per resolver; on a grid (several
    directions from each start point), coloured by the share that whips."""
    import matplotlib.pyplot as plt

    resolvers, longest = summary["resolvers"], max(summary["durations"])
    columns = min(len(resolvers), 4)
    panel_rows = -(-len(resolvers) // columns)
    figure, axes = plt.subplots(panel_rows, columns, figsize=(3.4 * columns, 3.5 * panel_rows), squeeze=False)
    for axis in axes.flat[len(resolvers) :]:
        axis.set_visible(False)
    longest_rows = table[table["duration"] == longest]
    repeated = longest_rows.groupby(["resolver", "start_1", "start_2"]).size().max() > 1
    for axis, resolver in zip(axes.flat, resolvers):
        rows = longest_rows[longest_rows["resolver"] == resolver]
        if repeated:
            shares = rows.assign(whip=rows["verdict"] == "whiplash").groupby(["start_1", "start_2"])["whip"].mean()
            starts = shares.index.to_frame(index=False)
            points = axis.scatter(
                starts["start_1"], starts["start_2"], c=shares.to_numpy(), cmap="Reds", vmin=0, vmax=1, s=22,
                edgecolors="k", linewidths=0.3,
            )  # fmt: skip
            figure.colorbar(points, ax=axis, fraction=0.046, pad=0.04, label="share of directions that whip")
        else:
            for verdict, colour in VERDICT_COLOURS.items():
                chosen = rows[rows["verdict"] == verdict]
                axis.scatter(
                    chosen["start_1"], chosen["start_2"], s=10, color=colour, label=f"{verdict} ({len(chosen)})",
                    linewidths=0,
                )  # fmt: skip
            axis.legend(fontsize=6, loc="lower left", markerscale=1.5, handletextpad=0.2, borderpad=0.3)
        if robot.name == "planar3":
            axis.add_patch(plt.Circle((0, 0), 3.0, fill=False, lw=0.6, color="k"))  # the arm's reach
        axis.set_aspect("equal")
        axis.set_title(f"{resolver}, T = {longest:g} s", fontsize=9)
        axis.set_xlabel("start x [m]", fontsize=8)
        axis.set_ylabel("start y [m]", fontsize=8)
    figure.tight_layout()
    return _save(figure, path)


def _draw_instability_times(table, colours: dict, path: Path) -> str:
    """Histograms of the instability time (as a fraction of the duration), per resolver."""
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6.5, 4))
    for resolver in colours:
        rows = table[(table["resolver"] == resolver) & table["unstable"]]
        if len(rows):
            axis.hist(
                rows["instability_time"] / rows["duration"], bins=np.linspace(0, 1, 21), histtype="step", lw=1.5,
                label=f"{resolver} ({len(rows)})", color=colours[resolver],
            )  # fmt: skip
    axis.set_xlabel("instability time / duration (2x-limit rule)")
    axis.set_ylabel("runs")
    if axis.get_legend_handles_labels()[0]:
        axis.legend(fontsize=8)
    else:  # a legend of nothing was matplotlib's "No artists with labels found" warning, and an empty figure
        axis.text(0.5, 0.5, "no run went unstable by the 2x-limit rule", ha="center", va="center",
                  transform=axis.transAxes, fontsize=10)  # fmt: skip
    axis.grid(alpha=0.3)
    figure.tight_layout()
    return _save(figure, path)


def _draw_tradeoff(table, summary: dict, colours: dict, path: Path) -> str:
    """Torque reduction (on the paths where the method and pinv are both stable) against the whiplash rate; with
    the global optimum, its point (a star) and a second panel: each method's median cost over the optimum's."""
    import matplotlib.pyplot as plt

    frontier = summary.get("global")
    if frontier is None:
        figure, axis = plt.subplots(figsize=(6.5, 4.5))
    else:
        figure, (axis, distance) = plt.subplots(1, 2, figsize=(13.5, 5.2))
        _draw_distances(distance, frontier, colours)
    pinv_stable = set(table.loc[(table["resolver"] == "pinv") & (table["verdict"] == "stable"), "path"])
    for resolver in summary["resolvers"]:
        rows = table[table["resolver"] == resolver]
        calm = rows[(rows["verdict"] == "stable") & rows["path"].isin(pinv_stable)]
        ratio = calm["torque_vs_pinv"].to_numpy(dtype=float)
        ratio = ratio[np.isfinite(ratio)]
        share = proportion(int((rows["verdict"] == "whiplash").sum()), len(rows)).as_dict()
        if ratio.size:
            marker = "*" if resolver == GLOBAL_RESOLVER else ("o" if resolver in _PAPER_RESOLVERS else "s")
            axis.errorbar(
                np.median(ratio), share["fraction"], yerr=_bars(share), marker=marker, capsize=3,
                color=colours[resolver], label=resolver, linestyle="none",
                markersize=14 if resolver == GLOBAL_RESOLVER else 6,
            )  # fmt: skip
    # pinv sits on x = 1 by definition: the reference line goes under the error bars, not over pinv's.
    axis.axvline(1.0, color="0.55", lw=0.8, ls="--", zorder=0.5)
    axis.set_xlabel("median peak |τ|/limit relative to pinv, paths where both are stable (left: less torque)")
    axis.set_ylabel("whiplash fraction, all durations")
    axis.legend(fontsize=8)
    axis.grid(alpha=0.3)
    figure.tight_layout()
    return _save(figure, path)


def _draw_distances(axis, frontier: dict, colours: dict) -> None:
    """Each local method's median cost over the global optimum's (x, log) against its share of problem-free paths."""
    for resolver, item in frontier["local"].items():
        cost, share = item["median_cost_vs_global"], item["problem_free"]
        if not math.isfinite(cost):
            continue
        marker = "o" if resolver in _PAPER_RESOLVERS else "s"
        axis.errorbar(
            cost, share["fraction"], yerr=_bars(share), marker=marker, capsize=3, color=colours.get(resolver, "k"),
            linestyle="none", label=resolver,
        )  # fmt: skip
        axis.annotate(resolver, (cost, share["fraction"]), fontsize=6, xytext=(4, 3), textcoords="offset points")
    own = frontier["problem_free"]
    axis.errorbar(
        1.0, own["fraction"], yerr=_bars(own), marker="*", markersize=14, capsize=3,
        color=colours.get(GLOBAL_RESOLVER, "k"), linestyle="none", label=GLOBAL_RESOLVER,
    )  # fmt: skip
    axis.set_xscale("log")
    axis.set_xlabel("median ∫‖τ‖² dt / the global optimum's on the same path (log)")
    axis.set_ylabel("problem-free share (stable, within the torque limits)")
    axis.set_title("distance to the global optimum", fontsize=9)
    axis.grid(alpha=0.3, which="both")


def _save(figure, path: Path) -> str:
    import matplotlib.pyplot as plt

    atomic_write(path, lambda handle: figure.savefig(handle, format="png", dpi=130))
    plt.close(figure)
    return path.name
