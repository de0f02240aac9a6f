"""The paper's scenario and its six claims, each checked on the numbers; the files and CLI of ``torqueopt paper``.

The claims are checked as the paper states them (comparisons between
resolvers and against the limits). The numbers torqueopt itself computed
(peak torques, instability times, alignment times) are regression pins,
kept in test_regression.py with their golden file.
"""

import contextlib
import io
import json
import math

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.cli import build_parser, main
from torqueopt.cli.paper import scenario_from_args
from torqueopt.errors import InvalidInput
from torqueopt.paper import MOVEMENTS, PAPER, alignment_times, run_paper, summary_entries

SUMMARY_FIELDS = {
    "movement", "resolver", "duration", "peak_torque", "torque_limit", "first_limit_violation", "unstable",
    "instability_time", "max_tip_error",
}  # fmt: skip


def peaks(paper, movement, resolver):
    return paper.runs[movement, resolver].peak_torque


# -- the scenario --------------------------------------------------------------
def test_the_scenario_is_the_papers_section_3(paper):
    assert np.degrees(PAPER.q0) == pytest.approx([-45.0, 135.0, -135.0])
    assert PAPER.direction == (1.0, 1.0) and PAPER.accel == pytest.approx(math.sqrt(2.0))
    assert PAPER.durations == (0.5, 1.25, 2.0) and PAPER.dt == 1e-3
    assert PAPER.torque_limit == (54.0, 24.0, 6.0)
    np.testing.assert_allclose(PAPER.weight, [1 / 54**2, 1 / 24**2, 1 / 6**2])
    robot = paper.robot
    assert robot.gravity.tolist() == [0.0, 0.0, 0.0]
    tip = robot.task_position(robot.configuration(PAPER.q0))
    np.testing.assert_allclose(tip, [math.sqrt(2.0), 1.0 - math.sqrt(2.0)], atol=1e-12)
    # The lines are 0.088 m, 0.55 m and 1.41 m long (a T^2 / 4).
    assert [PAPER.line(m).length for m in MOVEMENTS] == pytest.approx([0.0884, 0.5524, 1.4142], abs=1e-4)
    assert set(paper.runs) == {(m, r) for m in MOVEMENTS for r in ("pinv", "inertia-pinv", "null-space",
                                                                    "weighted-null-space")}  # fmt: skip
    assert all(result.completed for result in paper.runs.values())


def test_replace_gives_another_scenario():
    other = PAPER.replace(q0=np.radians([-40.0, 130.0, -130.0]), direction=(1.0, 0.5), durations=(0.4, 1.0, 1.6))
    assert other.duration("long") == 1.6 and other.direction == (1.0, 0.5)
    assert PAPER.duration("long") == 2.0


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"durations": (0.5, 2.0)}, "durations [0.5, 2.0] must be 3 positive numbers of seconds (short, medium, long)"),
        ({"durations": (0.5, -1.0, 2.0)}, "durations [0.5, -1.0, 2.0] must be 3 positive numbers of seconds"),
        ({"q0": (0.0, math.nan, 0.0)}, "q0 [0.0, nan, 0.0] must be finite numbers"),
        ({"torque_limit": (54.0, 0.0, 6.0)}, "torque_limit [54.0, 0.0, 6.0] must be positive numbers [N·m]"),
        ({"dt": 1.0}, "dt=1.0 s is longer than the shortest movement, 0.5 s"),
        (
            {"durations": (2.0, 1.0, 0.5)},
            "durations [2.0, 1.0, 0.5] must increase from the short movement to the long one, e.g. 0.5,1.25,2",
        ),
        (
            {"durations": (1.0, 2.0, 1e6)},
            "duration 1e+06 s at dt 0.001 s needs 1e+09 steps, more than the limit of "
            "1,000,000 steps; give a larger dt or a shorter duration",
        ),
    ],
)
def test_bad_scenarios_are_refused(changes, message):
    with pytest.raises(InvalidInput) as error:
        PAPER.replace(**changes)
    assert str(error.value).startswith(message)


def test_unknown_movement():
    with pytest.raises(InvalidInput, match=r"^unknown movement 'huge': choose one of short, medium, long$"):
        PAPER.duration("huge")


def test_a_singular_start_is_refused_before_simulating():
    with pytest.raises(InvalidInput, match=r"^q0 = \(0°, 0°, 0°\) is a singular configuration \(task Jacobian"):
        run_paper(PAPER.replace(q0=(0.0, 0.0, 0.0)))


# -- the claims ----------------------------------------------------------------
def test_claim_1_short_null_space_cuts_joint_1_and_pulls_joint_3_from_its_limit(paper):
    pinv, null = peaks(paper, "short", "pinv"), peaks(paper, "short", "null-space")
    assert null[0] < 0.06 * pinv[0]  # a twentieth
    assert pinv[2] / 6.0 > 0.93 and null[2] / 6.0 < 0.71  # 94 % of the limit down to 71 %
    assert paper.claims[0].holds
    evidence = paper.claims[0].evidence
    assert evidence["joint_1_fraction_of_pinv"] == pytest.approx(null[0] / pinv[0], rel=1e-12)
    assert evidence["joint_3_pulled_away"] == pytest.approx((pinv[2] - null[2]) / 6.0, rel=1e-12)


def test_claim_2_medium_null_space_still_lower_at_joints_1_and_3_within_limits(paper):
    pinv, null = peaks(paper, "medium", "pinv"), peaks(paper, "medium", "null-space")
    assert null[0] < pinv[0] and null[2] < pinv[2]
    assert null[1] > pinv[1]  # joint 2 is larger ...
    assert paper.runs["medium", "null-space"].first_limit_violation is None  # ... but within its 24 N·m
    assert not paper.whiplash["medium", "null-space"].unstable
    assert paper.claims[1].holds and paper.claims[1].evidence == {"null_space_first_limit_violation": None}


def test_claim_3_long_pinv_within_limits_null_space_unstable_late_through_alignment(paper):
    pinv, null = paper.runs["long", "pinv"], paper.runs["long", "null-space"]
    assert pinv.first_limit_violation is None and not paper.whiplash["long", "pinv"].unstable
    assert (pinv.peak_torque_ratio < 1.0).all() and (null.peak_torque_ratio > 2.0).any()
    verdict = paper.whiplash["long", "null-space"]
    assert verdict.unstable and verdict.time > 0.5 * null.duration
    # Links 2 and 3 pass through line (joint 3 at 0) once, shortly before the verdict, as the whip builds up ...
    (aligned,) = alignment_times(null)
    assert verdict.time - 0.1 < aligned < verdict.time
    row = int(np.searchsorted(null.t, aligned))
    pinv_fastest = np.abs(pinv.v).max()
    # ... with a joint three times faster than the fastest joint of pinv over the whole movement,
    assert np.abs(null.v[row]).max() > 3.0 * pinv_fastest
    # and every joint peaks later still, after the alignment.
    assert (null.t[np.argmax(np.abs(null.v), axis=0)] > aligned).all()
    assert paper.claims[2].holds
    evidence = paper.claims[2].evidence
    assert evidence["alignment_times"] == [aligned] and evidence["pinv_fastest_joint_speed"] == pinv_fastest
    assert evidence["fastest_joint_speed_at"] == [np.abs(null.v[row]).max()]


def test_claim_4_short_weighted_shrinks_joint_3_at_the_expense_of_joints_1_and_2(paper):
    weighted, null = peaks(paper, "short", "weighted-null-space"), peaks(paper, "short", "null-space")
    assert weighted[2] < 0.62 * null[2]
    assert weighted[0] > 20 * null[0] and weighted[1] > 2 * null[1]
    assert (weighted / np.array([54.0, 24.0, 6.0])).max() < 0.45  # well within the limits
    assert paper.claims[3].holds
    assert paper.claims[3].evidence["joint_3_fraction_of_null_space"] == pytest.approx(weighted[2] / null[2], rel=1e-12)


def test_claim_5_weighted_and_inertia_pinv_unstable_too_inertia_pinv_in_between(paper):
    for name in ("weighted-null-space", "inertia-pinv"):
        verdict = paper.whiplash["long", name]
        assert verdict.unstable and 0.0 < verdict.time < paper.runs["long", name].duration
    inertia, pinv, null = (peaks(paper, "short", name) for name in ("inertia-pinv", "pinv", "null-space"))
    between = [min(p, z) < i < max(p, z) for i, p, z in zip(inertia, pinv, null)]
    # Joints 1 and 3 lie between; joint 2 (1.16 N·m) is below both (3.54 and 3.20): "most joints" is 2 of 3.
    assert between == [True, False, True]
    assert paper.claims[4].holds and paper.claims[4].evidence == {"joints_between": [1, 3]}


def test_claim_6_the_free_swing_whips_as_links_2_and_3_straighten(paper):
    swing = paper.free_swing
    # Zero torque over every step; the final state (t = T) applies none at all.
    assert swing.resolver == "free swing" and not swing.tau[:-1].any() and np.isnan(swing.tau[-1]).all()
    # Gravity along the line direction, sized for a tip acceleration of √2 m/s² from rest.
    gravity = paper.free_swing_gravity
    np.testing.assert_allclose(gravity / np.linalg.norm(gravity), [1 / math.sqrt(2), 1 / math.sqrt(2), 0.0])
    tip_acceleration = (swing.x[2] - 2 * swing.x[1] + swing.x[0]) / swing.dt**2
    assert np.linalg.norm(tip_acceleration) == pytest.approx(math.sqrt(2.0), rel=1e-2)
    speed = np.abs(swing.v)
    peak_row = int(np.argmax(speed.max(axis=1)))
    assert np.argmax(speed[peak_row]) == 2  # joint 3
    # The speed peaks within 0.05 s of links 2 and 3 coming into line, once.
    (aligned,) = alignment_times(swing)
    assert abs(swing.t[peak_row] - aligned) < 0.05
    assert paper.claims[5].holds
    evidence = paper.claims[5].evidence
    assert (evidence["fastest_joint"], evidence["peak_time"]) == (swing.joint_names[2], swing.t[peak_row])
    assert evidence["peak_speed"] == speed[peak_row, 2]


def test_the_free_swing_conserves_energy(paper):
    # Independent of the integrator's use: with zero torque, kinetic + potential energy is constant.
    swing, robot = paper.free_swing, paper.robot
    data = robot.model.createData()
    mass = pin.computeTotalMass(robot.model)
    energy = []
    for q, v in zip(swing.q[::50], swing.v[::50]):
        inertia = robot.terms(q, v).inertia
        center = pin.centerOfMass(robot.model, data, q)
        energy.append(0.5 * v @ inertia @ v - mass * paper.free_swing_gravity @ center)
    kinetic_peak = 0.5 * mass * np.abs(swing.v).max() ** 2
    assert np.ptp(energy) < 1e-6 * kinetic_peak


def test_the_free_swing_leaves_the_callers_robot_alone(paper):
    from torqueopt.paper import free_swing

    robot = paper.scenario.load_robot()
    swing = free_swing(paper.scenario, robot, duration=0.05)
    assert robot.gravity.tolist() == [0.0, 0.0, 0.0]
    # The swing moved under gravity, through the one simulation loop.
    assert swing.completed and swing.t[-1] == pytest.approx(0.05) and np.abs(swing.v[-1]).max() > 0


def test_every_claim_holds(paper):
    assert [(claim.number, claim.holds) for claim in paper.claims] == [(n, True) for n in range(1, 7)]


def test_summary_entries_have_exactly_the_summary_fields(paper):
    entries = summary_entries(paper)
    assert len(entries) == 12
    for entry in entries:
        assert set(entry) == SUMMARY_FIELDS
        result = paper.runs[entry["movement"], entry["resolver"]]
        assert entry["peak_torque"] == result.peak_torque.tolist()
        assert entry["torque_limit"] == [54.0, 24.0, 6.0]
        assert entry["max_tip_error"] == result.max_tip_error
        assert entry["unstable"] == (entry["instability_time"] is not None)
    unstable = {(e["movement"], e["resolver"]) for e in entries if e["unstable"]}
    assert unstable == {("long", "null-space"), ("long", "weighted-null-space"), ("long", "inertia-pinv")}


# -- the command ---------------------------------------------------------------
@pytest.fixture(scope="module")
def paper_command(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper-out")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["paper", "--out", str(out)])
    return code, out, printed.getvalue()


@pytest.mark.slow
def test_paper_command_writes_every_figure_and_both_summaries(paper_command):
    code, out, printed = paper_command
    assert code == 0
    from torqueopt.paper import paper_files

    # The files the command checked before its work are the files it wrote.
    assert sorted(path.name for path in out.iterdir()) == sorted(
        path.name for path in paper_files(out, "png", remedies=True, sweep=True)
    )
    figures = [f"fig{i}.png" for i in range(2, 8)] + [
        f"arm_long_{name}.png" for name in ("pinv", "inertia-pinv", "null-space", "weighted-null-space")
    ]
    for name in figures:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    assert not list(out.glob(".*.part"))
    summary = json.loads((out / "summary.json").read_text())
    assert [set(entry) for entry in summary["runs"]] == [SUMMARY_FIELDS] * 12
    assert all(claim["holds"] for claim in summary["claims"])
    assert summary["scenario"]["q0_deg"] == [-45.0, 135.0, -135.0]
    assert summary["whiplash"]["limit_factor"] == 2.0 and summary["whiplash"]["growth_factor"] == 8.0
    markdown = (out / "summary.md").read_text()
    assert "| long | null-space | 2 | 510, 332, 75.7 | 54, 24, 6 | 0.859 | **yes** | 1.389 |" in markdown
    assert "| short | pinv | 0.5 | 13, 3.54, 5.61 | 54, 24, 6 | - | no | - |" in markdown
    assert markdown.count("**holds**") == 6
    assert "long     null-space                        13.83     t = 0.859 s  UNSTABLE from t = 1.389 s" in printed
    assert "claim 6: holds" in printed


def test_a_sweep_setting_that_loses_its_path_is_not_called_unstable(paper_command):
    # μ = 0.1, K_D = 50: the whiplash detector says not unstable (lost path, 1.15 mm); summary.md marked it **U**
    # and the answer said "every K_D swept leaves it unstable" (μ = 0.1 was listed as whipping at every K_D).
    _, out, _ = paper_command
    summary = json.loads((out / "summary.json").read_text())
    point = next(
        p for p in summary["remedies"]["sweep"]["points"] if (p["kinematic_weight"], p["damping"]) == (0.1, 50.0)
    )
    assert not point["long_stable"] and point["long_instability_time"] is None
    row = next(line for line in (out / "summary.md").read_text().splitlines() if line.startswith("| 0.1 |"))
    assert row.endswith("/ 1.15 **L** |") and row.count("**U**") == 4
    answer = summary["remedies"]["answers"]["kinematic_term"]
    assert answer["never_stable_weights"] == [0.1] and answer["always_unstable_weights"] == []
    assert "- μ with no stable K_D: 0.1; unstable at every K_D: -\n" in (out / "summary.md").read_text()


@pytest.mark.slow
def test_the_summary_the_pages_read_is_what_the_command_writes(paper_command):
    """docs/data/paper-summary.json, whence the numbers of docs/paper.md and docs/discussion/remedies.md (test_docs
    holds the pages to it), is `torqueopt paper`'s summary.json: a regression pin, written again by
    ``torqueopt paper --out DIR && cp DIR/summary.json docs/data/paper-summary.json``."""
    from pathlib import Path

    committed = Path(__file__).resolve().parent.parent / "docs" / "data" / "paper-summary.json"
    _assert_same(json.loads(committed.read_text()), json.loads((paper_command[1] / "summary.json").read_text()))


def _assert_same(committed, written, where="summary"):
    """Equal keys, lists, strings and flags; numbers within 1e-9 relative."""
    assert type(committed) is type(written) or {type(committed), type(written)} == {int, float}, where
    if isinstance(committed, dict):
        assert list(committed) == list(written), where
        for key in committed:
            _assert_same(committed[key], written[key], f"{where}.{key}")
    elif isinstance(committed, list):
        assert len(committed) == len(written), where
        for index, (a, b) in enumerate(zip(committed, written)):
            _assert_same(a, b, f"{where}.{index}")
    elif isinstance(committed, float):
        assert committed == pytest.approx(written, rel=1e-9, abs=1e-300), where
    else:
        assert committed == written, where


def test_paper_options_make_the_scenario():
    args = build_parser().parse_args([
        "paper", "--out", "x", "--q0=-40,130,-130", "--degrees", "--direction", "1,0.5",
        "--durations", "0.4,1,1.6", "--limit-factor", "3", "--growth-factor", "6",
    ])  # fmt: skip
    scenario, limit_factor, growth_factor = scenario_from_args(args)
    assert np.degrees(scenario.q0) == pytest.approx([-40.0, 130.0, -130.0])
    assert scenario.direction == (1.0, 0.5) and scenario.durations == (0.4, 1.0, 1.6)
    assert (limit_factor, growth_factor) == (3.0, 6.0)
    assert scenario.torque_limit == PAPER.torque_limit and scenario.accel == PAPER.accel


@pytest.mark.parametrize(
    "options, message",
    [
        (["--durations", "0.5,2"], "--durations has 2 values but needs 3"),
        (["--durations", "0.5,-1,2"], "--durations: -1.0 must be a positive finite number"),
        (
            ["--durations", "2,1,0.5"],
            "durations [2.0, 1.0, 0.5] must increase from the short movement to the long one, e.g. 0.5,1.25,2",
        ),
        (
            ["--durations", "1,2,1e6"],
            "duration 1e+06 s at dt 0.001 s needs 1e+09 steps, more than the limit of "
            "1,000,000 steps; give a larger dt or a shorter duration",
        ),
        (["--q0=1,2"], "--q0 has 2 values but needs 3"),
        (["--direction", "1,x"], "--direction: 'x' is not a number (give comma-separated numbers, e.g. 1,1)"),
        (["--limit-factor", "0"], "--limit-factor: 0 must be a positive finite number"),
        (["--growth-factor", "many"], "--growth-factor: 'many' is not a number"),
        (
            ["--q0=0,0,0"],
            (
                "q0 = (0°, 0°, 0°) is a singular configuration (task Jacobian is singular: smallest/largest "
                "singular value 0 is below the cutoff 1e-06); choose another start"
            ),
        ),
    ],
)
def test_paper_bad_options_exit_2_with_one_line(tmp_path, capsys, options, message):
    code = main(["paper", "--out", str(tmp_path / "out"), *options])
    assert code == 2
    assert capsys.readouterr().err == f"torqueopt paper: error: {message}\n"
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
@pytest.mark.parametrize("figure_format, magic", [("svg", b"<?xml"), ("pdf", b"%PDF")])
def test_write_paper_writes_vector_figures_when_asked(paper, tmp_path, figure_format, magic):
    """Every figure of the paper in the format asked for, the summary naming those files."""
    from torqueopt.paper import write_paper

    written = write_paper(paper, tmp_path, figure_format=figure_format)
    figures = [path for path in written if path.suffix not in (".json", ".md")]
    # Figs. 2-7 (six), four stick-figure strips and the tip paths
    assert len(figures) == 11 and all(path.suffix == f".{figure_format}" for path in figures)
    for path in figures:
        assert path.read_bytes()[: len(magic)] == magic, path.name
    assert not list(tmp_path.glob("*.png"))
    markdown = (tmp_path / "summary.md").read_text()
    assert all(f"- `{path.name}`\n" in markdown for path in figures)


def test_paper_refuses_an_unknown_figure_format(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["paper", "--out", "x", "--format", "jpeg"])
    assert stop.value.code == 2
    assert "argument --format: invalid choice: 'jpeg' (choose from 'png', 'pdf', 'svg')" in capsys.readouterr().err


def test_paper_checks_every_file_before_it_simulates(tmp_path, capsys, monkeypatch):
    """A file of the paper's it may not replace (a read-only tip_long.png) is refused before the 20 s of work."""
    import torqueopt.cli.paper as paper_module

    monkeypatch.setattr(paper_module, "run_paper", lambda *args, **kwargs: pytest.fail("simulated before the check"))
    (tmp_path / "fig2.png").write_text("the user's")
    (tmp_path / "tip_long.png").write_text("the user's")
    (tmp_path / "tip_long.png").chmod(0o444)
    assert main(["paper", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == (
        f"torqueopt paper: error: cannot write '{tmp_path}/tip_long.png': it is read-only; "
        "make it writable or write to a new name\n"
    )
    assert (tmp_path / "fig2.png").read_text() == "the user's"


def test_the_papers_files_are_named_before_the_work(tmp_path):
    from torqueopt.paper import paper_files

    names = [path.name for path in paper_files(tmp_path, "svg", remedies=True, sweep=False)]
    assert names == [
        *(f"fig{i}.svg" for i in range(2, 8)),
        *(f"arm_long_{name}.svg" for name in ("pinv", "inertia-pinv", "null-space", "weighted-null-space")),
        "tip_long.svg",
        "remedies_long.svg",
        "summary.json",
        "summary.md",
    ]


@pytest.mark.slow
def test_the_paper_figures_draw_the_runs_they_name(paper, tmp_path, saved_figures):
    """Each figure read back: the torques, speeds, arm poses and tip paths of the runs its title names."""
    from torqueopt.paper.figures import write_figures

    from .drawn import data, labelled, vertical_marks

    written = write_figures(paper, tmp_path, "svg")
    figures = {path.stem: figure for path, figure in zip(written, saved_figures, strict=True)}
    assert set(figures) == {"fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "tip_long"} | {
        f"arm_long_{name}" for name in ("pinv", "inertia-pinv", "null-space", "weighted-null-space")
    }
    for stem, movement, names in (("fig2", "short", ("pinv", "null-space")), ("fig3", "medium", ("pinv", "null-space")),
                                  ("fig4", "long", ("pinv", "null-space")),
                                  ("fig6", "short", ("weighted-null-space", "inertia-pinv"))):  # fmt: skip
        assert (
            figures[stem].get_suptitle().startswith(f"Fig. {stem[-1]}: joint torques, {' vs '.join(names)}, {movement}")
        )
        unstable = {
            f"{name} unstable from {paper.whiplash[movement, name].time:.2f} s": paper.whiplash[movement, name].time
            for name in names
            if paper.whiplash[movement, name].unstable
        }
        for joint, ax in enumerate(figures[stem].axes):
            for name in names:
                np.testing.assert_array_equal(data(ax, name)[1], paper.runs[movement, name].tau[:, joint])
            assert vertical_marks(ax) == unstable
    assert "null-space unstable from 1.39 s" in vertical_marks(figures["fig4"].axes[0])
    long_null = paper.runs["long", "null-space"]
    speed_ax, _ = figures["fig5"].axes
    for joint, name in enumerate(long_null.joint_names):
        np.testing.assert_array_equal(data(speed_ax, name)[1], long_null.v[:, joint])
    assert vertical_marks(speed_ax)[f"null-space unstable ({paper.whiplash['long', 'null-space'].time:.3f} s)"] > 0
    strips = [("fig7", paper.free_swing)] + [(f"arm_long_{name}", paper.runs["long", name]) for name in
                                             ("pinv", "inertia-pinv", "null-space", "weighted-null-space")]  # fmt: skip
    for stem, run in strips:
        panels = [
            ax
            for ax in figures[stem].axes
            if any(line.get_label() == "arm (joints as dots)" for line in ax.get_lines())
        ]
        assert len(panels) == 10, stem
        for ax in panels:
            row = len(labelled(ax, "tip path so far").get_xdata()) - 1
            absolute = np.cumsum(run.joint_angles[row])
            joints = np.cumsum(np.column_stack([np.cos(absolute), np.sin(absolute)]), axis=0)
            np.testing.assert_allclose(np.column_stack(data(ax, "arm (joints as dots)"))[1:], joints, atol=1e-12)
    path_ax, error_ax = figures["tip_long"].axes
    for name in ("pinv", "inertia-pinv", "null-space", "weighted-null-space"):
        run = paper.runs["long", name]
        np.testing.assert_allclose(data(error_ax, f"{name} tip")[1], 1e3 * np.linalg.norm(run.x - run.x_ref, axis=1))
        along = (run.x - run.x_ref[0]) @ (np.array([1.0, 1.0]) / math.sqrt(2.0))
        np.testing.assert_allclose(data(path_ax, f"{name} tip")[0], along, atol=1e-12)


def test_a_remedy_that_costs_more_than_pinv_keeps_none_of_the_cut(capsys):
    """The console said "keeps -80% of null-space's cut" for a remedy costing more than pinv."""
    from types import SimpleNamespace

    from torqueopt.cli.paper import print_remedies

    rows = [
        {"movement": "short", "resolver": "damped-null-space", "peak_torque_ratio": 0.83, "null_space_cut_kept": 0.4},
        {"movement": "medium", "resolver": "damped-null-space", "peak_torque_ratio": 0.94, "null_space_cut_kept": -0.8},
    ]
    study = SimpleNamespace(remedies=("damped-null-space",), skipped=(), entries=lambda: rows,
                            verdict=lambda movement, name: "stable", summary=lambda: {"answers": {}})  # fmt: skip
    print_remedies(study)
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].endswith("stable, keeps 40% of null-space's cut")
    assert lines[2].endswith("stable, keeps none of null-space's cut (it costs more than pinv)")


def test_the_free_swing_gets_no_note_about_holding_its_start():
    """The zero-torque swing was told that holding its start against gravity needs 1.23 times joint 3's limit."""
    import warnings

    from torqueopt.paper.free_swing import free_swing

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        swing = free_swing(PAPER, duration=0.05)
    assert [str(w.message) for w in caught] == [] and np.all(swing.tau[:-1] == 0.0)


def test_the_papers_arm_runs_its_bounded_resolvers_without_joint_limits(planar3):
    """The paper's arm has no joint limits: the scenario turns off those planar3's URDF writes (±2π) for resolvers that take them."""
    from torqueopt.paper import PAPER, run_movement

    assert PAPER.resolver_options("pinv") == {}
    assert PAPER.resolver_options("minmax-torque") == {"joint_limits": "off"}
    paper_run = run_movement(PAPER, "long", "minmax-torque")
    limited = torqueopt.simulate(
        PAPER.load_robot(), "minmax-torque", PAPER.line("long"), PAPER.q0, resolver_options={"joint_limits": "on"}
    )
    unlimited = torqueopt.simulate(
        PAPER.load_robot(), "minmax-torque", PAPER.line("long"), PAPER.q0, resolver_options={"joint_limits": "off"}
    )
    np.testing.assert_array_equal(paper_run.q, unlimited.q)
    # The URDF's limits would bind on the long movement (the stopping-distance bound under the paper's torque
    # limits; on the medium one they no longer do since the stopping deceleration counts gravity only): they
    # change the run by radians, and the steps they bind on name that bound.
    assert np.abs(limited.q - unlimited.q).max() > 0.1
    assert any("position limit (stopping distance) (upper) of joint joint3" in why for why in limited.limiting.values())
    assert not any("stopping distance" in why for why in unlimited.limiting.values())
