"""One resolver with several settings in the atlas: ``NAME[OPTION=VALUE,...]`` labels.

A variant's rows are held to :func:`torqueopt.simulate` with the same
options; two settings of ``bounded-torque`` on panda (joint limits on and
off) are held to the URDF's limits; the labels round-trip through the
parser; bad specs are one-line errors and exit 2.
"""

import json
import math

import numpy as np
import pytest

import torqueopt
from torqueopt.atlas import run_atlas
from torqueopt.atlas.jobs import ResolverChunk, RobotSpec
from torqueopt.atlas.population import Movement
from torqueopt.atlas.sweep import resolvers_from, run_chunk
from torqueopt.atlas.verdicts import Thresholds, run_row, self_motion_energy
from torqueopt.cli import main
from torqueopt.errors import InvalidInput, ResolverNotFound
from torqueopt.resolvers import get_resolver, resolver_from_label
from torqueopt.resolvers.options import parse_resolver_spec, split_resolver_list

pandas = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

ACCEL = math.sqrt(2.0)
#: A 1 s line from panda's default start on which bounded-torque without joint limits leaves them
#: (tests/test_resolver_joint_limits.py): the two settings must differ there.
PANDA_LINE = (0.0, 1.0, 0.0)
OFF = "bounded-torque[joint_limits=off]"


# -- labels ------------------------------------------------------------------------------------


def test_a_label_names_the_options_that_differ_from_the_defaults_and_reads_back():
    assert get_resolver("bounded-torque").label == "bounded-torque"
    assert get_resolver("bounded-torque", joint_limits="on").label == "bounded-torque"  # the default: no brackets
    variant = get_resolver("bounded-torque", damping="2", joint_limits="off")
    # Declared order, whatever order they were given in; values as converted (text "2" is the number 2).
    assert variant.label == "bounded-torque[damping=2,joint_limits=off]"
    assert variant.changed_settings() == {"damping": 2.0, "joint_limits": "off"}
    again = resolver_from_label(variant.label)
    assert again.label == variant.label and again.settings == variant.settings
    weighted = get_resolver("weighted-null-space", weight=[1.0, 2.0, 1.0 / 3.0])
    assert weighted.label == f"weighted-null-space[weight=1,2,{1.0 / 3.0!r}]"  # exact, not %g
    np.testing.assert_array_equal(resolver_from_label(weighted.label).weight, weighted.weight)
    # A vector value inside the brackets: the comma-separated elements stay with their option.
    name, options = parse_resolver_spec("weighted-null-space[weight=1,2,3,singular_tolerance=1e-6]")
    assert (name, options) == ("weighted-null-space", {"weight": "1,2,3", "singular_tolerance": "1e-6"})


def test_the_list_splits_at_commas_outside_the_brackets():
    text = "pinv, bounded-torque[joint_limits=off,damping=2],weighted-null-space[weight=1,2,3] ,null-space"
    assert split_resolver_list(text) == [
        "pinv", "bounded-torque[joint_limits=off,damping=2]", "weighted-null-space[weight=1,2,3]", "null-space",
    ]  # fmt: skip


@pytest.mark.parametrize(
    "text, error, message",
    [
        ("bounded-torque[joint_limits=maybe]", InvalidInput, "option joint_limits=maybe of resolver 'bounded-torque' "
         "must be 'on' or 'off'"),
        ("bounded-torque[jl=off]", InvalidInput, "unknown option 'jl' for resolver 'bounded-torque'"),
        ("bounded-torque[damping=-1]", InvalidInput, "option damping=-1 of resolver 'bounded-torque'"),
        ("bounded-torque[]", InvalidInput, "has empty brackets"),
        ("bounded-torque[off]", InvalidInput, "'off' is not OPTION=VALUE"),
        ("bounded-torque[damping=1,damping=2]", InvalidInput, "gives option damping twice"),
        ("bounded-torque[joint_limits=off]x", InvalidInput, "is not NAME or NAME[OPTION=VALUE,...]"),
        ("bounded-torqe[joint_limits=off]", ResolverNotFound, "unknown resolver 'bounded-torqe' (did you mean "
         "'bounded-torque'?)"),
    ],
)  # fmt: skip
def test_a_bad_spec_is_refused_by_the_resolvers_own_checks(text, error, message):
    with pytest.raises(error) as caught:
        resolvers_from(split_resolver_list(text))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_the_same_setting_twice_is_refused_and_pinv_stays_the_baseline():
    with pytest.raises(InvalidInput, match=r"resolvers bounded-torque given twice"):
        resolvers_from(["bounded-torque", "bounded-torque[joint_limits=on]"])
    resolvers = resolvers_from(["null-space", OFF, "bounded-torque", get_resolver("bounded-torque", damping=3.0)])
    assert [r.label for r in resolvers] == [
        "pinv", "null-space", OFF, "bounded-torque", "bounded-torque[damping=3]",
    ]  # fmt: skip


@pytest.mark.parametrize(
    "spec, message",
    [
        ("pinv,bounded-torque[joint_limits=maybe]", "option joint_limits=maybe of resolver 'bounded-torque' must be"),
        ("pinv,bounded-torque[joint_limits=off", "leaves a '[' unclosed"),
        ("pinv,bounded-torque,bounded-torque[joint_limits=on]", "resolvers bounded-torque given twice"),
        ("pinv,bounded-torque[nope=1]", "unknown option 'nope' for resolver 'bounded-torque'"),
    ],
)
def test_cli_bad_specs_are_one_line_and_exit_2(tmp_path, capsys, spec, message):
    code = main(["atlas", "--robot", "planar3", "--paths", "2", "--durations", "0.2", "--workers", "0",
                 "--no-progress", "--no-figures", "--resolvers", spec, "--out", str(tmp_path / "a")])  # fmt: skip
    error = capsys.readouterr().err
    assert code == 2 and message in error and error.count("\n") == 1, error
    assert not (tmp_path / "a").exists()


# -- the rows of each setting ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def panda_rows():
    """pinv and bounded-torque with joint limits on and off on one 1 s panda line, through the atlas's chunk."""
    robot = torqueopt.load_robot("panda", task="position")
    q0 = robot.default_configuration
    direction = np.asarray(PANDA_LINE)
    movement = Movement(0, 1.0, q0, direction, robot.task_position(robot.configuration(q0)), accel=ACCEL)
    resolvers = tuple(resolvers_from(["pinv", "bounded-torque", OFF]))
    job = ResolverChunk(RobotSpec("panda", task="position"), resolvers, (movement,), 1e-3, Thresholds(), True, "")
    return robot, {row["resolver"]: row for row in run_chunk(job)}


def test_a_variants_row_equals_simulate_with_its_options(panda_rows):
    robot, rows = panda_rows
    line = torqueopt.StraightLine(PANDA_LINE, accel=ACCEL, duration=1.0)
    pinv_peak = rows["pinv"]["pinv_peak_torque_ratio"]
    for label, options in (("bounded-torque", {}), (OFF, {"joint_limits": "off"})):
        run = torqueopt.simulate(
            robot, "bounded-torque", line, robot.default_configuration, dt=1e-3, resolver_options=options
        )
        kinetic, self_energy = self_motion_energy(robot, run)
        expected = run_row(run, kinetic, self_energy, pinv_peak, Thresholds())
        row = rows[label]
        assert json.loads(row["resolver_options"]) == options
        for key in ("verdict", "first_position_limit_violation", "first_velocity_limit_violation",
                    "position_limit_joint", "velocity_limit_joint", "infeasible_steps"):  # fmt: skip
            assert row[key] == expected[key] or (row[key] != row[key] and expected[key] != expected[key]), key
        # The batch's vectorised QP (warm-started DAQP per movement) and simulate's single-state one: the same run
        # (they drifted apart by 5e-6 of the tip error while the joint-limit bounds made the torque chatter).
        for key in ("peak_torque_ratio", "max_task_error", "max_tip_error"):
            assert row[key] == pytest.approx(expected[key], rel=1e-9, abs=1e-12), key


def test_joint_limits_on_and_off_differ_on_panda(panda_rows):
    """On: inside every position and velocity limit at every sample. Off: the same line leaves them."""
    robot, rows = panda_rows
    on, off = rows["bounded-torque"], rows[OFF]
    assert math.isnan(on["first_position_limit_violation"]) and math.isnan(on["first_velocity_limit_violation"])
    assert on["verdict"] != "joint limits"
    assert off["verdict"] == "joint limits"
    assert math.isfinite(off["first_position_limit_violation"]) or math.isfinite(off["first_velocity_limit_violation"])
    assert off["position_limit_joint"] in robot.joint_names or off["velocity_limit_joint"] in robot.joint_names


# -- the whole atlas ----------------------------------------------------------------------------


def test_every_file_of_the_atlas_keeps_the_settings_apart_and_resume_knows_them(tmp_path):
    """Two settings of one resolver: their own rows, verdict counts, figures' labels and explorer entries; the
    same command resumes every chunk, another setting is another atlas."""
    pytest.importorskip("matplotlib")
    pytest.importorskip("plotly")
    settings = {"paths": 2, "durations": (0.2,), "chunk_size": 1, "progress": False, "workers": 0, "keep_traces": 2}
    resolvers = ["pinv", "damped-null-space", "damped-null-space[damping=50]"]
    first = run_atlas("planar3", resolvers=resolvers, out=tmp_path / "a", **settings)
    table = first.table
    assert list(table["resolver"][:3]) == resolvers
    assert list(table["resolver_options"][:3]) == ["{}", "{}", '{"damping": 50.0}']
    assert first.summary["resolvers"] == resolvers
    assert set(first.summary["verdicts"]) == set(resolvers)
    one, other = (table[table["resolver"] == label] for label in resolvers[1:])
    assert not np.allclose(one["peak_torque_ratio"], other["peak_torque_ratio"])  # the option was applied
    text = (tmp_path / "a" / "atlas.md").read_text()
    assert "| damped-null-space[damping=50] |" in text and "| damped-null-space |" in text
    explorer = (tmp_path / "a" / "explorer.html").read_text()
    assert '"damped-null-space[damping=50]"' in explorer
    config = json.loads((tmp_path / "a" / "atlas-config.json").read_text())
    assert [r["label"] for r in config["resolvers"]] == resolvers
    again = run_atlas("planar3", resolvers=resolvers, out=tmp_path / "a", **settings)
    assert again.summary["resumed_chunks"] == 2
    pandas.testing.assert_frame_equal(again.table, table)
    with pytest.raises(InvalidInput, match=r"holds an atlas with other settings \(resolvers differ\)"):
        run_atlas(
            "planar3", resolvers=[*resolvers[:2], "damped-null-space[damping=20]"], out=tmp_path / "a", **settings
        )
