"""The plant registry and the ``--plant`` options, without MuJoCo installed (the core-only CI job runs these)."""

import json
import sys

import numpy as np
import pytest

from torqueopt import StraightLine, load_result, simulate
from torqueopt.cli import main
from torqueopt.cli.plant import PLANT_OPTIONS
from torqueopt.errors import InvalidInput, MissingDependency
from torqueopt.plants import PinocchioPlant, make_plant
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


def test_bad_plant_choices_are_refused_in_one_line(planar3, capsys):
    q0 = planar3.configuration(Q0)
    with pytest.raises(InvalidInput, match=r"^unknown plant 'mujuco' \(did you mean 'mujoco'\?\); choose one of "):
        simulate(planar3, "pinv", LINE, q0, plant="mujuco")
    with pytest.raises(InvalidInput, match=r"the pinocchio plant takes none"):
        make_plant(planar3, "pinocchio", {"integrator": "euler"})
    with pytest.raises(InvalidInput, match=r"resolver velocity-pinv works at the velocity level"):
        simulate(planar3, "velocity-pinv", LINE, q0, plant="mujoco")
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
