"""Gradient projection with the manipulability criterion on stacks: its kinematic-Hessian traces against Pinocchio's
Hessian, its closed-form curvature against the single state's (the same closed form) and against central and
five-point differences of the analytic gradient, and the batch against simulate."""

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.errors import SingularJacobian
from torqueopt.linalg import JacobianSolver
from torqueopt.resolvers.velocity.criteria import Manipulability
from torqueopt.resolvers.velocity.gradient_projection import (
    StackedGradientProjection,
    StackedManipulabilityGradient,
    hessian_traces,
    projected_gradient_steps,
)
from torqueopt.robot_copies import RobotForest
from torqueopt.tasks import FrameTask, Kinematics

from .conftest import PAPER_Q0
from .test_batch import _population, assert_same_run, batch_on_stacks
from .velocity_oracles import stacked_steps


def _states(robot, count, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.5, 1.5, (count, robot.nv)), rng.normal(size=(count, robot.nv))


def _robot(name, planar3, panda):
    return {"planar3": planar3, "panda": panda}.get(name) or torqueopt.load_robot(name, task="position")


def _stack(robot, gain=1.0, **options):
    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability", k=gain, **options)
    stacked = resolver.stack_rate_function(robot)
    assert isinstance(stacked, StackedManipulabilityGradient)
    return stacked


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_the_traces_of_the_kinematic_hessian_are_pinocchios_per_row(name, planar3, panda):
    """tr(W ∂J/∂q_k) from the forest's frame Jacobian columns against the same contraction of Pinocchio's
    ``getFrameKinematicHessian`` (LOCAL_WORLD_ALIGNED) of the task frame, row by row, for random W: planar3's xy
    task, panda's and baxter's position."""
    robot = _robot(name, planar3, panda)
    q, _ = _states(robot, 7, seed=11)
    weights = np.random.default_rng(12).normal(size=(7, robot.nv, robot.m))
    found = RobotForest(robot, copies=3).kinematics(q)
    stacked = _stack(robot)
    traces = hessian_traces(*stacked._frame_columns(found.jacobian), stacked._padded(weights))[0].T
    task, kinematics = FrameTask.of_robot(robot), Kinematics(robot)
    for row in range(7):
        kinematics.update(q[row])
        hessian = task.jacobian_derivative(kinematics)  # D[a, i, k] = ∂J_ai/∂q_k, Pinocchio's
        expected = np.einsum("ia,aik->k", weights[row], hessian)
        assert np.max(np.abs(traces[row] - expected)) <= 1e-13 * (1.0 + np.max(np.abs(expected)))


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_the_stacked_gradient_and_curvature_are_the_single_states(name, planar3, panda):
    """k ∂p/∂q of the stacked rates against :meth:`Manipulability.scaled_gradient` (Pinocchio's Hessian, Eigen's
    SVD) per row, and the stack's closed-form k∇²p q̇ against the single state's
    (:meth:`Manipulability.scaled_curvature`, the same formula on floats, with J⁺ by SVD where the stack's is
    JᵀG⁻¹): round-off apart (measured 3e-14 planar3, panda; 2e-12 baxter)."""
    robot = _robot(name, planar3, panda)
    q, v = _states(robot, 6, seed=2)
    forest, stacked = RobotForest(robot, copies=4), _stack(robot, gain=2.5)
    found = forest.kinematics(q)
    jacobian = found.jacobian[:, robot.task_rows]
    _, _, failures, state = stacked.rates(
        jacobian, np.zeros((6, robot.m)), q, found._replace(frame_jacobian=found.jacobian)
    )
    assert not failures
    _, _, shifted, _ = state
    moving = forest.kinematics(q, v, found.tip)
    moving = moving._replace(frame_rate=moving.rate)
    curvature = stacked.scaled_curvature(jacobian, moving.rate[:, robot.task_rows], v, state, moving)
    task, kinematics, criterion = FrameTask.of_robot(robot), Kinematics(robot), Manipulability()
    for row in range(6):
        kinematics.update(q[row])
        gradient = criterion.scaled_gradient(kinematics, task, 2.5)
        # shifted = J⁺c + k ∂p/∂q with c = 0
        assert np.max(np.abs(shifted[row] - gradient)) <= 1e-13 * np.max(np.abs(gradient))
        single = criterion.scaled_curvature(kinematics, task, v[row], 2.5)
        assert np.max(np.abs(curvature[row] - single)) <= 1e-11 * np.max(np.abs(single))


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_the_closed_form_curvature_is_the_rate_of_the_analytic_gradient(name, planar3, panda):
    """The single state's closed-form k∇²p q̇ against differences of the analytic gradient (Pinocchio's Hessian)
    along q̇: the central difference the single state took before (:meth:`Manipulability.differenced_curvature`,
    step 1e-5 rad, measured within 4e-10 of the term's size) at 2e-9, and a five-point difference (step 5e-4 rad,
    error O(δ⁴): measured within 1e-11) at 5e-11. With J⁺ from the caller's SVD and from the criterion's own."""
    robot = _robot(name, planar3, panda)
    q, v = _states(robot, 6, seed=2)
    task, kinematics, criterion = FrameTask.of_robot(robot), Kinematics(robot), Manipulability()
    solver = JacobianSolver(robot.m, robot.nv, 1e-6, null_space=False)
    for row in range(6):
        kinematics.update(q[row])
        closed = criterion.scaled_curvature(kinematics, task, v[row], 2.5)
        scale = np.max(np.abs(closed))
        solver.inverse_condition(task.jacobian(kinematics))
        decomposed = criterion.scaled_curvature(kinematics, task, v[row], 2.5, solver)
        assert np.max(np.abs(decomposed - closed)) <= 1e-13 * scale
        central = criterion.differenced_curvature(kinematics, task, v[row], 2.5)
        assert np.max(np.abs(central - closed)) <= 2e-9 * scale
        step = 5e-4 / np.linalg.norm(v[row])

        def gradient(offset, row=row):
            moved = Kinematics(robot).update(robot.integrate(q[row], offset * v[row]))
            return 2.5 * criterion.gradient(moved, task)

        five_point = (gradient(-2 * step) - 8 * gradient(-step) + 8 * gradient(step) - gradient(2 * step)) / (12 * step)
        assert np.max(np.abs(five_point - closed)) <= 5e-11 * scale


def test_a_pose_task_takes_the_central_difference(panda_pose):
    """The closed form covers position tasks; a pose task's curvature is the central difference."""
    task, criterion = FrameTask.of_robot(panda_pose), Manipulability()
    q, v = _states(panda_pose, 1, seed=4)
    kinematics = Kinematics(panda_pose).update(q[0])
    np.testing.assert_array_equal(
        criterion.scaled_curvature(kinematics, task, v[0], 2.0),
        criterion.differenced_curvature(kinematics, task, v[0], 2.0),
    )


@pytest.mark.parametrize(
    ("options", "ceilings", "stop"),
    [
        ({}, {"max_torque_ratio": 20.0}, "torque of joint"),
        ({}, {}, "torque of joint"),
        ({"k": 5.0, "position_gain": 3.0}, {"max_torque_ratio": 20.0}, "torque of joint"),
        ({"k": 0.5}, {"max_joint_speed": 2.0}, "speed of joint"),
        ({"singular_tolerance": 0.15}, {}, "task Jacobian is singular"),
        ({"position_gain": 3.0, "singular_tolerance": 0.1}, {"max_torque_ratio": 3.0}, "task Jacobian is singular"),
    ],
)
def test_the_batch_on_stacks_equals_simulate_on_planar3(planar3, options, ceilings, stop):
    """Random starts and directions plus the paper's movement, with the default gain and a given one, open and
    closed loop: the stacked Eq. (4) equals the kinematic loop run by run, through its stops, every array at 1e-9
    (q̈ and τ too). With the default ceilings (1000x torque) one movement whips past the elbow singularity
    (q2 ≈ 0.008) before its torque stop: there the stack's J⁺ = JᵀG⁻¹, whose round-off grows as cond(J)² where
    simulate's SVD's grows as cond(J), leaves q̇ 1.3e-9 from simulate's (measured): that case at 2e-9."""
    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability", **options)
    q0s, directions = _population(planar3, 8, seed=5)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.5) for d in directions]
    runs = batch_on_stacks(planar3, resolver, lines, q0s, **ceilings)
    singles = [torqueopt.simulate(planar3, resolver, line, q0, **ceilings) for line, q0 in zip(lines, q0s)]
    whipping = not options and not ceilings
    for run, single in zip(runs, singles):
        assert_same_run(run, single, 2e-9 if whipping else 1e-9)
    assert any(single.stop_reason and single.stop_reason.startswith(stop) for single in singles)
    assert any(single.stop_reason is None for single in singles)


@pytest.mark.parametrize("options", [{}, {"k": 3.0, "position_gain": 4.0}])
def test_the_batch_on_stacks_equals_simulate_on_panda(panda, options):
    """Seven joints, three task rows, gravity on: random lines from starts about the default configuration."""
    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability", **options)
    rng = np.random.default_rng(8)
    q0s = [panda.default_configuration + rng.normal(scale=0.3, size=panda.nv) for _ in range(4)]
    lines = [StraightLine(rng.normal(size=3), accel=0.5, duration=0.3) for _ in q0s]
    runs = batch_on_stacks(panda, resolver, lines, q0s)
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(panda, resolver, line, q0))


def test_what_the_manipulability_stack_leaves_to_one_movement_at_a_time(planar3, panda_pose):
    """A pose task and a callable criterion have no stacked form; the joint-limit criterion keeps its own."""
    manipulability = torqueopt.get_resolver("gradient-projection", criterion="manipulability")
    assert manipulability.stack_rate_function(panda_pose) is None
    squares = torqueopt.get_resolver("gradient-projection", criterion=lambda angles: float(angles @ angles))
    assert squares.stack_rate_function(planar3) is None
    joint_limits = torqueopt.get_resolver("gradient-projection")
    assert isinstance(joint_limits.stack_rate_function(planar3), StackedGradientProjection)
    default = manipulability.stack_rate_function(planar3)
    assert default.gain == 1.0 and default.m == 2  # the criterion's default gain, planar3's xy task


@pytest.fixture(scope="module")
def panda3():
    """panda with its last four joints locked and the ``xy`` task: a 2×3 Jacobian of a spatial chain."""
    return torqueopt.load_robot(
        "panda", task="xy", lock=["panda_joint4", "panda_joint5", "panda_joint6", "panda_joint7"]
    )


@pytest.mark.parametrize("options", [{}, {"k": 5.0, "position_gain": 3.0}])
def test_the_single_state_step_is_the_general_step(planar3, panda3, options):
    """The stacked form on a stack of one (the traces and their rates from the frame's J and J̇) against the
    single-state step, ``projected_gradient_steps`` (J⁺ by SVD, the traces from Pinocchio's kinematic Hessian):
    q̇ and σmin/σmax at 1e-12, q̈ at 1e-12, on planar3 and a spatial chain, and the same refusals in the same
    words (planar3 stretched, nearly stretched, and a cutoff that many states miss)."""
    rng = np.random.default_rng(21)
    for robot in (planar3, panda3):
        resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability", **options)
        task = FrameTask.of_robot(robot)
        fast, reference = stacked_steps(resolver, robot, task), resolver.step_functions(robot, task)
        assert reference[0].__qualname__.startswith("projected_gradient_steps")
        kinematics = Kinematics(robot)
        for _ in range(8):
            q, velocity = robot.default_configuration + rng.uniform(-1.0, 1.0, 3), rng.normal(size=3)
            command, command_rate = rng.normal(size=2), rng.normal(size=2)
            expected_rates, expected_condition = reference[0](kinematics.update(q), command)
            got_rates, got_condition = fast[0](kinematics.update(q), command)
            np.testing.assert_allclose(got_rates, expected_rates, rtol=0, atol=1e-12 * np.abs(expected_rates).max())
            assert got_condition == pytest.approx(expected_condition, rel=1e-12)
            expected = reference[1](kinematics.update(q), velocity, command, command_rate)
            got = fast[1](kinematics.update(q), velocity, command, command_rate)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    strict = torqueopt.get_resolver("gradient-projection", criterion="manipulability", singular_tolerance=0.4)
    cases = [(torqueopt.get_resolver("gradient-projection", criterion="manipulability"), np.zeros(3))]
    cases += [(strict, np.array([0.0, 1e-7, 0.0]))] + [(strict, rng.uniform(-2.0, 2.0, 3)) for _ in range(10)]
    task, kinematics, refused = FrameTask.of_robot(planar3), Kinematics(planar3), 0
    for resolver, q in cases:
        messages = []
        for rates in (
            stacked_steps(resolver, planar3, task)[0],
            projected_gradient_steps(planar3, task, resolver.singular_tolerance, resolver.objective, resolver.gain)[0],
        ):
            try:
                rates(kinematics.update(q), np.ones(2))
                messages.append(None)
            except SingularJacobian as error:
                messages.append(str(error))
        assert messages[0] == messages[1]
        refused += messages[0] is not None
    assert 3 <= refused < len(cases)


def test_the_batch_on_stacks_equals_simulate_on_a_spatial_chain(panda3):
    """Two task rows, three joints whose axes are not parallel, gravity on."""
    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability", k=3.0)
    rng = np.random.default_rng(7)
    q0s = [panda3.default_configuration + rng.normal(scale=0.3, size=3) for _ in range(4)]
    lines = [StraightLine(rng.normal(size=2), accel=0.5, duration=0.4) for _ in q0s]
    runs = batch_on_stacks(panda3, resolver, lines, q0s)
    singles = [torqueopt.simulate(panda3, resolver, line, q0) for line, q0 in zip(lines, q0s)]
    for run, single in zip(runs, singles):
        assert_same_run(run, single)
    assert all(single.completed for single in singles)
