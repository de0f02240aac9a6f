"""Task priority below one frame task on stacks (``StackedPriorityBelowFrame``) against the kinematic loop, run by run."""

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.resolvers.velocity.task_priority import StackedPriorityBelowFrame, StackedPriorityBelowFrameInPlane
from torqueopt.robot_copies import RobotForest, point_kinematics, point_products
from torqueopt.tasks import FrameTask, ObstacleTask, PostureTask

from .conftest import PAPER_Q0
from .test_batch import (
    _assert_batch_equals_simulate_on_panda,
    _population,
    assert_stacks_equal_simulate,
)


def test_a_frame_task_below_has_a_stacked_form_and_the_rest_none(planar3):
    """One xy or position frame task below, undamped: stacked; a pose frame task, damping, a second task below a
    frame task or an obstacle task: one movement at a time (None)."""
    elbow = FrameTask("link3", "xy", target=[0.5, -0.5])
    for secondary in ("link3:0.5,-0.5", FrameTask("link3", "position"), elbow):
        resolver = torqueopt.get_resolver("task-priority", secondary=secondary)
        assert isinstance(resolver.stack_rate_function(planar3), StackedPriorityBelowFrameInPlane)
    for options in (
        {"secondary": FrameTask("link3", "pose")},
        {"secondary": elbow, "damping": 0.1},
        {"secondary": [elbow, PostureTask()]},
        {"secondary": [PostureTask(), elbow]},
        {"secondary": ObstacleTask.from_spec([1.2, 0.3, 0.0, 0.1])},
    ):
        assert torqueopt.get_resolver("task-priority", **options).stack_rate_function(planar3) is None, options


@pytest.mark.parametrize(
    "options",
    [
        {"secondary": "link3:0.5,-0.5"},
        # no target: ẋ_l = 0, the elbow held still as well as the freedom allows
        {"secondary": FrameTask("link3", "xy")},
        {"secondary": FrameTask("link3", "xy", target=[0.2, 0.9], gain=6.0), "position_gain": 4.0},
        {"secondary": FrameTask("link3", "position", target=[1.0, 0.5, 0.3], gain=2.0)},
        # the shoulder point link2 moves in the null space as z₁ ∝ sin q₃: at q₃ = 0 its A loses its rank
        {"secondary": FrameTask("link2", "xy", target=[-0.5, 0.8], gain=3.0)},
        # the tip itself (A round-off, every singular value dropped) and the base point (A exactly zero)
        {"secondary": "tip:1,1"},
        {"secondary": "link1:1,1"},
    ],
)
def test_task_priority_below_a_frame_task_on_stacks_equals_the_kinematic_loop(planar3, options):
    """Random starts and directions plus the paper's movement, 1 s: Eq. (11) below one frame task on stacks (the
    frame's kinematics from the forest, A⁺ of rank one, the closed-form q̈) equals the kinematic loop run by run."""
    resolver = torqueopt.get_resolver("task-priority", **options)
    q0s, directions = _population(planar3, 6, seed=9)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.0) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    assert any(single.stop_reason is None for single in singles)


def test_a_secondary_task_near_its_singularity_equals_the_kinematic_loop(planar3):
    """Movements that drive the elbow angle q₃ toward zero, where the null space stops moving the shoulder point
    link2 (A = J_l(I − J⁺J) = (J_l z)zᵀ with J_l z ∝ sin q₃, so A⁺ and the rates grow as 1/sin q₃): the stack
    follows the single-state code there and stops where it stops (the torques past 5 times their limits).

    Closer in (sin q₃ below about 0.03) the closed-form q̈ of both is only as good as the round-off of J⁺ allows,
    growing as a high power of 1/sin q₃, and the two part by more than 1e-9: the test stays outside."""
    resolver = torqueopt.get_resolver("task-priority", secondary=FrameTask("link2", "xy", target=[1.0, 0.0]))
    q0s = [[0.2, 0.9, 0.6], [0.4, 0.6, -0.5], [0.1, 1.2, 0.8], [0.3, 0.7, 0.4], [1.0, -0.5, -0.7], [0.0, 0.5, 1.0]]
    directions = [[-0.183, 0.541], [1.935, -0.27], [-0.244, 1.002], [-0.886, -0.292], [0.883, 0.58], [0.092, 0.67]]
    lines = [StraightLine(d, duration=1.0) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, max_torque_ratio=5.0)
    near = [single for single in singles if np.abs(np.sin(single.q[:, 2])).min() < 0.1]
    assert near and all(single.stop_reason.startswith("torque of joint") for single in near)
    assert any(single.stop_reason is None for single in singles)


@pytest.mark.parametrize(
    ("options", "ceilings", "stop"),
    [
        ({"singular_tolerance": 0.15}, {}, "task Jacobian is singular"),
        ({}, {"max_joint_speed": 2.0}, "speed of joint"),
        ({}, {"max_torque_ratio": 1.0}, "torque of joint"),
        ({"position_gain": 3.0, "singular_tolerance": 0.1}, {"max_torque_ratio": 3.0}, "task Jacobian is singular"),
    ],
)
def test_task_priority_below_a_frame_task_stops_where_the_kinematic_loop_does(planar3, options, ceilings, stop):
    """The elbow below the tip on stacks through each stop of the kinematic loop: J singular (no row recorded),
    the rates or the torques past a ceiling (the row kept)."""
    resolver = torqueopt.get_resolver("task-priority", secondary="link3:0.5,-0.5", **options)
    q0s, directions = _population(planar3, 8, seed=5)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.5) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, **ceilings)
    assert any(single.stop_reason and single.stop_reason.startswith(stop) for single in singles)
    assert any(single.stop_reason is None for single in singles)


@pytest.mark.parametrize(
    "options",
    [
        {"secondary": FrameTask("panda_link4", "position", target=[0.1, 0.2, 0.6], gain=2.0)},
        {"secondary": FrameTask("panda_link4", "xy"), "position_gain": 4.0},
        # panda_link3's origin is moved by the first two joints only: A = J_l(I − J⁺J) has rank two of three rows
        {"secondary": FrameTask("panda_link3", "position", target=[0.0, 0.3, 0.5], gain=3.0)},
    ],
)
def test_task_priority_below_a_frame_task_on_stacks_equals_the_kinematic_loop_on_panda(panda, options):
    """Seven joints, a position task: a null space of dimension 4, A⁺ by the SVD per row with the single-state
    code's cutoff."""
    resolver = torqueopt.get_resolver("task-priority", **options)
    assert isinstance(resolver.stack_rate_function(panda), StackedPriorityBelowFrame)
    _assert_batch_equals_simulate_on_panda(panda, resolver, seed=8, count=4, duration=0.3)


@pytest.mark.parametrize("redundancy", [1, 2])
@pytest.mark.parametrize("options", [{"secondary": "link3:0.5,-0.5"}, {"secondary": "tip:1,1", "position_gain": 3.0}])
def test_the_matrix_form_on_planar3_equals_the_kinematic_loop(planar3, options, redundancy):
    """The general form (A = J_l(I − J⁺J) and its pseudoinverse by the SVD, as panda takes it) on planar3, where
    the vector form of one degree of redundancy is the default: both equal the kinematic loop. With redundancy 1
    A⁺ is Aᵀ/‖A‖²_F, with 2 the SVD per row (the same cutoff decision on planar3's A of rank one)."""
    resolver = torqueopt.get_resolver("task-priority", **options)
    lower = resolver.stack.tasks[0]
    resolver.stack_rate_function = lambda robot: StackedPriorityBelowFrame(
        resolver.singular_tolerance, RobotForest(robot), lower, redundancy
    )
    q0s, directions = _population(planar3, 4, seed=9)
    lines = [StraightLine(d, duration=0.6) for d in directions]
    assert_stacks_equal_simulate(planar3, resolver, lines, q0s, max_torque_ratio=20.0)


@pytest.mark.parametrize(
    ("robot_name", "frame"), [("planar3", "link3"), ("panda", "panda_link4"), ("panda", "panda_hand")]
)
def test_point_products_are_the_point_jacobian_and_its_rate_times_vectors(robot_name, frame):
    """point_products' JX and J̇Y are point_kinematics' J and J̇ (held to Pinocchio's frame calls) times X and Y."""
    robot = torqueopt.load_robot(robot_name)
    forest = RobotForest(robot)
    rng = np.random.default_rng(2)
    q, v = rng.uniform(-2.0, 2.0, (5, robot.nv)), rng.normal(size=(5, robot.nv))
    vectors, rate_vectors = rng.normal(size=(5, robot.nv, 2)), rng.normal(size=(5, robot.nv, 3))
    moving = forest.kinematics(q, v, joints=True)
    frame_id = robot.model.getFrameId(frame)
    columns = forest.support_columns(robot.model.frames[frame_id].parentJoint)
    point = forest.frame_points(moving.joints, frame_id)
    jacobian, rate = point_kinematics(moving.joints, columns, point, v)
    products, rate_products = point_products(
        moving.joints, columns, point, vectors, rate_vectors, np.einsum("bij,bj->bi", jacobian[:, :3], v)
    )
    np.testing.assert_allclose(products, jacobian @ vectors, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rate_products, rate @ rate_vectors, rtol=0, atol=1e-12)
    assert point_products(moving.joints, columns, point, vectors)[1] is None


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
@pytest.mark.parametrize("count", [1, 16, 37])
def test_every_joints_placements_are_pinocchios_bit_for_bit(robot_name, count):
    """The joints' origins and rotations the forest gives (read into place from its passes, a last pass partly
    filled) are ``pin.forwardKinematics``' placements exactly, row 0 the universe's, every row its own state."""
    import pinocchio as pin

    robot = torqueopt.load_robot(robot_name)
    forest, data = RobotForest(robot), robot.model.createData()
    q = np.random.default_rng(3).uniform(-2.0, 2.0, (count, robot.nv))
    joints = forest.kinematics(q, np.ones_like(q), joints=True).joints
    assert joints.origins.shape == (count, robot.model.njoints, 3)
    assert joints.rotations.shape == (count, robot.model.njoints, 3, 3)
    for row in range(count):
        pin.forwardKinematics(robot.model, data, q[row])
        for joint in range(robot.model.njoints):
            assert np.array_equal(joints.origins[row, joint], data.oMi[joint].translation)
            assert np.array_equal(joints.rotations[row, joint], data.oMi[joint].rotation)
