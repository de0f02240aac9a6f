"""The paper's rest-to-rest straight line."""

import math

import numpy as np
import pytest

import torqueopt
from torqueopt import InvalidInput, StraightLine


def test_profile_is_rest_to_rest_with_constant_acceleration_halves():
    line = StraightLine([3.0, 4.0], accel=2.0, duration=1.5).anchored([1.0, -1.0])
    np.testing.assert_allclose(line.direction, [0.6, 0.8])
    assert line.length == pytest.approx(2.0 * 1.5**2 / 4)
    t = np.linspace(0.0, 1.5, 3001)
    sample = line.sample(t)
    np.testing.assert_allclose(sample.position[0], [1.0, -1.0])
    np.testing.assert_allclose(sample.position[-1], line.end)
    np.testing.assert_allclose(sample.velocity[[0, -1]], 0.0, atol=1e-12)
    speed = sample.velocity.dot(line.direction)
    assert speed.max() == pytest.approx(line.peak_speed)
    tangential = sample.acceleration.dot(line.direction)
    assert np.all(tangential[t < 0.75] == 2.0) and np.all(tangential[(t > 0.75) & (t < 1.5)] == -2.0)
    # Velocity is the derivative of position, acceleration that of velocity.
    dt = t[1] - t[0]
    # (central differences straddle the acceleration jump at T/2, hence 1e-3)
    np.testing.assert_allclose(np.gradient(sample.position[:, 0], dt)[1:-1], sample.velocity[1:-1, 0], atol=1e-3)
    np.testing.assert_allclose(np.gradient(speed, dt)[5:700], 2.0, atol=1e-6)


def test_reference_rests_after_the_end():
    line = StraightLine([1, 1, 0], duration=1.0).anchored([0, 0, 0])
    after = line.sample(np.array([1.0, 1.5]))
    np.testing.assert_allclose(after.position[1], line.end)
    np.testing.assert_allclose(after.velocity, 0.0)
    np.testing.assert_allclose(after.acceleration, 0.0)


def test_paper_default_acceleration_is_root_two():
    line = StraightLine([1, 1])
    assert line.accel == pytest.approx(math.sqrt(2.0)) and line.duration == 2.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"direction": [0, 0]}, r"direction \[0.0, 0.0\] is zero; give a non-zero direction"),
        ({"direction": [1, float("nan")]}, "must be 2 or 3 finite numbers"),
        ({"direction": [1, 2, 3, 4]}, "must be 2 or 3 finite numbers"),
        ({"direction": [1, 1], "duration": 0}, r"duration=0 must be a positive finite number \[s\]"),
        ({"direction": [1, 1], "duration": -2.0}, r"duration=-2.0 must be a positive finite number \[s\]"),
        ({"direction": [1, 1], "accel": float("inf")}, r"accel=inf must be a positive finite number \[m/s²\]"),
    ],
)
def test_bad_lines_are_rejected_with_the_value(kwargs, message):
    with pytest.raises(InvalidInput, match=message):
        StraightLine(**kwargs)


def test_the_step_starting_at_half_time_decelerates():
    line = StraightLine([1, 0], accel=2.0, duration=1.0).anchored([0, 0])
    before, middle = line.sample(np.array([0.5 - 1e-3, 0.5])).acceleration[:, 0]
    assert before == 2.0 and middle == -2.0


def test_a_huge_direction_is_a_direction_not_zero():
    """--direction 1e308,1e308 was reported as "[0.0, 0.0] is zero": its norm overflowed."""
    line = torqueopt.StraightLine((1e308, 1e308), duration=1.0)
    np.testing.assert_allclose(line.direction, [2**-0.5, 2**-0.5], rtol=1e-15)
    np.testing.assert_allclose(torqueopt.StraightLine((5e-324, 0.0), duration=1.0).direction, [1.0, 0.0])
