"""The remedies study: its runs, its sweep, and the sentences it writes, held to the runs they describe.

The sentences are generated from the numbers; these tests recompute the
numbers from the SimResults (torque cost, whiplash verdicts) and check that
each sentence says what they say, and that a remedy missing from the
registry is skipped and reported rather than failing the study.
"""

import json
import math

import numpy as np
import pytest

import torqueopt
from torqueopt.cli import main
from torqueopt.resolvers import RESOLVERS
from torqueopt.studies import remedies as study_module
from torqueopt.studies.remedies import REMEDIES, run_remedies, torque_cost


@pytest.fixture(scope="module")
def study(paper):
    return run_remedies(paper, kinematic_weights=(0.0, 0.5, 5.0), dampings=(2.0, 10.0))


def test_torque_cost_is_the_integral_of_the_held_torques(paper):
    """∫‖τ‖²dt with τ held over each step: a rectangle sum over every row but the last (t = T)."""
    run = paper.runs["short", "pinv"]
    expected = sum(float(np.dot(row, row)) for row in run.tau[:-1]) * run.dt
    assert torque_cost(run) == pytest.approx(expected, rel=1e-12)
    assert torque_cost(run) > torque_cost(paper.runs["short", "null-space"])


def test_every_registered_remedy_runs_on_every_movement(study):
    registered = [name for name in REMEDIES if name in RESOLVERS]
    assert list(study.remedies) == registered
    assert list(study.skipped) == [name for name in REMEDIES if name not in RESOLVERS]
    assert set(study.runs) == {(m, name) for m in ("short", "medium", "long") for name in registered}
    for (movement, name), result in study.runs.items():
        assert result.resolver == name and len(result.t) > 1


def test_the_sweep_at_zero_weight_is_null_space_and_large_weight_approaches_self_motion_damping(study, paper):
    points = {(p.kinematic_weight, p.damping): p for p in study.sweep}
    assert len(points) == 6
    for damping in (2.0, 10.0):
        zero = points[0.0, damping]
        assert zero.short_kept == pytest.approx(1.0, abs=1e-9)  # it is null-space
        assert zero.long_peak_ratio == pytest.approx(paper.runs["long", "null-space"].peak_torque_ratio.max(), rel=1e-9)
        assert not zero.long_stable
    # μ = 5 is near the kinematic limit: little of the cut left, and stable like self-motion damping.
    assert points[5.0, 10.0].short_kept < 0.1 and points[5.0, 10.0].long_stable


def test_the_kinematic_term_answer_says_what_the_sweep_shows(study):
    answer = study.kinematic_term_answer()
    text = " ".join(answer["sentences"])
    swept = [p for p in study.sweep if p.kinematic_weight > 0]
    within = [p for p in swept if p.long_stable and p.long_peak_ratio <= 1 + 1e-6]
    assert answer["settings"] == len(swept) == 4
    assert answer["stable_settings"] == sum(p.long_stable for p in swept)
    assert answer["within_limit_settings"] == len(within)
    assert text.startswith(
        "Without a kinematic term (μ = 0, null-space) the long movement is unstable from t = 1.389 s"
    )
    if within:
        best = max(within, key=lambda p: p.short_kept)
        assert answer["best"]["kinematic_weight"] == best.kinematic_weight
        assert f"Yes on this arm: with μ = {best.kinematic_weight:g} and K_D = {best.damping:g} 1/s" in text
        assert f"keeps {round(100 * best.short_kept)}% of the cut" in text
    else:
        assert "Yes" not in text


def test_the_default_blend_row_matches_its_run(study, paper):
    row = next(r for r in study.entries() if r["movement"] == "short" and r["resolver"] == "damped-null-space")
    run = study.runs["short", "damped-null-space"]
    pinv, null = (torque_cost(paper.runs["short", name]) for name in ("pinv", "null-space"))
    assert row["null_space_cut_kept"] == pytest.approx((pinv - torque_cost(run)) / (pinv - null), rel=1e-12)
    assert row["options"] == {
        "kinematic_weight": 0.5,
        "damping": 10.0,
        "torque_weight": "unit",
        "singular_tolerance": 1e-6,
    }
    long_row = next(r for r in study.entries() if r["movement"] == "long" and r["resolver"] == "damped-null-space")
    assert long_row["unstable"] == study.whiplash["long", "damped-null-space"].unstable
    assert math.isclose(long_row["peak_torque_ratio"], study.runs["long", "damped-null-space"].peak_torque_ratio.max())


def test_the_lp_answer_is_honest_about_what_was_run(study):
    answer = study.linear_programming_answer()
    if "minmax-torque" not in study.remedies:
        assert answer == {
            "answered": False,
            "sentences": ["Not answered in this build: the LP resolver minmax-torque is not registered."],
        }
        return
    assert answer["answered"]
    lp = answer["minmax-torque"]
    for movement, peak in lp["peak_torque_ratio"].items():
        assert peak == pytest.approx(study.runs[movement, "minmax-torque"].peak_torque_ratio.max())
    assert (
        f"keeps every torque within its limits on {len(lp['within_limits'])} of 3 movements" in answer["sentences"][0]
    )
    for movement in ("short", "medium", "long"):
        run = study.runs[movement, "minmax-torque"]
        done = movement in lp["done_within_bounds"]
        assert done == (movement in lp["within_limits"] and run.infeasible_steps == 0)
        assert lp["infeasible_steps"][movement] == int(run.infeasible.sum())
    assert f"the LP does {len(lp['done_within_bounds'])} of 3 movements" in " ".join(answer["sentences"])


@pytest.mark.slow
def test_the_figures_draw_each_remedy_s_torque_ratios_and_the_sweep(study, paper, tmp_path, saved_figures):
    from torqueopt.studies.remedies.figures import plot_long_torques, plot_tradeoff

    from .drawn import data, horizontal_levels, vertical_times

    plot_long_torques(study, tmp_path / "long.svg")
    plot_tradeoff(study, tmp_path / "tradeoff.svg")
    long_figure, tradeoff_figure = saved_figures
    names = ("pinv", "null-space", *study.remedies)
    assert len(long_figure.axes) == len(names)
    for ax, name in zip(long_figure.axes, names):
        assert ax.get_title(loc="left").startswith(f"{name}: ")
        run, report = study.run("long", name), study.report("long", name)
        for joint, joint_name in enumerate(run.joint_names):
            np.testing.assert_allclose(
                data(ax, joint_name)[1], run.tau[:, joint] / (54.0, 24.0, 6.0)[joint], rtol=1e-15
            )
        assert horizontal_levels(ax) == [-1.0, 1.0]
        assert vertical_times(ax) == ([report.time] if report.unstable else [])
    assert vertical_times(long_figure.axes[1]) == [paper.whiplash["long", "null-space"].time]
    trade, by_weight = tradeoff_figure.axes
    for damping in (2.0, 10.0):
        points = sorted((p for p in study.sweep if p.damping == damping), key=lambda p: p.kinematic_weight)
        np.testing.assert_array_equal(data(trade, f"K_D = {damping:g} 1/s")[1], [p.long_peak_ratio for p in points])
        weights, peaks = data(by_weight, f"K_D = {damping:g} 1/s")
        np.testing.assert_array_equal(weights, [0.5, 5.0])
        np.testing.assert_array_equal(peaks, [p.long_peak_ratio for p in points[1:]])
        # μ = 0 is null-space itself
        assert points[0].long_peak_ratio == pytest.approx(
            paper.runs["long", "null-space"].peak_torque_ratio.max(), rel=1e-9
        )
    assert horizontal_levels(trade) == horizontal_levels(by_weight) == [1.0, paper.limit_factor]


@pytest.mark.slow
def test_a_remedy_missing_from_the_registry_is_skipped_and_said(paper):
    registered = dict(RESOLVERS)
    del RESOLVERS["damped-null-space"]
    try:
        missing = run_remedies(paper, sweep=False)
    finally:  # the registry as it was, in its order (monkeypatch.delitem put the name back last: resolver_names
        RESOLVERS.clear()  # and every "choose one of ..." message then listed it last in the tests after this one)
        RESOLVERS.update(registered)
    assert "damped-null-space" in missing.skipped and "damped-null-space" not in missing.remedies
    assert missing.sweep == []
    markdown = missing.markdown([])
    assert "Not registered in this build, so not run: damped-null-space" in markdown
    assert "### Sweep of damped-null-space (torque_weight=unit)\n\nNot run.\n" in markdown


def test_bad_sweep_grids_are_refused(paper):
    with pytest.raises(torqueopt.InvalidInput, match=r"sweep dampings \[-1.0\] must be finite numbers >= 0"):
        run_remedies(paper, dampings=[-1])


@pytest.mark.slow
def test_paper_command_writes_the_remedies_section_and_figures(tmp_path, capsys):
    # Short movements keep it quick: the wiring is under test here, the numbers above.
    code = main(["paper", "--out", str(tmp_path), "--no-remedy-sweep", "--durations", "0.1,0.2,0.3"])
    printed = capsys.readouterr().out
    assert code == 0
    assert (tmp_path / "remedies_long.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "remedies_tradeoff.png").exists()  # no sweep, no trade-off figure
    summary = json.loads((tmp_path / "summary.json").read_text())
    remedies = summary["remedies"]
    assert remedies["remedies"] == [name for name in REMEDIES if name in RESOLVERS]
    assert remedies["sweep"]["points"] == []
    assert set(remedies["answers"]) == {"kinematic_term", "linear_programming"}
    assert "remedies_long.png" in summary["figures"]
    markdown = (tmp_path / "summary.md").read_text()
    assert "## Remedies\n" in markdown and "| short | damped-null-space | " in markdown
    assert "kinematic term: Without a kinematic term" in printed and "linear programming: " in printed
    assert study_module.SWEPT_RESOLVER == "damped-null-space"


@pytest.mark.slow
def test_a_range_weighted_sweep_is_measured_against_weighted_null_space(paper):
    study = run_remedies(paper, kinematic_weights=(0.0, 0.5), dampings=(10.0,), torque_weight="range")
    zero = min(study.sweep, key=lambda p: p.kinematic_weight)
    assert zero.short_kept == pytest.approx(1.0, abs=1e-9)
    assert zero.long_peak_ratio == pytest.approx(
        paper.runs["long", "weighted-null-space"].peak_torque_ratio.max(), rel=1e-9
    )
    root = 1.0 / (paper.robot.torque_upper - paper.robot.torque_lower)
    run = paper.runs["short", "weighted-null-space"]
    assert torque_cost(run, "range") == pytest.approx(float(np.sum((run.tau[:-1] * root) ** 2)) * run.dt, rel=1e-12)
    text = " ".join(study.kinematic_term_answer()["sentences"])
    assert text.startswith("Without a kinematic term (μ = 0, weighted-null-space) the long movement is unstable")
    assert study.summary()["sweep"]["torque_weight"] == "range"
    with pytest.raises(torqueopt.InvalidInput, match="sweep torque weight 'diagonal' must be one of unit, range"):
        run_remedies(paper, torque_weight="diagonal")
