"""Default starts are well-conditioned, and a questionable start is said before the run."""

import warnings

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine, TorqueoptWarning
from torqueopt.simulate import NEAR_SINGULAR, start_notes

ARMS = [("planar3", None), ("panda", None), ("xarm7", None), ("baxter", "right_gripper"),
        ("baxter", "left_gripper"), ("tiago", None), ("kinova", None)]  # fmt: skip


@pytest.mark.parametrize("name, frame", ARMS)
def test_every_catalogue_arm_starts_well_conditioned_within_its_limits(name, frame):
    """Measured independently of start_notes: the SVD of the task Jacobian, the
    gravity torque from RNEA at rest, and the URDF's position limits."""
    robot = torqueopt.load_robot(name, frame=frame)
    q = robot.default_configuration
    terms = robot.terms(q, np.zeros(robot.nv))
    singular_values = np.linalg.svd(terms.jacobian, compute_uv=False)
    assert singular_values[-1] / singular_values[0] > 0.1
    assert (np.abs(terms.bias_torque) < 0.5 * robot.torque_upper).all()
    lower, upper, _ = robot.joint_limits
    angles = robot.joint_angles(q)
    assert ((angles >= lower) & (angles <= upper)).all()
    assert start_notes(robot, q) == []


def test_a_near_singular_start_is_a_note(planar3):
    q0 = [0.1, 0.05, 0.02]  # nearly stretched
    with pytest.warns(
        TorqueoptWarning, match=f"the start is near-singular: σmin/σmax .* \\(below {NEAR_SINGULAR:g}\\)"
    ):
        torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.01), q0)


def test_a_start_over_its_torque_limit_at_rest_is_a_note():
    """Gravity along -y in the arm's plane. By hand: at (-45°, 135°, -135°) link 3
    points along (1, -1)/√2, so its centre of mass is √2/4 m along x from joint 3,
    which holds 10 · 9.81 · √2/4 = 34.68 N·m, 5.78 times its 6 N·m (the largest
    ratio: joint 1 needs 208 N·m, 3.85 times its 54 N·m)."""
    robot = torqueopt.load_robot("planar3", gravity=[0.0, -9.81, 0.0])
    q0 = np.radians([-45.0, 135.0, -135.0])
    notes = start_notes(robot, robot.configuration(q0))
    expected = 10 * 9.81 * np.sqrt(2) / 4
    note = next(note for note in notes if note.startswith("holding the start against gravity needs"))
    torque = float(note.split("needs ")[1].split(" N·m")[0])
    assert abs(torque) == pytest.approx(expected, rel=1e-3) and "at joint joint3" in note
    assert f"{expected / 6:.3g} times its torque limit" in note


def test_a_start_outside_the_joint_limits_is_a_note(planar3):
    q0 = [7.0, 2.356, -2.356]  # joint1 beyond its URDF limit of 2π
    notes = start_notes(planar3, planar3.configuration(q0))
    assert notes == ["the start has joint joint1 at 7, outside its URDF limits [-6.283, 6.283]"]


def test_the_paper_start_raises_no_note(planar3):
    with warnings.catch_warnings():
        warnings.simplefilter("error", TorqueoptWarning)
        torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.01), np.radians([-45.0, 135.0, -135.0]))
