"""The run command: the summary, the files, and one-line errors with exit code 2."""

import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import torqueopt
from torqueopt.catalog import find_robot
from torqueopt.cli import main

from .conftest import PAPER_Q0

ROOT = Path(__file__).resolve().parents[1]
PAPER = ["--robot", "planar3", "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1"]


def test_run_prints_a_summary_and_writes_the_run(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["run", *PAPER, "--resolver", "null-space", "--duration", "0.5", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    assert "planar3: resolver null-space, task xy at frame 'tip' (n=3, m=2), 500 steps of 1 ms" in printed
    assert "first limit violation: none" in printed and "status: completed" in printed
    assert out.is_file() and (tmp_path / "run.csv.json").is_file()
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (501, 16 + 6)  # t, 3 q, 3 v, 3 tau, 2 x, 2 xref, task_error, infeasible, 6 dexterity
    # The summary's peak torque of joint 1 is the CSV's, to print precision.
    joint1 = next(line for line in printed.splitlines() if line.startswith("joint1"))
    assert float(joint1.split()[1]) == pytest.approx(np.nanmax(np.abs(table[:, 7])), abs=1e-3)
    # The row at t = T is the final state, with no torque applied from it.
    assert np.isnan(table[-1, 7:10]).all() and np.isfinite(table[:-1, 7:10]).all()


def test_degrees_and_npz(tmp_path, capsys):
    out = tmp_path / "run.npz"
    code = main(["run", "--robot", "planar3", "--q0=-45,135,-135", "--degrees", "--direction", "1,1",
                 "--resolver", "pinv", "--duration", "0.2", "--out", str(out)])  # fmt: skip
    assert code == 0 and out.is_file()
    # The start read back from the file: -45°, 135°, -135° in radians, and the tip where they put it
    # (link angles -45°, 90°, -45° of three unit links: x = √2, y = 1 - √2).
    run = torqueopt.load_result(out)
    np.testing.assert_allclose(run.q[0], [-np.pi / 4, 3 * np.pi / 4, -3 * np.pi / 4], atol=1e-15)
    np.testing.assert_allclose(run.x[0], [np.sqrt(2.0), 1.0 - np.sqrt(2.0)], atol=1e-12)
    with np.load(out) as saved:
        np.testing.assert_allclose(saved["q"][0], np.radians([-45.0, 135.0, -135.0]), atol=1e-15)


def test_run_that_explodes_exits_3_and_keeps_its_rows(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["run", "--robot", "xarm7", "--resolver", "null-space", "--direction", "0,1,0",
                 "--duration", "0.5", "--out", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 3
    assert "status: STOPPED EARLY: speed of joint" in printed
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert np.isfinite(table).all() and 10 < len(table) < 501


def broken_urdf(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text(find_robot("planar3").urdf.read_text().replace('<child link="link2"/>', ""))
    return str(path)


BAD_INPUTS = [
    (["--robot", "nowhere/arm.urdf"], "URDF file 'nowhere/arm.urdf' does not exist"),
    (["--robot", "BROKEN"], '<joint name="joint2"> has no <child link="..."/>'),
    (["--robot", "robbie"], "unknown robot 'robbie': give a URDF path or one of planar3, panda"),
    (["--robot", "planar3", "--frame", "hand"], "robot 'planar3' has no frame 'hand': choose one of"),
    (
        ["--robot", "planar3", "--resolver", "magic"],
        f"unknown resolver 'magic': choose one of {', '.join(torqueopt.resolver_names())}",
    ),
    (["--robot", "planar3", "--task", "spin"], "unknown task 'spin': choose one of xy, position, pose"),
    (["--robot", "planar3", "--q0=0.1,0.2"], "--q0 has 2 values but needs 3"),
    (["--robot", "planar3", "--q0=0.1,nan,0.2"], "--q0: 'nan' is not finite; give finite numbers"),
    (
        ["--robot", "planar3", "--q0=0.1,abc,0.2"],
        "--q0: 'abc' is not a number (give comma-separated numbers, e.g. 1,1)",
    ),
    (["--robot", "planar3", "--direction", "0,0"], "direction [0.0, 0.0] is zero; give a non-zero direction"),
    (["--robot", "planar3", "--duration", "0"], "--duration: 0 must be a positive finite number"),
    (["--robot", "planar3", "--duration", "-1"], "--duration: -1 must be a positive finite number"),
    (["--robot", "planar3", "--dt", "0"], "--dt: 0 must be a positive finite number"),
    (
        ["--robot", "planar3", "--task", "position", "--direction", "1,1,0"],
        "task 'position' (m=3) at frame 'tip' of robot 'planar3' can never be realised: its 3 joints move the frame in only 2 independent directions",
    ),
    (["--robot", "planar3", "--task", "position", "--direction", "1,1,0"], "valid: task xy at this frame"),
    (
        ["--robot", "panda", "--frame", "panda_link3", "--direction", "1,1,0"],
        "task 'position' (m=3) at frame 'panda_link3' of robot 'panda' can never be realised",
    ),
    (
        ["--robot", "planar3", "--resolver", "weighted-null-space", "--weight", "0,0,0"],
        "weight [0.0, 0.0, 0.0] is zero for every joint, which leaves no torque to minimise",
    ),
    (
        ["--robot", "planar3", "--duration", "2", "--dt", "0.3"],
        "dt=0.3 s does not divide the duration 2 s (6.667 steps); give a dt that does, such as 0.333333 s (6 steps) or 0.285714 s (7 steps)",
    ),
    (
        ["--robot", "planar3", "--duration", "1e9"],
        "duration 1e+09 s at dt 0.001 s needs 1e+12 steps, more than the limit of 1,000,000 steps (raise it with --max-steps)",
    ),
    (
        ["--robot", "planar3", "--duration", "2", "--dt", "1e-9"],
        "needs 2e+09 steps, more than the limit of 1,000,000 steps",
    ),
    (
        ["--robot", "planar3", "--duration", "1", "--max-steps", "999"],
        "duration 1 s at dt 0.001 s needs 1000 steps, more than the limit of 999 steps",
    ),
    (["--robot", "planar3", "--max-steps", "1.5"], "--max-steps: 1.5 must be a whole number >= 1"),
    (
        ["--robot", "planar3", "--html", "HTML", "--speed", "1e-9"],
        "needs 3e+09 frames, more than the limit of 100,000 frames (raise it with --max-frames)",
    ),
    (["--robot", "planar3", "--feedback=-100,1"], "feedback gain kp=-100.0 must be a finite number >= 0"),
    (["--robot", "planar3", "--torque-limit", "1,2"], "torque limit has 2 values; robot 'planar3' needs 1 or 3"),
    (["--robot", "planar3", "--feedback", "1"], "--feedback has 1 value but needs 2"),
    (["--robot", "planar3", "--torque-limit", "nan"], "--torque-limit: 'nan' is not finite"),
]


@pytest.mark.parametrize("arguments, message", BAD_INPUTS)
def test_bad_input_is_one_line_exit_2_and_no_file(arguments, message, tmp_path, capsys):
    arguments = [broken_urdf(tmp_path) if a == "BROKEN" else a for a in arguments]
    arguments = [str(tmp_path / "run.html") if a == "HTML" else a for a in arguments]
    defaults = {"--resolver": "null-space", "--direction": "1,1", "--duration": "0.1"}
    for option, value in defaults.items():
        if option not in arguments:
            arguments += [option, value]
    out = tmp_path / "run.csv"
    code = main(["run", *arguments, "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 2
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torqueopt run: error: ")
    assert message in lines[0]
    assert "Traceback" not in captured.err and not out.exists()
    # Refused before any work: no message uses numpy's repr or a plural for one value.
    assert "np.float64" not in lines[0] and "has 1 values" not in lines[0]
    assert not (tmp_path / "run.html").exists()


def test_bad_work_is_refused_before_it_starts(capsys):
    """A run of 1e12 steps must be refused at once, not after allocating: the
    limit is checked on duration / dt before the robot is even loaded."""
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "1e300"])
    assert code == 2 and "more than the limit of 1,000,000 steps" in capsys.readouterr().err
    # Raising the limit lets a longer run through: 1001 steps at the paper's dt with --max-steps 1001 ...
    assert main(["run", *PAPER, "--resolver", "pinv", "--duration", "1.001", "--max-steps", "1001"]) == 0
    assert "1001 steps of 1 ms" in capsys.readouterr().out


def test_an_infinite_torque_limit_means_unbounded(capsys):
    code = main(["run", *PAPER, "--resolver", "pinv", "--duration", "0.2", "--torque-limit", "54,inf,6"])
    printed = capsys.readouterr().out
    assert code == 0
    joint2 = next(line for line in printed.splitlines() if line.startswith("joint2"))
    assert joint2.split()[2] == "none"


def test_an_unknown_option_points_at_the_subcommand_help(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["run", *PAPER, "--resolver", "pinv", "--bogus", "3"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["torqueopt run: error: unrecognized arguments: --bogus 3 (see torqueopt run --help)"]


def test_usage_errors_are_one_line_too(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["run", "--robot", "planar3"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the following arguments are required: --resolver" in err[0]


def test_console_script_exit_code_and_no_traceback(tmp_path):
    process = subprocess.run(
        [sys.executable, "-m", "torqueopt", "run", *PAPER, "--resolver", "spline"],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert process.returncode == 2
    assert process.stderr.strip() == (
        f"torqueopt run: error: unknown resolver 'spline': choose one of {', '.join(torqueopt.resolver_names())}"
    )


def test_missing_torque_limits_are_reported_and_required_where_divided_by(tmp_path, capsys):
    path = tmp_path / "nolimit.urdf"
    path.write_text(find_robot("planar3").urdf.read_text().replace('effort="6.0"', 'effort="0"'))
    base = ["run", "--robot", str(path), "--frame", "tip", "--task", "xy", "--direction", "1,1", "--duration", "0.1",
            "--q0=-0.7853981634,2.3561944902,-2.3561944902"]  # fmt: skip
    assert main([*base, "--resolver", "weighted-null-space"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "torqueopt run: error: joints joint3 of robot 'nolimit' have no torque limit (URDF effort zero, infinite or "
        "missing) and weighted-null-space weights torques by their range: give --torque-limit (or a weight option)"
    ]
    assert main([*base, "--resolver", "weighted-null-space", "--torque-limit", "54,24,6"]) == 0
    assert main([*base, "--resolver", "null-space"]) == 0
    captured = capsys.readouterr()
    assert "note: joints joint3 of robot 'nolimit' have no torque limit" in captured.err
    assert "no torque limit for joints joint3" in captured.out


def test_a_user_s_file_that_shares_an_output_s_name_is_refused_before_any_work(tmp_path, capsys):
    # A sidecar that is not a run's, and a folder of the user's files, are left as they were.
    theirs = tmp_path / "data.csv.json"
    theirs.write_text('{"mine": 1}')
    code = main(["run", *PAPER, "--resolver", "pinv", "--duration", "0.1", "--out", str(tmp_path / "data.csv")])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == "" and theirs.read_text() == '{"mine": 1}'
    assert captured.err == (
        f"torqueopt run: error: cannot write '{theirs}': it is not a run's sidecar, and torqueopt replaces only "
        "its own; give --out another name\n"
    )
    assert not (tmp_path / "data.csv").exists()
    folder = tmp_path / "notes"
    folder.mkdir()
    (folder / "summary.md").write_text("my notes")
    assert main(["paper", "--out", str(folder)]) == 2
    assert capsys.readouterr().err == (
        f"torqueopt paper: error: cannot write '{folder / 'summary.md'}': it is not a file of a torqueopt paper "
        f"folder ('{folder}' holds no summary.json of one), and torqueopt replaces only its own; give an empty "
        "or new --out\n"
    )
    assert (folder / "summary.md").read_text() == "my notes" and sorted(p.name for p in folder.iterdir()) == [
        "summary.md"
    ]


def test_a_run_replaces_its_own_files(tmp_path, capsys):
    out = tmp_path / "run.csv"
    arguments = ["run", *PAPER, "--resolver", "pinv", "--duration", "0.1", "--out", str(out)]
    assert main(arguments) == 0 and main(arguments) == 0
    assert capsys.readouterr().out.endswith(f"wrote {out} and {out}.json\n")


def test_robots_lists_the_paper_arm_and_the_7dof_arms(capsys):
    assert main(["robots"]) == 0
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[1:]}
    assert rows["planar3"][1:3] == ["tip", "xy"]
    assert rows["panda"][1:3] == ["panda_hand", "position"]
    assert {"xarm7", "baxter", "tiago", "kinova"} <= set(rows)


def test_unwritable_output_is_refused_before_simulating(tmp_path, capsys):
    folder = tmp_path / "taken"
    folder.mkdir()
    code = main(["run", *PAPER, "--resolver", "pinv", "--duration", "0.1", "--out", str(folder)])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err == f"torqueopt run: error: cannot write '{folder}': it is a folder; give a file name\n"
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = main(["paper", "--out", str(blocker / "sub")])
    assert code == 2
    assert (
        capsys.readouterr().err
        == f"torqueopt paper: error: cannot write to '{blocker / 'sub'}': '{blocker}' is a file, not a folder\n"
    )
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    assert main(["paper", "--out", str(fifo)]) == 2
    assert (
        capsys.readouterr().err
        == f"torqueopt paper: error: cannot write to '{fifo}': '{fifo}' is a FIFO, not a folder\n"
    )
    assert stat.S_ISFIFO(fifo.lstat().st_mode)  # left as it was


def test_option_errors_are_one_line_exit_2(tmp_path, capsys):
    cases = [
        (["--resolver", "weighted-null-space", "--option", "wieght=1,1,1"],
         "unknown option 'wieght' for resolver 'weighted-null-space' (did you mean 'weight'?); valid options: weight, singular_tolerance"),
        (["--resolver", "pinv", "--weight", "1,1,1"], "unknown option 'weight' for resolver 'pinv'; valid options: singular_tolerance"),
        (["--resolver", "pinv", "--option", "singular_tolerance"], "--option 'singular_tolerance' must be NAME=VALUE, e.g. --option damping=2"),
        (["--resolver", "pinv", "--option", "singular_tolerance=-1"],
         "option singular_tolerance=-1 of resolver 'pinv' must be a finite number > 0"),
        (["--resolver", "weighted-null-space", "--weight", "1,1,1", "--option", "weight=1,1,1"],
         "--weight and --option weight= are the same option; give one"),
        (["--resolver", "weighted-null-space", "--weight", "1,1"],
         "weight must be a vector of 3 values or a symmetric 3x3 matrix, got shape (2,)"),
    ]  # fmt: skip
    out = tmp_path / "run.csv"
    for arguments, message in cases:
        code = main(["run", *PAPER, "--duration", "0.1", *arguments, "--out", str(out)])
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("torqueopt run: error: ")
        assert message in lines[0], lines[0]
        assert not out.exists()


def test_weight_alias_and_generic_option_give_the_same_run(tmp_path, capsys):
    base = ["run", *PAPER, "--duration", "0.2", "--resolver", "weighted-null-space"]
    assert main([*base, "--weight", "1,4,9", "--out", str(tmp_path / "alias.npz")]) == 0
    assert main([*base, "--option", "weight=1,4,9", "--out", str(tmp_path / "option.npz")]) == 0
    alias, option = (torqueopt.load_result(tmp_path / name) for name in ("alias.npz", "option.npz"))
    np.testing.assert_array_equal(alias.tau, option.tau)
    assert alias.resolver_options == {"weight": [1.0, 4.0, 9.0], "singular_tolerance": 1e-6}
    default = main([*base, "--out", str(tmp_path / "default.npz")])
    assert default == 0 and np.nanmax(np.abs(torqueopt.load_result(tmp_path / "default.npz").tau - alias.tau)) > 1e-3


def test_resolvers_command_lists_every_resolver_and_option(capsys):
    assert main(["resolvers"]) == 0
    printed = capsys.readouterr().out
    for name, cls in torqueopt.resolvers.RESOLVERS.items():
        assert f"{name}: {cls.summary()}" in printed
        for option in cls.declared_options():
            assert option.name in printed and option.meaning in printed
    assert "[1/(N·m)²]" in printed and "default 1/(τ⁺−τ⁻)², Eq. (33)" in printed
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "--option NAME=VALUE" in help_text and "weighted-null-space: weight [1/(N·m)²]" in help_text


def test_no_parser_takes_an_abbreviated_option(capsys):
    """argparse took any unambiguous prefix (--dur for --durations or --duration): every
    parser of the CLI, the examples and the benchmarks is built with allow_abbrev=False."""
    import re
    from pathlib import Path

    from torqueopt.cli import build_parser

    parser = build_parser()
    subparsers = next(action for action in parser._actions if action.choices and hasattr(action, "_name_parser_map"))
    assert not parser.allow_abbrev
    for name, subparser in subparsers.choices.items():
        assert not subparser.allow_abbrev, name
    for arguments, message in [
        (["paper", "--dur", "2,1", "--out", "x"], "torqueopt paper: error: unrecognized arguments: --dur 2,1"),
        (["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--dur", "2"],
         "torqueopt run: error: unrecognized arguments: --dur 2"),
    ]:  # fmt: skip
        with pytest.raises(SystemExit) as stop:
            main(arguments)
        assert stop.value.code == 2
        assert capsys.readouterr().err == f"{message} (see {message.split(':')[0]} --help)\n"
    root = Path(__file__).resolve().parent.parent
    for script in [*root.glob("examples/*.py"), *root.glob("benchmarks/*.py")]:
        for call in re.findall(r"ArgumentParser\((.*?)\)\n", script.read_text(), re.S):
            assert "allow_abbrev=False" in call, script.name


def _process(tmp_path, arguments, **environment):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root, **environment}
    return subprocess.run([sys.executable, "-m", "torqueopt", *arguments], capture_output=True, cwd=tmp_path,
                          env=env, timeout=120, check=False)  # fmt: skip


def test_an_ascii_terminal_gets_the_summary_with_replacements_not_a_traceback(tmp_path):
    """PYTHONIOENCODING=ascii raised UnicodeEncodeError at the first N·m, after the file was written."""
    process = _process(tmp_path, ["run", *PAPER, "--resolver", "pinv", "--duration", "0.2", "--out", "run.csv"],
                       PYTHONIOENCODING="ascii")  # fmt: skip
    assert process.returncode == 0, process.stderr
    assert process.stderr == b""
    out = process.stdout.decode("ascii")
    assert "peak |tau| [N?m]" in out and out.endswith("wrote run.csv and run.csv.json\n")


def test_an_unknown_matplotlib_backend_is_one_line_before_any_work(tmp_path):
    """MPLBACKEND=nonexistent made matplotlib's import raise ValueError inside the plot."""
    assert (
        _process(tmp_path, ["run", *PAPER, "--resolver", "pinv", "--duration", "0.2", "--out", "run.csv"]).returncode
        == 0
    )
    process = _process(tmp_path, ["plot", "run.csv"], MPLBACKEND="nonexistent")
    assert process.returncode == 2
    assert process.stderr.decode() == (
        "torqueopt plot: error: MPLBACKEND='nonexistent' is not a matplotlib backend; unset it or give one such as "
        "Agg (torqueopt draws its figures on its own canvas)\n"
    )
    assert not (tmp_path / "run.png").exists()


def test_the_summary_columns_stay_apart_whatever_the_numbers(planar3):
    """A runaway torque of 1.3e9 N·m ran into its limit column: "1305095808.068 54.00024168440.890"."""
    from torqueopt.cli.run import format_summary

    result = torqueopt.simulate(planar3, "pinv", torqueopt.StraightLine([1, 1], duration=0.1), PAPER_Q0)
    result.tau = result.tau * 1e8
    result.joint_names = ["joint1", "a_joint_with_a_name_longer_than_the_column", "joint3"]
    lines = format_summary(planar3, result).splitlines()
    header = lines[1]
    rows = lines[2:5]
    for row, name, peak, limit in zip(rows, result.joint_names, result.peak_torque, result.torque_upper):
        fields = row.split()
        assert fields[0] == name and float(fields[1]) == pytest.approx(peak, rel=1e-9)
        assert float(fields[2]) == limit and float(fields[3]) == pytest.approx(peak / limit, rel=1e-6)
        assert fields[4:] == ["OVER"]
        # every number ends where its header ends: the columns are aligned
        for title, value in zip(("peak |tau| [N·m]", "limit [N·m]", "peak/limit"), fields[1:4]):
            assert row.index(value) + len(value) == header.index(title) + len(title), (title, row)


def test_the_resolver_listing_is_plain_text(capsys):
    """`torqueopt resolvers` showed kinetic-energy-pinv as "with :math:`W = H`"."""
    assert main(["resolvers"]) == 0
    printed = capsys.readouterr().out
    assert "kinetic-energy-pinv: Weighted pseudoinverse with W = H: minimum kinetic energy" in printed
    assert ":math:" not in printed and "``" not in printed


def test_no_generated_sentence_speaks_of_study_motion():
    """A rename of 'self' to 'study' had left "hold the study-motion down" in the remedies' answers."""
    from pathlib import Path

    package = Path(torqueopt.__file__).parent
    assert not [path.name for path in package.rglob("*.py") if "study-motion" in path.read_text()]


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"torqueopt {torqueopt.__version__}\n"
    from importlib.metadata import version

    assert torqueopt.__version__ == version("torqueopt")  # the one in pyproject.toml


#: Commands run under ``python -W error::Warning`` (every warning an error), in order, in one folder.
UNDER_W_ERROR = [
    pytest.param(["robots"], id="robots"),  # cmeel's import left a temporary folder: a ResourceWarning at exit
    pytest.param(
        [
            "run",
            "--robot",
            "panda",
            "--direction",
            "1,0,0",
            "--duration",
            "0.1",
            "--resolver",
            "pinv",
            "--dexterity",
            "--out",
            "panda.csv",
        ],
        id="run panda",
        marks=pytest.mark.slow,
    ),
    pytest.param(["plot", "panda.csv", "--out", "panda.png", "--stick-figures"], id="plot", marks=pytest.mark.slow),
    # meshcat's import warned that pyzmq's zmq.eventloop.ioloop is deprecated (a traceback under -W error)
    pytest.param(["play", "panda.csv", "--html", "panda.html", "--fps", "5"], id="play --html", marks=pytest.mark.slow),
]


@pytest.fixture(scope="module")
def warnings_folder(tmp_path_factory):
    return tmp_path_factory.mktemp("warnings")


@pytest.mark.parametrize("arguments", UNDER_W_ERROR)
def test_no_python_warning_leaks_into_the_output(arguments, warnings_folder):
    """A warning of a library we use (or of ours) is fixed at its cause or said in our own words: none reaches
    stderr, and none breaks a command when every warning is an error."""
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    environment.pop("PYTHONWARNINGS", None)
    process = subprocess.run([sys.executable, "-W", "error::Warning", "-m", "torqueopt", *arguments],
                             cwd=warnings_folder, env=environment, capture_output=True, text=True, timeout=300,
                             check=False)  # fmt: skip
    assert process.returncode == 0, process.stderr
    assert "Warning" not in process.stderr and "Exception ignored" not in process.stderr, process.stderr


@pytest.mark.parametrize(
    "arguments, code",
    [
        (["--resolver", "pinv", "--torque-limit", "1e308"], 0),  # the stop ceiling 1000 x 1e308 overflowed
        (["--resolver", "pinv", "--accel", "1e308"], 3),  # the torque overflows: the run stops and says so
        (["--resolver", "damped-null-space", "--option", "damping=1e308"], 2),  # damping has a ceiling, 1e6
    ],
)
def test_extreme_values_leak_no_floating_point_warning(arguments, code):
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    environment.pop("PYTHONWARNINGS", None)
    process = subprocess.run([sys.executable, "-W", "error::Warning", "-m", "torqueopt", "run", *PAPER, "--duration",
                              "0.2", *arguments], env=environment, capture_output=True, text=True, timeout=300,
                             check=False)  # fmt: skip
    assert process.returncode == code, process.stderr
    assert "Warning" not in process.stderr and "Traceback" not in process.stderr, process.stderr


def test_run_says_up_front_when_the_path_leaves_the_arm_s_reach(tmp_path, capsys):
    from torqueopt.cli.run import path_beyond_reach

    planar3 = torqueopt.load_robot("planar3")
    q0 = np.radians([-45.0, 135.0, -135.0])  # planar3 reaches 3 m (three 1 m links) from its base at the origin
    start = planar3.frame_placement(q0).translation[:2]
    # The paper's 2 s line is 1.41 m long along (1, 1)/√2: it ends inside; 3 s (3.18 m) ends beyond 3 m.
    assert path_beyond_reach(planar3, torqueopt.StraightLine((1.0, 1.0), duration=2.0), q0) == ""
    note = path_beyond_reach(planar3, torqueopt.StraightLine((1.0, 1.0), duration=3.0), q0)
    end = np.linalg.norm(start + np.sqrt(2) * 9 / 4 * np.array([1, 1]) / np.sqrt(2))
    assert note.startswith(f"the path passes {end:.3g} m from the arm's base at t = 3 s, beyond the 3 m its task")
    panda = torqueopt.load_robot("panda")
    line = torqueopt.StraightLine((0.0, 1.0, 0.0), duration=2.0)  # run's default: 1.41 m on an arm of 0.86 m
    assert "beyond the 0.857 m" in path_beyond_reach(panda, line, panda.default_configuration)
    code = main(["run", *PAPER, "--resolver", "pinv", "--duration", "0.1"])
    assert code == 0 and "note: the path" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["run", *PAPER, "--resolver", "pinv", "--out", ""], "--out is empty"),
        (["run", *PAPER, "--resolver", "pinv", "--frame", ""], "--frame is empty"),
        (["run", *PAPER, "--resolver", "pinv", "--task", ""], "--task is empty"),
        (["run", "--robot", "", "--resolver", "pinv", "--direction", "1,1"], "--robot is empty"),
        (["play", ""], "RUN is empty; give a value"),
    ],
)
def test_an_empty_value_is_refused_not_taken_for_the_default(arguments, message, capsys):
    # --out '' wrote nothing with exit 0; --frame '' and --task '' fell back to the defaults; --robot '' was "a folder".
    with pytest.raises(SystemExit) as stop:
        main(arguments)
    error = capsys.readouterr().err
    assert stop.value.code == 2 and error.startswith(f"torqueopt {arguments[0]}: error: {message}")
    assert error.count("\n") == 1


def test_a_long_run_says_how_far_it_is(monkeypatch, capsys):
    # A run of 1e6 steps (2 min 45 s) printed nothing until its end. simulate calls progress as each block of
    # 4,096 steps starts; run shows a bar (one line off a terminal) from LONG_RUN_STEPS on.
    from torqueopt.cli import run as run_module

    planar3 = torqueopt.load_robot("planar3")
    told = []
    line = torqueopt.StraightLine((1.0, 0.0), accel=1e-3, duration=10.0)
    torqueopt.simulate(planar3, "pinv", line, [-0.78, 2.36, -2.36], progress=told.append)
    assert told == [0, 4096, 8192]
    told.clear()
    torqueopt.simulate(planar3, "velocity-pinv", line, [-0.78, 2.36, -2.36], progress=told.append)
    # The kinematic loop's rows are half steps, told in steps; each of its blocks starts on the last one's end row.
    assert told == [0, 4095, 8190]
    arguments = ["run", *PAPER, "--resolver", "pinv", "--accel", "1e-3", "--duration", "10"]
    assert main(arguments) == 0 and "torqueopt run:" not in capsys.readouterr().err
    monkeypatch.setattr(run_module, "LONG_RUN_STEPS", 10_000)
    assert main(arguments) == 0 and capsys.readouterr().err == "torqueopt run: 10,000 steps ...\n"
