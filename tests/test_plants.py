"""The plant registry and the ``--plant`` options, without MuJoCo installed (the core-only CI job runs these)."""

import json
import sys

import numpy as np
import pytest

from torqueopt import StraightLine, load_result, simulate
from torqueopt.batch import simulate_batch
from torqueopt.cli import main
from torqueopt.cli.plant import PLANT_OPTIONS
from torqueopt.errors import InvalidInput, MissingDependency
from torqueopt.plants import PinocchioPlant, make_plant, plant_names, register_plant
from torqueopt.plants import base as plant_registry
from torqueopt.plants.mujoco import OPTION_DEFAULTS, OPTION_NAMES

from .test_integrator import rk4_reference_step

LINE = StraightLine(direction=[1, 1], accel=1.0, duration=0.2)
Q0 = [-0.785398, 2.356194, -2.356194]


@pytest.fixture
def without_mujoco(monkeypatch):
    """As if mujoco were not installed: importing it raises ImportError."""
    monkeypatch.setitem(sys.modules, "mujoco", None)


def test_the_mujoco_plant_without_mujoco_says_how_to_install_it(planar3, without_mujoco, capsys):
    with pytest.raises(MissingDependency, match=r"pip install 'torqueopt\[mujoco\]'"):
        simulate(planar3, "pinv", LINE, planar3.configuration(Q0), plant="mujoco")
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--plant", "mujoco"])
    assert code == 2
    assert capsys.readouterr().err == (
        "torqueopt run: error: the mujoco plant needs the mujoco package: pip install 'torqueopt[mujoco]' "
        "(or pip install mujoco)\n"
    )


def test_the_pinocchio_plant_is_the_default_and_the_run_file_records_it(planar3, tmp_path):
    default = simulate(planar3, "pinv", LINE, planar3.configuration(Q0))
    named = simulate(planar3, "pinv", LINE, planar3.configuration(Q0), plant="pinocchio")
    assert np.array_equal(default.q, named.q)
    assert default.plant == {"name": "pinocchio", "integrator": "rk4", "torque": "held over each step"}
    for name in ("run.csv", "run.npz"):
        default.to_csv(tmp_path / name)
        assert load_result(tmp_path / name).plant == default.plant
    assert json.loads((tmp_path / "run.csv.json").read_text())["plant"]["name"] == "pinocchio"


def test_the_pinocchio_plants_step_is_rk4_with_the_torque_held(planar3, rng):
    plant = PinocchioPlant(planar3)
    q, v, tau = planar3.configuration(rng.uniform(-2, 2, 3)), rng.uniform(-1, 1, 3), rng.uniform(-5, 5, 3)
    stepped = plant.step(q, v, tau, 1e-3)
    reference = rk4_reference_step(planar3, q, v, tau, 1e-3)
    np.testing.assert_allclose(stepped[0], reference[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(stepped[1], reference[1], rtol=0, atol=1e-12)


def test_the_pinocchio_plant_steps_stacks_as_the_reference_steps_each_row(planar3, panda):
    for robot in (planar3, panda):
        rng = np.random.default_rng(4)
        q = np.array([robot.integrate(robot.default_configuration, rng.uniform(-1, 1, robot.nv)) for _ in range(5)])
        v, tau = rng.uniform(-1, 1, (5, robot.nv)), rng.uniform(-5, 5, (5, robot.nv))
        stack_q, stack_v = PinocchioPlant(robot).step_stack(q, v, tau, 1e-3)
        for row in range(5):
            reference = rk4_reference_step(robot, q[row], v[row], tau[row], 1e-3)
            np.testing.assert_allclose(stack_q[row], reference[0], rtol=0, atol=1e-14)
            np.testing.assert_allclose(stack_v[row], reference[1], rtol=0, atol=1e-12)


class EulerPlant:
    """A plant of the test's own, deliberately not RK4: explicit Euler of the Pinocchio model."""

    OPTION_NAMES = ("scale",)

    def __init__(self, robot, scale=1.0):
        self.robot, self.scale = robot, float(scale)

    def reset(self, dt):
        pass

    def step(self, q, v, tau, dt, acceleration=None):
        return q + dt * v, v + dt * self.scale * self.robot.forward_dynamics(q, v, tau)

    def step_stack(self, q, v, tau, dt, acceleration=None, movements=None):
        rows = [self.step(*row, dt) for row in zip(q, v, tau)]
        return np.array([row[0] for row in rows]), np.array([row[1] for row in rows])

    def record(self, movement=None):
        return {"name": "euler", "scale": self.scale}


@pytest.fixture
def euler_registered(monkeypatch):
    """The registry with the test's Euler plant registered by the decorator, as a user's package would."""
    monkeypatch.setattr(plant_registry, "_PLANTS", dict(plant_registry._PLANTS))
    register_plant("euler")(EulerPlant)
    return EulerPlant


def test_a_registered_plant_runs_by_name_and_the_loop_steps_it(planar3, euler_registered):
    """simulate and simulate_batch call the plant's step: replaying the run's torques by Euler gives its states."""
    assert plant_names() == ("pinocchio", "mujoco", "euler")
    q0 = planar3.configuration(Q0)
    run = simulate(planar3, "pinv", LINE, q0, plant="euler", plant_options={"scale": "0.5"})
    assert run.plant == {"name": "euler", "scale": 0.5}
    for k in range(0, len(run.t) - 1, 17):
        accel = planar3.forward_dynamics(run.q[k], run.v[k], run.tau[k])
        np.testing.assert_allclose(run.q[k + 1], run.q[k] + 1e-3 * run.v[k], rtol=0, atol=1e-15)
        np.testing.assert_allclose(run.v[k + 1], run.v[k] + 0.5e-3 * accel, rtol=0, atol=1e-12)
    rk4 = simulate(planar3, "pinv", LINE, q0)
    assert np.abs(run.q - rk4.q).max() > 1e-6  # Euler at half the acceleration is not RK4
    lines = [LINE, StraightLine(direction=[1, -1], accel=1.0, duration=0.2)]
    batch = simulate_batch(planar3, "pinv", lines, [q0, q0], plant="euler", plant_options={"scale": "0.5"})
    single = [simulate(planar3, "pinv", line, q0, plant="euler", plant_options={"scale": "0.5"}) for line in lines]
    for ours, theirs in zip(batch, single):
        np.testing.assert_allclose(ours.q, theirs.q, rtol=0, atol=1e-12)
        assert ours.plant == theirs.plant
    with pytest.raises(InvalidInput, match=r"^unexpected plant option 'colour'; the euler plant's options are scale$"):
        make_plant(planar3, "euler", {"colour": "red"})


def test_a_plant_registers_by_entry_point(planar3, monkeypatch):
    from importlib.metadata import EntryPoint

    monkeypatch.setattr(plant_registry, "_PLANTS", dict(plant_registry._PLANTS))
    entry = EntryPoint(name="euler-entry", value="tests.test_plants:EulerPlant", group="torqueopt.plants")
    monkeypatch.setattr(plant_registry, "entry_points", lambda group: [entry] if group == "torqueopt.plants" else [])
    assert "euler-entry" in plant_names()
    assert isinstance(make_plant(planar3, "euler-entry"), EulerPlant)


def test_bad_plant_choices_are_refused_in_one_line(planar3, capsys):
    q0 = planar3.configuration(Q0)
    with pytest.raises(
        InvalidInput, match=r"^unknown plant 'mujuco' \(did you mean 'mujoco'\?\); choose one of pinocchio, mujoco$"
    ):
        simulate(planar3, "pinv", LINE, q0, plant="mujuco")
    with pytest.raises(InvalidInput, match=r"^unknown plant 'bullet'; choose one of pinocchio, mujoco$"):
        simulate_batch(planar3, "pinv", [LINE], [q0], plant="bullet")
    with pytest.raises(InvalidInput, match=r"the pinocchio plant takes none"):
        make_plant(planar3, "pinocchio", {"integrator": "euler"})
    with pytest.raises(InvalidInput, match=r"resolver velocity-pinv works at the velocity level"):
        simulate(planar3, "velocity-pinv", LINE, q0, plant="mujoco")
    with pytest.raises(InvalidInput, match=r"resolver velocity-pinv works at the velocity level"):
        simulate_batch(planar3, "velocity-pinv", [LINE, LINE], [q0, q0], plant="mujoco")
    for arguments, message in [
        (["--plant-option", "integrator=euler"], "--plant-option applies to --plant mujoco, not --plant pinocchio"),
        (["--plant", "mujoco", "--plant-option", "colour=red"], "unknown --plant-option 'colour'; the options are "),
        (["--plant", "mujoco", "--plant-option", "integrator"], "--plant-option 'integrator' must be KEY=VALUE"),
        (["--plant", "mujoco", "--plant-option", "seed=1,seed=2"], "--plant-option seed is given twice"),
    ]:
        code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", *arguments])
        error = capsys.readouterr().err
        assert code == 2 and message in error and error.count("\n") == 1, arguments


def test_the_help_states_every_plant_options_default(capsys):
    assert {key: default for key, (default, _) in PLANT_OPTIONS.items()} == OPTION_DEFAULTS
    assert {key.replace("-", "_") for key in PLANT_OPTIONS} == set(OPTION_NAMES) - {"mjcf"}
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for key, default in OPTION_DEFAULTS.items():
        assert f"{key}=" in text and f"(default {default})" in text
    assert "--plant {pinocchio,mujoco}" in text and "--mjcf FILE" in text
