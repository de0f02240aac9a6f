"""The stability atlas: population, verdicts, statistics, the Dask sweep, resume after a kill, the CLI."""

import importlib.util
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

# The atlas is an extra (pip install torqueopt[atlas]): without it these tests skip, saying so.
# Dask is only looked for, not imported (that takes a third of a second): most tests here
# sweep in-process, and the sweep imports Dask itself when it needs it.
pandas = pytest.importorskip("pandas")
if importlib.util.find_spec("distributed") is None:
    pytest.skip("could not find 'distributed': the atlas needs dask[distributed]", allow_module_level=True)
pytest.importorskip("pyarrow")
pytest.importorskip("tqdm")

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population, run_atlas
from torqueopt.atlas.jobs import ResolverChunk, RobotSpec
from torqueopt.atlas.population import Movement, arm_reach, path_length
from torqueopt.atlas.stats import claims, proportion, unstable_fractions, wilson_interval
from torqueopt.atlas.sweep import resolvers_from, run_chunk
from torqueopt.atlas.verdicts import VERDICT_COLOURS, Thresholds, self_motion_energy
from torqueopt.batch import simulate_batch
from torqueopt.cli import main
from torqueopt.errors import InvalidInput, MissingDependency

from .conftest import PAPER_Q0

PAPER_RESOLVERS = ["pinv", "inertia-pinv", "null-space", "weighted-null-space"]
ROOT = Path(__file__).resolve().parents[1]
SMALL = {"paths": 6, "durations": (0.3, 1.8), "chunk_size": 4, "progress": False, "figures": False}


# -- statistics ----------------------------------------------------------------------


@pytest.mark.parametrize("successes, trials", [(0, 10), (5, 10), (10, 10), (1, 3), (37, 200), (199, 200)])
def test_wilson_interval_solves_the_score_equation(successes, trials):
    """The interval's ends are the two p with |p̂ − p| = z √(p(1−p)/n), the
    roots of (n + z²) p² − (2k + z²) p + k²/n = 0 (numpy.roots, independent)."""
    z = 1.959963984540054
    roots = np.sort(np.roots([trials + z * z, -(2 * successes + z * z), successes**2 / trials]).real)
    low, high = wilson_interval(successes, trials)
    assert low == pytest.approx(max(roots[0], 0.0), abs=1e-12)
    assert high == pytest.approx(min(roots[1], 1.0), abs=1e-12)


def wilson_closed_form(k, n, z=1.959963984540054):
    """The Wilson score interval as torqueopt.atlas.stats writes it (z: the normal quantile of the level)."""
    p = k / n
    denominator = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


def test_wilson_interval_by_scipy_is_the_closed_form_score_interval():
    """For every k of n <= 60, a few large n, and another level."""
    cases = [(k, n) for n in range(1, 61) for k in range(n + 1)] + [(37, 1000), (0, 10000), (9999, 10000), (5, 40000)]
    for k, n in cases:
        assert wilson_interval(k, n) == pytest.approx(wilson_closed_form(k, n), abs=1e-14), (k, n)
    assert wilson_interval(3, 10, confidence_level=0.99) == pytest.approx(
        wilson_closed_form(3, 10, z=2.5758293035489004), abs=1e-14
    )


def test_scipy_stats_imported_meanwhile_is_the_one_the_intervals_use():
    """The report's SciPy import, started on a thread while the workers compute, loads scipy.stats once and
    the intervals read it (checked in a fresh interpreter, where nothing imported it before)."""
    code = (
        "import sys, threading\n"
        "from torqueopt.atlas.stats import import_scipy_stats_meanwhile, wilson_interval\n"
        "assert 'scipy.stats' not in sys.modules\n"
        "import_scipy_stats_meanwhile()\n"
        "[t.join() for t in threading.enumerate() if t.name == 'import scipy.stats']\n"
        "imported = 'scipy.stats' in sys.modules\n"
        "low, high = wilson_interval(0, 10)\n"
        "print(imported, round(high, 7))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "0.2775328"]


@pytest.mark.slow
@pytest.mark.parametrize("chunks", [1, 2, 5])
def test_the_report_imports_start_once_a_worker_has_no_chunk_left(tmp_path, monkeypatch, chunks):
    """Started with the sweep, scipy.stats's import took 1.3-1.6 s of CPU from two workers on two cores; now it
    starts once fewer chunks are left than worker threads: with 2 threads and 5 chunks, after the fourth has
    come back (3 written), with 1 chunk at once."""
    import distributed

    from torqueopt.atlas import sweep

    monkeypatch.setattr(sweep, "chunk_output", lambda job: sweep.ChunkOutput([{"path": job.movements[0]}], None))
    jobs = {
        index: ResolverChunk(RobotSpec("planar3"), (), (index,), 1e-3, Thresholds(), True, "0" * 16)
        for index in range(chunks)
    }
    written_when_called = []

    def note():
        written_when_called.append(len(list((tmp_path / "chunks").glob("chunk-*.parquet"))))

    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as client:
        frames = sweep.run_chunks(
            jobs, tmp_path, client, progress=False, total_paths=chunks, done_paths=0, description="",
            once_a_worker_idles=note,
        )  # fmt: skip
    assert sorted(frames) == list(range(chunks))
    assert written_when_called == [max(chunks - 2, 0)]


def test_the_reach_is_sampled_once_per_robot_and_handed_out_as_a_copy(panda):
    base, reach = arm_reach(panda, samples=64)
    base[:] = 99.0
    again, reach_again = arm_reach(panda, samples=64)
    assert reach_again == reach and not np.allclose(again, 99.0)
    data = panda.model.createData()
    for q in np.random.default_rng(3).uniform(panda.model.lowerPositionLimit, panda.model.upperPositionLimit, (64, 7)):
        pin.framesForwardKinematics(panda.model, data, q)
        assert np.linalg.norm(data.oMf[panda.frame_id].translation - again) < 1.3 * reach


def test_wilson_interval_known_values():
    # 0 of 10: upper end z²/(n + z²) = 0.27753; 5 of 10: 0.5 ± 0.26342 (Wilson 1927 / Agresti & Coull 1998 tables).
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775328), abs=1e-6)
    assert wilson_interval(5, 10) == pytest.approx((0.2365931, 0.7634069), abs=1e-6)
    assert all(math.isnan(x) for x in wilson_interval(0, 0))


def _synthetic_table(rng, paths=120):
    rows = []
    for path in range(paths):
        duration = [0.5, 2.0][path % 2]
        flags = rng.random(4) < [0.05, 0.3, 0.5, 0.6] if duration == 2.0 else rng.random(4) < 0.1
        for resolver, flag in zip(PAPER_RESOLVERS, flags):
            whip = bool(flag and rng.random() < 0.7)
            rows.append(
                {
                    "path": path,
                    "duration": duration,
                    "resolver": resolver,
                    "unstable": bool(flag),
                    "verdict": "whiplash" if whip else ("too demanding" if flag else "stable"),
                }
            )
    return pandas.DataFrame(rows)


def test_claims_and_fractions_against_a_direct_count(rng):
    table = _synthetic_table(rng)
    records = table.to_dict("records")
    for criterion, flag_of in (
        ("unstable", lambda r: r["unstable"]),
        ("whiplash", lambda r: r["verdict"] == "whiplash"),
    ):
        flag = {(r["path"], r["resolver"]): flag_of(r) for r in records}
        fractions = unstable_fractions(table, criterion)
        for item in fractions:
            chosen = [r for r in records if r["resolver"] == item["resolver"] and r["duration"] == item["duration"]]
            assert item["trials"] == len(chosen)
            assert item["successes"] == sum(flag_of(r) for r in chosen)
        paths = sorted({r["path"] for r in records})
        long_paths = [p for p in paths if p % 2 == 1]
        by_claim = {c["figure"].split(",")[0].split(" on the")[0]: c for c in claims(table, criterion)}
        ns = by_claim["null-space unstable"]
        assert (ns["successes"], ns["trials"]) == (sum(flag[p, "null-space"] for p in long_paths), len(long_paths))
        pv = by_claim["pinv unstable"]
        assert pv["successes"] == sum(flag[p, "pinv"] for p in long_paths)
        only_w = by_claim["weighted-null-space unstable and null-space not"]
        assert only_w["successes"] == sum(flag[p, "weighted-null-space"] and not flag[p, "null-space"] for p in paths)
        assert only_w["trials"] == len(paths)
        only_n = by_claim["null-space unstable and weighted-null-space not"]
        assert only_n["successes"] == sum(flag[p, "null-space"] and not flag[p, "weighted-null-space"] for p in paths)
        assert only_n["holds"] == ("yes" if only_n["successes"] == 0 else "no")
        given = by_claim["P(inertia-pinv unstable | null-space unstable)"]
        assert given["trials"] == sum(flag[p, "null-space"] for p in paths)
        assert given["successes"] == sum(flag[p, "null-space"] and flag[p, "inertia-pinv"] for p in paths)
        low, high = wilson_interval(given["successes"], given["trials"])
        assert (given["low"], given["high"]) == (low, high)
    assert proportion(3, 4).text() == "75.0% (3/4; 95% CI 30.1%-95.4%)"


# -- population ------------------------------------------------------------------


def test_population_is_seeded_and_obeys_its_acceptance_rules(planar3):
    spec = PopulationSpec(paths=40, durations=(0.5, 2.0), seed=11, reach_fraction=0.8, min_condition=0.2)
    movements = draw_population(planar3, spec)
    again = draw_population(planar3, spec)
    assert [m.path for m in movements] == list(range(80))
    assert all(
        np.array_equal(a.q0, b.q0) and np.array_equal(a.direction, b.direction) for a, b in zip(movements, again)
    )
    data = planar3.model.createData()
    for movement in movements:
        q = planar3.configuration(movement.q0)
        tip = planar3.task_position(q)
        assert np.allclose(tip, movement.start)
        assert movement.accel == math.sqrt(2.0)  # the default on planar3: √2 m/s² x reach 3 m / 3 m
        end = tip + path_length(movement.accel, movement.duration) * movement.direction
        assert np.linalg.norm(tip) <= 0.8 * 3.0 + 1e-12 and np.linalg.norm(end) <= 0.8 * 3.0 + 1e-12
        assert np.linalg.norm(movement.direction) == pytest.approx(1.0)
        jacobian = pin.computeFrameJacobian(planar3.model, data, q, planar3.frame_id, pin.LOCAL_WORLD_ALIGNED)[:2]
        singular_values = np.linalg.svd(jacobian, compute_uv=False)
        assert singular_values[-1] / singular_values[0] >= 0.2
    # Another seed draws other movements; another list of durations keeps the 2 s ones.
    other = draw_population(
        planar3, PopulationSpec(paths=40, durations=(0.5, 2.0), seed=12, reach_fraction=0.8, min_condition=0.2)
    )
    assert not np.allclose(other[0].q0, movements[0].q0)
    only_long = draw_population(
        planar3, PopulationSpec(paths=40, durations=(2.0,), seed=11, reach_fraction=0.8, min_condition=0.2)
    )
    assert all(np.array_equal(a.q0, b.q0) for a, b in zip(only_long, movements[40:]))
    # Directions are uniform on the circle: the mean resultant of 2000 draws is near zero.
    many = draw_population(planar3, PopulationSpec(paths=2000, durations=(0.3,), seed=1))
    resultant = np.linalg.norm(np.mean([m.direction for m in many], axis=0))
    assert resultant < 4 / math.sqrt(2000)


def test_reach_and_grid_mode(planar3):
    base, reach = arm_reach(planar3)
    assert np.allclose(base, 0.0) and reach == 3.0
    spec = PopulationSpec(mode="grid", durations=(0.5,), grid_spacing=0.5, grid_directions=4, reach_fraction=0.9)
    movements = draw_population(planar3, spec)
    starts = {tuple(np.round(m.start, 9)) for m in movements}
    assert len(starts) > 20
    for movement in movements:
        assert np.allclose(np.round(movement.start / 0.5), movement.start / 0.5)  # on the grid
        assert np.allclose(planar3.task_position(planar3.configuration(movement.q0)), movement.start, atol=1e-9)
    assert {tuple(np.round(m.direction, 12)) for m in movements} <= {(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)}


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"paths": 0}, "paths=0 must be a whole number from 1 to 1,000,000"),
        ({"durations": (0.5, -1)}, r"durations \[0.5, -1.0\] must be 1 to 100 numbers of seconds in \(0, 600\]"),
        ({"mode": "sobol"}, "unknown population mode 'sobol': choose one of random, grid"),
        ({"reach_fraction": 1.5}, r"reach_fraction=1.5 must be a number in \(0, 1\]"),
    ],
)
def test_bad_population_settings(kwargs, message):
    with pytest.raises(InvalidInput, match=message):
        PopulationSpec(**kwargs)


def test_impossible_acceptance_rules_say_what_to_loosen(planar3):
    with pytest.raises(InvalidInput, match="the acceptance rules kept only 0 of 2000 draws for duration 4 s"):
        draw_population(planar3, PopulationSpec(paths=2, durations=(4.0,), max_draws_per_path=1000))


# -- verdicts --------------------------------------------------------------------


PAPER_ACCEL = math.sqrt(2.0)


def _rows(movements, accel=PAPER_ACCEL, resolvers=PAPER_RESOLVERS, batch=True):
    planar3 = torqueopt.load_robot("planar3")
    lines = tuple(
        Movement(i, duration, np.asarray(q0, float), np.asarray(d, float) / np.linalg.norm(d),
                 planar3.task_position(planar3.configuration(q0)), accel=accel)
        for i, (duration, q0, d) in enumerate(movements)
    )  # fmt: skip
    job = ResolverChunk(RobotSpec("planar3"), tuple(resolvers_from(resolvers)), lines, 1e-3, Thresholds(), batch, "")
    return {(row["path"], row["resolver"]): row for row in run_chunk(job)}


@pytest.mark.slow
def test_verdicts_on_the_papers_three_movements():
    """Short (0.5 s) and medium (1.25 s): every resolver stable. Long (2 s): the
    three kinetic methods whip (the paper's Figs. 4 and 6), links 2 and 3 in line
    (joint 3 nearest aligned), while pinv stays stable."""
    rows = _rows([(0.5, PAPER_Q0, (1, 1)), (1.25, PAPER_Q0, (1, 1)), (2.0, PAPER_Q0, (1, 1))])
    for path in (0, 1):
        for name in PAPER_RESOLVERS:
            assert rows[path, name]["verdict"] == "stable" and not rows[path, name]["unstable"]
    assert rows[2, "pinv"]["verdict"] == "stable"
    for name in ("inertia-pinv", "null-space", "weighted-null-space"):
        row = rows[2, name]
        assert row["verdict"] == "whiplash" and row["unstable"] and row["runaway"]
        assert 0.5 < row["instability_time"] < 2.0
        assert row["torque_vs_pinv"] > 2.0
        assert row["aligned_joint"] == "joint3"
        assert row["whip_time"] == row["instability_time"]  # the whip is located at the instability's sample
    assert rows[2, "null-space"]["instability_time"] > 1.0  # "near the movement end"


@pytest.mark.slow
def test_a_path_too_demanding_for_pinv_is_not_called_whiplash():
    """Eight times the paper's acceleration over 0.5 s: pinv itself needs more
    than twice the limits, so every resolver fails the 2x-limit rule, and none
    of it is whiplash."""
    rows = _rows([(0.5, PAPER_Q0, (1, 1))], accel=8.0)
    assert rows[0, "pinv"]["peak_torque_ratio"] > 2.0
    for name in PAPER_RESOLVERS:
        assert rows[0, name]["unstable"] and rows[0, name]["verdict"] == "too demanding"
        assert rows[0, name]["torque_vs_pinv"] < 2.0
    # Six times the acceleration over 0.6 s: weighted-null-space fails later than the
    # first sample, but its torque stays near pinv's and its self-motion small.
    rows = _rows([(0.6, PAPER_Q0, (1, 1))], accel=6.0, resolvers=["pinv", "weighted-null-space"])
    assert rows[0, "weighted-null-space"]["instability_time"] > 0.1
    assert rows[0, "weighted-null-space"]["verdict"] == "too demanding"


def test_row_columns_and_first_violation_against_the_run(planar3):
    rows = _rows([(2.0, PAPER_Q0, (1, 1))], resolvers=["pinv", "null-space"])
    row = rows[0, "null-space"]
    run = torqueopt.simulate(planar3, "null-space", torqueopt.StraightLine([1, 1], duration=2.0), PAPER_Q0)
    applied = run.torque_ratio[:-1]  # the sample at t = T is not an applied torque
    assert row["peak_torque_ratio"] == pytest.approx(applied.max(), rel=1e-9)
    first = np.argmax((applied > 1.0).any(axis=1))
    assert row["first_limit_violation"] == pytest.approx(run.t[first])
    over_two = np.argmax((applied > 2.0).any(axis=1))
    assert row["instability_time"] == pytest.approx(run.t[over_two])
    assert row["max_tip_error"] == pytest.approx(run.max_tip_error, rel=1e-6)
    assert row["pinv_peak_torque_ratio"] == pytest.approx(rows[0, "pinv"]["peak_torque_ratio"])
    assert row["torque_vs_pinv"] == pytest.approx(row["peak_torque_ratio"] / row["pinv_peak_torque_ratio"])
    assert row["q0_1"] == PAPER_Q0[0] and row["direction_1"] == pytest.approx(2**-0.5)


def test_post_hoc_energy_equals_the_batched_one(planar3):
    lines = [torqueopt.StraightLine([1, 1], duration=1.5)]
    (run,), (extra,) = simulate_batch(planar3, "null-space", lines, [PAPER_Q0], extras=True)
    kinetic, self_motion = self_motion_energy(planar3, run)
    assert np.allclose(kinetic, extra.kinetic_energy, rtol=1e-9, atol=1e-12)
    assert np.allclose(self_motion, extra.self_motion_energy, rtol=1e-7, atol=1e-9)


@pytest.mark.slow
def test_unbatched_rows_equal_batched_rows():
    movements = [(1.0, PAPER_Q0, (1, 1)), (1.0, [0.3, 1.2, -0.9], (-1, 0.4))]
    batched, unbatched = _rows(movements, batch=True), _rows(movements, batch=False)
    for key, row in batched.items():
        other = unbatched[key]
        assert row["verdict"] == other["verdict"] and row["unstable"] == other["unstable"]
        for column in ("peak_torque_ratio", "self_motion_energy_ratio", "max_tip_error", "torque_vs_pinv"):
            assert row[column] == pytest.approx(other[column], rel=1e-7), column


# -- the sweep --------------------------------------------------------------------


def _table(out):
    return pandas.read_parquet(Path(out) / "results.parquet")


@pytest.fixture(scope="module")
def reference_atlas(tmp_path_factory):
    """The small atlas run in this process, without Dask: what every other run must reproduce."""
    out = tmp_path_factory.mktemp("reference")
    run_atlas("planar3", out=out, workers=0, seed=5, **SMALL)
    return _table(out)


@pytest.mark.slow
def test_in_process_atlas_files_and_columns(reference_atlas, tmp_path):
    table = reference_atlas
    required = [
        "path",
        "duration",
        "resolver",
        "q0_1",
        "q0_2",
        "q0_3",
        "direction_1",
        "direction_2",
        "resolver_options",
        "unstable",
        "verdict",
        "instability_time",
        "peak_torque_ratio",
        "first_limit_violation",
        "max_tip_error",
    ]
    assert list(table.columns[: len(required)]) == required
    assert len(table) == 12 * 4 and table["path"].nunique() == 12
    assert list(table["resolver"][:4]) == PAPER_RESOLVERS
    assert set(table["verdict"]) <= {
        "stable",
        "whiplash",
        "too demanding",
        "joint limits",
        "singular",
        "lost path",
        "stopped early",
    }


@pytest.mark.slow
def test_local_dask_cluster_gives_the_same_table(reference_atlas, tmp_path):
    result = run_atlas("planar3", out=tmp_path, workers=2, seed=5, **{**SMALL, "figures": True})
    pandas.testing.assert_frame_equal(_table(tmp_path), reference_atlas)
    summary = json.loads((tmp_path / "atlas.json").read_text())
    assert summary["paths"] == 12 and set(summary["claims"]) == {"unstable", "whiplash"}
    for name in ("atlas.md", "unstable_fraction.png", "workspace_map.png", "instability_time.png", "tradeoff.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert "## The paper's claims" in (tmp_path / "atlas.md").read_text().replace("### ", "## ")
    assert result.summary["verdicts"]["pinv"]["stable"] >= 1
    # The whips' table: one row per resolver that whipped, counted again from the rows.
    whipped = reference_atlas[reference_atlas["verdict"] == "whiplash"]
    assert len(whipped)
    for resolver, rows in whipped.groupby("resolver", sort=False):
        joints = ", ".join(f"{joint} {count}" for joint, count in rows["aligned_joint"].value_counts().items())
        assert f"\n| {resolver} | {len(rows)} | {joints} | " in (tmp_path / "atlas.md").read_text()


@pytest.mark.slow
def test_an_atlas_where_nothing_went_unstable_says_so_in_its_histogram(
    reference_atlas, planar3, tmp_path, saved_figures
):
    """With no unstable run, the histogram called legend() on nothing: matplotlib's warning "No artists with
    labels found to put in legend" in the atlas's output, and an empty figure."""
    import warnings

    from torqueopt.atlas.report import summarise, write_figures

    table = reference_atlas.assign(unstable=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        write_figures(table, summarise(table, {}), tmp_path, planar3)
    assert [str(warning.message) for warning in caught] == []
    (hist_ax,) = saved_figures[2].axes
    assert hist_ax.get_legend() is None and not hist_ax.patches
    assert [text.get_text() for text in hist_ax.texts] == ["no run went unstable by the 2x-limit rule"]


@pytest.mark.slow
def test_the_atlas_figures_draw_the_table(reference_atlas, planar3, tmp_path, saved_figures):
    """Each figure read back against a direct count over the table's rows."""
    from torqueopt.atlas.report import summarise, write_figures

    from .drawn import errorbar

    table = reference_atlas
    summary = summarise(table, {})
    made = write_figures(table, summary, tmp_path, planar3)
    assert list(made.values()) == ["unstable_fraction.png", "workspace_map.png", "instability_time.png", "tradeoff.png"]
    fractions, workspace, histogram, tradeoff = saved_figures
    records = table.to_dict("records")
    durations = sorted({r["duration"] for r in records})
    for ax, flag in zip(fractions.axes, (lambda r: r["unstable"], lambda r: r["verdict"] == "whiplash")):
        for resolver in PAPER_RESOLVERS:
            x, y, low, high = errorbar(ax, resolver)
            np.testing.assert_allclose(x, durations, atol=0.05)  # each resolver shifted a little sideways
            for duration, fraction, bar_low, bar_high in zip(durations, y, low, high):
                chosen = [r for r in records if r["resolver"] == resolver and r["duration"] == duration]
                count = sum(flag(r) for r in chosen)
                assert fraction == count / len(chosen)
                assert (bar_low, bar_high) == pytest.approx(wilson_interval(count, len(chosen)), abs=1e-12)
    longest = max(durations)
    for ax, resolver in zip(workspace.axes, PAPER_RESOLVERS):
        drawn = {collection.get_label().split(" (")[0]: collection.get_offsets() for collection in ax.collections}
        for verdict, offsets in drawn.items():
            chosen = [
                r for r in records if r["resolver"] == resolver and r["duration"] == longest and r["verdict"] == verdict
            ]
            np.testing.assert_array_equal(
                np.reshape(offsets, (-1, 2)), [[r["start_1"], r["start_2"]] for r in chosen] or np.zeros((0, 2))
            )
        assert sum(len(offsets) for offsets in drawn.values()) == len(table["path"].unique()) // len(durations)
        from matplotlib.colors import to_rgba

        # Every verdict in a colour of its own, the explorer's (joint limits and lost path were one purple here).
        colours = {c.get_label().split(" (")[0]: tuple(c.get_facecolor()[0]) for c in ax.collections}
        assert len(set(colours.values())) == len(colours) == len(VERDICT_COLOURS)
        assert colours == {v: to_rgba(c) for v, c in VERDICT_COLOURS.items()}
    (hist_ax,) = histogram.axes
    for patch in hist_ax.patches:
        resolver, count = patch.get_label().rsplit(" (", 1)
        assert int(count.rstrip(")")) == sum(r["unstable"] for r in records if r["resolver"] == resolver)
    (trade_ax,) = tradeoff.axes
    pinv_stable = {r["path"] for r in records if r["resolver"] == "pinv" and r["verdict"] == "stable"}
    for resolver in PAPER_RESOLVERS:
        rows = [r for r in records if r["resolver"] == resolver]
        ratios = [r["torque_vs_pinv"] for r in rows if r["verdict"] == "stable" and r["path"] in pinv_stable]
        x, y, low, high = errorbar(trade_ax, resolver)
        whips = sum(r["verdict"] == "whiplash" for r in rows)
        assert x[0] == pytest.approx(np.median(ratios), rel=1e-12)
        assert y[0] == pytest.approx(whips / len(rows), rel=1e-12)
        assert (low[0], high[0]) == pytest.approx(wilson_interval(whips, len(rows)), abs=1e-12)
    # the x = 1 reference line is drawn under every error bar (it hid pinv's, which sits on it)
    (reference,) = [line for line in trade_ax.get_lines() if list(line.get_xdata()) == [1.0, 1.0]]
    bars = [line for container in trade_ax.containers for line in container.lines[2]]
    assert all(reference.get_zorder() < bar.get_zorder() for bar in bars)


@pytest.mark.slow
def test_scheduler_and_workers_in_separate_processes(reference_atlas, tmp_path):
    """A real Dask scheduler and two workers started as processes on 127.0.0.1, reached by address."""
    scheduler_file = tmp_path / "scheduler.json"
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    bin_dir = Path(sys.executable).parent
    processes = [subprocess.Popen(
        [str(bin_dir / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
         "--scheduler-file", str(scheduler_file)],
        env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )]  # fmt: skip
    try:
        deadline = time.monotonic() + 30
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for _ in range(2):
            processes.append(subprocess.Popen(
                [str(bin_dir / "dask"), "worker", address, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            ))  # fmt: skip
        out = tmp_path / "atlas"
        run_atlas("planar3", out=out, scheduler=address, seed=5, **SMALL)
        pandas.testing.assert_frame_equal(_table(out), reference_atlas)
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@pytest.mark.slow
def test_a_sweep_killed_midway_resumes_to_the_identical_table(reference_atlas, tmp_path):
    """SIGKILL the CLI after two chunks landed, run the same command again:
    the table equals the uninterrupted one, nothing lost or counted twice."""
    out = tmp_path / "killed"
    command = [
        sys.executable,
        "-m",
        "torqueopt",
        "atlas",
        "--robot",
        "planar3",
        "--paths",
        "6",
        "--durations",
        "0.3,1.8",
        "--chunk-size",
        "4",
        "--seed",
        "5",
        "--workers",
        "0",
        "--no-progress",
        "--no-figures",
        "--out",
        str(out),
    ]
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen(command, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    chunks = out / "chunks"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        if chunks.is_dir() and len(list(chunks.glob("chunk-*.parquet"))) >= 2:
            break
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    landed = len(list(chunks.glob("chunk-*.parquet")))
    assert 2 <= landed < 4 and not (out / "results.parquet").exists()  # 12 paths in 4 chunks of up to 4
    finished = subprocess.run(command, env=environment, capture_output=True, text=True, timeout=120, check=False)
    assert finished.returncode == 0, finished.stderr
    assert f"{landed} chunks resumed from an earlier run" in finished.stdout
    pandas.testing.assert_frame_equal(_table(out), reference_atlas)
    assert not list(chunks.glob(".*.part"))


def test_resume_refuses_other_settings_and_folders_not_ours(tmp_path):
    tiny = {**SMALL, "paths": 1, "durations": (0.2,)}
    run_atlas("planar3", out=tmp_path, workers=0, seed=5, **tiny)
    with pytest.raises(InvalidInput, match=r"holds an atlas with other settings \(population differ\)"):
        run_atlas("planar3", out=tmp_path, workers=0, seed=6, **tiny)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "results.parquet").write_text("someone else's")
    with pytest.raises(InvalidInput, match=r"is not empty and holds no atlas \(no atlas-config.json\)"):
        run_atlas("planar3", out=foreign, workers=0, **SMALL)
    assert (foreign / "results.parquet").read_text() == "someone else's"


# -- the CLI ------------------------------------------------------------------------


def test_cli_runs_and_prints_the_claims(tmp_path, capsys):
    code = main(["atlas", "--robot", "planar3", "--paths", "3", "--durations", "0.3", "--workers", "0",
                 "--no-progress", "--no-figures", "--out", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert "null-space" in out and "wrote" in out and "claim (" in out
    assert len(_table(tmp_path)) == 12


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--paths", "1000000", "--durations", "2,2.5"], "the atlas would simulate 1.8e+10 trajectory-steps"),
        (["--paths", "3", "--resolvers", "pinv,nope"], "unknown resolver 'nope': choose one of"),
        (["--paths", "two"], "--paths: 'two' is not a whole number"),
        (["--paths", "3", "--durations", "0.5,x"], "--durations: 'x' is not a number"),
        ([], "--paths N is required in random mode (the default); grid mode places its own starts"),
    ],
)
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, capsys, arguments, message):
    code = main(["atlas", "--workers", "0", "--no-progress", "--out", str(tmp_path / "a"), *arguments])
    error = capsys.readouterr().err
    assert code == 2 and message in error and error.count("\n") == 1
    assert not (tmp_path / "a").exists()


def test_missing_dask_names_the_package(monkeypatch, tmp_path):
    import builtins

    real_import = builtins.__import__

    def no_distributed(name, *args, **kwargs):
        if name == "distributed":
            raise ImportError("no distributed")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_distributed)
    import importlib

    monkeypatch.setattr(importlib, "import_module", lambda name: no_distributed(name))
    with pytest.raises(
        MissingDependency, match=r"the atlas needs 'dask\[distributed\]'.*pip install 'torqueopt\[atlas\]'"
    ):
        run_atlas("planar3", out=tmp_path, **{**SMALL, "paths": 1, "durations": (0.2,)})


def test_a_resolver_without_a_vectorised_step_runs_batched_too():
    """A bounded resolver (the QP bounded-torque) and a velocity-level one go through the batch (the QP's
    single-state step row by row, the kinematic loop per movement): their rows equal simulate's runs."""
    rows = _rows([(1.0, PAPER_Q0, (1, 1))], resolvers=["pinv", "bounded-torque", "velocity-pinv"])
    assert all(rows[0, name]["batched"] for name in ("pinv", "bounded-torque", "velocity-pinv"))
    planar3 = torqueopt.load_robot("planar3")
    for name in ("bounded-torque", "velocity-pinv"):
        run = torqueopt.simulate(planar3, name, torqueopt.StraightLine([1, 1], duration=1.0), PAPER_Q0)
        assert rows[0, name]["peak_torque_ratio"] == pytest.approx(np.nanmax(run.torque_ratio), rel=1e-12)


@pytest.mark.slow
def test_bounded_resolver_rows_keep_the_task_it_gave_up(planar3):
    """bounded-torque holds the limits on the paper's long movement and gives up
    task acceleration instead: the row says how much, as the run does."""
    rows = _rows([(2.0, PAPER_Q0, (1, 1))], resolvers=["pinv", "bounded-torque"])
    row = rows[0, "bounded-torque"]
    run = torqueopt.simulate(planar3, "bounded-torque", torqueopt.StraightLine([1, 1], duration=2.0), PAPER_Q0)
    assert row["max_task_error"] == pytest.approx(run.max_task_error)
    assert row["infeasible_steps"] == run.infeasible_steps
    assert row["peak_torque_ratio"] <= 1.0 + 1e-9 and not row["unstable"]
    assert rows[0, "pinv"]["max_task_error"] == 0.0 and rows[0, "pinv"]["infeasible_steps"] == 0


def test_an_algorithmic_singularity_at_the_start_is_a_singular_verdict_not_stable(planar3):
    """A start where the extended Jacobian is already singular (found by a seeded
    search) gives a run with no rows: the atlas calls it singular, not stable."""
    from torqueopt.atlas.verdicts import run_row

    q0 = [2.7336406607023154, 1.9845664104768632, -3.1243861495570098]
    run = torqueopt.simulate(planar3, "extended-jacobian", torqueopt.StraightLine([1, 1], duration=0.2), q0)
    assert len(run.t) == 0 and run.stop_reason.startswith("extended Jacobian is singular")
    kinetic, self_motion = self_motion_energy(planar3, run)
    row = run_row(run, kinetic, self_motion, 1.0, Thresholds())
    assert not row["unstable"] and row["verdict"] == "singular"


# -- folders and chunks that are not this atlas's -----------------------------------

TINY = ["atlas", "--robot", "planar3", "--paths", "3", "--durations", "0.2,0.3", "--chunk-size", "2",
        "--workers", "0", "--no-progress", "--no-figures"]  # fmt: skip


def test_a_folder_holding_a_users_files_is_refused_and_left_as_it_was(tmp_path, capsys):
    """A user's tradeoff.png (named like an atlas figure) or any other file: the folder is not this atlas's."""
    for name in ("tradeoff.png", "notes.txt"):
        out = tmp_path / name.split(".")[0]
        out.mkdir()
        (out / name).write_text("the user's")
        assert main([*TINY, "--out", str(out)]) == 2
        assert capsys.readouterr().err == (
            f"torqueopt atlas: error: '{out}' is not empty and holds no atlas (no atlas-config.json), so it is "
            "not this atlas's folder: give an empty or new folder, or this atlas's folder to resume it\n"
        )
        assert [path.name for path in out.iterdir()] == [name] and (out / name).read_text() == "the user's"


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--dt", "0.3"], "dt=0.3 s does not divide the duration 0.2 s"),
        (["--dt", "0.07"], "dt=0.07 s does not divide the duration 0.2 s"),
        (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'"),
    ],
    ids=["dt longer than a duration", "dt that does not divide", "unreachable scheduler"],
)
def test_a_refused_atlas_leaves_nothing_behind(tmp_path, capsys, monkeypatch, arguments, message):
    """Refused for a bad --dt or an unreachable scheduler: no folder, no atlas-config.json, so the corrected
    command is not refused for 'other settings'."""
    from torqueopt.atlas import sweep

    monkeypatch.setattr(sweep, "SCHEDULER_TIMEOUT", "1s")
    out = tmp_path / "atlas"
    assert main([*TINY, "--out", str(out), *arguments]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"torqueopt atlas: error: {message}") and error.count("\n") == 1
    assert not out.exists()
    out.mkdir()
    assert main([*TINY, "--out", str(out), *arguments]) == 2
    assert list(out.iterdir()) == []
    capsys.readouterr()
    assert main([*TINY, "--out", str(out)]) == 0


def _spoil_other_seed(chunk, tmp_path):
    other = tmp_path / "other"
    assert main([*TINY, "--seed", "6", "--out", str(other)]) == 0
    chunk.write_bytes((other / "chunks" / chunk.name).read_bytes())
    return "written by another atlas (other settings)"


def _spoil_truncated(chunk, tmp_path):
    chunk.write_bytes(chunk.read_bytes()[: chunk.stat().st_size // 2])
    return "unreadable (truncated or corrupt)"


def _spoil_flipped_byte(chunk, tmp_path):
    import pyarrow.parquet

    column = pyarrow.parquet.ParquetFile(chunk).metadata.row_group(0).column(11)  # peak_torque_ratio
    data = bytearray(chunk.read_bytes())
    data[column.data_page_offset + column.total_compressed_size - 3] ^= 0xFF  # in the last bytes of its page data
    chunk.write_bytes(bytes(data))
    return "unreadable (truncated or corrupt)"  # the page's CRC32 no longer matches


def _spoil_edited_rows(chunk, tmp_path):
    """A value changed and the file written again with its proof kept: only the rows' checksum tells."""
    import pyarrow
    import pyarrow.parquet

    table = pyarrow.parquet.read_table(chunk)
    column = table.schema.get_field_index("peak_torque_ratio")
    ratios = table.column(column).to_pylist()
    table = table.set_column(column, "peak_torque_ratio", pyarrow.array([ratios[0] / 2, *ratios[1:]]))
    pyarrow.parquet.write_table(table, chunk)
    return "its rows do not match their checksum (corrupt)"


def _spoil_no_fingerprint(chunk, tmp_path):
    pandas.read_parquet(chunk).to_parquet(chunk, index=False)
    return "written without the atlas fingerprint"


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    """The TINY atlas, run once: each test that spoils one of its chunks spoils a copy of its own."""
    out = tmp_path_factory.mktemp("tiny") / "atlas"
    assert main([*TINY, "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize(
    "spoil", [_spoil_other_seed, _spoil_truncated, _spoil_flipped_byte, _spoil_edited_rows, _spoil_no_fingerprint],
    ids=["other seed", "truncated", "flipped byte", "edited rows", "no fingerprint"],
)  # fmt: skip
def test_a_chunk_that_does_not_match_is_recomputed_and_the_run_says_so(tiny_atlas, tmp_path, capsys, spoil):
    out = tmp_path / "atlas"
    shutil.copytree(tiny_atlas, out)  # the atlas as its run left it
    reference = _table(out)
    chunk = out / "chunks" / "chunk-000001.parquet"
    reason = spoil(chunk, tmp_path)
    capsys.readouterr()
    assert main([*TINY, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    note = captured.err.splitlines()
    assert len(note) == 1 and note[0].startswith(
        "torqueopt atlas: note: recomputing 1 of 4 chunks, which do not match this atlas: chunk-000001.parquet ("
    ), captured.err
    if reason is not None:
        assert note[0].endswith(f"chunk-000001.parquet ({reason})")
    assert "3 chunks resumed from an earlier run" in captured.out
    pandas.testing.assert_frame_equal(_table(out), reference)
    capsys.readouterr()
    assert main([*TINY, "--out", str(out)]) == 0  # the recomputed chunk is trusted now
    captured = capsys.readouterr()
    assert captured.err == "" and "4 chunks resumed" in captured.out


# -- a grid counted before it is built ------------------------------------------------


@pytest.mark.parametrize(
    "arguments, message",
    [
        (
            ["--grid-spacing", "1e-6"],
            "the grid of spacing 1e-06 m has at least 2.29e+13 start points within 2.7 m of the base (x 8 "
            "directions: 1.83e+14 movements per duration), more than the 1,000,000 movements per duration an "
            "atlas takes: give a coarser --grid-spacing or fewer --grid-directions",
        ),
        (
            ["--grid-spacing", "0.01"],
            "the grid of spacing 0.01 m has at least 2.28e+05 start points within 2.7 m of the base (x 8 "
            "directions: 1.82e+06 movements per duration), more than the 1,000,000 movements per duration an "
            "atlas takes: give a coarser --grid-spacing or fewer --grid-directions",
        ),
        (
            ["--grid-spacing", "0.01", "--grid-directions", "1", "--max-steps", "1e8"],
            "the grid atlas would simulate up to 4.6e+08 trajectory-steps (228,977 start points x 1 direction, "
            "durations 0.2, 0.3 s at dt 0.001 s, 4 resolvers, pinv included), more than max_steps=1e+08: a "
            "coarser --grid-spacing, fewer --grid-directions, durations or resolvers, a larger dt, or raise "
            "max_steps (--max-steps)",
        ),
    ],
    ids=["212 TiB", "90 s of inverse kinematics", "steps"],
)
def test_a_grid_too_large_is_refused_before_it_is_built(tmp_path, capsys, monkeypatch, arguments, message):
    from torqueopt.atlas import population

    monkeypatch.setattr(population, "_inverse_kinematics", lambda *a, **k: pytest.fail("built the grid"))
    out = tmp_path / "atlas"
    assert main([*TINY, "--mode", "grid", "--out", str(out), *arguments]) == 2
    assert capsys.readouterr().err == f"torqueopt atlas: error: {message}\n"
    assert not out.exists()


def test_a_grid_atlas_needs_no_paths(tmp_path, capsys):
    # --paths counts random movements only; the grid places its own starts (it was required all the same).
    tiny = [a for a in TINY if a not in ("--paths", "3")]
    out = tmp_path / "atlas"
    assert main([*tiny, "--mode", "grid", "--grid-spacing", "1.0", "--grid-directions", "2", "--out", str(out)]) == 0
    assert (out / "results.parquet").exists() and "wrote" in capsys.readouterr().out


def test_the_grid_count_is_the_number_of_start_points_the_grid_tries(planar3, monkeypatch):
    from torqueopt.atlas import population

    tried = []
    monkeypatch.setattr(population, "_inverse_kinematics", lambda robot, data, point, posture: tried.append(point))
    for spacing in (0.25, 0.1, 0.3):
        tried.clear()
        spec = PopulationSpec(mode="grid", grid_spacing=spacing, durations=(0.2,))
        with pytest.raises(InvalidInput, match="keeps no movement"):
            draw_population(planar3, spec)
        assert population.grid_start_points(planar3, spec) == len(tried) > 0


def test_a_run_that_leaves_its_path_is_a_lost_path_verdict_not_stable():
    """minmax-torque on the paper's long movement keeps every torque within its limit by giving up task
    acceleration, and ends far off its path (178 mm with planar3's URDF joint limits on, as the atlas runs it;
    833 mm with them off, the paper's scenario): the atlas calls it lost path, never stable."""
    rows = _rows([(2.0, PAPER_Q0, (1, 1))], resolvers=["pinv", "minmax-torque"])
    row = rows[0, "minmax-torque"]
    assert not row["unstable"] and row["peak_torque_ratio"] <= 1.0 + 1e-9
    assert row["max_tip_error"] > 0.1 and row["infeasible_steps"] > 100
    assert row["verdict"] == "lost path"
    assert rows[0, "pinv"]["verdict"] == "stable" and rows[0, "pinv"]["max_tip_error"] < 1e-3


@pytest.mark.parametrize("address", ["notaurl", "tcp://", "http://10.0.0.5:8786", "tcp://host:port"])
def test_a_scheduler_that_is_no_address_is_refused_before_any_work(tmp_path, capsys, address):
    """--scheduler notaurl raised distributed's ValueError after the population was drawn."""
    from torqueopt.cli import main

    out = tmp_path / "atlas"
    assert main(["atlas", "--robot", "planar3", "--paths", "2", "--durations", "0.2", "--scheduler", address,
                 "--out", str(out)]) == 2  # fmt: skip
    assert capsys.readouterr().err == (
        f"torqueopt atlas: error: scheduler '{address}' is not a Dask scheduler address; "
        "give tcp://HOST:PORT (or tls://HOST:PORT), e.g. tcp://10.0.0.5:8786\n"
    )
    assert not out.exists()


#: Where Ctrl-C lands: (the stderr line, or chunk, to wait for before it; whether the atlas's folder exists after).
#: While the cluster starts, once a worker process exists (forked by the fork server: two processes with its
#: command line), before the cluster is up.
CTRL_C_POINTS = {
    "loading the robot": ("torqueopt atlas: loading robot 'planar3' ...", False),
    "starting the cluster": ("torqueopt atlas: starting 2 Dask workers ...", False),
    "during the sweep": ("a chunk", True),
}


@pytest.mark.slow
@pytest.mark.parametrize("point", list(CTRL_C_POINTS))
def test_ctrl_c_at_any_point_of_a_dask_atlas_is_one_line_and_exit_130(tmp_path, point):
    """Ctrl-C reaches the whole process group: the two Dask workers printed a KeyboardInterrupt traceback each
    (about 30 lines), and during the cluster's start it was ignored, or failed the start with a traceback
    ('Nanny failed to start', exit 1). Now: exit 130, the main process's one line, no process left behind."""
    import threading

    awaited, folder_made = CTRL_C_POINTS[point]
    out = tmp_path / "interrupted"
    command = [sys.executable, "-m", "torqueopt", "atlas", "--robot", "planar3", "--paths", "1000", "--durations",
               "2", "--chunk-size", "8", "--workers", "2", "--no-figures", "--out", str(out)]  # fmt: skip
    # Every said-if-slow line at once: they mark where the atlas is.
    environment = {**os.environ, "PYTHONPATH": str(ROOT), "TORQUEOPT_SLOW_SECONDS": "0"}
    process = subprocess.Popen(command, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               start_new_session=True, text=True, preexec_fn=_hears_ctrl_c)  # fmt: skip
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(process.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if awaited == "a chunk" and list((out / "chunks").glob("chunk-*")):
            break
        workers_forked = (
            point != "starting the cluster"
            or sum("multiprocessing.forkserver" in line for line in _live_processes_of_group(process.pid)) >= 2
        )
        if f"{awaited}\n" in lines and workers_forked:
            break
        time.sleep(0.05)
    assert process.poll() is None, f"the atlas ended before it could be interrupted: {lines}"
    os.killpg(process.pid, signal.SIGINT)  # what the terminal does on Ctrl-C
    process.wait(timeout=120)
    reader.join(timeout=60)  # stderr closes when every process holding it (the workers too) has gone
    assert process.returncode == 130
    error = "".join(lines)
    assert "Traceback" not in error and error.endswith("torqueopt atlas: interrupted\n"), error
    assert all(line.startswith("torqueopt atlas: ") for line in lines), error
    assert out.exists() == folder_made  # interrupted before the cluster was up: nothing written
    # No worker of the atlas is left; multiprocessing's fork server and resource tracker end once they see the
    # main process gone (a second or two on a loaded machine).
    deadline = time.monotonic() + 60
    while _live_processes_of_group(process.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert _live_processes_of_group(process.pid) == []


def _hears_ctrl_c() -> None:
    """In the child, before it runs: SIGINT as a terminal's process has it, even when the tests run where it is
    ignored (a shell's background job, nohup), a disposition a process inherits and keeps."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _live_processes_of_group(group: int) -> list[str]:
    """The command lines of the processes in process group ``group`` that are not zombies."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                if int(fields[2]) == group and fields[0] != "Z":
                    found.append((entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"))
            except (OSError, IndexError, ValueError):
                continue  # gone meanwhile
    return found


def test_a_ctrl_c_while_the_command_imports_its_modules_is_one_line_and_exit_130():
    """A Ctrl-C that cut an import short printed the traceback of numpy's or Pinocchio's; here it lands while
    ``torqueopt.cli.main`` imports the first command's module."""
    code = (
        "import importlib, os, signal, sys\n"
        "import torqueopt.cli\n"
        "real = importlib.import_module\n"
        "def interrupted(name):\n"
        "    os.kill(os.getpid(), signal.SIGINT)  # what the terminal does on Ctrl-C\n"
        "    return real(name)\n"
        "torqueopt.cli.importlib.import_module = interrupted\n"
        "sys.exit(torqueopt.cli.main(['robots']))\n"
    )
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True,
                             timeout=120, check=False, preexec_fn=_hears_ctrl_c)  # fmt: skip
    assert (process.returncode, process.stderr) == (130, "torqueopt: interrupted\n")


def test_importing_torqueopt_or_its_command_line_leaves_ctrl_c_to_python():
    """No import side effect: SIGINT keeps Python's handler (KeyboardInterrupt) after importing the package and
    the CLI, even in a process that is the ``torqueopt`` command (its first lines installed a handler of its own)."""
    code = (
        "import os, signal, sys\n"
        "sys.argv[0] = os.path.join(os.path.dirname(sys.executable), 'torqueopt')  # the console script\n"
        "import torqueopt, torqueopt.cli\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n"
    )
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.run([sys.executable, "-c", code], env=environment, capture_output=True, text=True,
                             timeout=120, check=False, preexec_fn=_hears_ctrl_c)  # fmt: skip
    assert process.stdout == "True\n", process.stderr


def test_the_console_table_and_claims_say_which_criterion_and_stay_aligned(tmp_path, capsys):
    """The claim lines said "unstable" beside the whiplash verdict's numbers; a long resolver name pushed its
    row's cells out of their columns."""
    out = tmp_path / "console"
    assert main(["atlas", "--robot", "planar3", "--paths", "3", "--durations", "0.2,0.3", "--workers", "0",
                 "--no-progress", "--no-figures", "--resolvers", "null-space,inverse-inertia-squared-torque",
                 "--out", str(out)]) == 0  # fmt: skip
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.startswith("resolver"))
    rows = [
        line for line in lines if line.split()[:1] in (["pinv"], ["null-space"], ["inverse-inertia-squared-torque"])
    ]
    assert len(rows) == 3
    for title in ("T=0.2 s", "T=0.3 s"):
        end = header.index(title) + len(title)
        for row in rows:
            assert row[end - 1] != " " and (len(row) == end or row[end] == " "), (title, row)
    claims = [line for line in lines if line.startswith("claim")]
    assert claims and all(line.startswith(("claim (yes, by the whiplash verdict)", "claim (no, by the whiplash "
                                           "verdict)", "claim (undecided, by the whiplash verdict)")) for line in claims)  # fmt: skip
    assert not any(" unstable " in line.split('": ', 1)[1] for line in claims)
    # --no-figures: no figure is written, and the last line does not say there are any
    assert lines[-1].startswith(f"wrote {out}/results.parquet, atlas.md and atlas.json in ")
    assert not list(out.glob("*.png"))


def test_a_second_atlas_on_a_folder_in_use_is_refused(tmp_path, capsys):
    # Two atlases on one --out both did all the work; the first holds the folder while its chunks run.
    from torqueopt.io import held_exclusively

    out = tmp_path / "atlas"
    assert main([*TINY, "--out", str(out)]) == 0
    capsys.readouterr()
    with held_exclusively(out / "atlas-config.json", "torqueopt atlas"):  # as a run in progress holds it
        assert main([*TINY, "--out", str(out)]) == 2
        assert capsys.readouterr().err == (
            f"torqueopt atlas: error: '{out}' is in use by another torqueopt atlas running now: wait for it to "
            "finish (then run this again to read its results), or give another --out\n"
        )
    assert main([*TINY, "--out", str(out)]) == 0  # released: it resumes


def test_drawing_a_large_population_says_so(planar3, monkeypatch, capsys):
    # --paths 1000000 printed nothing for almost 4 minutes while it drew the movements.
    from torqueopt.atlas import population

    spec = PopulationSpec(paths=30, durations=(0.5, 1.0), seed=3)
    quiet = draw_population(planar3, spec, progress=True)
    assert capsys.readouterr().err == ""  # 60 movements: below DRAW_PROGRESS_FROM
    monkeypatch.setattr(population, "DRAW_PROGRESS_FROM", 60)
    said = draw_population(planar3, spec, progress=True)
    assert capsys.readouterr().err == "torqueopt atlas: drawing 60 movements ...\n"
    assert [m.q0.tolist() for m in said] == [m.q0.tolist() for m in quiet]  # the same draw, told or not
