"""The atlas's global optimum (``--global``), the cost of every row, the stability-margin columns and the frontier.

Each figure is checked against something computed apart from the atlas: ``torqueopt.optimize`` run directly on the
same movement, a rectangle sum of a ``simulate`` run's torques in numpy, ``torqueopt.stability_margin`` at the
sampled states, a brute-force pairwise count for the AUC.
"""

import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pandas = pytest.importorskip("pandas")
if importlib.util.find_spec("distributed") is None:
    pytest.skip("could not find 'distributed': the atlas needs dask[distributed]", allow_module_level=True)
pytest.importorskip("pyarrow")
pytest.importorskip("tqdm")

import torqueopt
from torqueopt import StraightLine
from torqueopt.atlas import PopulationSpec, draw_population, run_atlas
from torqueopt.atlas.frontier import auc, roc_curve
from torqueopt.atlas.global_optimum import GLOBAL_RESOLVER
from torqueopt.atlas.margins import margin_columns
from torqueopt.atlas.verdicts import Thresholds, run_row, self_motion_energy
from torqueopt.cli import main
from torqueopt.errors import InvalidInput

from .conftest import PAPER_Q0

ROOT = Path(__file__).resolve().parents[1]
ACCEL = math.sqrt(2.0)
#: Three 0.5 s paths, pinv and null-space, the global optimum and the margins, in chunks of two.
SETTINGS = {
    "paths": 3,
    "durations": (0.5,),
    "resolvers": ("pinv", "null-space"),
    "seed": 5,
    "chunk_size": 2,
    "progress": False,
    "figures": False,
    "global_optimum": True,
    "margin": True,
}


def _table(out):
    return pandas.read_parquet(Path(out) / "results.parquet")


@pytest.fixture(scope="module")
def global_atlas(tmp_path_factory):
    out = tmp_path_factory.mktemp("global")
    result = run_atlas("planar3", out=out, workers=0, **SETTINGS)
    return result


def _movements(planar3):
    return draw_population(planar3, PopulationSpec(paths=3, durations=(0.5,), seed=5))


def _line(movement):
    return StraightLine(movement.direction, accel=ACCEL, duration=movement.duration, start=movement.start)


def test_global_rows_equal_optimize_run_directly(global_atlas, planar3):
    """Every path has one global-optimum row, and it is torqueopt.optimize on the same start, line and duration
    (end free, pinv's warm start): its status, cost, peak torque ratio and replay tip error."""
    table = global_atlas.table
    rows = table[table["resolver"] == GLOBAL_RESOLVER].set_index("path")
    assert sorted(rows.index) == [0, 1, 2]
    for movement in _movements(planar3):
        solved = torqueopt.optimize(planar3, _line(movement), movement.q0, end="free", transcription="direct")
        row = rows.loc[movement.path]
        assert row["optimizer_status"] == solved.status == "converged"
        assert row["optimizer_iterations"] == solved.iterations
        assert row["cost"] == pytest.approx(solved.cost, rel=1e-9)
        assert row["peak_torque_ratio"] == pytest.approx(float(solved.peak_torque_ratio.max()), rel=1e-12)
        assert row["replay_tip_error"] == pytest.approx(solved.replay_tip_error, rel=1e-9)
        # The verdict's tip error is the replay's too, and the replay stays on the path.
        assert row["max_tip_error"] == pytest.approx(solved.replay_tip_error, rel=1e-6) and row["max_tip_error"] < 1e-4
        assert row["verdict"] == "stable" and row["cost_vs_global"] == 1.0 and row["peak_vs_global"] == 1.0
        assert math.isnan(row["peak_stability_margin"])  # no resolver closed loop


def test_cost_is_the_rectangle_sum_of_a_simulate_runs_torques(global_atlas, planar3):
    """cost = Σ_j dt ‖τ_j‖² over the applied torques (not the sample at T) of an independent simulate run,
    τ_mid = 0 for planar3's symmetric limits; and the ratios to the global optimum are those costs' ratios."""
    table = global_atlas.table.set_index(["path", "resolver"])
    assert np.all(planar3.torque_upper == -planar3.torque_lower)
    for movement in _movements(planar3):
        global_cost = table.loc[(movement.path, GLOBAL_RESOLVER), "cost"]
        for name in ("pinv", "null-space"):
            run = torqueopt.simulate(planar3, name, _line(movement), movement.q0, dt=1e-3)
            assert np.isnan(run.tau[-1]).all() and len(run.t) == 501
            expected = 1e-3 * float(np.sum(run.tau[:-1] ** 2))
            row = table.loc[(movement.path, name)]
            assert row["cost"] == pytest.approx(expected, rel=1e-8)
            assert row["cost_vs_global"] == pytest.approx(expected / global_cost, rel=1e-8)
            assert row["peak_vs_global"] == pytest.approx(
                row["peak_torque_ratio"] / table.loc[(movement.path, GLOBAL_RESOLVER), "peak_torque_ratio"]
            )
            # The optimum is the cheapest of the tracking runs, as its end is free.
            assert row["cost_vs_global"] > 1.0


def test_a_path_where_the_optimiser_does_not_converge_keeps_its_row(tmp_path):
    """One IPOPT iteration per Hessian: the path's row is there, says how the solve ended, has no ratios, and the
    report counts it."""
    result = run_atlas(
        "planar3", out=tmp_path, workers=0, **{**SETTINGS, "paths": 1, "margin": False, "global_max_iterations": 1}
    )
    table = result.table
    row = table[table["resolver"] == GLOBAL_RESOLVER].iloc[0]
    assert row["optimizer_status"] == "iteration limit" and row["optimizer_iterations"] == 2
    assert math.isfinite(row["cost"]) and row["verdict"] in torqueopt.atlas.VERDICTS
    assert table["cost_vs_global"].isna().all() and table["peak_vs_global"].isna().all()
    frontier = result.summary["global"]
    assert frontier["not_converged"] == 1 and frontier["optimizer_status"] == {"iteration limit": 1}
    text = (tmp_path / "atlas.md").read_text()
    assert "| optimiser status | iteration limit 1 |" in text and "| problem-free where it converged | 0 of 0 |" in text


def test_margin_columns_on_the_papers_long_movement(planar3):
    """null-space whips on the paper's long movement (Fig. 4): its peak margin is the largest of
    torqueopt.stability_margin at the states every 20 ms up to the instability, and the margin turned positive
    well before it."""
    line = StraightLine((1.0, 1.0), accel=ACCEL, duration=2.0)
    run = torqueopt.simulate(planar3, "null-space", line, PAPER_Q0, dt=1e-3)
    kinetic, self_energy = self_motion_energy(planar3, run)
    pinv_peak = float(np.nanmax(torqueopt.simulate(planar3, "pinv", line, PAPER_Q0).torque_ratio[:-1]))
    row = run_row(run, kinetic, self_energy, pinv_peak, Thresholds())
    assert row["verdict"] == "whiplash" and 1.3 < row["instability_time"] < 1.5
    resolver = torqueopt.get_resolver("null-space")
    anchored = line.anchored(planar3.task_position(planar3.configuration(PAPER_Q0))[:2])
    columns = margin_columns(planar3, resolver, run, anchored, row, every=0.02)
    times = np.arange(0.0, row["instability_time"] + 1e-9, 0.02)
    margins = []
    for t in times:
        j = round(t / 1e-3)
        acceleration = anchored.sample(np.array([run.t[j]])).acceleration[0]
        margins.append(torqueopt.stability_margin(planar3, "null-space", run.q[j], run.v[j], acceleration))
    margins = np.array(margins)
    assert columns["margin_samples"] == len(times)
    assert columns["peak_stability_margin"] == pytest.approx(margins.max(), rel=1e-9)
    first = times[np.argmax(margins > 0)]
    assert columns["margin_warning_time"] == pytest.approx(row["instability_time"] - first, abs=1e-12)
    assert columns["margin_warning_time"] > 0.3


def test_the_atlas_margin_is_the_largest_stability_margin_of_the_sampled_states(global_atlas, planar3):
    table = global_atlas.table.set_index(["path", "resolver"])
    movement = _movements(planar3)[1]
    run = torqueopt.simulate(planar3, "pinv", _line(movement), movement.q0)
    acceleration = _line(movement).sample(run.t).acceleration
    rows = np.arange(0, 500, 20)  # every 20 ms, the applied rows (not t = T)
    expected = max(torqueopt.stability_margin(planar3, "pinv", run.q[j], run.v[j], acceleration[j]) for j in rows)
    row = table.loc[(movement.path, "pinv")]
    assert row["margin_samples"] == len(rows) and row["verdict"] != "whiplash"
    assert row["peak_stability_margin"] == pytest.approx(expected, rel=1e-6)
    assert math.isnan(row["margin_warning_time"])


def test_auc_is_the_pairwise_probability_and_the_roc_is_monotone():
    rng = np.random.default_rng(3)
    labels = rng.random(300) < 0.3
    scores = np.round(rng.normal(size=300) + 1.2 * labels, 1)  # rounded: ties
    pairs = scores[labels][:, None] - scores[~labels][None, :]
    expected = (np.count_nonzero(pairs > 0) + 0.5 * np.count_nonzero(pairs == 0)) / pairs.size
    assert auc(scores, labels) == pytest.approx(expected, rel=1e-12)
    fpr, tpr, thresholds = roc_curve(scores, labels)
    assert fpr[0] == tpr[0] == 0 and fpr[-1] == tpr[-1] == 1
    assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0) and np.all(np.diff(thresholds) < 0)
    assert math.isnan(auc(scores, np.ones(300, bool)))


def test_the_global_work_is_bounded_up_front(tmp_path):
    with pytest.raises(InvalidInput, match=r"a global optimum counted as 25 runs\), more than max_steps"):
        run_atlas(
            "planar3", out=tmp_path / "a", paths=1000, durations=(2.0,), global_optimum=True, max_steps=10_000_000
        )
    assert not (tmp_path / "a").exists()


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--global", "--global-max-time", "0"], "global-max-time"),
        (["--global", "--global-max-iterations", "0"], "global-max-iterations"),
        (["--margin", "--margin-every", "0.0001"], "margin_every=0.0001 s is shorter than the step"),
        (["--global-bounded"], "--global-bounded (global_bounded=True) says how the global optimum is solved: give"),
    ],
)
def test_cli_bad_global_and_margin_options_are_one_line_and_exit_2(tmp_path, capsys, arguments, message):
    code = main(["atlas", "--paths", "1", "--durations", "0.5", "--out", str(tmp_path / "x"), *arguments])
    captured = capsys.readouterr()
    assert code == 2 and message in captured.err and len(captured.err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_a_killed_global_sweep_resumes_and_keeps_its_global_rows(global_atlas, tmp_path):
    """SIGKILL the CLI once a global chunk has landed, run the same command again: the table equals the
    uninterrupted one, its global rows included."""
    out = tmp_path / "killed"
    command = [
        sys.executable, "-m", "torqueopt", "atlas", "--robot", "planar3", "--paths", "3", "--durations", "0.5",
        "--resolvers", "pinv,null-space", "--seed", "5", "--chunk-size", "2", "--workers", "0", "--no-progress",
        "--no-figures", "--global", "--margin", "--out", str(out),
    ]  # fmt: skip
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen(command, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    chunks = out / "chunks"
    deadline = time.monotonic() + 120
    # Chunks 0 and 1 are the resolvers' (paths 0-1, path 2), 2 and 3 the global optimum's of the same paths, sent
    # path by path: 0, 2, 1, 3 (in that order without Dask).
    while time.monotonic() < deadline and process.poll() is None:
        if (chunks / "chunk-000002.parquet").is_file():
            break
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    landed = sorted(path.name for path in chunks.glob("chunk-*.parquet"))
    assert landed[:2] == ["chunk-000000.parquet", "chunk-000002.parquet"] and len(landed) < 4
    assert not (out / "results.parquet").exists()
    finished = subprocess.run(command, env=environment, capture_output=True, text=True, timeout=300, check=False)
    assert finished.returncode == 0, finished.stderr
    assert f"{len(landed)} chunks resumed from an earlier run" in finished.stdout
    pandas.testing.assert_frame_equal(_table(out), _table(global_atlas.out))


def test_the_report_of_a_stopped_sweep_is_its_whole_prefix_of_paths(global_atlas, tmp_path):
    """Without the chunks of path 2 (a sweep stopped before them), prefix_report writes the report of paths 0-1,
    whose rows are the finished atlas's rows of those paths."""
    import shutil

    from torqueopt.atlas.prefix import prefix_report

    copy = tmp_path / "stopped"
    shutil.copytree(global_atlas.out, copy)
    for name in ("chunk-000001.parquet", "chunk-000003.parquet", "results.parquet"):
        (copy / "chunks" / name).unlink(missing_ok=True)
    (copy / "results.parquet").unlink()
    summary = prefix_report(copy, tmp_path / "report", note="The first {paths} paths.")
    assert summary["partial"] == {"paths": 2, "of": 3} and summary["paths"] == 2
    expected = _table(global_atlas.out)
    expected = expected[expected["path"] < 2].reset_index(drop=True)

    def plain(frame):  # an all-missing text column reads back as None from one file and NaN from the other
        return frame.astype(object).where(frame.notna(), None)

    pandas.testing.assert_frame_equal(plain(_table(tmp_path / "report")), plain(expected))
    text = (tmp_path / "report" / "atlas.md").read_text()
    assert text.splitlines()[2] == "The first 2 paths." and "## The global optimum against the local methods" in text
    assert (tmp_path / "report" / "tradeoff.png").is_file() and (tmp_path / "report" / "margin_roc.png").is_file()


def test_the_readme_answer_is_generated_from_the_committed_global_atlas():
    """The README's answer to the paper's broader question is what broader_answer writes from docs/atlas/global.json
    (readme_answer leaves the README as it is)."""
    from torqueopt.atlas.frontier import ANSWER_BEGIN, ANSWER_END, broader_answer, readme_answer

    summary = json.loads((ROOT / "docs" / "atlas" / "global.json").read_text())
    readme = (ROOT / "README.md").read_text()
    assert readme.count(ANSWER_BEGIN + "\n") == 1 and readme.count("\n" + ANSWER_END) == 1
    assert readme.split(ANSWER_BEGIN + "\n", 1)[1].split("\n" + ANSWER_END, 1)[0] == broader_answer(summary)
    assert readme_answer(readme, summary) == readme
    # The committed rows are the atlas the page and its summary were made from.
    rows = pandas.read_parquet(ROOT / "docs" / "atlas" / "global" / "results.parquet")
    assert len(rows) == summary["rows"] and rows["path"].nunique() == summary["paths"]
    assert (rows["resolver"] == GLOBAL_RESOLVER).sum() == summary["global"]["paths"]


def test_the_page_and_the_readme_answer_are_rewritten_from_an_atlas_folder(global_atlas, tmp_path):
    """write_atlas_page copies the report, its summary, its rows and the trade-off figure into the docs' folder,
    the note under the title; readme_answer replaces the old paragraph by the new atlas's; bad input says why."""
    from torqueopt.atlas.frontier import ANSWER_BEGIN, ANSWER_END, broader_answer
    from torqueopt.atlas.prefix import main as frontier
    from torqueopt.atlas.prefix import prefix_report

    report = tmp_path / "report"
    prefix_report(global_atlas.out, report)  # a folder with every file a finished atlas has, figures drawn
    docs = tmp_path / "docs"
    assert frontier(["page", str(report), str(docs), "global", "What ran."]) == 0
    page = (docs / "global.md").read_text()
    assert page.splitlines()[:3] == ["# Stability atlas: planar3 (xy task)", "", "What ran."]
    assert "![tradeoff.png](global_tradeoff.png)" in page and "margin_roc.png" in page and "explorer" not in page
    assert (docs / "global_tradeoff.png").read_bytes() == (report / "tradeoff.png").read_bytes()
    assert json.loads((docs / "global.json").read_text()) == json.loads((report / "atlas.json").read_text())
    pandas.testing.assert_frame_equal(
        pandas.read_parquet(docs / "global" / "results.parquet"), pandas.read_parquet(report / "results.parquet")
    )
    # Given the sweep's own folder, the page is the same (the report of its paths written again).
    assert frontier(["page", str(global_atlas.out), str(tmp_path / "again"), "global", "What ran."]) == 0
    assert (tmp_path / "again" / "global.md").read_text() == page
    assert json.loads((tmp_path / "again" / "global.json").read_text()) == json.loads(
        (docs / "global.json").read_text()
    )
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\n{ANSWER_BEGIN}\nthe old answer\n{ANSWER_END}\n\nthe rest\n")
    assert frontier(["readme", str(readme), str(docs / "global.json")]) == 0
    summary = json.loads((docs / "global.json").read_text())
    assert readme.read_text() == f"# title\n\n{ANSWER_BEGIN}\n{broader_answer(summary)}\n{ANSWER_END}\n\nthe rest\n"
    assert " on 3 random 0.5 s movements of planar3 " in " ".join(readme.read_text().split())
    readme.write_text("no markers\n")
    with pytest.raises(ValueError, match="broader-answer"):
        frontier(["readme", str(readme), str(docs / "global.json")])
    with pytest.raises(InvalidInput, match="no finished atlas report"):
        frontier(["page", str(tmp_path / "nothing"), str(docs), "x"])


def test_the_frontier_counts_against_a_hand_made_table():
    """Four paths, two local methods and the optimum (path 3's did not converge): the problem-free shares, the
    failures where the optimum is problem-free, the most successful method and the median cost ratios, by hand."""
    from torqueopt.atlas.frontier import global_summary

    rows = []
    for path, (a, b, g) in enumerate(
        [
            # (verdict, peak, cost) of method a, method b, the optimum
            (("stable", 0.9, 20.0), ("whiplash", 5.0, 900.0), ("stable", 0.8, 10.0)),
            (("stable", 1.2, 30.0), ("stable", 0.9, 15.0), ("stable", 0.7, 10.0)),
            (("lost path", 0.5, 40.0), ("stable", 0.9, 12.0), ("stable", 1.5, 8.0)),
            (("stable", 0.9, 20.0), ("stable", 0.9, 25.0), ("stable", 0.9, 5.0)),
        ]
    ):
        for name, (verdict, peak, cost) in (("a", a), ("b", b), (GLOBAL_RESOLVER, g)):
            rows.append({"path": path, "resolver": name, "verdict": verdict, "peak_torque_ratio": peak, "cost": cost})
    table = pandas.DataFrame(rows)
    table["optimizer_status"] = np.where(
        table["resolver"] == GLOBAL_RESOLVER, np.where(table["path"] == 3, "iteration limit", "converged"), None
    )
    for column in ("optimizer_iterations", "replay_tip_error", "torque_vs_pinv"):
        table[column] = 1.0
    from torqueopt.atlas.global_optimum import add_global_ratios

    summary = global_summary(add_global_ratios(table))
    # The optimum is problem-free on paths 0, 1, 3 (path 2: over a limit); a on 0, 3; b on 1, 2, 3.
    assert summary["problem_free"]["successes"] == 3 and summary["converged"] == 3 and summary["not_converged"] == 1
    assert summary["local"]["a"]["problem_free"]["successes"] == 2
    assert summary["local"]["a"]["fails_where_global_is_problem_free"] == 1  # path 1
    assert summary["local"]["b"]["fails_where_global_is_problem_free"] == 1  # path 0
    assert summary["most_successful_local"] == "b" and summary["completely_successful"] == []
    # Ratios on the converged paths 0-2 only: a 2, 3, 5; b 90, 1.5, 1.5.
    assert summary["local"]["a"]["median_cost_vs_global"] == 3.0
    assert summary["local"]["b"]["median_cost_vs_global"] == 1.5
    assert summary["cheapest_local"] == "b"
    assert summary["median_global_cost_vs_most_successful"] == pytest.approx(np.median([1 / 90, 1 / 1.5, 1 / 1.5]))


def test_the_answer_says_how_the_method_with_the_energy_bound_fares():
    """With energy-bounded-torque among the local methods (not the most successful), the README's answer gives its
    whips, its problem-free share and its lost paths, counted from the rows."""
    from torqueopt.atlas.frontier import GUARANTEED, broader_answer, global_summary
    from torqueopt.atlas.global_optimum import add_global_ratios

    rows = []
    for path in range(5):
        lost = path < 3
        for name, verdict, peak in (
            ("pinv", "stable", 0.9),
            (GUARANTEED, "lost path" if lost else "stable", 0.8),
            (GLOBAL_RESOLVER, "stable", 0.7),
        ):
            rows.append({"path": path, "resolver": name, "verdict": verdict, "peak_torque_ratio": peak, "cost": 2.0})
    table = pandas.DataFrame(rows)
    table["optimizer_status"] = np.where(table["resolver"] == GLOBAL_RESOLVER, "converged", None)
    for column in ("optimizer_iterations", "replay_tip_error", "torque_vs_pinv"):
        table[column] = 1.0
    frontier = global_summary(add_global_ratios(table))
    assert frontier["local"][GUARANTEED]["lost_path"] == 3 and frontier["local"]["pinv"]["lost_path"] == 0
    text = " ".join(
        broader_answer({"global": frontier, "config": {"robot_name": "planar3"}, "durations": [2.0]}).split()
    )
    assert "Yes, on 5 random 2 s movements of planar3" in text and "`pinv` is problem-free" in text
    assert (
        f"`{GUARANTEED}`, the local method with a bound on the self-motion energy, whips on 0 % [0, 43] of the paths "
        "but is problem-free on 40 % [12, 77]: it leaves the path (the tip more than 1 mm off) on 3 of 5." in text
    )


def test_a_diverging_replay_stops_at_simulates_speed_ceiling_without_warnings(planar3):
    """A global row's open-loop replay that runs away is cut where ``simulate`` would stop it.

    Joint 3 of planar3 driven by a torque growing as e^(800 t) spins past
    1000 rad/s and, unstopped, to states whose kinetic energy overflows a
    float (the three runaway replays of the 1000-path global atlas did): the
    rows must end at the last state under the ceiling, with the speed stop's
    words, and the verdict's energies must come out without a floating-point
    warning.
    """
    import warnings
    from types import SimpleNamespace

    from torqueopt.atlas.global_optimum import replay_result
    from torqueopt.optimal import replay_torques

    dt, steps = 1e-3, 500
    t = np.arange(steps + 1) * dt
    tau = np.zeros((steps + 1, 3))
    tau[:, 2] = 1e3 * np.exp(800.0 * t)
    q0 = np.radians([-45.0, 135.0, -135.0])
    line = StraightLine(direction=[1, 1], accel=np.sqrt(2), duration=steps * dt)
    solved = SimpleNamespace(
        tau=tau,
        q=np.tile(q0, (steps + 1, 1)),
        dt=dt,
        t=t,
        acceleration=np.zeros((steps + 1, 3)),
        x_ref=np.zeros((steps + 1, 2)),
        duration=steps * dt,
        trajectory=line,
    )
    raw = replay_torques(planar3, q0, np.zeros(3), tau[:-1], dt)
    with np.errstate(invalid="ignore", over="ignore"):
        first_over = int(np.argmax(~(np.abs(raw.v) <= 1e3).all(axis=1)))
    assert 5 < first_over < steps  # the drive does run away inside the movement
    with np.errstate(over="ignore"):
        assert not np.isfinite(0.5 * (raw.v**2).sum(axis=1)).all()  # and beyond float range unstopped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = replay_result(planar3, solved)
        kinetic, self_energy = self_motion_energy(planar3, result)
        row = run_row(result, kinetic, self_energy, 1.0, Thresholds())
    assert len(result.t) == first_over
    assert np.abs(result.v).max() <= 1e3
    assert result.stop_time == pytest.approx(t[first_over])
    assert "speed of joint joint" in result.stop_reason and "beyond 1000 rad/s" in result.stop_reason
    assert math.isfinite(row["peak_self_motion_energy"])


def test_the_margin_guide_quotes_the_800_path_report_whose_auc_is_the_mann_whitney_statistic():
    """The committed 800-path margin report (docs/atlas/margin800): its held-out AUC equals the Mann-Whitney U
    statistic of the rows' peak margins (whips against the rest) over n₁n₀, scipy's, not ours; its threshold's
    rates are the rows' counts; and the guide and the discussion quote these figures."""
    from scipy.stats import mannwhitneyu

    rows = pandas.read_parquet(ROOT / "docs" / "atlas" / "margin800" / "results.parquet")
    margin = json.loads((ROOT / "docs" / "atlas" / "margin800.json").read_text())["margin"]
    held_out = rows[(rows["path"] % 2 == 1) & np.isfinite(rows["peak_stability_margin"])]
    whips = (held_out["verdict"] == "whiplash").to_numpy()
    scores = held_out["peak_stability_margin"].to_numpy(float)
    statistic = mannwhitneyu(scores[whips], scores[~whips]).statistic
    assert statistic / (whips.sum() * (~whips).sum()) == pytest.approx(margin["auc"], abs=1e-12)
    assert (margin["held_out_runs"], margin["held_out_whips"]) == (len(held_out), whips.sum()) == (2800, 793)
    threshold = margin["at_threshold"]["threshold"]
    assert margin["at_threshold"]["true_positive_rate"]["successes"] == (scores[whips] >= threshold).sum()
    assert margin["at_threshold"]["false_positive_rate"]["successes"] == (scores[~whips] >= threshold).sum()
    guide = (ROOT / "docs" / "guide" / "stability-margin.md").read_text()
    discussion = (ROOT / "docs" / "discussion" / "global-atlas.md").read_text()
    for text in (guide, discussion):
        assert f"**AUC {margin['auc']:.3f}**" in text and f"**σ ≥ {threshold:.2f} 1/s**" in text
        assert f"{100 * margin['at_threshold']['true_positive_rate']['fraction']:.1f} %" in text


@pytest.mark.slow
def test_a_path_no_motion_can_do_within_the_limits_is_infeasible_for_every_resolver(planar3):
    """--global-bounded on a path whose torque limits are a hundredth of gravity's static torque at the start: the row's
    verdict is 'infeasible for every resolver' (not 'too demanding', not an iteration limit), with phase-1's evidence;
    with the URDF's limits the same path is feasible and keeps a verdict of its own."""
    import pinocchio as pin

    from torqueopt.atlas.global_optimum import global_row, settings
    from torqueopt.atlas.verdicts import INFEASIBLE

    movement = _movements(planar3)[0]
    robot = planar3.with_gravity([0.0, -9.81, 0.0])
    q0 = robot.configuration(movement.q0)
    static = np.abs(pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q0))
    bounded = settings(500, 120.0, bounded=True)
    assert bounded["torque_bounds"] and bounded["joint_limits"] and bounded["transcription"] == "shooting"
    bounded.update(grid_step=0.02, compiled=False)  # a coarser grid and no compile, for the test's time
    with pytest.warns(torqueopt.TorqueoptWarning, match="holding the start against gravity"):
        row, _ = global_row(
            robot.with_torque_limit(0.01 * static), movement, dt=1e-3, thresholds=Thresholds(), settings=bounded
        )
    assert row["optimizer_status"] == "infeasible", row
    assert row["verdict"] == INFEASIBLE
    assert row["optimizer_evidence"].startswith(
        "phase-1: the least excess over the limits of a motion along the path is"
    )
    assert row["optimizer_excess"] > 1.0  # the limits are a hundredth of what holding the start needs
    row, _ = global_row(planar3, movement, dt=1e-3, thresholds=Thresholds(), settings=bounded)
    assert row["optimizer_status"] == "converged" and row["verdict"] != INFEASIBLE
    assert row["optimizer_evidence"] == "" and math.isnan(row["optimizer_excess"])


def test_problem_free_shares_over_the_feasible_paths_beside_the_raw_ones():
    """Four paths, one local method (pinv, 'a' below): under --global-bounded path 2 is infeasible for every resolver. Raw shares count
    it, the feasible shares do not: by hand, a is problem-free on paths 0 and 3 -> 2/4 raw, 2/3 feasible; the optimum
    on 0, 1, 3 -> 3/4, 3/3."""
    from torqueopt.atlas.frontier import frontier_markdown, global_summary
    from torqueopt.atlas.global_optimum import add_global_ratios
    from torqueopt.atlas.verdicts import INFEASIBLE

    rows = []
    for path, (a, g) in enumerate(
        [
            (("stable", 0.9), ("stable", 0.8)),
            (("whiplash", 5.0), ("stable", 0.7)),
            (("too demanding", 3.0), (INFEASIBLE, 1.2)),
            (("stable", 0.9), ("stable", 0.9)),
        ]
    ):
        for name, (verdict, peak) in (("pinv", a), (GLOBAL_RESOLVER, g)):
            rows.append({"path": path, "resolver": name, "verdict": verdict, "peak_torque_ratio": peak, "cost": 1.0})
    table = pandas.DataFrame(rows)
    is_global = table["resolver"] == GLOBAL_RESOLVER
    table["optimizer_status"] = np.where(is_global, np.where(table["path"] == 2, "infeasible", "converged"), None)
    table["optimizer_excess"] = np.where(is_global & (table["path"] == 2), 0.2, np.nan)
    for column in ("optimizer_iterations", "replay_tip_error", "torque_vs_pinv"):
        table[column] = 1.0
    table = add_global_ratios(table)
    assert table["infeasible_path"].tolist() == [False, False, False, False, True, True, False, False]
    summary = global_summary(table)
    assert summary["feasible_paths"] == 3 and summary["infeasible_paths"] == 1
    assert (summary["problem_free"]["successes"], summary["problem_free"]["trials"]) == (3, 4)
    assert (summary["problem_free_of_feasible"]["successes"], summary["problem_free_of_feasible"]["trials"]) == (3, 3)
    local = summary["local"]["pinv"]
    assert (local["problem_free"]["successes"], local["problem_free"]["trials"]) == (2, 4)
    assert local["problem_free_of_feasible"]["fraction"] == pytest.approx(2 / 3)
    # The report: the feasible shares stand beside the raw ones.
    markdown = "\n".join(
        frontier_markdown({"global": summary, "config": {"robot_name": "planar3"}, "durations": [0.5]})
    )
    assert f"| infeasible paths (no motion within the limits, verdict `{INFEASIBLE}`) | 1 of 4 |" in markdown
    assert "| pinv | 50.0% [15.0%, 85.0%] | 66.7% [20.8%, 93.9%] |" in markdown  # Wilson 95 % of 2/4 and of 2/3
