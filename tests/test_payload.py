"""A payload on the task frame: Pinocchio's terms against the hand-derived dynamics of planar3 carrying a mass
at its tip, MuJoCo's model of the same load, the run's record of it and the refusals of bad payloads."""

import numpy as np
import pytest

import torqueopt
from torqueopt import Payload, StraightLine, simulate
from torqueopt.errors import InvalidInput

from .conftest import PAPER_Q0
from .test_dynamics import closed_form_coriolis, closed_form_gravity, closed_form_inertia, random_states

#: 2 kg, 0.2 m beyond the tip along link 3 and 0.1 m beside it, turning about z with 0.025 kg·m².
LOAD = Payload(2.0, (0.2, 0.1, 0.0), (0.01, 0.02, 0.025))
#: Gravity in planar3's plane: the arm hangs on a wall.
WALL = np.array([0.0, -9.81, 0.0])


def load_point(q, offset):
    """The load's centre of mass p(q), its Jacobian ∂p/∂q and its drift (∂p/∂q)˙ q̇, for unit rods, by hand.

    p = Σᵢ u(θᵢ) + R(θ₃) d with θᵢ = q₁ + … + qᵢ, u(θ) = (cos θ, sin θ) and d the load's offset in link 3's axes.
    """
    angles = np.cumsum(q)
    along = np.array([np.cos(angles), np.sin(angles)])  # u(θᵢ), one column per link
    c, s = np.cos(angles[2]), np.sin(angles[2])
    carried = np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])  # R(θ₃) d
    point = along.sum(axis=1) + carried

    def turned(vector):  # ∂/∂θ of a vector turning with θ
        return np.array([-vector[1], vector[0]])

    columns = [turned(along[:, k:].sum(axis=1) + carried) for k in range(3)]
    return point, np.column_stack(columns), angles


def payload_terms(payload, q, v, gravity):
    """What a load of mass M and moment I_zz adds to H and to the bias torques (Coriolis and gravity)."""
    mass, offset, moment = payload.mass, payload.position[:2], payload.inertia[2]
    _, jacobian, angles = load_point(q, offset)
    rates = np.cumsum(v)
    along = np.array([np.cos(angles), np.sin(angles)])
    c, s = np.cos(angles[2]), np.sin(angles[2])
    carried = np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]])
    drift = -(along * rates**2).sum(axis=1) - carried * rates[2] ** 2  # p̈ at q̈ = 0
    # Its kinetic energy ½ M |ṗ|² + ½ I_zz θ̇₃², θ̇₃ = q̇₁ + q̇₂ + q̇₃; its weight −M g at p.
    inertia = mass * jacobian.T @ jacobian + moment * np.ones((3, 3))
    bias = mass * jacobian.T @ drift - mass * jacobian.T @ np.asarray(gravity[:2])
    return inertia, bias


@pytest.mark.parametrize("payload", [Payload(2.0), LOAD], ids=["point mass at the tip", "body beside the tip"])
def test_a_payload_on_planar3s_tip_adds_the_hand_derived_dynamics_of_a_mass_at_the_tip(payload, rng):
    robot = torqueopt.load_robot("planar3", gravity=WALL, payload=payload)
    assert robot.payload == payload
    for q, v in random_states(rng, 20, 3):
        terms = robot.terms(q, v)
        inertia, bias = payload_terms(payload, q, v, WALL)
        np.testing.assert_allclose(terms.inertia, closed_form_inertia(q) + inertia, rtol=1e-12, atol=1e-12)
        expected_bias = closed_form_coriolis(q, v) + closed_form_gravity(q, WALL) + bias
        np.testing.assert_allclose(terms.bias_torque, expected_bias, rtol=1e-10, atol=1e-10)
    # The hand-derived Jacobian of the load's point is its position's derivative (central differences).
    q = PAPER_Q0
    _, jacobian, _ = load_point(q, LOAD.position[:2])
    step = 1e-6
    for k in range(3):
        dq = np.eye(3)[k] * step
        ahead, behind = load_point(q + dq, LOAD.position[:2])[0], load_point(q - dq, LOAD.position[:2])[0]
        np.testing.assert_allclose(jacobian[:, k], (ahead - behind) / (2 * step), atol=1e-8)


def test_a_payload_leaves_the_kinematics_and_a_payload_free_robot_as_they_were(planar3, rng):
    robot = torqueopt.load_robot("planar3", payload=LOAD)
    for q, v in random_states(rng, 5, 3):
        loaded, bare = robot.terms(q, v), planar3.terms(q, v)
        np.testing.assert_array_equal(loaded.jacobian, bare.jacobian)
        np.testing.assert_array_equal(loaded.drift, bare.drift)
    assert planar3.payload is None and [i.mass for i in planar3.model.inertias[1:]] == [10.0, 10.0, 10.0]
    # The copies a robot gives keep its payload (it is in the model they share or copy).
    copy = robot.with_gravity(WALL).with_torque_limit(100.0)
    assert copy.payload == LOAD
    np.testing.assert_array_equal(copy.terms(PAPER_Q0, np.zeros(3)).inertia, robot.terms(PAPER_Q0, np.zeros(3)).inertia)


def test_a_payload_beyond_a_locked_joint_rides_on_the_joint_that_carries_it(rng):
    # With joint3 locked the tip is on joint2's body: the load must still sit at the tip.
    locked = torqueopt.load_robot("planar3", lock=["joint3"], payload=LOAD)
    free = torqueopt.load_robot("planar3", payload=LOAD)
    held = locked.locked_configuration[2]  # joint3's angle where it is locked (planar3's SRDF start)
    for q, v in random_states(rng, 5, 2):
        full_q = np.append(q, held)
        full_v = np.append(v, 0.0)
        inertia = free.terms(full_q, full_v).inertia[:2, :2]
        np.testing.assert_allclose(locked.terms(q, v).inertia, inertia, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    ("keywords", "message"),
    [
        ({"mass": -2.0}, r"^payload mass=-2.0 must be a positive finite number \[kg\]$"),
        ({"mass": 0.0}, r"^payload mass=0.0 must be a positive finite number \[kg\]$"),
        ({"mass": float("nan")}, r"^payload mass=nan must be a positive finite number \[kg\]$"),
        ({"mass": 1.0, "position": (0.1, 0.2)}, r"^payload position has 2 values but needs 3$"),
        ({"mass": 1.0, "position": (0.1, np.inf, 0)}, r"^payload position \[0.1, inf, 0.0\] has a non-finite value"),
        (
            {"mass": 1.0, "inertia": (0.0, 0.1, 0.1)},
            r"^payload inertia \(0, 0.1, 0.1\) kg·m² is not positive definite: give three positive principal "
            r"moments, or none \(zeros\) for a point mass$",
        ),
        ({"mass": 1.0, "inertia": (-0.1, 0.1, 0.1)}, r"is not positive definite"),
        (
            {"mass": 1.0, "inertia": (1.0, 0.1, 0.1)},
            r"^payload inertia \(1, 0.1, 0.1\) kg·m² is no rigid body's: each principal moment must be at most the "
            r"sum of the other two$",
        ),
    ],
)
def test_a_bad_payload_is_refused_in_one_line(keywords, message):
    with pytest.raises(InvalidInput, match=message):
        Payload(**keywords)


def test_load_robot_takes_only_a_payload_object():
    with pytest.raises(
        InvalidInput, match=r"^payload must be a torqueopt.Payload\(mass, position, inertia\), not float"
    ):
        torqueopt.load_robot("planar3", payload=2.0)


#: A 1.5 kg tool 8 cm beyond the flange and off its axis, as the MuJoCo tests carry it.
TOOL = Payload(1.5, (0.02, -0.03, 0.08), (0.004, 0.005, 0.006))
#: The matched MuJoCo plant (see test_mujoco_plant): the URDF, no contacts, limits or damping, MuJoCo's RK4 at dt.
MATCHED = {"integrator": "rk4", "contacts": "off", "joint-limits": "off", "damping": "zero"}


@pytest.mark.parametrize(
    ("robot_name", "lock"),
    [("xarm7", []), ("panda", []), ("panda", ["panda_joint7"])],
    ids=["xarm7", "panda (its hand frame turned 45° about z)", "panda, the hand's joint locked"],
)
def test_mujocos_model_of_the_payload_has_pinocchios_mass_matrix_and_bias_forces(robot_name, lock, rng):
    pytest.importorskip("mujoco")
    from torqueopt.plants.mujoco import MujocoPlant

    robot = torqueopt.load_robot(robot_name, task="position", lock=lock, payload=TOOL)
    bare = torqueopt.load_robot(robot_name, task="position", lock=lock)
    plant = MujocoPlant(robot, damping="zero")
    lower, upper, _ = robot.joint_limits
    for _ in range(10):
        q = robot.configuration(rng.uniform(np.maximum(lower, -3.0), np.minimum(upper, 3.0)))
        v = rng.uniform(-2.0, 2.0, robot.nv)
        inertia, bias = plant.terms(q, v)
        terms = robot.terms(q, v)
        assert np.abs(inertia - terms.inertia).max() <= 1e-10 * np.abs(terms.inertia).max()
        assert np.abs(bias - terms.bias_torque).max() <= 1e-10 * np.abs(terms.bias_torque).max()
        # The payload is there to be matched: it changes the gravity torques by far more than the tolerance.
        assert np.abs(bare.terms(q, v).bias_torque - terms.bias_torque).max() > 0.1


def test_a_matched_mujoco_run_with_a_payload_equals_the_pinocchio_run():
    pytest.importorskip("mujoco")
    robot = torqueopt.load_robot("xarm7", task="position", payload=TOOL)
    line = StraightLine(direction=[0, 1, -1], accel=1.0, duration=0.2)
    reference = simulate(robot, "pinv", line, robot.default_configuration)
    run = simulate(robot, "pinv", line, robot.default_configuration, plant="mujoco", plant_options=MATCHED)
    assert reference.completed and run.completed and len(run.t) == 201
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 1e-9
    assert run.plant["start_inertia_difference"] < 1e-12


def test_a_payload_with_an_mjcf_plant_is_refused_in_one_line(tmp_path):
    pytest.importorskip("mujoco")
    from torqueopt.plants.mujoco import MujocoPlant

    mjcf = tmp_path / "arm.xml"
    mjcf.write_text("<mujoco/>")
    robot = torqueopt.load_robot("xarm7", task="position", payload=TOOL)
    with pytest.raises(
        InvalidInput, match=r"^robot 'xarm7' carries a payload, which torqueopt adds to the URDF's model;"
    ):
        MujocoPlant(robot, mjcf=mjcf)


@pytest.mark.filterwarnings("ignore:holding the start against gravity")  # the wall-hung arm's limits are small
def test_an_atlas_carries_the_payload_and_gravity_it_is_given(tmp_path, capsys):
    """``torqueopt atlas --payload ... --gravity X,Y,Z``: each row is the run of the robot loaded with them (the
    planar arm on a wall, a load at its tip), the settings read back from atlas-config.json, and the rows differ
    from the atlas of the bare arm."""
    pytest.importorskip("pandas")
    from torqueopt.atlas import run_atlas
    from torqueopt.atlas.jobs import RobotSpec
    from torqueopt.atlas.population import PopulationSpec, draw_population, movement_trajectory
    from torqueopt.cli import main

    out = tmp_path / "loaded"
    arguments = ["atlas", "--payload", "2,0.2,0.1,0,0.01,0.02,0.025", "--gravity=0,-9.81,0", "--paths", "2",
                 "--durations", "0.3", "--resolvers", "pinv", "--workers", "0", "--no-figures", "--no-progress"]  # fmt: skip
    assert main([*arguments, "--out", str(out)]) == 0
    capsys.readouterr()
    import json

    config = json.loads((out / "atlas-config.json").read_text())
    spec = RobotSpec(**config["robot"])
    assert spec.payload == LOAD and spec.gravity == (0.0, -9.81, 0.0)
    assert (
        "Model: a payload of 2 kg at (0.2, 0.1, 0) m in the task frame; gravity (0, -9.81, 0) m/s²."
        in (out / "atlas.md").read_text()
    )
    loaded = torqueopt.load_robot("planar3", payload=LOAD, gravity=WALL)
    movements = draw_population(loaded, PopulationSpec(paths=2, durations=(0.3,), seed=0))
    import pandas

    table = pandas.read_parquet(out / "results.parquet").set_index("path")
    for movement in movements:
        run = simulate(loaded, "pinv", movement_trajectory(movement), movement.q0)
        assert table.loc[int(movement.path), "peak_torque_ratio"] == pytest.approx(
            run.peak_torque_ratio.max(), rel=1e-9
        )
    bare = run_atlas("planar3", paths=2, durations=[0.3], resolvers=["pinv"], workers=0, figures=False,
                     progress=False, out=tmp_path / "bare").table.set_index("path")  # fmt: skip
    assert "payload" not in json.loads((tmp_path / "bare" / "atlas-config.json").read_text())["robot"]
    assert (abs(bare["peak_torque_ratio"] - table["peak_torque_ratio"]) > 1e-3).all()
