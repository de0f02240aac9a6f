"""The atlas verdict ``joint limits`` and its columns, against a plain scan of the run's samples."""

import math

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.atlas.verdicts import VERDICTS, Thresholds, run_row, self_motion_energy
from torqueopt.catalog import find_robot

from .conftest import PAPER_Q0

LIMITS = 'lower="-6.283185307179586" upper="6.283185307179586" effort="6.0" velocity="100.0"'


@pytest.fixture(scope="module")
def tight_arm(tmp_path_factory):
    """planar3 with joint3 limited to 0.3 rad/s and to [-2.4, -2.2] rad (it starts at -3π/4 = -2.356 rad)."""
    text = find_robot("planar3").urdf.read_text()
    path = tmp_path_factory.mktemp("urdf") / "tight.urdf"
    path.write_text(text.replace(LIMITS, 'lower="-2.4" upper="-2.2" effort="6.0" velocity="0.3"'))
    return torqueopt.load_robot(str(path), frame="tip", task="xy", gravity=False)


def _row(robot, result):
    kinetic, self_motion = self_motion_energy(robot, result)
    return run_row(result, kinetic, self_motion, float(np.nanmax(result.torque_ratio)), Thresholds())


def _first_outside(values, lower, upper, times, names):
    """(time, joint) of the first sample outside [lower, upper], by a plain loop."""
    for row, sample in enumerate(values):
        for joint, value in enumerate(sample):
            if not lower[joint] <= value <= upper[joint]:
                return times[row], names[joint]
    return math.nan, None


def test_a_run_that_leaves_its_joint_limits_has_its_own_verdict(tight_arm):
    result = torqueopt.simulate(tight_arm, "pinv", StraightLine([1, 1], duration=1.0), PAPER_Q0)
    row = _row(tight_arm, result)
    assert "joint limits" in VERDICTS
    assert not row["unstable"] and row["verdict"] == "joint limits"
    lower, upper, velocity = tight_arm.joint_limits
    names = tight_arm.joint_names
    assert (row["first_position_limit_violation"], row["position_limit_joint"]) == pytest.approx(
        _first_outside(result.joint_angles, lower, upper, result.t, names)
    )
    assert (row["first_velocity_limit_violation"], row["velocity_limit_joint"]) == pytest.approx(
        _first_outside(result.v, -velocity, velocity, result.t, names)
    )
    assert row["position_limit_joint"] == row["velocity_limit_joint"] == "joint3"


def test_a_run_within_its_joint_limits_has_nan_and_none(planar3):
    result = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), PAPER_Q0)
    row = _row(planar3, result)
    assert row["verdict"] == "stable"
    assert math.isnan(row["first_position_limit_violation"]) and math.isnan(row["first_velocity_limit_violation"])
    assert row["position_limit_joint"] is None and row["velocity_limit_joint"] is None


def test_whiplash_stays_whiplash_and_keeps_the_joint_limit_columns(planar3):
    """The paper's long movement: null-space whips (and passes 100 rad/s, planar3's velocity limit, or not)."""
    result = torqueopt.simulate(planar3, "null-space", StraightLine([1, 1], duration=2.0), PAPER_Q0)
    pinv = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=2.0), PAPER_Q0)
    kinetic, self_motion = self_motion_energy(planar3, result)
    row = run_row(result, kinetic, self_motion, float(np.nanmax(pinv.torque_ratio)), Thresholds())
    assert row["verdict"] == "whiplash"
    expected = result.first_velocity_violation
    assert row["velocity_limit_joint"] == (None if expected is None else expected[1])
