"""The atlas explorer (explorer.html): its figures hold the table's numbers; in Chromium it loads, filters and selects."""

import importlib.util
import json
import math
import re
import subprocess
import tempfile

import numpy as np
import pytest

pandas = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")
pytest.importorskip("tqdm")
pytest.importorskip("plotly")
if importlib.util.find_spec("distributed") is None:
    pytest.skip("could not find 'distributed': the atlas needs dask[distributed]", allow_module_level=True)

from torqueopt.atlas import run_atlas  # noqa: E402
from torqueopt.atlas.explorer import choose_paths  # noqa: E402

# Five movements of 1.8 s on the paper's arm, pinv and null-space: with seed 5, null-space whips on paths 1 and 2.
TINY = {"paths": 5, "durations": (1.8,), "resolvers": ("pinv", "null-space"), "seed": 5, "workers": 0}
KEEP = 3


@pytest.fixture(scope="module")
def atlas(tmp_path_factory):
    out = tmp_path_factory.mktemp("explorer")
    return run_atlas("planar3", out=out, progress=False, keep_traces=KEEP, **TINY)


def page_data(path):
    text = path.read_text()
    match = re.search(r'<script type="application/json" id="explorer-data">(.*?)</script>', text, re.S)
    return json.loads(match.group(1).replace("<\\/", "</"))


def same(a, b):
    return (a is None and (b is None or (isinstance(b, float) and math.isnan(b)))) or a == b


def test_the_map_holds_the_tables_numbers(atlas):
    data = page_data(atlas.out / "explorer.html")
    table = atlas.table.set_index(["path", "resolver"])
    seen = set()
    for trace in data["map"]["data"]:
        resolver, duration = trace["meta"]["resolver"], trace["meta"]["duration"]
        for x, y, (path, peak, verdict, instability, aligned, row_resolver, row_duration) in zip(
            trace["x"], trace["y"], trace["customdata"]
        ):
            row = table.loc[(path, resolver)]
            assert (row_resolver, row_duration) == (resolver, duration) == (resolver, row["duration"])
            assert (x, y) == (row["start_1"], row["start_2"])
            assert verdict == row["verdict"] == trace["name"]
            assert same(peak, row["peak_torque_ratio"]) and same(instability, row["instability_time"])
            assert aligned == row["aligned_joint"]
            seen.add((path, resolver))
    assert seen == set(table.index)  # every run once


def test_the_kept_traces_are_the_whips_first_and_peak_where_the_table_says(atlas):
    table = atlas.table
    whipped = sorted(set(table.loc[table["verdict"] == "whiplash", "path"]))
    assert whipped, "the tiny atlas should have a whip"
    assert choose_paths(table, KEEP)[: len(whipped)] == whipped
    data = page_data(atlas.out / "explorer.html")
    assert sorted(data["paths"], key=int) == [str(p) for p in sorted(choose_paths(table, KEEP))]
    limits = np.array(atlas.summary["config"]["torque_limit"], dtype=float)
    joints = len(limits)
    for path, figures in data["paths"].items():
        lines = figures["torque"]["data"]
        assert len(lines) == 2 * joints
        for resolver_index, resolver in enumerate(TINY["resolvers"]):
            mine = lines[resolver_index * joints : (resolver_index + 1) * joints]
            assert {line["name"] for line in mine} == {resolver}
            # The re-simulated traces peak where the sweep's row says (|τ|/τ⁺, applied torques; kept to 1e-3 N·m).
            peak = max(np.max(np.abs(line["y"])) / limit for line, limit in zip(mine, limits))
            row = table[(table["path"] == int(path)) & (table["resolver"] == resolver)].iloc[0]
            assert peak == pytest.approx(row["peak_torque_ratio"], abs=1e-3 / limits.min())


def _path_figures_by_graph_objects(path, runs, robot_summary):
    """The kept path's figures as plotly.graph_objects builds them (validating every value): the reference."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    colours = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf")
    joints, limits = robot_summary["joint_names"], robot_summary["torque_limit"]
    torque = make_subplots(rows=len(joints), cols=1, shared_xaxes=True, subplot_titles=joints)
    arm = go.Figure()
    for index, (resolver, run) in enumerate(runs.items()):
        colour = colours[index % len(colours)]
        for joint in range(len(joints)):
            torque.add_trace(go.Scatter(x=np.round(run["t"], 4).tolist(), y=np.round(run["tau"][:, joint], 3).tolist(),
                                        mode="lines", name=resolver, legendgroup=resolver, showlegend=joint == 0,
                                        line={"color": colour, "width": 1.4, "simplify": False}),
                             row=joint + 1, col=1)  # fmt: skip
        arm.add_trace(go.Scatter(x=np.round(run["arm"][:, 0], 4).tolist(), y=np.round(run["arm"][:, 1], 4).tolist(),
                                 mode="lines+markers", name=f"{resolver} at {run['arm_time']:.3f} s",
                                 line={"color": colour, "width": 3}))  # fmt: skip
    first = next(iter(runs.values()))
    arm.add_trace(go.Scatter(x=np.round(first["start_arm"][:, 0], 4).tolist(),
                             y=np.round(first["start_arm"][:, 1], 4).tolist(), mode="lines", name="start pose",
                             line={"color": "#aaaaaa", "width": 2, "dash": "dot"}))  # fmt: skip
    for joint, limit in enumerate(limits):
        if limit is not None:
            for sign in (1, -1):
                torque.add_hline(
                    y=sign * limit, line={"color": "black", "dash": "dash", "width": 1}, row=joint + 1, col=1
                )
    torque.update_layout(title=f"path {path}: torque of every resolver [N·m], limits ±τ⁺ dashed",
                         height=max(320, 190 * len(joints)), xaxis={"title": "t [s]"} if len(joints) == 1 else {})  # fmt: skip
    torque.update_xaxes(title_text="t [s]", row=len(joints), col=1)
    arm.update_layout(title=f"path {path}: the arm at each resolver's instability (else its peak demand)",
                      xaxis={"title": "x [m]", "scaleanchor": "y"}, yaxis={"title": "y [m]"}, height=480)  # fmt: skip
    return json.loads(json.dumps({"torque": torque.to_plotly_json(), "arm": arm.to_plotly_json()}, default=list))


@pytest.mark.parametrize("limits", [[54.0, 24.0, None], [3.0], [87.0] * 4 + [12.0] * 3], ids=["3 joints", "1", "7"])
def test_a_kept_path_s_figures_are_what_plotly_s_figure_objects_make(limits):
    """The page writes the traces as plain JSON (through graph_objects, 200 kept paths took most of an atlas's
    time): the same figures, value for value, as graph_objects builds them."""
    from torqueopt.atlas.explorer import path_figures, path_layouts

    rng = np.random.default_rng(3)
    joints = [f"joint{i + 1}" for i in range(len(limits))]
    runs = {
        resolver: {"t": np.linspace(0, 1.8, 300), "tau": 20 * rng.normal(size=(300, len(joints))), "arm_time": 0.25 * i,
                   "arm": rng.normal(size=(len(joints) + 1, 2)), "start_arm": rng.normal(size=(len(joints) + 1, 2))}
        for i, resolver in enumerate(("pinv", "null-space", "weighted-null-space"))
    }  # fmt: skip
    summary = {"joint_names": joints, "torque_limit": limits}
    expected = _path_figures_by_graph_objects(4, runs, summary)
    assert json.loads(json.dumps(path_figures(4, runs, summary))) == expected
    assert json.loads(json.dumps(path_figures(4, runs, summary, path_layouts(summary)))) == expected
    shapes = expected["torque"]["layout"]["shapes"]
    assert sorted(shape["y0"] for shape in shapes) == sorted(s * x for x in limits if x is not None for s in (1, -1))


@pytest.mark.slow
def test_no_figures_writes_no_explorer_and_keep_traces_zero_keeps_none(tmp_path):
    run_atlas("planar3", out=tmp_path / "a", progress=False, figures=False, **TINY)
    assert not (tmp_path / "a" / "explorer.html").exists()
    run_atlas("planar3", out=tmp_path / "b", progress=False, keep_traces=0, **TINY)
    assert page_data(tmp_path / "b" / "explorer.html")["paths"] == {}


@pytest.mark.parametrize("parts", [1, 2], ids=["resolver chunks", "and global chunks"])
def test_the_paths_ruled_out_by_some_chunks_are_never_chosen_and_all_chunks_give_the_choice(parts):
    """KeptPaths, told the rows chunk by chunk in any order (each path in ``parts`` chunks, a whip in any one of
    them makes it whipped), never rules out a path choose_paths keeps from the whole table, and told every chunk
    it keeps exactly those."""
    from torqueopt.atlas.traces import KeptPaths

    rng = np.random.default_rng(7 + parts)
    for _ in range(300):
        count = int(rng.integers(1, 25))
        keep = int(rng.integers(0, count + 3))
        whip_share = rng.uniform(0.0, 0.8)
        chunks = []
        for _part in range(parts):
            rows = [
                {"path": path, "verdict": "whiplash" if rng.uniform() < whip_share / parts else "stable"}
                for path in range(count)
                for _resolver in range(int(rng.integers(1, 3)))
            ]
            cuts = sorted(rng.choice(np.arange(1, count), size=min(int(rng.integers(0, 4)), count - 1), replace=False))
            bounds = [0, *cuts, count]
            chunks += [[row for row in rows if low <= row["path"] < high] for low, high in zip(bounds, bounds[1:])]
        chosen = set(choose_paths(pandas.DataFrame([row for chunk in chunks for row in chunk]), keep))
        kept, told = KeptPaths(keep, parts), set()
        for index in rng.permutation(len(chunks)):
            kept.tell_rows(chunks[index])
            told |= {row["path"] for row in chunks[index]}
            assert chosen & told <= {path for path in told if kept.may_keep(path)}
        assert {path for path in range(count) if kept.may_keep(path)} == chosen


@pytest.mark.slow
def test_the_chunk_keeps_the_chosen_paths_traces_as_a_new_simulation_gives_them(atlas, monkeypatch, tmp_path):
    """The page's traces come from the chunk, no path is simulated after the sweep, and they are those of the
    chosen paths simulated again here by the sweep's code: the samples the explorer keeps (of the applied rows,
    300 evenly spaced and each joint's row of peak |τ|/τ⁺), the arm at the row of the table's whip_time and at
    the start, bit for bit."""
    from torqueopt.atlas import AtlasSettings, _load_and_draw, explorer
    from torqueopt.atlas.population import movement_trajectory
    from torqueopt.atlas.sweep import config_digest, simulate_all, traces_path
    from torqueopt.atlas.traces import Traces
    from torqueopt.plots.stick import arm_points

    table = atlas.table
    chosen = choose_paths(table, KEEP)
    digest = config_digest(json.loads((atlas.out / "atlas-config.json").read_text()))
    stored, why = Traces.read(traces_path(atlas.out, 0), digest, 0)
    assert why is None and sorted(set(stored.path.tolist())) == sorted(chosen)  # one chunk: it rules out the rest
    assert Traces.read(traces_path(atlas.out, 0), "0" * 16, 0) == (None, "another atlas's or chunk's")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(traces_path(atlas.out, 0).read_bytes()[:-100])
    assert Traces.read(truncated, digest, 0) == (None, "unreadable (truncated or corrupt)")

    settings = AtlasSettings.from_keywords(robot="planar3", out=atlas.out, keep_traces=KEEP, **TINY)
    robot, _, movements = _load_and_draw(settings)
    monkeypatch.setattr(explorer, "simulate_all", None)  # the page's traces must need no simulation
    traces = explorer.page_traces(
        robot, table, movements, list(settings.resolvers), lambda paths: [stored], keep=KEEP, dt=1e-3, batch=True
    )
    picked = [m for m in movements if m.path in chosen]
    lines, q0s = [movement_trajectory(m) for m in picked], [m.q0 for m in picked]
    whip_times = table.set_index(["path", "resolver"])["whip_time"]
    lengths = set()
    for resolver in settings.resolvers:
        for movement, run in zip(picked, simulate_all(robot, resolver, lines, q0s, 1e-3, True)[0]):
            # A run to the end holds a sample at t = T, whose torque is never applied; a whip stops a run early.
            applied = len(run.t) - int(run.t[-1] > 1.8 - 0.5e-3)
            lengths.add(applied)
            ratio = np.abs(run.tau[:applied]) / np.array(atlas.summary["config"]["torque_limit"], dtype=float)
            rows = sorted({*np.linspace(0, applied - 1, 300).round().astype(int), *np.argmax(ratio, axis=0)})
            whip_time = whip_times[(movement.path, resolver.label)]
            whip_row = int(np.argmin(np.abs(run.t[:applied] - whip_time))) if math.isfinite(whip_time) else applied - 1
            kept = traces[movement.path][resolver.label]
            np.testing.assert_array_equal(kept["t"], run.t[rows])
            np.testing.assert_array_equal(kept["tau"], run.tau[rows])
            np.testing.assert_array_equal(kept["arm"], arm_points(robot, run.joint_angles[whip_row])[:, :2])
            np.testing.assert_array_equal(kept["start_arm"], arm_points(robot, movement.q0)[:, :2])
            assert kept["arm_time"] == run.t[whip_row]
    assert sorted(traces) == sorted(chosen) and all(list(runs) == list(TINY["resolvers"]) for runs in traces.values())
    assert 1800 in lengths and min(lengths) < 1800  # runs to the end and runs stopped by a whip


@pytest.mark.slow
def test_a_resumed_atlas_whose_chunks_kept_no_traces_simulates_those_paths_and_says_so(atlas, tmp_path, capsys):
    """An atlas of an older torqueopt, resumed: its chunk has no traces file; the report simulates the chosen
    paths again, says so, and the page holds the same traces."""
    import shutil

    out = tmp_path / "older"
    shutil.copytree(atlas.out, out)
    for path in (out / "chunks").glob("*.traces.npz"):
        path.unlink()
    run_atlas("planar3", out=out, progress=True, keep_traces=KEEP, **TINY)
    assert f"simulating {KEEP} paths again for explorer.html" in capsys.readouterr().err
    assert page_data(out / "explorer.html") == page_data(atlas.out / "explorer.html")


# -- in a real browser ------------------------------------------------------------------------


def dump_dom(chromium, page, fragment=""):
    """The page's DOM after its scripts ran, in headless Chromium with every host name unresolvable (no network)."""
    with tempfile.TemporaryDirectory() as profile:
        done = subprocess.run(
            [
                chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                f"--user-data-dir={profile}", "--host-resolver-rules=MAP * ~NOTFOUND", "--virtual-time-budget=10000",
                "--window-size=1200,2400", "--dump-dom", page.as_uri() + fragment,
            ],
            capture_output=True, text=True, timeout=180, check=True,
        )  # fmt: skip
    return done.stdout


def drawn_lines(html):
    """The 'd' of every plotted line (not a legend's sample line, which is d="M5,0h30")."""
    return [d for d in re.findall(r'<path class="js-line" d="([^"]*)"', html) if d != "M5,0h30"]


def section(dom, start, end):
    return dom[dom.index(f'id="{start}"') : dom.index(f'id="{end}"')]


@pytest.mark.slow
@pytest.mark.browser
def test_the_page_loads_offline_filters_and_draws_a_selected_path(chromium, atlas):
    page = atlas.out / "explorer.html"
    assert not re.search(r"<script[^>]+src=", page.read_text())  # nothing to fetch
    table = atlas.table
    whip = int(table.loc[table["verdict"] == "whiplash", "path"].iloc[0])
    dom = dump_dom(chromium, page, f"#select={whip}")
    assert 'data-ready="yes"' in dom
    assert re.search(r'<pre id="errors"[^>]*></pre>', dom), "the page raised a JavaScript error"
    # Shown first: pinv's runs, one point per movement.
    assert section(dom, "map", "selection").count('<path class="point') == TINY["paths"]
    selected = section(dom, "selection", "errors")
    assert f'data-path="{whip}">path {whip}: every resolver' in selected
    joints = len(atlas.summary["config"]["joint_names"])
    torque = section(dom, "torque", "arm")
    lines = drawn_lines(torque)
    kept = page_data(page)["paths"][str(whip)]["torque"]["data"]
    # Every sample drawn (the page draws panel by panel, the data lists resolver by resolver).
    assert sorted(line.count("L") + 1 for line in lines) == sorted(len(trace["x"]) for trace in kept)
    assert re.findall(r'data-unformatted="([^"]+)"', torque).count("null-space") == 1  # in the legend
    arm = section(dom, "arm", "errors")
    assert [line.count("L") for line in drawn_lines(arm)] == [joints] * 3  # each resolver's arm and the start pose

    # The resolver filter: null-space's runs, its whips drawn red (#d62728).
    dom = dump_dom(chromium, page, "#resolver=null-space&duration=1.8")
    points = re.findall(r'<path class="point[^>]*fill: rgb\(([0-9, ]+)\)', section(dom, "map", "selection"))
    whips = int(((table["resolver"] == "null-space") & (table["verdict"] == "whiplash")).sum())
    assert len(points) == TINY["paths"] and points.count("214, 39, 40") == whips
    # A path whose traces were not kept says so.
    skipped = next(p for p in range(TINY["paths"]) if p not in choose_paths(table, KEEP))
    dom = dump_dom(chromium, page, f"#select={skipped}")
    assert f"path {skipped}: no traces kept" in section(dom, "selection", "errors")
    assert drawn_lines(section(dom, "torque", "errors")) == []
