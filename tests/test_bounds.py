"""Work is bounded up front, every step that is simulated is a whole step, and a task is realisable."""

import numpy as np
import pytest

import torqueopt
from torqueopt import InvalidInput, StraightLine
from torqueopt.checks import bounded_count, step_count, task_ranks
from torqueopt.viewer.frames import frame_count, sample_frames

from .conftest import PAPER_Q0


def test_a_dt_that_does_not_divide_the_duration_is_refused_with_ones_that_do(planar3):
    line = StraightLine([1, 1], duration=2.0)
    with pytest.raises(InvalidInput, match=r"dt=0.3 s does not divide the duration 2 s") as error:
        torqueopt.simulate(planar3, "pinv", line, PAPER_Q0, dt=0.3)
    # Each dt the message offers divides the duration: the run ends exactly at T.
    offered = [float(text.split(" s (")[0]) for text in str(error.value).split("such as ")[1].split(" or ")]
    assert offered == pytest.approx([2 / 6, 2 / 7], rel=1e-5)
    result = torqueopt.simulate(planar3, "pinv", line, PAPER_Q0, dt=2 / 7)
    assert result.completed and len(result.t) == 8 and result.t[-1] == pytest.approx(2.0, abs=1e-12)


@pytest.mark.parametrize("dt", [0.001, 0.1, 0.002, 1 / 3])
def test_decimal_steps_that_divide_the_duration_are_accepted(dt):
    assert step_count(2.0, dt) == round(2.0 / dt)


def test_the_step_limit_is_checked_before_any_work(planar3):
    line = StraightLine([1, 1], duration=1e300)
    with pytest.raises(
        InvalidInput, match=r"needs 1e\+303 steps \(about .* of memory\), more than the limit of 1,000,000"
    ):
        torqueopt.simulate(planar3, "pinv", line, PAPER_Q0)
    with pytest.raises(InvalidInput, match="more than the limit of 99 steps"):
        torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.1), PAPER_Q0, max_steps=99)
    result = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.1), PAPER_Q0, max_steps=100)
    assert len(result.t) == 101


def test_bounded_count_refuses_huge_and_infinite_requests():
    assert bounded_count(10.0, 10, "it", "cells", "--max-cells") == 10
    for count in (11.0, float("inf"), float("nan")):
        with pytest.raises(InvalidInput, match=r"more than the limit of 10 cells \(raise it with --max-cells\)"):
            bounded_count(count, 10, "it", "cells", "--max-cells")


def test_playback_frames_are_bounded(short_run):
    assert frame_count(2.0, 1.0, 30.0) == 61
    with pytest.raises(InvalidInput, match=r"needs 6e\+10 frames, more than the limit of 100,000 frames"):
        frame_count(2.0, 1e-9, 30.0)
    with pytest.raises(InvalidInput, match="more than the limit of 5 frames"):
        sample_frames(short_run, fps=30.0, max_frames=5)


@pytest.fixture(scope="module")
def short_run(planar3):
    return torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.2), PAPER_Q0)


def test_the_final_row_is_a_state_with_no_torque(short_run):
    """The row at t = T holds where the arm ended up; no torque is applied from it,
    so it is NaN and never counts in the peaks."""
    assert short_run.t[-1] == pytest.approx(0.2)
    assert np.isnan(short_run.tau[-1]).all() and np.isfinite(short_run.tau[:-1]).all()
    np.testing.assert_allclose(short_run.peak_torque, np.abs(short_run.tau[:-1]).max(axis=0))
    assert np.isfinite(short_run.x[-1]).all() and np.isfinite(short_run.v[-1]).all()


def test_the_planar_arm_cannot_realise_a_3d_position(planar3):
    """Every joint of planar3 turns about z, so the z row of the Jacobian is
    zero at every configuration (closed form): position has rank 2, and the
    orientation adds only rotation about z (pose rank 3)."""
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = planar3.configuration(rng.uniform(-np.pi, np.pi, 3))
        jacobian6 = torqueopt.load_robot("planar3", task="pose").terms(q, np.zeros(3)).jacobian
        np.testing.assert_allclose(jacobian6[[2, 3, 4]], 0.0, atol=1e-12)
    assert task_ranks(planar3) == {"xy": 2, "position": 2, "pose": 3}
    with pytest.raises(InvalidInput, match="valid: task xy at this frame"):
        torqueopt.load_robot("planar3", task="position")


def test_a_frame_with_too_few_joints_above_it_is_refused():
    with pytest.raises(
        InvalidInput, match=r"frame 'panda_link3' of robot 'panda' can never be realised.*such as 'panda_hand'"
    ):
        torqueopt.load_robot("panda", frame="panda_link3", task="position")


def test_a_zero_weight_leaves_no_criterion_and_is_refused(planar3):
    resolver = torqueopt.get_resolver("weighted-null-space", weight=[0.0, 0.0, 0.0])
    with pytest.raises(InvalidInput, match="leaves no torque to minimise"):
        torqueopt.simulate(planar3, resolver, StraightLine([1, 1], duration=0.1), PAPER_Q0)
    # One positive weight is a criterion: it runs.
    resolver = torqueopt.get_resolver("weighted-null-space", weight=[0.0, 0.0, 1.0])
    assert torqueopt.simulate(planar3, resolver, StraightLine([1, 1], duration=0.1), PAPER_Q0).completed
