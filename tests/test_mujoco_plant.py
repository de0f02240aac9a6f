"""MuJoCo as the plant: a second physics engine held to Pinocchio, and the options that make it differ.

The independent checks: MuJoCo's own mass matrix (``mj_fullM``) and bias
forces (``qfrc_bias``) against Pinocchio's CRBA and RNEA at random states, and
MuJoCo's own RK4 (``mj_step``) against torqueopt's over whole runs. Then each
option is shown to change the run (limits stop a joint, damping slows it, a
perturbed model tracks worse), so that none can be ignored silently.
"""

import json

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import torqueopt  # noqa: E402
from torqueopt import StraightLine, simulate  # noqa: E402
from torqueopt.cli import main  # noqa: E402
from torqueopt.errors import InvalidInput, PlantError  # noqa: E402
from torqueopt.paper import PAPER  # noqa: E402
from torqueopt.plants.mujoco import MujocoPlant  # noqa: E402

#: The issue's matched settings: the URDF, no contacts or limits, no damping or armature, MuJoCo's RK4 at dt.
MATCHED = {"integrator": "rk4", "contacts": "off", "joint-limits": "off", "damping": "zero"}
#: A 0.5 s rest-to-rest line (down and sideways, 0.125 m long).
LINE = StraightLine(direction=[0, 1, -1], accel=1.0, duration=0.5)
#: xarm7 from its default start along −x for 1 s: joint4 runs from 0 past its lower limit −0.19198 rad at t = 0.247 s.
INTO_THE_LIMIT = StraightLine(direction=[-1, 0, 0], accel=2.0, duration=1.0)


def random_states(robot, rng, count):
    lower, upper, _ = robot.joint_limits
    for _ in range(count):
        angles = rng.uniform(np.maximum(lower, -3.0), np.minimum(upper, 3.0))
        yield robot.configuration(angles), rng.uniform(-2.0, 2.0, robot.nv)


@pytest.mark.parametrize("robot_name", ["xarm7", pytest.param("panda", marks=pytest.mark.slow)])
def test_mujocos_mass_matrix_and_bias_forces_equal_pinocchios_at_random_states(robot_name, request, rng):
    robot = request.getfixturevalue(robot_name)
    plant = MujocoPlant(robot, damping="zero")
    for q, v in random_states(robot, rng, 25):
        inertia, bias = plant.terms(q, v)
        terms = robot.terms(q, v)
        assert np.abs(inertia - terms.inertia).max() <= 1e-10 * np.abs(terms.inertia).max()
        assert np.abs(bias - terms.bias_torque).max() <= 1e-10 * np.abs(terms.bias_torque).max()


@pytest.mark.parametrize(
    ("robot_name", "resolver"),
    [
        ("xarm7", "pinv"),
        *(
            pytest.param(robot_name, resolver, marks=pytest.mark.slow)
            for robot_name, resolver in [
                ("xarm7", "damped-null-space"),
                ("xarm7", "bounded-torque"),
                ("panda", "pinv"),
                ("panda", "damped-null-space"),
                ("panda", "bounded-torque"),
            ]
        ),
    ],
)
def test_a_matched_mujoco_run_equals_the_pinocchio_run(robot_name, resolver, request):
    robot = request.getfixturevalue(robot_name)
    reference = simulate(robot, resolver, LINE, robot.default_configuration)
    run = simulate(robot, resolver, LINE, robot.default_configuration, plant="mujoco", plant_options=MATCHED)
    assert reference.completed and run.completed and len(run.t) == len(reference.t) == 501
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 1e-9
    assert run.plant["name"] == "mujoco" and run.plant["integrator"] == "rk4" and reference.plant["name"] == "pinocchio"


def test_the_matched_planar_arm_needs_an_inertia_floor_and_then_equals_pinocchio(planar3):
    q0 = planar3.configuration(PAPER.q0)
    line = StraightLine(direction=[1, 1], accel=1.0, duration=0.5)
    with pytest.raises(
        PlantError,
        match=r"^MuJoCo refuses robot 'planar3' \(its URDF 'planar3.urdf' compiled by MuJoCo .*\): link 'link1' has "
        r"principal moments of inertia \(0, 0.8333, 0.8333\) kg·m², one of them zero \(a thin rod\); give "
        r"--plant-option inertia-floor=1e-6",
    ):
        simulate(planar3, "null-space", line, q0, plant="mujoco", plant_options=MATCHED)
    # The rods turn about z only, so the floored moment about their own axis enters no equation of motion.
    run = simulate(planar3, "null-space", line, q0, plant="mujoco", plant_options={**MATCHED, "inertia-floor": 1e-6})
    reference = simulate(planar3, "null-space", line, q0)
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 1e-9
    assert run.plant["inertia_floor"] == 1e-6 and "raised to it (inertia-floor) on links link1" in run.plant["notes"][0]


def test_locked_joints_are_welded_at_pinocchios_angles():
    # panda_joint4 locked at its SRDF angle −2.356 rad (not 0): MuJoCo's 6-joint model must carry the same inertia.
    robot = torqueopt.load_robot("panda", lock=["panda_joint4"])
    plant = MujocoPlant(robot, damping="zero")
    rng = np.random.default_rng(7)
    for q, v in random_states(robot, rng, 10):
        inertia, bias = plant.terms(q, v)
        terms = robot.terms(q, v)
        assert np.abs(inertia - terms.inertia).max() <= 1e-10 * np.abs(terms.inertia).max()
        assert np.abs(bias - terms.bias_torque).max() <= 1e-10 * np.abs(terms.bias_torque).max()


def test_joint_limits_stop_a_joint_that_the_pinocchio_plant_lets_through(xarm7, capsys):
    lower = xarm7.joint_limits[0][3]
    free = simulate(xarm7, "pinv", INTO_THE_LIMIT, xarm7.default_configuration)
    limited = simulate(
        xarm7, "pinv", INTO_THE_LIMIT, xarm7.default_configuration, plant="mujoco", plant_options={"damping": "zero"}
    )
    unlimited = simulate(
        xarm7, "pinv", INTO_THE_LIMIT, xarm7.default_configuration, plant="mujoco",
        plant_options={"damping": "zero", "joint-limits": "off"},
    )  # fmt: skip
    assert free.joint_angles[:, 3].min() < lower - 1.0  # on through its limit to −1.52 rad
    assert np.abs(unlimited.joint_angles - free.joint_angles).max() < 1e-9
    # MuJoCo's soft limit lets joint4 in by some 12 mrad, then pushes it back.
    assert lower - 0.03 < limited.joint_angles[:, 3].min() < lower
    events = {event["joint"]: event for event in limited.plant["limit_events"]}
    assert events["joint4"]["first_time"] == pytest.approx(free.first_position_violation[0], abs=2e-3)
    assert events["joint4"]["peak_force"] > 10.0 and unlimited.plant["limit_events"] == []

    code = main(["run", "--robot", "xarm7", "--resolver", "pinv", "--direction=-1,0,0", "--accel", "2",
                 "--duration", "1", "--plant", "mujoco", "--plant-option", "damping=zero", "--no-dexterity"])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert "joint-limit force: MuJoCo's limit stopped joint joint4 from t = 0.246 s (peak " in printed
    assert "plant: MuJoCo" in printed and "joint limits on, damping zero" in printed


@pytest.mark.slow
def test_each_plant_option_changes_the_run(xarm7):
    def run(**options):
        return simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco",
                        plant_options={**MATCHED, **options})  # fmt: skip

    matched = run()
    for options, smallest in [
        ({"damping": "urdf"}, 1e-3),  # xarm7's URDF: damping 10, 10, 5, ... N·m·s/rad and friction 1 N·m
        ({"integrator": "euler"}, 1e-9),
        ({"integrator": "implicitfast"}, 1e-9),
        ({"perturb": "0.2"}, 1e-4),
    ]:
        assert np.abs(run(**options).joint_angles - matched.joint_angles).max() > smallest, options
    # Sub-steps of MuJoCo's RK4 converge on the same motion: closer to the matched run than Euler, not equal.
    finer = run(timestep="0.00025")
    assert finer.plant["substeps"] == 4 and finer.plant["timestep"] == 0.00025
    assert 0 < np.abs(finer.joint_angles - matched.joint_angles).max() < 1e-9


def test_a_perturbed_plant_gives_a_different_run_and_records_its_factors(xarm7):
    exact = MujocoPlant(xarm7, **{key.replace("-", "_"): value for key, value in MATCHED.items()})
    plant = MujocoPlant(xarm7, integrator="rk4", joint_limits=False, damping="zero", perturb=0.1, seed=3)
    record = plant.record()["perturbation"]
    assert record["links"] == [f"link{i}" for i in range(1, 8)] and record["seed"] == 3
    for name, mass_factor, inertia_factor in zip(record["links"], record["mass_factors"], record["inertia_factors"]):
        assert 0.9 <= mass_factor <= 1.1 and 0.9 <= inertia_factor <= 1.1
        assert plant.model.body(name).mass[0] == pytest.approx(mass_factor * exact.model.body(name).mass[0], rel=1e-12)
        np.testing.assert_allclose(plant.model.body(name).inertia, inertia_factor * exact.model.body(name).inertia)
    exact_run = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant=exact)
    perturbed_run = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant=plant)
    assert np.abs(perturbed_run.joint_angles - exact_run.joint_angles).max() > 1e-4
    assert perturbed_run.max_tip_error > 10 * exact_run.max_tip_error
    assert perturbed_run.plant["perturbation"] == record
    other_seed = MujocoPlant(xarm7, joint_limits=False, damping="zero", perturb=0.1, seed=4)
    assert other_seed.record()["perturbation"]["mass_factors"] != record["mass_factors"]


def test_feedback_corrects_from_the_plants_measured_state(xarm7):
    options = {**MATCHED, "perturb": "0.2", "seed": "1"}
    open_loop = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco", plant_options=options)
    closed = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco", plant_options=options,
                      feedback=(400.0, 40.0))  # fmt: skip
    assert closed.max_tip_error < open_loop.max_tip_error / 5


@pytest.fixture(scope="module")
def xarm7_mjcf(tmp_path_factory):
    """xarm7's URDF as MuJoCo compiles it, saved as MJCF (without its meshes): a model a user could give."""
    robot = torqueopt.load_robot("xarm7")
    spec = mujoco.MjSpec.from_string(robot.source.urdf.read_text())
    for geom in list(spec.geoms):
        spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compile()
    path = tmp_path_factory.mktemp("mjcf") / "xarm7.xml"
    path.write_text(spec.to_xml())
    return path


def test_an_mjcf_with_the_urdfs_joint_names_is_the_plant(xarm7, xarm7_mjcf, tmp_path, capsys):
    from_urdf = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco", plant_options=MATCHED)
    from_mjcf = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco",
                         plant_options={**MATCHED, "mjcf": xarm7_mjcf})  # fmt: skip
    # MuJoCo writes MJCF numbers to 6 digits: the saved model's inertias differ from the URDF's by ~1e-6.
    assert 1e-7 < from_mjcf.plant["start_inertia_difference"] < 1e-5
    assert 1e-7 < np.abs(from_mjcf.joint_angles - from_urdf.joint_angles).max() < 1e-4
    assert from_mjcf.plant["model"] == "mjcf" and from_mjcf.plant["model_file"] == str(xarm7_mjcf)

    out = tmp_path / "run.csv"
    code = main(["run", "--robot", "xarm7", "--resolver", "pinv", "--direction", "0,1,-1", "--accel", "1",
                 "--duration", "0.5", "--mjcf", str(xarm7_mjcf), "--plant-option", "joint-limits=off,damping=zero",
                 "--out", str(out)])  # fmt: skip
    assert code == 0 and f"on MJCF {xarm7_mjcf.name}" in capsys.readouterr().out
    record = json.loads((tmp_path / "run.csv.json").read_text())["plant"]
    assert record["model"] == "mjcf" and record["joint_limits"] == "off" and record["damping"] == "zero"
    assert torqueopt.load_result(out).plant == record


def test_an_mjcf_whose_joints_do_not_match_is_refused_in_one_line(xarm7, xarm7_mjcf, tmp_path, capsys):
    renamed = tmp_path / "renamed.xml"
    renamed.write_text(xarm7_mjcf.read_text().replace('name="joint3"', 'name="elbow"'))
    with pytest.raises(PlantError, match=r"has no joint joint3: the plant's joints must carry the robot's names"):
        MujocoPlant(xarm7, mjcf=renamed)
    code = main(["run", "--robot", "xarm7", "--resolver", "pinv", "--direction", "0,1,-1", "--mjcf", str(renamed)])
    error = capsys.readouterr().err
    assert code == 2 and error.count("\n") == 1
    assert error.startswith(f"torqueopt run: error: the MJCF '{renamed}' has no joint joint3: the plant's joints")
    assert "its joints are joint1, joint2, elbow, joint4" in error


def test_a_state_mujoco_flags_as_bad_stops_the_run(xarm7, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # 2e10 rad/s is beyond MuJoCo's 1e10 ceiling: it flags the state, which comes back NaN, and the run stops.
    run = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, v0=np.full(7, 2e10), max_joint_speed=np.inf,
                   max_torque_ratio=np.inf, plant="mujoco", plant_options=MATCHED)  # fmt: skip
    assert not run.completed and run.stop_reason == "state became non-finite during the step from t = 0.0000 s"
    assert run.plant["bad_state"] == (
        "MuJoCo flagged a bad state in the step ending at t = 0.0010 s: Nan, Inf or huge value in QVEL at DOF 0. "
        "The simulation is unstable. Time = 0.0000."
    )
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT


def test_bad_plant_options_are_refused_by_name(xarm7):
    for options, message in [
        ({"integrator": "rk45"}, "plant option integrator=rk45 is not one of rk4, implicitfast, euler"),
        ({"contacts": "maybe"}, "plant option contacts=maybe is not on or off"),
        ({"timestep": "-1"}, r"plant option timestep=-1 must be a positive finite number \[s\]"),
        ({"perturb": 1.5}, r"plant option perturb=1.5 must be a number in \[0, 1\)"),
        ({"seed": "x"}, "plant option seed=x must be a whole number >= 0"),
        ({"colour": "red"}, "unexpected plant option 'colour'"),
    ]:
        with pytest.raises(InvalidInput, match=message):
            simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco", plant_options=options)
    with pytest.raises(InvalidInput, match=r"timestep=0.0003 s does not divide the control step dt=0.001 s; give "):
        simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant="mujoco", plant_options={"timestep": 3e-4})


def test_meshes_are_found_from_the_package_folders_or_dropped_with_a_note(xarm7):
    # xarm7's collision meshes are STL files under package://example-robot-data/...: MuJoCo reads all eight.
    assert MujocoPlant(xarm7, contacts=True).model.nmesh == 8
    kinova = MujocoPlant(torqueopt.load_robot("kinova"))  # COLLADA meshes, which MuJoCo does not read
    assert kinova.model.nmesh == 0 and kinova.model.ngeom == 0
    assert kinova.notes[0].startswith(
        "9 meshes MuJoCo cannot read or find (arm.dae, base.dae, finger_distal.dae and 6 "
    )


@pytest.mark.slow
def test_a_mobile_bases_refused_inertias_are_left_out_and_the_arm_still_matches(rng):
    # tiago's antenna links, fixed to the base, have a negative principal moment (−3.5e-8 kg·m²).
    tiago = torqueopt.load_robot("tiago")
    plant = MujocoPlant(tiago, damping="zero")
    assert any("(base_antenna_left_link, base_antenna_right_link) left out" in note for note in plant.notes)
    for q, v in random_states(tiago, rng, 5):
        inertia, bias = plant.terms(q, v)
        terms = tiago.terms(q, v)
        assert np.abs(inertia - terms.inertia).max() <= 1e-10 * np.abs(terms.inertia).max()
        assert np.abs(bias - terms.bias_torque).max() <= 1e-10 * np.abs(terms.bias_torque).max()


@pytest.mark.slow
def test_contacts_on_act_where_the_collision_geometry_overlaps():
    baxter = torqueopt.load_robot("baxter")
    line = StraightLine(direction=[0, 0, 1], accel=0.2, duration=0.2)
    runs = {
        contacts: simulate(
            baxter,
            "pinv",
            line,
            baxter.default_configuration,
            plant="mujoco",
            plant_options={"contacts": contacts, "damping": "zero"},
        )
        for contacts in ("off", "on")
    }
    assert runs["off"].max_tip_error < 1e-3 < 0.1 < runs["on"].max_tip_error
    assert any(note.startswith("with contacts on, MuJoCo found 6 contacts in the first step (right_lower_elbow-")
               for note in runs["on"].plant["notes"])  # fmt: skip


def test_feedback_from_the_command_line_works_with_the_mujoco_plant(capsys):
    arguments = ["run", "--robot", "xarm7", "--resolver", "pinv", "--direction", "0,1,-1", "--accel", "1",
                 "--duration", "0.5", "--plant", "mujoco", "--plant-option", "perturb=0.2,seed=1,damping=zero", "--no-dexterity"]  # fmt: skip
    errors = {}
    for feedback in ([], ["--feedback", "400,40"]):
        assert main(arguments + feedback) == 0
        printed = capsys.readouterr().out
        errors[bool(feedback)] = float(printed.split("max tip error: ")[1].split(" mm")[0])
        assert "plant perturbed: 7 link masses and inertias scaled by factors from U(0.8, 1.2), seed 1" in printed
    assert errors[True] < errors[False] / 5


def test_an_mjcfs_extra_joints_are_welded_and_its_actuators_removed(xarm7, xarm7_mjcf, tmp_path):
    # A Menagerie-like arm: a two-finger gripper (slides coupled by a tendon and an equality) under link7,
    # a position servo on joint2 and a sensor: the plant keeps the seven arm joints and none of the rest.
    gripper = """
      <body name="left_finger" pos="0 0.02 0.05"><joint name="left_slide" type="slide" axis="0 1 0" ref="0.01"/>
        <inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/></body>
      <body name="right_finger" pos="0 -0.02 0.05"><joint name="right_slide" type="slide" axis="0 -1 0"/>
        <inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/></body>"""
    extras = """
  <tendon><fixed name="split"><joint joint="left_slide" coef="0.5"/><joint joint="right_slide" coef="0.5"/></fixed></tendon>
  <equality><joint joint1="left_slide" joint2="right_slide"/></equality>
  <actuator><position name="servo" joint="joint2" kp="1000"/></actuator>
  <sensor><jointpos joint="joint1"/></sensor>
</mujoco>"""
    text = xarm7_mjcf.read_text()
    link7 = text.index("<joint", text.index('<body name="link7"'))
    link7 = text.index("/>", link7) + 2
    text = text[:link7] + gripper + text[link7:]
    text = text[: text.rindex("</mujoco>")] + extras
    path = tmp_path / "xarm7_gripper.xml"
    path.write_text(text)
    plant = MujocoPlant(xarm7, mjcf=path, damping="zero", joint_limits=False)
    assert plant.model.nv == 7 and plant.model.nu == 0 and plant.model.ntendon == 0 and plant.model.neq == 0
    assert any(
        "joint 'left_slide' of the MJCF" in note and "welded at its reference 0.01" in note for note in plant.notes
    )
    assert any(note.startswith("the 1 actuator of the MJCF") for note in plant.notes)
    # 0.1 kg more at the hand: the plant's inertia differs from the controller's, by more than the 6-digit file alone.
    assert 1e-3 < plant.start_inertia_difference < 0.1
    run = simulate(xarm7, "pinv", LINE, xarm7.default_configuration, plant=plant)
    assert run.completed and run.max_tip_error > 1e-3


@pytest.mark.parametrize("resolver", ["pinv", "damped-null-space"])
def test_a_mujoco_batch_equals_mujoco_single_runs(xarm7, resolver):
    """Each movement of a batch on the MuJoCo plant is its own single run: states, stops and plant records.

    One movement runs into joint4's limit (MuJoCo's limit force acts), one is pushed past the torque ceiling
    so that it leaves the batch early. (bounded-torque is left out: on these movements its batch leaves its
    single runs at step 226 with the Pinocchio plant too, already on main.)
    """
    from torqueopt.batch import simulate_batch

    start = xarm7.default_configuration
    lines = [
        INTO_THE_LIMIT,
        StraightLine(direction=[0, 1, -1], accel=1.0, duration=1.0),
        StraightLine(direction=[1, 0, 1], accel=6.0, duration=1.0),
    ]
    options = {"damping": "zero"}
    common = {"max_torque_ratio": 1.5}
    batch = simulate_batch(xarm7, resolver, lines, [start] * 3, plant="mujoco", plant_options=options, **common)
    for line, ours in zip(lines, batch):
        single = simulate(xarm7, resolver, line, start, plant="mujoco", plant_options=options, **common)
        assert ours.stop_reason == single.stop_reason and len(ours.t) == len(single.t)
        assert np.abs(ours.joint_angles - single.joint_angles).max() < 1e-9
        assert np.nanmax(np.abs(ours.tau - single.tau)) < 1e-9 * np.nanmax(np.abs(single.tau))
        # the batch's torques are the stacked resolver's, equal to round-off: so are the limit forces they meet
        assert {**ours.plant, "limit_events": None} == {**single.plant, "limit_events": None}
        for event, expected in zip(ours.plant["limit_events"], single.plant["limit_events"], strict=True):
            assert event == {**expected, "peak_force": pytest.approx(expected["peak_force"], rel=1e-9)}
    assert "joint4" in [event["joint"] for event in batch[0].plant["limit_events"]]
    assert batch[0].plant["limit_events"] != batch[1].plant["limit_events"]  # each movement's own record
    assert not batch[2].completed and len(batch[2].t) < len(batch[0].t)  # it left the batch first


#: planar3 on MuJoCo: its thin rods need the floor; each link's mass and inertia scaled by U(0.9, 1.1).
PERTURBED = {"inertia-floor": "1e-6", "perturb": "0.1", "seed": "2"}


def test_an_atlas_on_the_mujoco_plant_is_a_model_error_atlas(tmp_path):
    """``torqueopt atlas --plant mujoco --plant-option perturb=0.1``: every row is the run that ``simulate`` gives on
    the same perturbed plant (batch and worker path against the single run), and the rows differ from the atlas on
    the robot's own model, where the controller's model is exact."""
    pytest.importorskip("pandas")
    from torqueopt.atlas import run_atlas
    from torqueopt.atlas.population import movement_trajectory
    from torqueopt.atlas.sweep import simulate_all

    common = {"paths": 2, "durations": [0.3], "resolvers": ["pinv", "null-space"], "workers": 0, "figures": False,
              "progress": False}  # fmt: skip
    mujoco_atlas = run_atlas("planar3", out=tmp_path / "mujoco", plant="mujoco", plant_options=PERTURBED, **common)
    own_atlas = run_atlas("planar3", out=tmp_path / "own", **common)
    config = json.loads((tmp_path / "mujoco" / "atlas-config.json").read_text())
    assert config["plant"] == {"name": "mujoco", "options": PERTURBED}
    assert "plant" not in json.loads((tmp_path / "own" / "atlas-config.json").read_text())
    assert (
        "the torques acting on the mujoco plant (inertia-floor=1e-6, perturb=0.1, seed=2)"
        in (tmp_path / "mujoco" / "atlas.md").read_text()
    )

    robot = torqueopt.load_robot("planar3")
    from torqueopt.atlas.population import PopulationSpec, draw_population

    movements = draw_population(robot, PopulationSpec(paths=2, durations=(0.3,), seed=0))
    table = mujoco_atlas.table.set_index(["path", "resolver"])
    for name in ("pinv", "null-space"):
        resolver = torqueopt.get_resolver(name)
        lines = [movement_trajectory(m) for m in movements]
        runs, _ = simulate_all(robot, resolver, lines, [m.q0 for m in movements], 1e-3, False,
                               plant="mujoco", plant_options=PERTURBED)  # fmt: skip
        for movement, run in zip(movements, runs):
            row = table.loc[(int(movement.path), name)]
            assert row["max_tip_error"] == pytest.approx(run.max_tip_error, rel=1e-9, abs=1e-12)
    own = own_atlas.table.set_index(["path", "resolver"])
    assert (abs(table["max_tip_error"] - own["max_tip_error"]) > 1e-4).all()  # a 10 % model error shows


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--plant-option", "perturb"], "--plant-option 'perturb' must be KEY=VALUE"),
        (["--plant", "bullet"], "--plant: 'bullet' is not a plant; choose one of pinocchio, mujoco"),
        (["--plant", "mujoco", "--plant-option", "inertia-floor=1e-6", "--global"], "--global judges each optimum"),
        (["--plant", "mujoco", "--plant-option", "inertia-floor=1e-6", "--resolvers", "velocity-pinv"],
         "resolver velocity-pinv works at the velocity level"),
        (["--plant", "mujoco", "--plant-option", "wobble=1"], "wobble"),
    ],
)  # fmt: skip
def test_an_atlas_plant_that_cannot_run_is_refused_in_one_line_before_any_work(tmp_path, capsys, arguments, message):
    out = tmp_path / "atlas"
    code = main(["atlas", "--paths", "2", "--durations", "0.3", "--workers", "0", "--out", str(out), *arguments])
    error = capsys.readouterr().err
    assert code == 2 and message in error and error.count("\n") == 1, error
    assert not out.exists()
