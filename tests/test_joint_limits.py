"""URDF joint position and velocity limits: the first time a run leaves them is reported, and read back."""

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.catalog import find_robot
from torqueopt.cli import main

PAPER_Q0 = np.radians([-45.0, 135.0, -135.0])
LIMITS = 'lower="-6.283185307179586" upper="6.283185307179586" effort="6.0" velocity="100.0"'


@pytest.fixture(scope="module")
def tight_arm(tmp_path_factory):
    """planar3 with joint3 limited to 0.3 rad/s and to [-2.4, -2.2] rad (it starts at -3π/4 = -2.356 rad)."""
    text = find_robot("planar3").urdf.read_text()
    assert LIMITS in text
    path = tmp_path_factory.mktemp("urdf") / "tight.urdf"
    path.write_text(text.replace(LIMITS, 'lower="-2.4" upper="-2.2" effort="6.0" velocity="0.3"'))
    return torqueopt.load_robot(str(path), frame="tip", task="xy", gravity=False)


@pytest.fixture(scope="module")
def run(tight_arm):
    return torqueopt.simulate(tight_arm, "pinv", StraightLine([1, 1], duration=1.0), PAPER_Q0)


def test_the_robot_reads_the_urdf_limits(tight_arm):
    lower, upper, velocity = tight_arm.joint_limits
    np.testing.assert_allclose(lower, [-2 * np.pi, -2 * np.pi, -2.4])
    np.testing.assert_allclose(upper, [2 * np.pi, 2 * np.pi, -2.2])
    np.testing.assert_allclose(velocity, [100.0, 100.0, 0.3])


def test_the_first_violations_are_the_first_rows_outside_the_limits(run):
    """Checked against a plain scan of the recorded arrays."""
    speed_row = next(k for k, v in enumerate(run.v[:, 2]) if abs(v) > 0.3)
    time, joint, value, limit = run.first_velocity_violation
    assert (time, joint) == (pytest.approx(run.t[speed_row]), "joint3")
    assert value == pytest.approx(run.v[speed_row, 2]) and abs(limit) == 0.3
    angle_row = next(k for k, q in enumerate(run.joint_angles[:, 2]) if not -2.4 <= q <= -2.2)
    time, joint, value, limit = run.first_position_violation
    assert (time, joint) == (pytest.approx(run.t[angle_row]), "joint3")
    assert limit in (-2.4, -2.2) and not -2.4 <= value <= -2.2
    # Before those rows, every joint was within its limits.
    assert (np.abs(run.v[:speed_row]) <= run.velocity_limit).all()


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_the_limits_and_violations_survive_the_files(run, tmp_path, suffix):
    back = torqueopt.load_result(run.to_csv(tmp_path / f"run{suffix}"))
    assert back.first_velocity_violation == pytest.approx(run.first_velocity_violation)
    assert back.first_position_violation[0] == pytest.approx(run.first_position_violation[0])
    assert back.first_position_violation[1] == run.first_position_violation[1]
    np.testing.assert_array_equal(back.velocity_limit, run.velocity_limit)
    assert back.summary()["first_velocity_violation"]["joint"] == "joint3"


def test_a_run_within_its_limits_reports_none(planar3):
    result = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), PAPER_Q0)
    assert result.first_position_violation is None and result.first_velocity_violation is None


def test_the_summary_reports_them_beside_the_torque_limits(tight_arm, capsys, tmp_path):
    urdf = tight_arm.source.urdf
    code = main(["run", "--robot", str(urdf), "--frame", "tip", "--task", "xy", "--no-gravity", "--resolver", "pinv",
                 "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1", "--duration", "1"])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert "first joint velocity limit exceeded: t = " in printed and "at joint joint3" in printed
    assert "first joint position limit exceeded: t = " in printed
