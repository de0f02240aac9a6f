"""The atlas explorer: ``explorer.html``, one self-contained page to point at a start point and see its runs.

The page holds three Plotly figures, all drawn by Plotly (plotly.js is
inlined, so the page opens without a network):

* the workspace map: one point per (movement, resolver) at the movement's
  start (x and y of the task frame's start, the plane of the planar arm; a
  projection on x-y for a 3-D task), coloured by verdict; hovering shows the
  row's ``peak_torque_ratio``, ``verdict``, ``instability_time`` and
  ``aligned_joint`` (the results table's columns). Two dropdowns filter by
  resolver and by duration (a small inline script combines them);
* on a click (or ``explorer.html#select=PATH``; ``#resolver=NAME&duration=T``
  sets the menus, ``duration=all`` for every duration): the torque of every
  resolver on that path, one panel per joint, against the limits ±τ⁺, and
  the arm's stick figure at each resolver's ``whip_time`` (the instability,
  else the peak demand), beside its start pose.

Traces are kept for a bounded sample of paths (``keep``, the atlas's
``--keep-traces``): every path on which some resolver whips first, then the
others, in path order (:func:`~torqueopt.atlas.traces.choose_paths`). The
sweep's chunks keep them as they run (:mod:`torqueopt.atlas.traces`); a path
whose chunk did not (a chunk of an older atlas, resumed) is simulated again
with the sweep's own settings (:func:`keep_traces`). They live in the page: at
most :data:`MAX_SAMPLES` samples per run, evenly spaced, plus each joint's
sample of peak :math:`|\\tau|/\\tau^+`.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from ..io import atomic_write
from ..progress import command_name, progress_bar
from ..units import shared_unit
from .population import movement_trajectory
from .sweep import require, simulate_all
from .traces import MAX_SAMPLES, Traces, choose_paths, run_trace
from .verdicts import VERDICT_COLOURS

__all__ = [
    "DEFAULT_KEEP_TRACES",
    "MAX_SAMPLES",
    "choose_paths",
    "explorer_html",
    "keep_traces",
    "page_traces",
    "write_explorer",
]

#: Paths whose traces the atlas keeps for the explorer by default (``--keep-traces``).
DEFAULT_KEEP_TRACES = 200
_RESOLVER_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf")


def page_traces(
    robot, table, movements, resolvers, stored: Callable[[list[int]], Iterable[Traces | None]], *, keep: int,
    dt: float, batch: bool, plant="pinocchio", plant_options=None, progress: bool = False,
) -> dict:  # fmt: skip
    """The traces of the paths the page keeps (:func:`choose_paths`), as :func:`keep_traces` returns them.

    ``stored(paths)`` gives the kept traces of the chunks that hold ``paths`` (None for a chunk that has
    none), read one at a time: only the chosen paths' are held. A chosen path that no chunk kept is
    simulated again (:func:`keep_traces`), with a line on stderr that says so when ``progress``.
    """
    chosen = choose_paths(table, keep)
    kept: dict = {}
    for traces in stored(chosen) if chosen else ():
        if traces is not None:
            kept.update(traces.only(chosen).by_path())
    missing = [path for path in chosen if path not in kept]
    if missing:
        kept.update(
            keep_traces(
                robot, table, movements, resolvers, dt=dt, batch=batch, keep=keep, plant=plant,
                plant_options=plant_options, paths=missing, progress=progress,
            )
        )  # fmt: skip
    return kept


def keep_traces(
    robot, table, movements, resolvers, *, dt: float, batch: bool, keep: int, plant="pinocchio", plant_options=None,
    paths=None, progress: bool = False,
) -> dict:  # fmt: skip
    """Simulate the chosen paths (``paths``, else :func:`choose_paths`) again, with the sweep's settings, plant and
    code path, and keep what the page draws (:func:`~torqueopt.atlas.traces.run_trace`).

    Returns:
        ``{path: {resolver: {"t", "tau" (samples × joints) [s, N·m], "arm", "start_arm" (points × 2) [m]}}}``.
    """
    chosen = set(choose_paths(table, keep) if paths is None else (int(path) for path in paths))
    picked = [m for m in movements if int(m.path) in chosen]
    if not picked:
        return {}
    lines = [movement_trajectory(m) for m in picked]
    q0s = [m.q0 for m in picked]
    whip_times = table.set_index(["path", "resolver"])["whip_time"]
    kept: dict = {}
    bar = progress_bar(
        f"{command_name('torqueopt atlas')}: simulating {len(picked)} paths again for explorer.html (their chunks "
        "kept no traces: an older atlas's, or run with --no-figures or a smaller --keep-traces)",
        total=len(picked) * len(resolvers), unit="run", enabled=progress,
    )  # fmt: skip
    with bar:
        for resolver in resolvers:
            results, _ = simulate_all(robot, resolver, lines, q0s, dt, batch, plant=plant, plant_options=plant_options)
            for movement, result in zip(picked, results):
                whip_time = float(whip_times.get((int(movement.path), resolver.label), math.nan))
                kept.setdefault(int(movement.path), {})[resolver.label] = run_trace(robot, result, whip_time)
            bar.update(len(picked))
    return kept


def _number(value):
    """A JSON number (None for NaN/inf)."""
    value = float(value)
    return value if math.isfinite(value) else None


def map_figure(table, summary: dict):
    """The workspace map: one scatter trace per (resolver, duration, verdict), the first resolver's longest shown."""
    go = require("plotly.graph_objects")
    resolvers, durations = summary["resolvers"], summary["durations"]
    shown = (resolvers[0], max(durations))
    figure = go.Figure()
    for resolver in resolvers:
        for duration in durations:
            rows = table[(table["resolver"] == resolver) & (table["duration"] == duration)]
            for verdict, colour in VERDICT_COLOURS.items():
                chosen = rows[rows["verdict"] == verdict]
                if not len(chosen):
                    continue
                customdata = [
                    [int(r.path), _number(r.peak_torque_ratio), r.verdict, _number(r.instability_time),
                     r.aligned_joint, resolver, float(r.duration)]
                    for r in chosen.itertuples()
                ]  # fmt: skip
                figure.add_trace(
                    go.Scatter(
                        x=[float(x) for x in chosen["start_1"]],
                        y=[float(y) for y in chosen["start_2"]],
                        mode="markers",
                        marker={"color": colour, "size": 7},
                        name=verdict,
                        legendgroup=verdict,
                        customdata=customdata,
                        meta={"resolver": resolver, "duration": float(duration)},
                        visible=(resolver, duration) == shown,
                        hovertemplate=(
                            "path %{customdata[0]} (%{customdata[5]}, T = %{customdata[6]} s)<br>"
                            "peak |τ|/τ⁺ %{customdata[1]:.3g}<br>verdict %{customdata[2]}<br>"
                            "instability at %{customdata[3]:.3f} s<br>aligned joint %{customdata[4]}<extra></extra>"
                        ),
                    )
                )

    def menu(kind, values, active, x, label):
        return {
            "type": "dropdown", "name": kind, "active": active, "x": x, "y": 1.14, "xanchor": "left",
            "buttons": [{"label": label(v), "method": "skip", "args": [kind, v]} for v in values],
        }  # fmt: skip

    figure.update_layout(
        title=f"start points by verdict: {summary['config']['robot_name']}",
        xaxis={"title": "start x [m]", "scaleanchor": "y"},
        yaxis={"title": "start y [m]"},
        updatemenus=[
            menu("resolver", resolvers, 0, 0.0, str),
            menu("duration", ["all", *durations], 1 + durations.index(shown[1]), 0.35, _duration_label),
        ],
        margin={"t": 90},
        height=560,
    )
    return figure


def _duration_label(value) -> str:
    return "all durations" if value == "all" else f"T = {value:g} s"


def path_figures(path: int, runs: dict, robot_summary: dict, layouts: tuple[dict, dict] | None = None) -> dict:
    """The torque panels (one per joint, every resolver, the limits) and the stick figures of one kept path.

    The traces are plain Plotly JSON: building each through ``plotly.graph_objects`` (which validates every
    value) took about 1 s a path, most of the page's time for the default 200 kept paths. ``layouts`` are
    :func:`path_layouts` of the robot, made once for every path when given.
    """
    torque_layout, arm_layout = layouts if layouts is not None else path_layouts(robot_summary)
    joints = len(robot_summary["joint_names"])
    torque, arm = [], []
    for index, (resolver, run) in enumerate(runs.items()):
        colour = _RESOLVER_COLOURS[index % len(_RESOLVER_COLOURS)]
        t = np.round(run["t"], 4).tolist()
        for joint in range(joints):
            axis = "" if joint == 0 else str(joint + 1)
            torque.append({
                "type": "scatter", "x": t, "y": np.round(run["tau"][:, joint], 3).tolist(), "mode": "lines",
                "name": resolver, "legendgroup": resolver, "showlegend": joint == 0,
                "line": {"color": colour, "width": 1.4, "simplify": False}, "xaxis": f"x{axis}", "yaxis": f"y{axis}",
            })  # fmt: skip
        arm.append({
            "type": "scatter", "x": np.round(run["arm"][:, 0], 4).tolist(), "y": np.round(run["arm"][:, 1], 4).tolist(),
            "mode": "lines+markers", "name": f"{resolver} at {run['arm_time']:.3f} s", "line": {"color": colour, "width": 3},
        })  # fmt: skip
    first = next(iter(runs.values()))
    arm.append({
        "type": "scatter", "x": np.round(first["start_arm"][:, 0], 4).tolist(),
        "y": np.round(first["start_arm"][:, 1], 4).tolist(), "mode": "lines", "name": "start pose",
        "line": {"color": "#aaaaaa", "width": 2, "dash": "dot"},
    })  # fmt: skip
    torque_layout = {
        **torque_layout,
        "title": {
            "text": f"path {path}: torque of every resolver "
            f"[{shared_unit(robot_summary.get('joint_kinds'), 'torque')}], limits ±τ⁺ dashed"
        },
    }
    arm_layout = {
        **arm_layout,
        "title": {"text": f"path {path}: the arm at each resolver's instability (else its peak demand)"},
    }
    return {"torque": {"data": torque, "layout": torque_layout}, "arm": {"data": arm, "layout": arm_layout}}


def path_layouts(robot_summary: dict) -> tuple[dict, dict]:
    """The layouts of :func:`path_figures` without their titles, by Plotly (one panel per joint, the limits dashed)."""
    go = require("plotly.graph_objects")
    subplots = require("plotly.subplots")
    joints = robot_summary["joint_names"]
    limits = robot_summary["torque_limit"]
    torque = subplots.make_subplots(rows=len(joints), cols=1, shared_xaxes=True, subplot_titles=joints)
    for joint, limit in enumerate(limits):
        if limit is not None:
            for sign in (1, -1):
                torque.add_hline(
                    y=sign * limit,
                    line={"color": "black", "dash": "dash", "width": 1},
                    row=joint + 1,
                    col=1,
                    exclude_empty_subplots=False,  # the layout is made before any trace
                )
    torque.update_layout(height=max(320, 190 * len(joints)), xaxis={"title": "t [s]"} if len(joints) == 1 else {})
    torque.update_xaxes(title_text="t [s]", row=len(joints), col=1)
    arm = go.Figure()
    arm.update_layout(xaxis={"title": "x [m]", "scaleanchor": "y"}, yaxis={"title": "y [m]"}, height=480)
    return torque.to_plotly_json()["layout"], arm.to_plotly_json()["layout"]


_SCRIPT = """
window.addEventListener('error', function (event) {
  document.getElementById('errors').textContent += String(event.message) + '\\n';
});
(function () {
  var spec = JSON.parse(document.getElementById('explorer-data').textContent);
  var map = document.getElementById('map');
  var state = {resolver: spec.shown.resolver, duration: spec.shown.duration};
  function filter() {
    var visible = map.data.map(function (trace) {
      return trace.meta.resolver === state.resolver && (state.duration === 'all' || trace.meta.duration === state.duration);
    });
    Plotly.restyle(map, {visible: visible});
  }
  function select(path) {
    var kept = spec.paths[String(path)];
    var note = document.getElementById('selection');
    note.dataset.path = String(path);
    if (!kept) {
      note.textContent = 'path ' + path + ': no traces kept (the atlas keeps ' + spec.keep_note + ')';
      Plotly.purge('torque'); Plotly.purge('arm');
      return;
    }
    note.textContent = 'path ' + path + ': every resolver on this path';
    Plotly.react('torque', kept.torque.data, kept.torque.layout);
    Plotly.react('arm', kept.arm.data, kept.arm.layout);
  }
  function fromHash() {
    var hash = window.location.hash;
    var resolver = /resolver=([^&]+)/.exec(hash), duration = /duration=([^&]+)/.exec(hash);
    if (resolver) { state.resolver = decodeURIComponent(resolver[1]); }
    if (duration) { state.duration = duration[1] === 'all' ? 'all' : Number(duration[1]); }
    if (resolver || duration) {
      filter();
      Plotly.relayout(map, {
        'updatemenus[0].active': spec.resolvers.indexOf(state.resolver),
        'updatemenus[1].active': ['all'].concat(spec.durations).indexOf(state.duration)
      });
    }
    var match = /select=(\\d+)/.exec(hash);
    if (match) { select(Number(match[1])); }
  }
  Plotly.newPlot(map, spec.map.data, spec.map.layout).then(function () {
    map.on('plotly_click', function (event) { select(event.points[0].customdata[0]); });
    map.on('plotly_buttonclicked', function (event) {
      state[event.button.args[0]] = event.button.args[1];
      filter();
    });
    window.addEventListener('hashchange', fromHash);
    fromHash();
    document.body.dataset.ready = 'yes';
  });
})();
"""


def explorer_html(table, summary: dict, traces: dict, keep: int) -> str:
    """The page's text: plotly.js inlined, the figures' JSON in one ``<script type="application/json">``."""
    plotly_io = require("plotly.io")
    offline = require("plotly.offline")
    config = summary["config"]
    robot_summary = {
        "joint_names": config["joint_names"],
        "torque_limit": config["torque_limit"],
        "joint_kinds": config.get("joint_kinds"),
    }
    figure = map_figure(table, summary)
    layouts = path_layouts(robot_summary) if traces else None
    kept_note = f"the traces of at most {keep} paths, those where a resolver whips first ({len(traces)} kept here)"
    spec = {
        "map": figure.to_plotly_json(),
        "resolvers": list(summary["resolvers"]),
        "durations": [float(d) for d in summary["durations"]],
        "shown": {"resolver": summary["resolvers"][0], "duration": float(max(summary["durations"]))},
        "paths": {str(path): path_figures(path, runs, robot_summary, layouts) for path, runs in sorted(traces.items())},
        "keep_note": kept_note,
    }
    data = plotly_io.to_json(spec, validate=False).replace("</", "<\\/")
    title = f"torqueopt atlas explorer: {config['robot_name']}"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<script>{offline.get_plotlyjs()}</script></head>
<body style="font-family: sans-serif; margin: 1em 2em">
<h1 style="font-size: 1.3em">{html.escape(title)}</h1>
<p>{summary["paths"]} movements x {len(summary["resolvers"])} resolvers. Each point is one run at its start point,
coloured by verdict; hover for its numbers, click for the torque of every resolver on its path and the arm at the
instability. Pick the resolver and the duration with the menus. Traces: {html.escape(kept_note)}, kept from the
sweep's runs, at most {MAX_SAMPLES} samples per run plus each joint's peak.</p>
<div id="map"></div>
<p id="selection">click a point (or open the page with #select=PATH)</p>
<div id="torque"></div>
<div id="arm"></div>
<pre id="errors" style="color: #b00"></pre>
<script type="application/json" id="explorer-data">{data}</script>
<script>{_SCRIPT}</script>
</body></html>
"""


def write_explorer(path: Path, table, summary: dict, traces: dict, keep: int) -> str:
    """Write ``explorer.html`` atomically (inside the atlas's ``written_together`` block); returns its name."""
    text = explorer_html(table, summary, traces, keep).encode()
    atomic_write(path, lambda handle: handle.write(text))
    return path.name
