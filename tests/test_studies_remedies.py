"""The remedies study: its runs, its sweep, and the numbers of its answers, held to the runs they describe.

These tests recompute the answers' numbers from the SimResults (torque cost,
whiplash verdicts, a fresh run of the best setting) and check that a remedy
missing from the registry is skipped and reported rather than failing the study.
docs/discussion/remedies.md says the answers in words, from these numbers.
"""

import json
import math

import numpy as np
import pytest

import torqueopt
from torqueopt.cli import main
from torqueopt.paper import PAPER
from torqueopt.resolvers import RESOLVERS
from torqueopt.studies import remedies as study_module
from torqueopt.studies.remedies import REMEDIES, run_remedies, torque_cost
from torqueopt.studies.remedies.discussion_answers import kinematic_term_answer, linear_programming_answer


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


def test_the_kinematic_term_answer_counts_and_picks_what_the_sweep_shows(study, paper):
    answer = kinematic_term_answer(study)
    swept = [p for p in study.sweep if p.kinematic_weight > 0]
    stable = [p for p in swept if p.long_stable]
    within = [p for p in stable if p.long_peak_ratio <= 1 + 1e-6]
    assert answer["reference"] == "null-space" and paper.whiplash["long", "null-space"].time == pytest.approx(1.389)
    assert answer["settings"] == len(swept) == 4
    assert answer["stable_settings"] == len(stable) and answer["within_limit_settings"] == len(within)
    assert answer["stable_short_kept"] == [min(p.short_kept for p in stable), max(p.short_kept for p in stable)]
    for mu in (0.5, 5.0):
        at = [p for p in swept if p.kinematic_weight == mu]
        assert (mu in answer["never_stable_weights"]) == (not any(p.long_stable for p in at))
        assert (mu in answer["always_unstable_weights"]) == all(p.long_instability_time is not None for p in at)
    rows = [[p.short_kept for p in sorted(swept, key=lambda p: p.kinematic_weight) if p.damping == d] for d in (2, 10)]
    assert answer["short_kept_falls_with_weight"] == all(row[1] <= row[0] + 1e-9 for row in rows)  # μ = 0.5, then 5
    best = answer["best"]
    assert best["within_limits"] == bool(within)
    assert best["short_kept"] == max(p.short_kept for p in within or stable)
    # The best setting run afresh: its short movement's cut kept and its long movement's peak.
    options = {"kinematic_weight": best["kinematic_weight"], "damping": best["damping"]}
    runs = {
        m: torqueopt.simulate(paper.robot, "damped-null-space", PAPER.line(m), PAPER.q0, dt=PAPER.dt,
                              resolver_options=options)
        for m in ("short", "long")
    }  # fmt: skip
    pinv, null, run = (paper.runs["short", "pinv"], paper.runs["short", "null-space"], runs["short"])
    cost = {name: sum(float(np.dot(row, row)) for row in r.tau[:-1]) * r.dt for name, r in
            (("pinv", pinv), ("null-space", null), ("best", run))}  # fmt: skip
    kept = (cost["pinv"] - cost["best"]) / (cost["pinv"] - cost["null-space"])
    assert best["short_kept"] == pytest.approx(kept, rel=1e-9)
    peak = np.nanmax(np.abs(runs["long"].tau) / np.asarray(PAPER.torque_limit))
    assert best["long_peak_ratio"] == pytest.approx(peak, rel=1e-12)


def test_the_kinematic_term_answer_on_a_sweep_written_by_hand():
    """Four settings whose facts are known: one whips, one loses its path, one is stable over a limit, one within."""
    from types import SimpleNamespace

    from torqueopt.studies.remedies import SweepPoint

    def point(mu, damping, kept, peak, stable, whip=None):
        return SweepPoint(mu, damping, 1.0, kept, 0.5, peak, stable, whip)

    sweep = [
        point(0.0, 2.0, 1.0, 13.8, False, 1.389),
        point(0.1, 2.0, 0.99, 5.0, False, 1.0),
        point(0.1, 10.0, 0.98, 1.1, False),
        point(0.5, 2.0, 0.9, 1.05, True),
        point(0.5, 10.0, 0.8, 0.95, True),
    ]
    study = SimpleNamespace(sweep=sweep, dampings=(2.0, 10.0), sweep_reference="null-space", sweep_torque_weight="unit")
    answer = kinematic_term_answer(study)
    assert (answer["settings"], answer["stable_settings"], answer["within_limit_settings"]) == (4, 2, 1)
    assert (answer["best"]["kinematic_weight"], answer["best"]["damping"], answer["best"]["within_limits"]) == (
        0.5, 10.0, True)  # fmt: skip
    assert answer["never_stable_weights"] == [0.1] and answer["always_unstable_weights"] == []  # 0.1, 10 lost its path
    assert answer["stable_short_kept"] == [0.8, 0.9] and answer["short_kept_falls_with_weight"] is True
    sweep[-1] = point(0.5, 10.0, 0.995, 1.2, True)  # now none within the limits, and the share rises at K_D = 10
    answer = kinematic_term_answer(study)
    assert answer["best"]["damping"] == 10.0 and answer["best"]["within_limits"] is False
    assert answer["short_kept_falls_with_weight"] is False
    sweep[2] = point(0.1, 10.0, 0.98, 3.0, False, 1.2)  # μ = 0.1 now whips at every K_D
    assert kinematic_term_answer(study)["always_unstable_weights"] == [0.1]


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


def test_the_lp_answer_judges_each_movement_by_its_run(study):
    answer = linear_programming_answer(study)
    if "minmax-torque" not in study.remedies:
        assert answer == {"answered": False}
        return
    assert answer["answered"]
    done = {}
    for name, entry in answer["resolvers"].items():
        for movement in ("short", "medium", "long"):
            run, report = study.run(movement, name), study.report(movement, name)
            peak = float(np.nanmax(np.abs(run.tau) / np.asarray(PAPER.torque_limit)))
            assert entry["peak_torque_ratio"][movement] == pytest.approx(peak, rel=1e-12)
            assert entry["infeasible_steps"][movement] == int(run.infeasible.sum())
            within = peak <= 1 + 1e-6 and run.completed and not report.unstable
            assert (movement in entry["within_limits"]) == within
            assert (movement in entry["done_within_bounds"]) == (within and not run.infeasible.any() and report.stable)
        done[name] = len(entry["done_within_bounds"])
    assert answer["lp_lead"] == {name: done["minmax-torque"] - n for name, n in done.items() if name != "minmax-torque"}
    assert answer["resolvers"]["minmax-torque"]["infeasible_steps"]["long"] > 0  # it gives the path up


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
    del RESOLVERS["damped-null-space"], RESOLVERS["minmax-torque"]
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
    assert linear_programming_answer(missing) == {"answered": False}
    term = kinematic_term_answer(missing)  # no sweep: no settings, nothing picked
    assert term["settings"] == 0 and term["best"] is None and term["stable_short_kept"] is None
    assert term["short_kept_falls_with_weight"] is None and term["never_stable_weights"] == []
    assert "| not run: the LP is not registered |" in markdown


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
    assert "- kinematic term, sweep settings with μ > 0: 0;" in printed and "\n| minmax-torque | " in printed
    assert "### The answers' numbers (`remedies.answers`)" in markdown
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
    assert kinematic_term_answer(study)["reference"] == "weighted-null-space"
    assert paper.whiplash["long", "weighted-null-space"].unstable
    assert study.summary()["sweep"]["torque_weight"] == "range"
    with pytest.raises(torqueopt.InvalidInput, match="sweep torque weight 'diagonal' must be one of unit, range"):
        run_remedies(paper, torque_weight="diagonal")
