"""Obstacle avoidance on stacks (Eq. (12), Eq. (13)): the batch's stacked form against the kinematic loop, run by run."""

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.tasks import FrameTask, Kinematics, ObstacleTask, stacked_undamped_pseudoinverse, undamped_pseudoinverse

from .conftest import PAPER_Q0
from .test_batch import _population, assert_stacks_equal_simulate

#: The CLI's example obstacle (centre x, y, z and radius [m]), in reach of planar3's paper movement.
OBSTACLE = "1.2,0.3,0.0,0.1"


def _closest_segments(robot, obstacle, influence, run):
    """The segments the closest point is on at the run's rows within the influence distance (empty if none)."""
    kinematics = Kinematics(robot)
    segments = set()
    for q in run.q:
        closest = obstacle.closest_point(kinematics.update(q))
        if closest.clearance < influence:
            segments.add(closest.segment)
    return segments


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"position_gain": 4.0, "speed": 0.8},
        {"influence": 0.8, "critical": 0.3, "speed": 1.0},
    ],
)
def test_obstacle_avoidance_on_stacks_equals_the_kinematic_loop_on_planar3(planar3, options):
    """Movements that never come within the influence distance (α_h = 0: J⁺c alone), that pass inside it on one
    segment, and whose closest point passes from one segment to another within it (the columns of J_o gathered
    per row change), open loop and with the position feedback: the stacked Eq. (13) and its closed-form q̈ equal
    the kinematic loop run by run."""
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=OBSTACLE, **options)
    q0s, directions = _population(planar3, 12, seed=21)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.0) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    segments = [_closest_segments(planar3, resolver.obstacle, resolver.influence, single) for single in singles]
    assert any(not seen for seen in segments)  # never within the influence distance
    assert any(len(seen) == 1 for seen in segments)  # within it, on one segment
    assert any(len(seen) > 1 for seen in segments)  # within it, the closest point changing segment


@pytest.mark.parametrize(
    ("options", "ceilings", "stop"),
    [
        ({"singular_tolerance": 0.15}, {"max_torque_ratio": 5.0}, "task Jacobian is singular"),
        ({}, {"max_joint_speed": 2.0}, "speed of joint"),
        ({}, {"max_torque_ratio": 1.0}, "torque of joint"),
        ({"position_gain": 3.0, "singular_tolerance": 0.1}, {"max_torque_ratio": 3.0}, "task Jacobian is singular"),
    ],
)
def test_obstacle_avoidance_on_stacks_stops_where_the_kinematic_loop_does(planar3, options, ceilings, stop):
    """The stacked form stops each movement where the loop does, with its message: the method undefined (J
    singular), its rates past the speed ceiling, its torques past the torque ceiling; the others go on. A torque
    ceiling stops the movement that runs into the method's algorithmic singularity (‖J_o(I − J⁺J)‖ towards 0)
    before it gets there: there the problem itself amplifies round-off beyond 1e-9 (one ulp of q0 moves simulate's
    own q̈ by 1.3e-9 near its end)."""
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=OBSTACLE, **options)
    q0s, directions = _population(planar3, 8, seed=5)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.5) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, **ceilings)
    assert any(single.stop_reason and single.stop_reason.startswith(stop) for single in singles)
    assert any(single.stop_reason is None for single in singles)
    assert any(_closest_segments(planar3, resolver.obstacle, resolver.influence, single) for single in singles)


def test_an_obstacle_on_a_chain_ending_at_another_frame_on_stacks(planar3):
    """An obstacle task whose chain ends at another frame than the task's (link3, at joint 3's origin: the last
    segment has no length), placed from its joint's placement on stacks: the same runs as the loop."""
    obstacle = ObstacleTask([0.9, 0.4], 0.05, frame="link3")
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=obstacle, influence=0.6, critical=0.1)
    q0s, directions = _population(planar3, 6, seed=21)
    lines = [StraightLine(d, duration=1.0) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    assert any(_closest_segments(planar3, obstacle, resolver.influence, single) for single in singles)


@pytest.mark.parametrize(
    ("obstacle", "options", "count"),
    [
        (ObstacleTask([0.0, 0.0, 1.0], 0.05), {"influence": 0.3, "critical": 0.05}, 5),
        (ObstacleTask([0.5, -0.1, 0.6], 0.05, frame="panda_hand_tcp"), {}, 2),
    ],
    ids=["inner-segments", "tcp-chain"],
)
def test_obstacle_avoidance_on_stacks_equals_the_kinematic_loop_on_panda(panda, obstacle, options, count):
    """Seven joints, three task rows: [J_o(I − J⁺J)]⁺ of a 3×7 matrix of rank up to 3 by numpy's SVD with the
    single-state cutoff; movements beyond the influence distance and within it, the closest point on inner
    segments (on the last one, at the task point itself, J_o(I − J⁺J) = 0 and the term vanishes), and a chain
    that ends at the tool frame, beyond the task point. Movements that run into the method's algorithmic
    singularity (the smallest nonzero singular value of J_o(I − J⁺J) towards 0, torques a thousand times the
    limits) amplify the round-off by which two SVDs differ beyond 1e-9: these starts keep clear of it."""
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=obstacle, **options)
    rng = np.random.default_rng(3)
    q0s = [panda.default_configuration + rng.normal(scale=0.3, size=panda.nv) for _ in range(5)]
    lines = [StraightLine(rng.normal(size=3), accel=0.5, duration=0.3) for _ in q0s]
    singles = assert_stacks_equal_simulate(panda, resolver, lines[:count], q0s[:count])
    segments = [_closest_segments(panda, obstacle, resolver.influence, single) for single in singles]
    assert all(single.completed for single in singles)
    inner = {segment for seen in segments for segment in seen} - {len(obstacle.chain(panda.model, panda.frame)[0]) - 1}
    assert inner if obstacle.frame is None else any(segments)
    if obstacle.frame is None:
        assert any(not seen for seen in segments)


def test_a_pose_task_runs_one_movement_at_a_time(panda_pose, panda):
    """No closed-form q̈ on a pose task in the loop either: no stacked form."""
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=[0.4, 0.2, 0.5, 0.05])
    assert resolver.stack_rate_function(panda_pose) is None
    assert resolver.stack_rate_function(panda) is not None


def _rank_deficient(rng, count, rows, columns, rank):
    left = rng.normal(size=(count, rows, rank))
    right = rng.normal(size=(count, rank, columns))
    return left @ right * np.exp(rng.uniform(-3, 3, (count, 1, 1)))


def test_the_stacked_pseudoinverse_is_the_single_state_one(rng, planar3):
    """numpy's SVD with the single-state cutoff, on 3×7 matrices of every rank, and Aᵀ/‖A‖² on rank-one ones
    (J_o(I − J⁺J) of planar3 at random states among them), equal undamped_pseudoinverse per matrix; a matrix
    at the absolute cutoff or below gets zero."""
    for rank in range(4):
        matrices = _rank_deficient(rng, 20, 3, 7, rank)
        expected = np.array([undamped_pseudoinverse(matrix) for matrix in matrices])
        np.testing.assert_allclose(stacked_undamped_pseudoinverse(matrices), expected, rtol=1e-9, atol=1e-12)
    kinematics, task = Kinematics(planar3), FrameTask.of_robot(planar3)
    obstacle = ObstacleTask.from_spec([1.2, 0.3, 0.0, 0.1])
    projected = []
    for q in rng.uniform(-np.pi, np.pi, (20, 3)):
        kinematics.update(q)
        jacobian = task.jacobian(kinematics)
        point_jacobian = obstacle.point_jacobian(kinematics, obstacle.closest_point(kinematics))
        projected.append(point_jacobian @ (np.eye(3) - np.linalg.pinv(jacobian) @ jacobian))
    matrices = np.concatenate(
        [_rank_deficient(rng, 20, 3, 3, 1), projected, np.zeros((1, 3, 3)), [1e-11 * np.eye(3)[:, :1] * np.ones(3)]]
    )
    expected = np.array([undamped_pseudoinverse(matrix) for matrix in matrices])
    for rank_one in (False, True):
        found = stacked_undamped_pseudoinverse(matrices, rank_one=rank_one)
        np.testing.assert_allclose(found, expected, rtol=1e-9, atol=1e-12)
    assert not stacked_undamped_pseudoinverse(matrices[-2:], rank_one=True).any()


@pytest.mark.parametrize(
    ("robot_name", "options"),
    [
        ("planar3", {"obstacle": OBSTACLE}),
        ("panda", {"obstacle": ObstacleTask([0.0, 0.0, 1.0], 0.05), "influence": 0.6, "critical": 0.2}),
    ],
)
def test_the_stacked_rates_and_acceleration_are_the_single_state_step_row_by_row(robot_name, options, request, rng):
    """At random states, the stack's q̇ of Eq. (13) and its q̈ (the homogeneous term computed on every row, rows
    last, and added with α_h and α̇_h) equal the single-state step's row by row: rows beyond the influence (J⁺c
    and its rate alone), between it and the critical clearance, and within that (α_h = 1)."""
    from torqueopt.robot_copies import RobotForest

    robot = request.getfixturevalue(robot_name)
    resolver = torqueopt.get_resolver("obstacle-avoidance", **options)
    stack = resolver.stack_rate_function(robot)
    rates, acceleration = resolver.step_functions(robot, FrameTask.of_robot(robot))
    count = 60
    q = np.array([robot.configuration(rng.uniform(-np.pi, np.pi, robot.nv)) for _ in range(count)])
    command, command_rate = rng.normal(size=(count, robot.m)), rng.normal(size=(count, robot.m))
    forest, rows = RobotForest(robot), robot.task_rows
    still = forest.kinematics(q, joints=True)
    jacobian = still.jacobian[:, rows]
    velocity, conditions, failures, state = stack.rates(jacobian, command, q, still)
    moving = forest.kinematics(q, velocity, joints=True)
    found = stack.acceleration(jacobian, moving.rate[:, rows], velocity, command_rate, state, moving)
    kinematics, gains = Kinematics(robot), []
    for row in range(count):
        if row in failures:
            continue
        kinematics.update(q[row])
        expected, condition = rates(kinematics, command[row])
        np.testing.assert_allclose(velocity[row], expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
        assert conditions[row] == pytest.approx(condition, rel=1e-9)
        expected = acceleration(kinematics, velocity[row], command[row], command_rate[row])
        np.testing.assert_allclose(found[row], expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max())
        clearance = resolver.obstacle.closest_point(kinematics).clearance
        gains.append(0.0 if clearance >= resolver.influence else 1.0 if clearance <= resolver.critical else 0.5)
    assert {0.0, 0.5, 1.0} <= set(gains)
