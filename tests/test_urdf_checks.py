"""Physical checks of a user URDF: every impossible quantity is refused in one line naming its link or joint."""

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import torqueopt
from torqueopt import TorqueoptWarning, UrdfError
from torqueopt.catalog import find_robot
from torqueopt.urdf_checks import build_model

ROOT = Path(__file__).resolve().parent.parent
PLANAR3 = find_robot("planar3").urdf.read_text()
FIRST_INERTIA = 'ixx="0.0" ixy="0" ixz="0" iyy="0.8333333333333334" iyz="0" izz="0.8333333333333334"'


def variant(tmp_path, old, new, name="arm"):
    assert old in PLANAR3, old
    path = tmp_path / f"{name}.urdf"
    path.write_text(PLANAR3.replace(old, new, 1))
    return path


BROKEN = [
    ('<mass value="10.0"/>', '<mass value="nan"/>', "link 'link1': <mass> has value=\"nan\"; it must be a finite number"),
    ('<mass value="10.0"/>', '<mass value="-1"/>', "link 'link1' has mass -1; a mass must be a finite number >= 0 [kg]"),
    (FIRST_INERTIA, FIRST_INERTIA.replace('ixx="0.0"', 'ixx="-1"'), "link 'link1' has an inertia that is not positive semi-definite"),
    (FIRST_INERTIA, FIRST_INERTIA.replace('ixy="0"', 'ixy="5"'), "link 'link1' has an inertia that is not positive semi-definite"),
    (FIRST_INERTIA, FIRST_INERTIA.replace('iyz="0"', 'iyz="inf"'), "link 'link1': <inertia> has iyz=\"inf\"; it must be a finite number"),
    ('effort="24.0"', 'effort="-5"', "joint 'joint2' has effort limit -5; give a number >= 0 [N·m or N] (0 or inf: unbounded)"),
    ('effort="24.0"', 'effort="nan"', "joint 'joint2' has effort limit nan"),
    ('velocity="100.0"', 'velocity="-1"', "joint 'joint1' has velocity limit -1; give a number >= 0"),
    ('lower="-6.283185307179586" upper="6.283185307179586" effort="54.0"', 'lower="1" upper="-1" effort="54.0"', "joint 'joint1' has lower position limit 1 above its upper limit -1"),
    ('lower="-6.283185307179586"', 'lower="-inf"', "joint 'joint1' has lower position limit -inf; give a finite number (a revolute joint without position limits is type=\"continuous\")"),
    ('<child link="link2"/>', '<child link="link3"/>', "link 'link3' is the child of both joint 'joint2' and joint 'joint3', which closes a kinematic loop"),
    ('<link name="link3">', '<link name="link2"/><link name="link3">', "has two <link> elements named 'link2'; every link needs a name of its own"),
    # Numbers Python reads but urdfdom does not: it would drop the element (the link's mass 0, exit 0).
    ('<mass value="10.0"/>', '<mass value=" 10.0 "/>', 'link \'link1\': <mass> value=" 10.0 " is not a number as URDF parsers read it'),
    ('<mass value="10.0"/>', '<mass value="1_0"/>', 'link \'link1\': <mass> value="1_0" is not a number as URDF parsers read it'),
    ('<mass value="10.0"/>', '<mass value="１０"/>', "is not a number as URDF parsers read it"),
    (FIRST_INERTIA, FIRST_INERTIA.replace('iyy="0.8333333333333334"', 'iyy="0.8333333333333334 "'), '<inertia> iyy="0.8333333333333334 " is not a number as URDF parsers read it'),
    ('effort="24.0"', 'effort="24.0 "', "joint 'joint2': <limit effort>=\"24.0 \" is not a number as URDF parsers read it"),
    ('<origin xyz="0.5 0 0" rpy="0 0 0"/>', '<origin xyz="0.5_0 0 0" rpy="0 0 0"/>', "link 'link1': <inertial><origin> xyz=\"0.5_0 0 0\" is not three numbers as URDF parsers read them"),
    ('<origin xyz="0.5 0 0" rpy="0 0 0"/>', '<origin xyz="0.5&#9;0 0" rpy="0 0 0"/>', "<inertial><origin> xyz=\"0.5\t0 0\" is not three numbers"),
    ('<joint name="joint3" type="revolute">', '<joint name="joint3" type="revolute"><dynamics damping="-1"/>', "joint 'joint3' has damping -1; give a finite number >= 0"),
    ('<joint name="joint3"', '<joint name="joint2" type="fixed"><parent link="link3"/><child link="extra"/></joint><link name="extra"/><joint name="joint3"', "has two <joint> elements named 'joint2'; every joint needs a name of its own"),
]  # fmt: skip


@pytest.mark.parametrize("old, new, message", BROKEN)
def test_impossible_physics_is_refused_naming_the_link_or_joint(tmp_path, old, new, message):
    path = variant(tmp_path, old, new)
    with pytest.raises(UrdfError) as error:
        torqueopt.load_robot(str(path), frame="tip", task="xy")
    text = str(error.value)
    assert message in text and "\n" not in text


# Each case starts a process: the first runs in the quick selection (-m "not slow"), all in the full suite.
@pytest.mark.parametrize(
    "old, new, message",
    BROKEN[:1] + [pytest.param(*case, marks=pytest.mark.slow) for case in BROKEN[1:2] + BROKEN[5:6] + BROKEN[-1:]],
)
def test_the_cli_prints_one_line_and_nothing_from_urdfdom(tmp_path, old, new, message):
    """Run as a process, so that anything the C++ parser writes to fd 2 would show."""
    path = variant(tmp_path, old, new)
    process = subprocess.run(
        [sys.executable, "-m", "torqueopt", "run", "--robot", str(path), "--frame", "tip", "--task", "xy",
         "--resolver", "pinv", "--direction", "1,1", "--duration", "0.1"],
        capture_output=True, text=True, cwd=tmp_path, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        timeout=120, check=False,
    )  # fmt: skip
    assert process.returncode == 2
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torqueopt run: error: URDF ") and message in lines[0], lines


def test_a_urdfdom_failure_is_one_line_too(tmp_path, capfd):
    """A file our checks pass but urdfdom rejects (a revolute joint without <limit>):
    its multi-line C++ message never reaches fd 2, and its first error becomes our one line."""
    limit = '<limit lower="-6.283185307179586" upper="6.283185307179586" effort="54.0" velocity="100.0"/>'
    path = variant(tmp_path, limit, "")
    with pytest.raises(UrdfError) as error:
        build_model(path, mimic=False)  # Pinocchio's parse alone (load_robot asks yourdfpy first)
    assert "\n" not in str(error.value) and "joint1" in str(error.value)
    assert capfd.readouterr().err == ""


def test_an_infinite_effort_means_unbounded_with_the_same_dynamics(tmp_path):
    path = variant(tmp_path, 'effort="54.0"', 'effort="inf"')
    robot = torqueopt.load_robot(str(path), frame="tip", task="xy", gravity=False)
    reference = torqueopt.load_robot("planar3")
    assert robot.joints_without_torque_limit == ["joint1"]
    np.testing.assert_array_equal(robot.torque_upper[1:], reference.torque_upper[1:])
    rng = np.random.default_rng(3)
    q, v = reference.configuration(rng.uniform(-3, 3, 3)), rng.uniform(-1, 1, 3)
    ours, theirs = robot.terms(q, v), reference.terms(q, v)
    np.testing.assert_allclose(ours.inertia, theirs.inertia, atol=1e-12)
    np.testing.assert_allclose(ours.bias_torque, theirs.bias_torque, atol=1e-12)


def test_a_joint_that_moves_no_mass_is_refused_when_the_task_moves_it(tmp_path):
    massless = PLANAR3
    for _ in range(3):
        massless = massless.replace('<mass value="10.0"/>', '<mass value="0"/>', 1)
        massless = massless.replace(FIRST_INERTIA, FIRST_INERTIA.replace("0.8333333333333334", "0"), 1)
    path = tmp_path / "massless.urdf"
    path.write_text(massless)
    with pytest.raises(UrdfError, match="joint 'joint1' moves no mass: link 'link1' and every link below it"):
        torqueopt.load_robot(str(path), frame="tip", task="xy")


def test_an_inertia_beyond_the_triangle_inequality_is_a_note(tmp_path):
    """Impossible for a body, harmless to the dynamics, common in shipped files: a warning, not a refusal."""
    path = variant(tmp_path, FIRST_INERTIA, FIRST_INERTIA.replace('izz="0.8333333333333334"', 'izz="5"'))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = torqueopt.load_robot(str(path), frame="tip", task="xy")
    assert robot.nv == 3
    notes = [str(w.message) for w in caught if issubclass(w.category, TorqueoptWarning)]
    assert len(notes) == 1 and "link 'link1' has an inertia that no body can have" in notes[0]


def test_every_catalogue_arm_passes_the_checks():
    for name in ("planar3", "panda", "xarm7", "baxter", "tiago", "kinova"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", TorqueoptWarning)
            assert torqueopt.load_robot(name).nv >= 3


FLOATING_BASE = (
    '<link name="base">',
    '<link name="world_base"><inertial><mass value="5.0"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" '
    'izz="0.1"/></inertial></link><joint name="float" type="floating"><parent link="world_base"/>'
    '<child link="base"/></joint><link name="base"><inertial><mass value="5.0"/><inertia ixx="0.1" ixy="0" '
    'ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>',
)


def test_a_floating_base_in_the_task_chain_is_refused_in_one_line(tmp_path, capsys):
    """A floating (or planar) joint has degrees of freedom no actuator drives: with --task xy the run gave
    LinAlgError at the default start, or torques on the free base and a "stable" verdict."""
    from torqueopt.cli import main

    path = variant(tmp_path, *FLOATING_BASE)
    code = main(["run", "--robot", str(path), "--frame", "tip", "--task", "xy", "--resolver", "pinv",
                 "--direction", "1,1", "--duration", "0.1"])  # fmt: skip
    assert code == 2
    assert capsys.readouterr().err == (
        "torqueopt run: error: joint 'float' of robot 'arm' is a floating joint (6 degrees of freedom that no "
        "actuator drives): torqueopt resolves fixed-base arms, every joint driven; make it a fixed joint in the "
        "URDF, or lock it with --lock float\n"
    )
    robot = torqueopt.load_robot(str(path), frame="tip", task="xy", lock=["float"])
    assert robot.nv == 3


#: Attributes of numbers, and of vectors of numbers, that Pinocchio's model is built from.
_SCALARS = {"value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz", "effort", "velocity", "lower", "upper", "damping",
            "friction", "multiplier", "offset"}  # fmt: skip
_VECTORS = {"xyz", "rpy"}


def _canonical(text):
    """The URDF with every number rewritten as Python reads it (``repr(float(...))``), the checks' reading."""
    from xml.etree import ElementTree

    root = ElementTree.fromstring(text)
    for element in root.iter():
        for name, value in element.attrib.items():
            if name in _SCALARS:
                element.set(name, repr(float(value)))
            elif name in _VECTORS:
                element.set(name, " ".join(repr(float(part)) for part in value.split()))
    return ElementTree.tostring(root, encoding="unicode")


def _model_numbers(model):
    inertias = [np.concatenate([[i.mass], i.lever, i.inertia.ravel()]) for i in model.inertias]
    placements = [p.homogeneous.ravel() for p in model.jointPlacements]
    limits = [model.effortLimit, model.velocityLimit, model.lowerPositionLimit, model.upperPositionLimit]
    return np.concatenate([*inertias, *placements, *limits, model.damping, model.friction])


ACCEPTED = [  # written otherwise, read alike by both parsers
    ('<mass value="10.0"/>', '<mass value=" 10.0"/>'),
    ('<mass value="10.0"/>', '<mass value="1e1"/>'),
    ('<origin xyz="0.5 0 0" rpy="0 0 0"/>', '<origin xyz=" 0.5  0 0 " rpy="0 0 0"/>'),
]


@pytest.mark.parametrize("name", ["planar3", "panda", "xarm7", "baxter", "tiago", "kinova", *range(len(ACCEPTED))])
def test_pinocchio_builds_the_numbers_the_checks_read(name, tmp_path):
    # Independent of the checks' code: Pinocchio's model of the file equals its model of the file rewritten
    # with every number as Python read it, so no number the checks passed was read otherwise (or dropped).
    if isinstance(name, int):
        path = variant(tmp_path, *ACCEPTED[name])
    else:
        path = find_robot(name).urdf
    from torqueopt.urdf_checks import checked_urdf_text

    text = checked_urdf_text(path)
    built = _model_numbers(build_model(path, mimic=False))
    canonical = tmp_path / "canonical.urdf"
    canonical.write_text(_canonical(text))
    np.testing.assert_array_equal(built, _model_numbers(build_model(canonical, mimic=False)))


def test_the_comparison_sees_a_number_urdfdom_drops():
    # The oracle above can fail: a trailing blank, read by Python, makes urdfdom drop link1's <inertial>.
    import pinocchio as pin

    from torqueopt.urdf_checks import quiet_stderr

    text = PLANAR3.replace('<mass value="10.0"/>', '<mass value="10.0 "/>', 1)
    with quiet_stderr():
        dropped = pin.buildModelFromXML(text)
    assert dropped.inertias[1].mass == 0.0
    assert not np.array_equal(_model_numbers(dropped), _model_numbers(pin.buildModelFromXML(_canonical(text))))


def _chain(joints):
    inertial = (
        '<inertial><mass value="0.1"/><inertia ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1e-3"/></inertial>'
    )
    parts = [f'<robot name="chain"><link name="l0">{inertial}</link>']
    for i in range(1, joints + 1):
        parts.append(
            f'<link name="l{i}">{inertial}</link><joint name="j{i}" type="revolute"><parent link="l{i - 1}"/>'
            f'<child link="l{i}"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="10"/></joint>'
        )
    return "".join(parts) + "</robot>"


def test_a_chain_too_long_for_pinocchio_s_data_is_refused_before_it_is_made(tmp_path):
    # Pinocchio's Data grows as 64·nv³ bytes (68 MB measured at nv = 100): a 1000-joint chain asked for 64 GB.
    import resource

    from torqueopt.loading import MAX_DOFS

    path = tmp_path / "chain.urdf"
    path.write_text(_chain(MAX_DOFS + 1))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(UrdfError, match=rf"has {MAX_DOFS + 1} degrees of freedom, more than the {MAX_DOFS} torqueopt"):
        torqueopt.load_robot(str(path), frame=f"l{MAX_DOFS + 1}", task="xy")
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # kB: no Data of it was made
    path.write_text(_chain(12))
    assert torqueopt.load_robot(str(path), frame="l12", task="xy").nv == 12
