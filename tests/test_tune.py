"""``torqueopt tune``: the choice against a brute-force pick, the evidence against the atlas's own rows,
dropping settings early against running them all, reproducibility, the options used back, and bad input."""

# ruff: noqa: E402

from __future__ import annotations

import importlib.util
import json
import math

import numpy as np
import pytest

pandas = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")
pytest.importorskip("tqdm")
if importlib.util.find_spec("distributed") is None:
    pytest.skip("the atlas needs dask[distributed]", allow_module_level=True)

import torqueopt
from torqueopt.cli import main
from torqueopt.errors import InvalidInput
from torqueopt.tune import tune, tuned_options

GRID = {"kinematic_weight": (0.0, 0.5, 2.0, 8.0), "damping": (10.0,)}
SMALL = {
    "grid": GRID, "paths": 8, "chunk_size": 4, "durations": (0.3, 0.5), "seed": 0, "whiplash_bound": 0.5,
    "workers": 0, "progress": False,
}  # fmt: skip


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    out = tmp_path_factory.mktemp("tune") / "planar3"
    return tune("planar3", "damped-null-space", out=out, **SMALL)


def _wilson_upper(successes: int, trials: int, z: float = 1.959963984540054) -> float:
    """The Wilson score interval's upper end, from its formula (not SciPy's)."""
    p = successes / trials
    centre = p + z * z / (2 * trials)
    spread = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials))
    return (centre + spread) / (1 + z * z / trials)


def test_the_choice_is_the_brute_force_pick_from_the_evidence_table(tuned):
    written = json.loads((tuned.out / "tune.json").read_text())
    rows = written["settings"]
    assert len(rows) == 4 and written["chosen"] is not None
    everywhere = written["pinv_handles"]  # a qualifying setting ran on every path pinv handles
    eligible = [
        row for row in rows
        if row["pinv_handles"] == everywhere and _wilson_upper(row["whips"], row["pinv_handles"]) <= 0.5
        and row["over_limits"] == 0 and row["saving"] is not None and row["saving"] > 0
    ]  # fmt: skip
    assert [row["qualifies"] for row in rows] == [row in eligible for row in rows]
    best = max(eligible, key=lambda row: row["saving"])
    assert written["chosen"]["options"] == best["options"] == {"kinematic_weight": 2.0, "damping": 10.0}
    # Two settings qualify, with different savings: the pick is a choice, not the only candidate.
    assert len(eligible) == 2 and eligible[0]["saving"] != eligible[1]["saving"]
    markdown = (tuned.out / "tune.md").read_text()
    assert "**Chosen:** kinematic_weight=2, damping=10" in markdown
    assert "--resolver damped-null-space --option kinematic_weight=2 --option damping=10" in markdown
    assert markdown.count("| kinematic_weight=") == 4
    # The settings as a table (docs/guide/tune.md says the sentences): the bound and the count of P from the runs.
    assert written["criteria"] == {
        "whip_high_at_most": 0.5, "peak_torque_ratio_at_most": 1.0, "median_torque_vs_pinv_below": 1.0
    }  # fmt: skip
    assert markdown.splitlines()[4].endswith(f"| 50% | {everywhere} of {written['movements']} |")


def test_the_evidence_is_the_atlas_rows_counted_again(tuned):
    """Recount a fully-run setting's figures from the rows on disk (pinv's atlas, the settings' chunks), by the
    criteria's words."""
    assert _recounted(tuned) >= 2


def _recounted(tuned) -> int:
    """How many fully-run settings of ``tuned`` have the figures its rows on disk give again (asserted)."""
    pinv = pandas.read_parquet(tuned.out / "pinv" / "results.parquet").set_index("path")
    handled = [p for p, row in pinv.iterrows() if row["verdict"] == "stable" and row["peak_torque_ratio"] <= 1]
    table = pandas.concat(
        [pandas.read_parquet(path) for path in sorted((tuned.out / "settings" / "chunks").glob("*.parquet"))]
    )
    assert sorted(set(table["path"])) == handled  # the settings ran on those paths and no other
    counted = 0
    for row in tuned.settings:
        if not row["stage"].startswith("all "):
            continue
        counted += 1
        runs = table[table["resolver"] == row["label"]].set_index("path").loc[handled]
        assert row["pinv_handles"] == len(handled) > 0
        assert row["whips"] == int((runs["verdict"] == "whiplash").sum())
        outside = [
            p for p, run in runs.iterrows()
            if not run["peak_torque_ratio"] <= 1 or not math.isnan(run["first_position_limit_violation"])
            or not math.isnan(run["first_velocity_limit_violation"])
        ]  # fmt: skip
        assert row["over_limits"] == len(outside)
        ratios = sorted(runs["torque_vs_pinv"])
        middle = len(ratios) // 2
        median = ratios[middle] if len(ratios) % 2 else (ratios[middle - 1] + ratios[middle]) / 2
        assert row["saving"] == pytest.approx(1 - median, abs=1e-15)
    return counted


@pytest.mark.slow
def test_energy_bounded_torque_is_tuned_by_the_same_rules(tmp_path):
    """The guaranteed resolver's E_max and α: its evidence recounted from the rows, the pick the
    brute-force one, and its flags run."""
    options = {**SMALL, "grid": {"energy_limit": (0.03, 1.0), "energy_rate": (20.0,)}}
    tuned = tune("planar3", "energy-bounded-torque", out=tmp_path / "energy", **options)
    assert [row["options"]["energy_limit"] for row in tuned.settings] == [0.03, 1.0]
    assert _recounted(tuned) == 2
    # Each setting ran with its own E_max: the runs without an infeasible step keep E_N at it (to the held
    # torque's overshoot), and the 1 J setting's self-motion goes above the 0.03 J one's.
    table = pandas.concat(pandas.read_parquet(path) for path in (tuned.out / "settings" / "chunks").glob("*.parquet"))
    peaks = {}
    for row in tuned.settings:
        runs = table[(table["resolver"] == row["label"]) & (table["infeasible_steps"] == 0)]
        assert len(runs) >= 4
        assert runs["peak_self_motion_energy"].max() <= 1.01 * row["options"]["energy_limit"]
        peaks[row["options"]["energy_limit"]] = runs["peak_self_motion_energy"].max()
    assert peaks[1.0] > 0.1 > peaks[0.03]
    eligible = [row for row in tuned.settings if row["qualifies"]]
    assert tuned.chosen == (max(eligible, key=lambda row: row["saving"]) if eligible else None)
    assert all(
        row["flags"] == f"--resolver energy-bounded-torque --option energy_limit={row['options']['energy_limit']:g} "
        "--option energy_rate=20"
        for row in tuned.settings
    )


def test_dropping_settings_early_changes_nothing(tmp_path, tuned):
    """Without dropping, every setting runs on every path: the same choice, the same figures for the settings
    that ran to the end, and each dropped setting fails on all the paths too."""
    everything = tune("planar3", "damped-null-space", out=tmp_path, **{**SMALL, "eliminate": False})
    assert everything.chosen["options"] == tuned.chosen["options"]
    full = {row["label"]: row for row in everything.settings}
    dropped = [row for row in tuned.settings if row["stage"].startswith("dropped")]
    assert dropped  # something was dropped early here
    for row in tuned.settings:
        if row in dropped:
            assert not full[row["label"]]["qualifies"] and row["pinv_handles"] < full[row["label"]]["pinv_handles"]
        else:
            assert {k: v for k, v in row.items() if k != "stage"} == {
                k: v for k, v in full[row["label"]].items() if k != "stage"
            }


def test_a_seeded_tune_reproduces_and_resumes(tmp_path, tuned):
    again = tune("planar3", "damped-null-space", out=tmp_path / "again", **SMALL)
    strip = lambda summary: {k: v for k, v in summary.items() if k != "atlas_config"}  # noqa: E731
    assert json.dumps(strip(again.summary), default=str) == json.dumps(strip(tuned.summary), default=str)
    before = (tmp_path / "again" / "tune.json").read_bytes()
    resumed = tune("planar3", "damped-null-space", out=tmp_path / "again", **SMALL)  # every chunk is on disk
    assert resumed.chosen == again.chosen and (tmp_path / "again" / "tune.json").read_bytes() == before


def test_the_chosen_options_go_back_into_the_api_and_the_cli(tuned, planar3, capsys):
    name, options = tuned_options(tuned.out / "tune.json")
    resolver = torqueopt.get_resolver(name, **options)
    assert resolver.label == tuned.chosen["label"] == "damped-null-space[kinematic_weight=2]"
    line = torqueopt.StraightLine([1.0, 1.0], duration=0.5)
    q0 = planar3.configuration([-0.78, 2.36, -2.36])
    direct = torqueopt.simulate(planar3, resolver, line, q0)
    through = torqueopt.simulate(planar3, name, line, q0, resolver_options=options)
    assert np.array_equal(direct.tau, through.tau, equal_nan=True)
    default = torqueopt.simulate(planar3, name, line, q0)
    assert not np.array_equal(default.tau, direct.tau, equal_nan=True)  # the options changed the run
    flags = ["run", "--robot", "planar3", "--resolver", "damped-null-space", "--direction", "1,1", "--duration", "0.5",
             "--q0=-0.78,2.36,-2.36", "--no-dexterity"]  # fmt: skip
    assert main([*flags, "--options-from", str(tuned.out / "tune.json")]) == 0
    from_file = capsys.readouterr().out
    assert main([*flags, *tuned.chosen["flags"].split()[2:]]) == 0
    assert capsys.readouterr().out == from_file
    assert main(flags) == 0
    assert capsys.readouterr().out != from_file


def test_a_tune_file_is_checked_before_its_options_are_used(tuned, tmp_path, capsys):
    flags = ["run", "--robot", "planar3", "--resolver", "damped-null-space", "--direction", "1,1", "--duration", "0.1"]
    chosen = json.loads((tuned.out / "tune.json").read_text())
    for name, content, message in [
        ("missing.json", None, "tune file '{path}' does not exist"),
        ("no-options.json", {**chosen, "chosen": {"label": "x"}}, "'{path}' is not a tune.json written by torqueopt tune"),
        ("panda.json", {**chosen, "robot_name": "panda"},
         "the tune in '{path}' was made on robot 'panda', not 'planar3': tune on 'planar3' (torqueopt tune) or give "
         "the options with --option"),
    ]:  # fmt: skip
        path = tmp_path / name
        if content is not None:
            path.write_text(json.dumps(content))
        assert main([*flags, "--options-from", str(path)]) == 2
        assert capsys.readouterr().err == f"torqueopt run: error: {message.format(path=path)}\n"


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--resolver", "pinv"], "pinv is the baseline every setting is measured against; tune another resolver"),
        (["--resolver", "null-space"], "resolver 'null-space' has no default grid"),
        (["--values", "dampin=1,2"], "unknown option 'dampin' for resolver 'damped-null-space' (did you mean 'damping'?)"),
        (["--values", "damping=1,x"], "option damping=x of resolver 'damped-null-space'"),
        (["--values", "damping"], "--values 'damping' must be NAME=VALUE"),
        (["--values", "damping=1", "--option", "damping=2"], "option damping is both held fixed and in the grid"),
        (["--values", "damping=" + ",".join(str(i) for i in range(1, 66))], "the grid has 65 settings"),
        (["--path", "square"], "--path: 'square' is not a kind of path for the atlas"),
        (["--paths", "1000000"], "the tune would simulate up to"),
        (["--whiplash-bound", "2"], "whiplash_bound=2.0 must be a number in (0, 1]"),
        # Too few movements for the bound even if pinv handled every one: refused before any run.
        (["--paths", "5", "--durations", "0.5,1"], "whiplash_bound=0.01 needs at least 381 movements that pinv "
         "handles, and paths=5 over 2 durations gives 10 at most: give paths=191 or more"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, arguments, message):
    out = tmp_path / "t"
    code = main(["tune", "--robot", "planar3", "--workers", "0", "--no-progress", "--out", str(out), *arguments])
    error = capsys.readouterr().err
    assert code == 2 and message in error and error.count("\n") == 1, error
    assert not out.exists()


def test_a_folder_that_is_not_a_tunes_is_refused(tmp_path, capsys, tuned):
    (tmp_path / "notes.txt").write_text("mine")
    code = main(["tune", "--robot", "planar3", "--workers", "0", "--no-progress", "--out", str(tmp_path)])
    assert code == 2 and "is not empty and holds no tune" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
    with pytest.raises(InvalidInput, match="holds a tune with other settings"):
        tune("planar3", "damped-null-space", out=tuned.out, **{**SMALL, "seed": 1})


def test_its_progress_lines_name_tune_not_the_atlas_it_runs(tmp_path, capsys):
    """A user who typed ``torqueopt tune`` reads "torqueopt tune" in every progress line, the pinv atlas's too."""
    code = main(["tune", "--robot", "planar3", "--torque-limit", "0.01", "--values", "kinematic_weight=2", "--paths",
                 "4", "--durations", "0.3", "--whiplash-bound", "0.5", "--workers", "0", "--out", str(tmp_path)])  # fmt: skip
    error = capsys.readouterr().err
    assert code == 4 and error == "torqueopt tune (the pinv atlas): 4 paths x 1 resolvers ...\n"


def test_no_qualifying_setting_says_so_and_exits_4(tmp_path, capsys):
    """Limits pinv exceeds on every path: it handles none of the 4 the bound needs, no setting is run, the table says
    why, exit 4."""
    code = main(["tune", "--robot", "planar3", "--torque-limit", "0.01", "--values", "kinematic_weight=2", "--paths",
                 "4", "--durations", "0.3", "--whiplash-bound", "0.5", "--workers", "0", "--no-progress",
                 "--out", str(tmp_path)])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 4 and "Traceback" not in captured.err
    assert "no setting of damped-null-space qualifies on planar3: see the table" in captured.out
    written = json.loads((tmp_path / "tune.json").read_text())
    reason = written["settings"][0]["reason"]
    assert written["chosen"] is None and reason == "pinv handles 0 paths; no whip at all needs 4 for the bound"
    assert written["settings"][0]["stage"] == "not run" and not (tmp_path / "settings").exists()
    assert "**No setting qualifies**" in (tmp_path / "tune.md").read_text()
    with pytest.raises(InvalidInput, match="chose no setting"):
        tuned_options(tmp_path / "tune.json")


def test_every_option_of_the_command_sets_its_setting_as_the_api_does():
    """``torqueopt tune``'s options and tune()'s keywords are one declaration (TuneSettings): each option, away
    from its default, is read into the setting of its name with the value the keyword gives."""
    from torqueopt.atlas.jobs import RobotSpec
    from torqueopt.cli import build_parser
    from torqueopt.cli.atlas import robot_spec
    from torqueopt.tune import TuneSettings

    every = {
        "resolver": (["--resolver", "energy-bounded-torque"], "energy-bounded-torque"),
        "grid": (["--values", "energy_limit=0.1,1", "--values", "energy_rate=10"],
                 {"energy_limit": ["0.1", "1"], "energy_rate": ["10"]}),
        "options": (["--option", "torque_weight=unit"], {"torque_weight": "unit"}),
        "paths": (["--paths", "9"], 9),
        "chunk_size": (["--chunk-size", "3"], 3),
        "durations": (["--durations", "0.4,0.8"], (0.4, 0.8)),
        "seed": (["--seed", "5"], 5),
        "out": (["--out", "there"], "there"),
        "whiplash_bound": (["--whiplash-bound", "0.2"], 0.2),
        "path": (["--path", "min-jerk"], "min-jerk"),
        "accel": (["--accel", "1.5"], 1.5),
        "dt": (["--dt", "0.002"], 0.002),
        "workers": (["--workers", "0"], 0),
        "max_steps": (["--max-steps", "1e6"], 1_000_000),
        "progress": (["--no-progress"], False),
    }  # fmt: skip
    assert set(every) == set(TuneSettings.names()) - {"robot", "eliminate"}  # eliminate: the API's only
    argv = ["tune", "--robot", "planar3", "--torque-limit", "40"]
    for arguments, _ in every.values():
        argv += arguments
    args = build_parser().parse_args(argv)
    from_command = TuneSettings.from_arguments(args, robot=robot_spec(args))
    from_api = TuneSettings.from_keywords(
        robot=RobotSpec("planar3", torque_limit=(40.0,)), **{name: value for name, (_, value) in every.items()}
    )
    assert from_command == from_api
    defaults = TuneSettings().as_keywords()
    assert all(from_api.as_keywords()[name] != defaults[name] for name in every)
    with pytest.raises(TypeError, match=r"unknown setting path_kind; the settings are: robot, resolver, grid"):
        tune("planar3", path_kind="line")


def test_a_plug_in_resolver_is_tuned_by_its_import_path(tmp_path):
    # tune read the registry by name (RESOLVERS[name]: a KeyError traceback for module:Class). The plug-in brakes
    # the self-motion as self-motion-damping does, so its evidence equals that resolver's at the same rate.
    small = {**SMALL, "paths": 4, "durations": (0.3,)}
    plug_in = tune("planar3", "tests.plugin_pkg.resolvers:SelfMotionBrake", out=tmp_path / "p",
                   **{**small, "grid": {"gain": (3.0, 8.0)}})  # fmt: skip
    built_in = tune("planar3", "self-motion-damping", out=tmp_path / "b", **{**small, "grid": {"damping": (3.0, 8.0)}})
    assert plug_in.resolver == "tests.plugin_pkg.resolvers:SelfMotionBrake"
    for ours, theirs in zip(plug_in.settings, built_in.settings):
        assert ours["flags"].startswith("--resolver tests.plugin_pkg.resolvers:SelfMotionBrake --option gain=")
        figures = sorted(set(ours) - {"options", "flags", "label"})
        assert figures == sorted(set(theirs) - {"options", "flags", "label"})
        # Its law is the built-in's, written outside the package (its own steps: equal to round-off).
        for key in figures:
            if isinstance(theirs[key], float):
                assert ours[key] == pytest.approx(theirs[key], rel=1e-9, nan_ok=True), key
            else:
                assert ours[key] == theirs[key], key
