"""Loading robots: the paper's arm, example-robot-data arms, chains, limits, bad URDFs."""

import numpy as np
import pytest

import torqueopt
from torqueopt import FrameNotFound, InvalidInput, RobotNotFound, TaskNotFound, UrdfError
from torqueopt.catalog import available_robots, find_robot


@pytest.mark.parametrize(
    "name, frame, joints",
    [
        ("panda", "panda_hand", [f"panda_joint{i}" for i in range(1, 8)]),
        ("xarm7", "link_eef", [f"joint{i}" for i in range(1, 8)]),
        (
            "baxter",
            "right_gripper",
            ["right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"],
        ),
        ("tiago", "arm_tool_link", [f"arm_{i}_joint" for i in range(1, 8)]),
    ],
)
def test_seven_dof_arms_load_with_only_their_chain(name, frame, joints):
    robot = torqueopt.load_robot(name)
    assert robot.frame == frame and robot.task == "position"
    assert robot.joint_names == joints and robot.nv == 7
    assert np.all(np.isfinite(robot.torque_limit)) and np.all(robot.torque_limit > 0)
    np.testing.assert_allclose(robot.gravity, [0, 0, -9.81])


def test_other_chain_is_chosen_by_the_task_frame():
    left = torqueopt.load_robot("baxter", frame="left_gripper")
    assert left.joint_names[0] == "left_s0" and left.nv == 7
    assert "right_s0" in left.locked_joints and "head_pan" in left.locked_joints


def test_panda_fingers_are_locked_and_srdf_configuration_is_the_default():
    panda = torqueopt.load_robot("panda")
    assert set(panda.locked_joints) == {"panda_finger_joint1", "panda_finger_joint2"}
    np.testing.assert_allclose(panda.default_configuration[[1, 3]], [-0.785398, -2.35619])


def test_user_urdf_path_and_extra_locks(tmp_path):
    path = find_robot("planar3").urdf
    robot = torqueopt.load_robot(str(path), frame="tip", task="xy", lock=["joint1"])
    assert robot.joint_names == ["joint2", "joint3"] and robot.nv == 2


def test_torque_limit_override_and_missing_limits(tmp_path):
    source = find_robot("planar3").urdf.read_text()
    no_limit = tmp_path / "nolimit.urdf"
    no_limit.write_text(source.replace('effort="24.0"', 'effort="0"'))
    robot = torqueopt.load_robot(str(no_limit), frame="tip", task="xy")
    assert robot.joints_without_torque_limit == ["joint2"]
    assert np.isinf(robot.torque_limit[1])
    limited = robot.with_torque_limit([54, 24, 6])
    assert limited.joints_without_torque_limit == [] and robot.joints_without_torque_limit == ["joint2"]
    with pytest.raises(InvalidInput, match=r"torque limit has 2 values; robot 'nolimit' needs 1 or 3"):
        robot.with_torque_limit([1, 2])
    with pytest.raises(InvalidInput, match="must be positive numbers"):
        robot.with_torque_limit([1, -2, 3])


def test_configuration_from_angles_round_trips_for_continuous_joints():
    kinova = torqueopt.load_robot("kinova")
    angles = np.array([0.3, -2.0, 1.0, 2.5, -0.4, 3.0])
    np.testing.assert_allclose(kinova.joint_angles(kinova.configuration(angles)), angles, atol=1e-12)


def test_unknown_names_list_the_valid_choices():
    with pytest.raises(
        RobotNotFound, match=r"unknown robot 'robbie': give a URDF path or one of planar3, panda, xarm7, baxter"
    ):
        torqueopt.load_robot("robbie")
    with pytest.raises(RobotNotFound, match=r"URDF file 'missing/arm.urdf' does not exist"):
        torqueopt.load_robot("missing/arm.urdf")
    with pytest.raises(FrameNotFound, match=r"robot 'planar3' has no frame 'hand': choose one of .*tip"):
        torqueopt.load_robot("planar3", frame="hand")
    with pytest.raises(TaskNotFound, match=r"^unknown task 'orientation': choose one of xy, position, pose$"):
        torqueopt.load_robot("planar3", task="orientation")


@pytest.mark.parametrize(
    "edit, message",
    [
        (('<parent link="link1"/>', ""), r'<joint name="joint2"> has no <parent link="..."/>'),
        (
            ('<child link="link2"/>', '<child link="linkX"/>'),
            r"<joint name=\"joint2\"> has child link 'linkX', which is not a <link>",
        ),
        (('<mass value="10.0"/>', '<mass value="ten"/>'), r'<mass value="ten"> in <link name="link1"> is not a number'),
        (("</robot>", ""), "XML syntax error"),
        (('effort="6.0" velocity="100.0"/>', "/>"), "URDFIncompleteError"),
    ],
)
def test_malformed_urdf_names_the_broken_tag(tmp_path, edit, message):
    text = find_robot("planar3").urdf.read_text().replace(*edit, 1)
    path = tmp_path / "broken.urdf"
    path.write_text(text)
    with pytest.raises(UrdfError, match=f"malformed URDF '.*broken.urdf': .*{message}"):
        torqueopt.load_robot(str(path), frame="tip")


def test_planar3_starts_at_the_papers_configuration_by_default(planar3):
    np.testing.assert_allclose(planar3.default_configuration, np.radians([-45.0, 135.0, -135.0]))
    np.testing.assert_allclose(
        planar3.task_position(planar3.default_configuration), [np.sqrt(2), 1 - np.sqrt(2)], atol=1e-12
    )


def test_joint_angles_of_many_configurations_at_once():
    for robot in (torqueopt.load_robot("kinova"), torqueopt.load_robot("planar3")):
        angles = np.random.default_rng(3).uniform(-3.0, 3.0, (5, robot.nv))
        configurations = np.array([robot.configuration(row) for row in angles])
        np.testing.assert_allclose(robot.joint_angles(configurations), angles, atol=1e-12)


VETTED = [name for name in available_robots() if find_robot(name).vetted]


def test_the_catalogue_vets_the_papers_arm_and_the_known_arms_only():
    assert VETTED == ["planar3", "panda", "xarm7", "baxter", "tiago", "kinova"]
    assert not find_robot("a1").vetted
    assert not find_robot(str(find_robot("planar3").urdf)).vetted


@pytest.mark.parametrize("name", VETTED)
def test_vetted_urdfs_pass_yourdfpy_and_agree_on_mimic_joints(name):
    """Loading a vetted robot skips yourdfpy, so its check is made here; the
    mimic joints read off the XML must be the ones yourdfpy finds."""
    import yourdfpy

    from torqueopt.loading import _validate_urdf

    path = find_robot(name).urdf
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False)
    assert urdf.validate(), urdf.errors
    assert _validate_urdf(path) == {joint.name for joint in urdf.robot.joints if joint.mimic is not None}


def test_loading_the_papers_arm_does_not_import_yourdfpy():
    import subprocess
    import sys

    code = "import sys, torqueopt; torqueopt.load_robot('planar3'); print('yourdfpy' in sys.modules)"
    completed = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert completed.stdout.strip() == "False"


def test_with_gravity_is_a_copy_and_leaves_the_robot_alone():
    robot = torqueopt.load_robot("planar3", torque_limit=[54, 24, 6])
    heavy = robot.with_gravity([0.0, -9.81, 0.0])
    assert robot.gravity.tolist() == [0.0, 0.0, 0.0]
    assert heavy.gravity.tolist() == [0.0, -9.81, 0.0]
    assert heavy.model is not robot.model
    np.testing.assert_array_equal(heavy.torque_limit, robot.torque_limit)
    q, zero = robot.configuration([0.3, 0.2, 0.1]), np.zeros(3)
    assert not robot.forward_dynamics(q, zero, zero).any()
    assert heavy.forward_dynamics(q, zero, zero).any()


def test_a_folder_or_a_xacro_given_as_robot_says_what_it_is(tmp_path, monkeypatch):
    """A folder was said not to exist, and an existing .xacro was an "unknown robot"."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "arm").mkdir()
    (tmp_path / "arm" / "arm.urdf").write_text("<robot/>")
    (tmp_path / "arm.urdf.xacro").write_text("<robot/>")
    cases = [
        ("arm", "robot 'arm' is a folder; give the URDF file in it, e.g. arm/arm.urdf"),
        ("arm/", "robot 'arm/' is a folder; give the URDF file in it, e.g. arm/arm.urdf"),
        ("arm.urdf.xacro", "robot 'arm.urdf.xacro' is a xacro file, which torqueopt does not expand; expand it to a "
         "URDF first (xacro arm.urdf.xacro -o arm.urdf) and give that file"),
    ]  # fmt: skip
    for source, message in cases:
        with pytest.raises(RobotNotFound) as error:
            torqueopt.load_robot(source)
        assert str(error.value) == message
