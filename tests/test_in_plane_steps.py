"""The stacked forms of task priority and obstacle avoidance (the batch's) on a stack of one, on planar3's task,
against the single-state steps that ``simulate`` takes (SVDs, numpy, ``pseudoinverse_rate``): the same rates, q̈ and
σmin/σmax at each state, the same refusals, the same runs."""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import SingularJacobian
from torqueopt.resolvers.velocity.obstacle_avoidance import ObstacleAvoidance
from torqueopt.resolvers.velocity.task_priority import TaskPriority, below_one_task_steps
from torqueopt.tasks import FrameTask, Kinematics, ObstacleTask

from .conftest import PAPER_Q0
from .velocity_oracles import stacked_steps

ELBOW_TARGET = [0.5, -0.5]


def stacked_priority_steps(robot, task, lower, tolerance):
    """Task priority's stacked form below ``lower`` on a stack of one."""
    resolver = torqueopt.get_resolver("task-priority", secondary=lower, singular_tolerance=tolerance)
    resolver.check(robot)
    return stacked_steps(resolver, robot, task)


def _well_conditioned_priority(task, lower, kinematics) -> bool:
    """J away from singular (σmin/σmax >= 0.1) and J_l z (z spanning J's null space) at least 0.05 long: near
    either the rates grow as 1/σ, and so do both paths' round-off."""
    jacobian = task.jacobian(kinematics)
    null = np.cross(jacobian[0], jacobian[1])
    singular = np.linalg.svd(jacobian, compute_uv=False)
    return singular[-1] >= 0.1 * singular[0] and np.linalg.norm(lower.jacobian(kinematics).dot(null)) >= 0.05 * (
        np.linalg.norm(null)
    )


@pytest.mark.parametrize(
    "lower",
    [
        FrameTask("link3", "xy", target=ELBOW_TARGET, gain=2.0),
        FrameTask("link3", "xy"),  # no target: ẋ_l = 0
        FrameTask("link2", "xy", target=[0.3, 0.4], gain=0.5),
    ],
    ids=["elbow", "no-target", "link2"],
)
def test_task_priority_stacked_step_equals_the_general_one(planar3, rng, lower):
    """Rates, σmin/σmax and the closed-form q̈ of Eq. (11) below one xy frame task, on a stack of one, against
    below_one_task_steps (SVDs and the q̈ of accelerations_below_one_task) at random states: 1e-12."""
    task = FrameTask.of_robot(planar3)
    general = below_one_task_steps(planar3, task, lower, 1e-6)
    fast = stacked_priority_steps(planar3, task, lower, 1e-6)
    reference, kinematics = Kinematics(planar3), Kinematics(planar3)
    tested = 0
    while tested < 40:
        q = rng.uniform(-2.5, 2.5, 3)
        if not _well_conditioned_priority(task, lower, reference.update(q)):
            continue
        tested += 1
        command, command_rate = rng.normal(size=2), rng.normal(size=2)
        expected, expected_condition = general[0](reference.update(q), command)
        got, condition = fast[0](kinematics.update(q), command)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
        assert condition == pytest.approx(expected_condition, rel=1e-12)
        velocity = expected
        expected_acceleration = general[1](reference, velocity, command, command_rate)
        got_acceleration = fast[1](kinematics, velocity, command, command_rate)
        np.testing.assert_allclose(
            got_acceleration, expected_acceleration, rtol=0, atol=1e-12 * np.abs(expected_acceleration).max()
        )


def test_task_priority_stacked_step_drops_a_lower_task_the_null_space_cannot_move(planar3, rng):
    """Below the tip's own xy task, J_l(I − J⁺J) = 0: both paths drop it (q̇ = J⁺c and its derivative)."""
    task = FrameTask.of_robot(planar3)
    lower = FrameTask("tip", "xy", target=[1.0, 1.0], gain=3.0)
    general = below_one_task_steps(planar3, task, lower, 1e-6)
    fast = stacked_priority_steps(planar3, task, lower, 1e-6)
    reference, kinematics = Kinematics(planar3), Kinematics(planar3)
    for _ in range(10):
        q, command, command_rate = rng.uniform(-2, 2, 3), rng.normal(size=2), rng.normal(size=2)
        expected = general[0](reference.update(q), command)[0]
        got = fast[0](kinematics.update(q), command)[0]
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
        np.testing.assert_allclose(
            fast[1](kinematics, expected, command, command_rate),
            general[1](reference, expected, command, command_rate),
            rtol=0,
            atol=1e-11 * np.abs(expected).max(),
        )


def test_task_priority_stacked_step_refuses_a_singular_task_jacobian_as_the_svd_does(planar3):
    """The outstretched arm (q = 0): J has rank one, both paths raise SingularJacobian saying so."""
    task = FrameTask.of_robot(planar3)
    lower = FrameTask("link3", "xy", target=ELBOW_TARGET)
    for steps in (below_one_task_steps, stacked_priority_steps):
        rates, _ = steps(planar3, task, lower, 1e-6)
        with pytest.raises(SingularJacobian, match="task Jacobian is singular: smallest/largest singular value"):
            rates(Kinematics(planar3).update(np.zeros(3)), np.ones(2))


def test_task_priority_has_a_stacked_form_where_the_batch_has_one(planar3):
    """One frame task (xy or position) below the robot's task has a stacked form; two tasks and damping do not."""

    def stacked(robot, **options):
        resolver = torqueopt.get_resolver("task-priority", **options)
        resolver.check(robot)
        return stacked_steps(resolver, robot, FrameTask.of_robot(robot)) is not None

    assert stacked(planar3, secondary="link3:0.5,-0.5")
    assert stacked(planar3, secondary="link3:0.5,-0.5,0")
    assert not stacked(planar3, secondary="link3:0.5,-0.5;link2:0.1,0.2")
    assert not stacked(planar3, secondary="link3:0.5,-0.5", damping=0.01)


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_task_priority_runs_on_the_stacked_step_equal_those_on_the_general_one(planar3, monkeypatch, gain):
    """The paper's movement below the elbow's xy task, whole runs: the stacked form's (on a stack of one) q, q̇, q̈,
    τ and σmin/σmax against those of ``simulate``'s own step, below_one_task_steps, within round-off (1e-12 of each
    array's largest value)."""
    line = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
    options = {"secondary": "link3:0.5,-0.5", "position_gain": gain}
    general = torqueopt.simulate(planar3, "task-priority", line, PAPER_Q0, resolver_options=options)
    monkeypatch.setattr(TaskPriority, "step_functions", stacked_steps)
    fast = torqueopt.simulate(planar3, "task-priority", line, PAPER_Q0, resolver_options=options)
    assert (fast.stop_reason, len(fast.t)) == (general.stop_reason, len(general.t))
    for name in ("q", "v", "acceleration", "tau", "jacobian_inverse_condition"):
        got, expected = getattr(fast, name), getattr(general, name)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max(), err_msg=name)


def test_jacobian_time_variations_of_frames_and_joints_from_one_computation(planar3, panda, rng):
    """Kinematics.jacobian_time_variations: each frame's J̇ that of frame_jacobian_time_variation (bit for bit), each
    joint's a central difference of Pinocchio's joint Jacobian (world-aligned, at the joint's origin) along v."""

    pin.seed(int(rng.integers(2**31)))
    world_aligned = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for robot in (planar3, panda):
        model, kinematics = robot.model, Kinematics(robot)
        q, v = pin.randomConfiguration(model), rng.normal(size=robot.nv)
        frame_ids, joint_ids = (robot.frame_id, model.nframes - 1), (1, model.njoints - 1)
        frames, joints = kinematics.update(q).jacobian_time_variations(v, frame_ids, joint_ids)
        for frame_id, rate in zip(frame_ids, frames):
            np.testing.assert_array_equal(rate, kinematics.frame_jacobian_time_variation(frame_id, v))
        step = 1e-6
        for joint_id, rate in zip(joint_ids, joints):
            ahead = pin.getJointJacobian(model, kinematics.update(q + step * v).data, joint_id, world_aligned).copy()
            behind = pin.getJointJacobian(model, kinematics.update(q - step * v).data, joint_id, world_aligned)
            np.testing.assert_allclose(rate, (ahead - behind) / (2 * step), rtol=0, atol=1e-7)


def _obstacle_resolver(robot, center, radius, influence, critical):
    resolver = torqueopt.get_resolver(
        "obstacle-avoidance", obstacle=ObstacleTask(center, radius), influence=influence, critical=critical
    )
    resolver.check(robot)
    return resolver


def _well_conditioned_obstacle(resolver, task, kinematics) -> bool:
    """J away from singular (σmin/σmax >= 0.1) and, where the avoidance acts, b = J_o z at least 0.05 long."""
    jacobian = task.jacobian(kinematics)
    singular = np.linalg.svd(jacobian, compute_uv=False)
    if singular[-1] < 0.1 * singular[0]:
        return False
    obstacle = resolver.obstacle
    closest = obstacle.closest_point(kinematics)
    null = np.cross(jacobian[0], jacobian[1])
    return np.linalg.norm(obstacle.point_jacobian(kinematics, closest).dot(null)) >= 0.05 * np.linalg.norm(null)


def _acting_states_where_the_steps_agree(planar3, rng, draw_resolver, influence, own_rates):
    """Eight drawn obstacles, six well-conditioned states each: obstacle avoidance's stacked form (a stack of one)
    against its single-state step, general_step_functions (rates, σmin/σmax, q̈ at 1e-12; q̈ at the rates
    themselves if ``own_rates``, else at a random velocity). Returns how many states had the arm within ``influence`` of the obstacle."""
    task = FrameTask.of_robot(planar3)
    reference, kinematics = Kinematics(planar3), Kinematics(planar3)
    acting = 0
    for _ in range(8):
        resolver = draw_resolver()
        general = resolver.step_functions(planar3, task)
        fast = stacked_steps(resolver, planar3, task)
        tested = 0
        while tested < 6:
            q = rng.uniform(-2.5, 2.5, 3)
            if not _well_conditioned_obstacle(resolver, task, reference.update(q)):
                continue
            tested += 1
            acting += resolver.obstacle.clearance(reference) < influence
            command, command_rate, velocity = rng.normal(size=2), rng.normal(size=2), rng.normal(size=3)
            expected, expected_condition = general[0](reference.update(q), command)
            got, condition = fast[0](kinematics.update(q), command)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
            assert condition == pytest.approx(expected_condition, rel=1e-12)
            velocity = expected if own_rates else velocity
            expected_acceleration = general[1](reference, velocity, command, command_rate)
            got_acceleration = fast[1](kinematics, velocity, command, command_rate)
            np.testing.assert_allclose(
                got_acceleration, expected_acceleration, rtol=0, atol=1e-12 * np.abs(expected_acceleration).max()
            )
    return acting


@pytest.mark.parametrize(
    "influence, critical", [(3.0, 0.0), (0.5, 0.1), (0.05, 0.0)], ids=["activating", "paper", "mostly-off"]
)
def test_obstacle_avoidance_stacked_step_equals_the_general_one(planar3, rng, influence, critical):
    """Rates, σmin/σmax and the closed-form q̈ of Eq. (13), on a stack of one, against general_step_functions (SVDs, numpy
    and pseudoinverse_rate) at random states and obstacles, with the avoidance partly, fully and not acting: 1e-12."""

    def in_the_plane():
        return _obstacle_resolver(planar3, rng.uniform(-1.5, 1.5, 2), rng.uniform(0.0, 0.2), influence, critical)

    acting = _acting_states_where_the_steps_agree(planar3, rng, in_the_plane, influence, own_rates=True)
    assert acting > 0 and (influence > 0.05 or acting < 24)  # the avoidance acts at some states, not all


def test_obstacle_avoidance_stacked_step_refuses_a_singular_task_jacobian_as_the_svd_does(planar3):
    """The outstretched arm (q = 0): both paths raise SingularJacobian saying so."""
    resolver = _obstacle_resolver(planar3, [1.2, 0.3], 0.1, 0.5, 0.1)
    task = FrameTask.of_robot(planar3)
    for rates, _ in (resolver.step_functions(planar3, task), stacked_steps(resolver, planar3, task)):
        with pytest.raises(SingularJacobian, match="task Jacobian is singular: smallest/largest singular value"):
            rates(Kinematics(planar3).update(np.zeros(3)), np.ones(2))


def test_obstacle_avoidance_has_a_stacked_form_on_the_robots_position_task_only(planar3, panda):
    for robot, expected in ((planar3, True), (panda, panda.task != "pose")):
        resolver = _obstacle_resolver(robot, [1.2, 0.3, 0.0], 0.1, 0.5, 0.1)
        assert (stacked_steps(resolver, robot, FrameTask.of_robot(robot)) is not None) is expected


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_obstacle_avoidance_runs_on_the_stacked_step_equal_those_on_the_general_one(planar3, monkeypatch, gain):
    """The paper's movement past the CLI's obstacle (1.2, 0.3, r = 0.1), whole runs: the stacked form's (on a stack
    of one) q, q̇, q̈, τ and σmin/σmax against those of ``simulate``'s own step, general_step_functions, 1e-12 of each
    array's largest value."""
    line = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
    options = {"obstacle": "1.2,0.3,0,0.1", "position_gain": gain}
    general = torqueopt.simulate(planar3, "obstacle-avoidance", line, PAPER_Q0, resolver_options=options)
    monkeypatch.setattr(ObstacleAvoidance, "step_functions", stacked_steps)
    fast = torqueopt.simulate(planar3, "obstacle-avoidance", line, PAPER_Q0, resolver_options=options)
    assert (fast.stop_reason, len(fast.t)) == (general.stop_reason, len(general.t))
    for name in ("q", "v", "acceleration", "tau", "jacobian_inverse_condition"):
        got, expected = getattr(fast, name), getattr(general, name)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max(), err_msg=name)


def _support_columns(model, frame_id) -> np.ndarray:
    """(n,) ones at the columns of the joints that move the frame's body, zeros elsewhere."""
    columns = np.zeros(model.nv)
    for joint in model.supports[model.frames[frame_id].parentJoint]:
        if joint > 0:
            columns[model.idx_vs[joint] : model.idx_vs[joint] + model.nvs[joint]] = 1.0
    return columns


def test_world_jacobians_moved_to_a_frame_are_pinocchios_frame_jacobian_and_its_rate(planar3, panda, rng):
    """Kinematics.world_jacobians and world_jacobian_rates (views of Pinocchio's WORLD J and J̇ that hold the latest
    update) moved to a frame's origin p over the joints that move it, J_v + J_ω × p and
    J̇_v + J̇_ω × p + J_ω × ṗ, are getFrameJacobian and getFrameJacobianTimeVariation (LOCAL_WORLD_ALIGNED)."""
    for robot in (planar3, panda):
        model, kinematics = robot.model, Kinematics(robot)
        for frame in (model.getFrameId(robot.frame), model.getFrameId(model.frames[model.nframes // 2].name)):
            columns = _support_columns(model, frame)
            for _ in range(4):
                q, v = rng.uniform(-2.0, 2.0, model.nq), rng.normal(size=model.nv)
                world = kinematics.update(q).world_jacobians()
                assert world is kinematics.world_jacobians() and not world.flags.writeable
                expected = kinematics.frame_jacobian(frame)
                point = kinematics.frame_position(frame)
                moved = world * columns
                moved[:3] += np.cross(moved[3:].T, point).T
                np.testing.assert_allclose(moved, expected, rtol=0, atol=1e-12)
                rate = kinematics.world_jacobian_rates(v) * columns
                moved_rate = rate.copy()
                moved_rate[:3] += np.cross(rate[3:].T, point).T + np.cross(moved[3:].T, expected[:3].dot(v)).T
                expected_rate = kinematics.frame_jacobian_time_variation(frame, v)
                np.testing.assert_allclose(moved_rate, expected_rate, rtol=0, atol=1e-12)


def test_obstacle_avoidance_stacked_step_equals_the_general_one_off_the_plane(planar3, rng):
    """Spheres whose centre is off the arm's plane (z ≠ 0), so that n̂ has a z part: the stacked step's rates,
    σmin/σmax and q̈ against general_step_functions, 1e-12."""

    def off_the_plane():
        center = [*rng.uniform(-1.5, 1.5, 2), rng.uniform(-0.4, 0.4)]
        return _obstacle_resolver(planar3, center, rng.uniform(0.0, 0.1), 1.0, 0.1)

    acting = _acting_states_where_the_steps_agree(planar3, rng, off_the_plane, 1.0, own_rates=False)
    assert acting > 10


def test_closest_values_read_the_configuration_of_the_kinematics_given(planar3, panda, rng):
    """One obstacle read in turn through two Kinematics at different configurations: each call gives what a fresh
    obstacle (nothing kept from earlier calls) gives for that kinematics."""
    for robot in (planar3, panda):
        obstacle = ObstacleTask([0.4, 0.3, 0.2], 0.05)
        first, second = Kinematics(robot), Kinematics(robot)
        for _ in range(3):
            first.update(rng.uniform(-2.0, 2.0, robot.model.nq))
            second.update(rng.uniform(-2.0, 2.0, robot.model.nq))
            for kinematics in (first, second, first, second):
                expected = ObstacleTask([0.4, 0.3, 0.2], 0.05).closest_values(kinematics)
                assert obstacle.closest_values(kinematics) == expected


@pytest.mark.parametrize("stacked", [False, True], ids=["single-state", "stack-of-one"])
def test_obstacle_avoidance_step_reads_the_configuration_of_the_kinematics_given(planar3, rng, stacked):
    """One pair of the step's functions (``simulate``'s, or the stacked form's on a stack of one) read in turn
    through two Kinematics at different configurations (what it keeps, the views of a Kinematics' data and its
    values at a configuration, belong to the last one read): each call's rates, σmin/σmax and q̈ are what a fresh
    pair gives for that kinematics."""
    resolver = _obstacle_resolver(planar3, [1.2, 0.3], 0.1, 3.0, 0.0)
    task = FrameTask.of_robot(planar3)
    steps = stacked_steps if stacked else type(resolver).step_functions
    rates, acceleration = steps(resolver, planar3, task)
    first, second = Kinematics(planar3), Kinematics(planar3)
    for _ in range(3):
        for kinematics in (first, second):
            kinematics.update(rng.uniform(0.3, 2.5, 3) * (1.0, -1.0, 1.0))
        command, command_rate, velocity = rng.normal(size=2), rng.normal(size=2), rng.normal(size=3)
        for kinematics in (first, second, first, second):
            fresh_rates, fresh_acceleration = steps(resolver, planar3, task)
            expected, expected_condition = fresh_rates(kinematics, command)
            got, condition = rates(kinematics, command)
            assert got.tolist() == expected.tolist() and condition == expected_condition
            expected_acceleration = fresh_acceleration(kinematics, velocity, command, command_rate)
            assert acceleration(kinematics, velocity, command, command_rate).tolist() == expected_acceleration.tolist()


def test_the_stacked_step_takes_its_rates_again_for_another_command(planar3, rng):
    """q̈ asked for a command other than the one the rates were last given at that configuration: what a fresh pair
    gives after its rates for that command (the stack's state depends on the command)."""
    resolver = _obstacle_resolver(planar3, [1.2, 0.3], 0.1, 3.0, 0.0)
    task = FrameTask.of_robot(planar3)
    rates, acceleration = stacked_steps(resolver, planar3, task)
    kinematics = Kinematics(planar3).update(np.array([0.4, 1.2, -0.9]))
    command, other, command_rate, velocity = (
        rng.normal(size=2),
        rng.normal(size=2),
        rng.normal(size=2),
        rng.normal(size=3),
    )
    rates(kinematics, command)
    got = acceleration(kinematics, velocity, other, command_rate)
    fresh_rates, fresh_acceleration = stacked_steps(resolver, planar3, task)
    fresh_rates(kinematics, other)
    assert got.tolist() == fresh_acceleration(kinematics, velocity, other, command_rate).tolist()
    assert got.tolist() != fresh_acceleration(kinematics, velocity, command, command_rate).tolist()
