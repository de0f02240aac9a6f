"""The starts on other self-motion branches (torqueopt.optimal.branches): checked with Pinocchio's frame placement,
the joint limits and the shooting program's own rows."""

import numpy as np
import pytest

import torqueopt
from torqueopt.optimal import ShootingTranscription, weight_root
from torqueopt.optimal.branches import END_MARGIN, branch_starts, end_configurations
from torqueopt.paper import PAPER
from torqueopt.resolvers.null_space import torque_midpoint

pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def problem():
    robot = PAPER.load_robot()
    q0 = robot.configuration(PAPER.q0)
    line = torqueopt.StraightLine([1.0, 1.0], duration=0.4).anchored(robot.task_position(q0)[:2])
    nodes = np.linspace(0.0, 0.4, 21)
    return ShootingTranscription(
        robot, 0.4, 20, line.sample(nodes).position, q0, weight_root(robot), torque_midpoint(robot), joint_limits=True
    )


def _tip(robot, angles):
    return robot.frame_placement(robot.configuration(angles)).translation[robot.task_rows]


def test_end_configurations_reach_the_path_s_end_on_distinct_branches(problem):
    robot = problem.robot
    ends = end_configurations(problem, 4)
    lower, upper, _ = robot.joint_limits
    assert len(ends) == 4  # elbow up and down, and turns by 2π within the placeholder limits of ±2π
    for angles in ends:
        np.testing.assert_allclose(_tip(robot, angles), problem.reference[-1], atol=1e-10)
        assert np.all(angles >= lower + END_MARGIN) and np.all(angles <= upper - END_MARGIN)
    assert min(np.max(np.abs(a - b)) for i, a in enumerate(ends) for b in ends[:i]) > 0.3
    elbows = {bool(np.sin(angles[1]) > 0) for angles in ends}
    assert elbows == {True, False}


def test_branch_starts_follow_the_path_from_q0_at_rest_to_their_end(problem):
    robot = problem.robot
    starts = list(branch_starts(problem, count=4))
    ends = end_configurations(problem, 4)
    assert len(starts) >= 2  # a branch whose backward track fails (a singular knot) is left out
    for name, w in starts:
        end = ends[int(name.removeprefix("end branch ")) - 1]
        q, v, a = problem.split(w)
        np.testing.assert_array_equal(q[0], problem.q0)
        np.testing.assert_allclose(q[-1], end, atol=1e-9)
        assert np.all(v[0] == 0.0) and np.all(v[-1] == 0.0)
        for k in range(1, len(q)):
            np.testing.assert_allclose(_tip(robot, q[k]), problem.reference[k], atol=1e-10)
        np.testing.assert_allclose(v[1:] - v[:-1], problem.h * a, atol=1e-12)  # the program's velocity rows
