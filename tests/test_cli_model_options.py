"""The robot as it really is, from the command line: ``--payload``, ``--gravity X,Y,Z`` and ``--v0``.

Each option is checked against something independent of the CLI (planar3's hand-derived gravity torques,
Pinocchio's ``computeGeneralizedGravity`` on a model whose gravity is set by hand, MuJoCo's bias forces, the
API run), shown to change the run, and refused in one line with exit 2 when its value is bad.
"""

import argparse
import json

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt import Payload, StraightLine, simulate
from torqueopt.cli import main

from .conftest import PAPER_Q0
from .test_dynamics import closed_form_gravity, random_states
from .test_units import SLIDER_ARM

#: The paper's start, as the CLI takes it.
Q0 = "--q0=" + ",".join(repr(float(angle)) for angle in PAPER_Q0)
#: planar3 on a wall: gravity along −x, in the arm's plane [m/s²].
WALL = np.array([-9.81, 0.0, 0.0])

BAD_INPUTS = [
    (["--payload=-2"], "payload mass=-2.0 must be a positive finite number [kg]"),
    (["--payload", "0"], "payload mass=0.0 must be a positive finite number [kg]"),
    (["--payload", "nan"], "--payload: 'nan' is not finite; give finite numbers"),
    (["--payload", "2,0,inf,0"], "--payload: 'inf' is not finite; give finite numbers"),
    (
        ["--payload", "2,0.1"],
        "--payload 2,0.1 has 2 values; give MASS, MASS,X,Y,Z, MASS,X,Y,Z,IXX,IYY,IZZ (kg, m in the task frame, kg·m²)",
    ),
    (["--payload", "2,0,0,0,0,1,1"], "payload inertia (0, 1, 1) kg·m² is not positive definite"),
    (["--payload=2,0,0,0,-1,1,1"], "payload inertia (-1, 1, 1) kg·m² is not positive definite"),
    (["--payload", "2,0,0,0,1,0.1,0.1"], "payload inertia (1, 0.1, 0.1) kg·m² is no rigid body's"),
    (
        ["--gravity=0,-9.81"],
        "--gravity 0,-9.81: give three numbers X,Y,Z [m/s²] in world axes (e.g. --gravity=0,0,-9.81), or --gravity "
        "alone for 9.81 m/s² along −z",
    ),
    (["--gravity", "run.csv"], "--gravity run.csv: give three numbers X,Y,Z [m/s²] in world axes"),
    (["--gravity=0,nan,0"], "--gravity: 'nan' is not finite; give finite numbers"),
    (["--gravity=0,0,-inf"], "--gravity: '-inf' is not finite; give finite numbers"),
    (["--gravity=0,g,0"], "--gravity: 'g' is not a number (give comma-separated numbers, e.g. 1,1)"),
    (["--v0=0.1,0.2"], "--v0 has 2 values but needs 3"),
    (["--v0=0.1,nan,0.2"], "--v0: 'nan' is not finite; give finite numbers"),
    (["--v0=0.1,inf,0.2"], "--v0: 'inf' is not finite; give finite numbers"),
    (["--v0=0.1,abc,0.2"], "--v0: 'abc' is not a number (give comma-separated numbers, e.g. 1,1)"),
]


def one_line_refusal(capsys, code: int, command: str, message: str) -> None:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"torqueopt {command}: error: "), captured.err
    assert message in lines[0] and "Traceback" not in captured.err


@pytest.mark.parametrize("arguments, message", BAD_INPUTS)
def test_a_bad_payload_gravity_or_start_velocity_is_one_line_exit_2_and_no_file(arguments, message, tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "0.1",
                 *arguments, "--out", str(out)])  # fmt: skip
    one_line_refusal(capsys, code, "run", message)
    assert not out.exists()


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("saved") / "run.csv"
    assert main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "0.1",
                 "--no-dexterity", "--out", str(path)]) == 0  # fmt: skip
    return path


@pytest.mark.parametrize("option", ["--gravity=1,2", "--payload=-1"])
def test_every_command_with_robot_options_refuses_a_bad_gravity_or_payload(option, saved_run, tmp_path, capsys):
    commands = {
        "optimize": ["optimize", "--robot", "planar3", "--direction", "1,1", "--duration", "0.1"],
        "plot": ["plot", str(saved_run), "--stick-figures", "--out", str(tmp_path / "figure.png")],
    }
    message = "--gravity 1,2: give three numbers" if option.startswith("--gravity") else "payload mass=-1.0 must be"
    for command, arguments in commands.items():
        capsys.readouterr()
        code = main([*arguments, option])
        one_line_refusal(capsys, code, command, message)
    assert not (tmp_path / "figure.png").exists()


def test_a_bare_gravity_before_the_run_file_leaves_the_file_to_plot(saved_run, tmp_path, capsys):
    # --gravity takes an optional vector: without the reordering, argparse reads the run file as the vector.
    figure = tmp_path / "figure.png"
    assert main(["plot", "--gravity", str(saved_run), "--stick-figures", "--out", str(figure)]) == 0
    assert figure.stat().st_size > 0
    code = main(
        ["plot", "--gravity", "abc", str(saved_run), "--stick-figures", "--out", str(figure)]
    )  # not a file, not X,Y,Z: still refused as a vector
    one_line_refusal(capsys, code, "plot", "--gravity abc: give three numbers")


def test_the_help_of_every_command_with_robot_options_names_the_new_options(capsys):
    for command in ("run", "optimize", "plot"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "--gravity [X,Y,Z]" in text and "--no-gravity" in text
        assert "--payload MASS[,X,Y,Z[,IXX,IYY,IZZ]]" in text
        assert ("--v0 RATES" in text) == (command == "run")  # optimize starts at rest (its API takes no v0)


def test_a_wall_mounted_planar_arm_holds_itself_with_the_gravity_torques_of_its_vector(rng):
    robot = torqueopt.load_robot("planar3", gravity=WALL)
    # Pinocchio's own gravity torques, its model's gravity set here by hand, not through torqueopt.
    model = torqueopt.load_robot("planar3").model.copy()
    model.gravity = pin.Motion(WALL, np.zeros(3))
    data = model.createData()
    for q, _ in random_states(rng, 10, 3):
        # Holding still: pinv's torque for zero task acceleration at rest is the static torque.
        static = torqueopt.resolve(robot, "pinv", q, np.zeros(3), [0.0, 0.0]).torque
        np.testing.assert_allclose(static, pin.computeGeneralizedGravity(model, data, q), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(static, closed_form_gravity(q, WALL), rtol=1e-10, atol=1e-10)
    assert np.abs(closed_form_gravity(PAPER_Q0, WALL)).max() > 10.0  # the wall's gravity does act


def test_the_mujoco_plant_follows_the_gravity_vector():
    pytest.importorskip("mujoco")
    from torqueopt.plants.mujoco import MujocoPlant

    robot = torqueopt.load_robot("planar3", gravity=WALL)
    plant = MujocoPlant(
        robot, damping="zero", inertia_floor=1e-6
    )  # planar3's rods need the floor (see test_mujoco_plant)
    _, bias = plant.terms(robot.configuration(PAPER_Q0), np.zeros(3))
    np.testing.assert_allclose(bias, closed_form_gravity(PAPER_Q0, WALL), rtol=1e-10, atol=1e-10)
    matched = {"integrator": "rk4", "contacts": "off", "joint-limits": "off", "damping": "zero", "inertia-floor": 1e-6}
    line = StraightLine(direction=[1, 1], accel=0.5, duration=0.2)
    with pytest.warns(torqueopt.TorqueoptWarning, match="holding the start against gravity needs"):
        run = simulate(robot, "pinv", line, PAPER_Q0, plant="mujoco", plant_options=matched)
        reference = simulate(robot, "pinv", line, PAPER_Q0)
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 1e-9


def run_cli(tmp_path, capsys, *arguments, name="run.csv"):
    out = tmp_path / name
    start = "--q0=-45,135,-135" if "--degrees" in arguments else Q0  # --degrees reads --q0 and --v0 alike
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", start, "--direction", "1,1", "--duration", "0.2",
                 "--no-dexterity", *arguments, "--out", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    return torqueopt.load_result(out), json.loads((tmp_path / f"{name}.json").read_text()), printed


def test_the_command_lines_payload_gravity_and_start_velocity_are_the_apis(tmp_path, capsys):
    line = StraightLine(direction=[1, 1], accel=np.sqrt(2), duration=0.2)
    result, sidecar, printed = run_cli(
        tmp_path, capsys, "--payload", "2,0.2,0.1,0,0.01,0.02,0.025", "--gravity=-9.81,0,0", "--v0=10,-5,2", "--degrees"
    )
    robot = torqueopt.load_robot("planar3", gravity=WALL, payload=Payload(2.0, (0.2, 0.1, 0.0), (0.01, 0.02, 0.025)))
    with pytest.warns(torqueopt.TorqueoptWarning, match="holding the start against gravity"):  # joint3's 6 N·m
        reference = simulate(robot, "pinv", line, PAPER_Q0, np.radians([10.0, -5.0, 2.0]))
    np.testing.assert_allclose(result.v[0], np.radians([10.0, -5.0, 2.0]), rtol=1e-9)  # --degrees read --v0 in deg/s
    np.testing.assert_allclose(result.tau[:-1], reference.tau[:-1], rtol=1e-9, atol=1e-9)  # the CSV keeps 10 digits
    assert sidecar["payload"] == {"mass": 2.0, "position": [0.2, 0.1, 0.0], "inertia": [0.01, 0.02, 0.025]}
    assert sidecar["gravity"] == [-9.81, 0.0, 0.0] and result.payload == sidecar["payload"]
    assert "payload: 2 kg at (0.2, 0.1, 0) m in frame 'tip', moments 0.01, 0.02, 0.025 kg·m²" in printed
    assert "gravity: (-9.81, 0, 0) m/s²" in printed
    again = torqueopt.load_result(reference.to_csv(tmp_path / "run.npz"))  # the .npz keeps them too
    assert again.payload == sidecar["payload"] and again.gravity == [-9.81, 0.0, 0.0]


def test_each_option_changes_the_run_and_their_defaults_leave_it_as_it_was(tmp_path, capsys):
    plain, sidecar, printed = run_cli(tmp_path, capsys)
    assert sidecar["payload"] is None and sidecar["gravity"] == [0.0, 0.0, 0.0]
    assert "payload:" not in printed and "gravity:" not in printed
    default = simulate(torqueopt.load_robot("planar3"), "pinv", StraightLine([1, 1], np.sqrt(2), 0.2), PAPER_Q0)
    np.testing.assert_allclose(plain.tau[:-1], default.tau[:-1], rtol=1e-9, atol=1e-9)
    for index, arguments in enumerate(
        [["--payload", "0.5"], ["--gravity=0,-1,0"], ["--v0=0,0,0.1"], ["--v0=0,0,0.1", "--degrees"]]
    ):
        changed, sidecar, _ = run_cli(tmp_path, capsys, *arguments, name=f"run{index}.csv")
        assert np.abs(changed.tau[:-1] - plain.tau[:-1]).max() > 1e-3, arguments
    # --gravity alone is 9.81 m/s² along −z (which planar3, turning about z, never feels); a zero vector is fine.
    _, sidecar, _ = run_cli(tmp_path, capsys, "--gravity", name="down.csv")
    assert sidecar["gravity"] == [0.0, 0.0, -9.81]
    _, sidecar, _ = run_cli(tmp_path, capsys, "--gravity=0,0,0", name="none.csv")
    assert sidecar["gravity"] == [0.0, 0.0, 0.0]


def test_the_stick_figures_take_the_runs_payload_unless_told_otherwise(saved_run, tmp_path, capsys):
    from torqueopt.cli.stick import stick_robot

    result = torqueopt.load_result(saved_run)
    result.payload = {"mass": 2.0, "position": [0.2, 0.1, 0.0], "inertia": [0.0, 0.0, 0.0]}
    options = {"robot": None, "frame": None, "task": None, "torque_limit": None, "lock": None, "gravity": None}
    assert stick_robot(argparse.Namespace(**options, payload=None), result).payload == Payload(2.0, (0.2, 0.1, 0.0))
    assert stick_robot(argparse.Namespace(**options, payload="1"), result).payload == Payload(1.0)


@pytest.mark.slow  # a user URDF: yourdfpy's validation, 2 s
def test_degrees_read_v0_as_they_read_q0_revolute_joints_only(tmp_path, capsys):
    urdf = tmp_path / "slider3.urdf"
    urdf.write_text(SLIDER_ARM)
    out = tmp_path / "run.csv"
    code = main(["run", "--resolver", "pinv", "--robot", str(urdf), "--frame", "tip", "--task", "xy", "--degrees",
                 "--q0", "30,0.2,-60", "--v0=10,0.05,-20", "--direction", "0,1", "--accel", "0.2", "--duration", "0.1",
                 "--no-dexterity", "--out", str(out)])  # fmt: skip
    capsys.readouterr()
    assert code == 0
    # The slider starts out at 0.05 m/s, not 0.05°/s.
    np.testing.assert_allclose(torqueopt.load_result(out).v[0], [np.radians(10.0), 0.05, np.radians(-20.0)], atol=1e-9)
