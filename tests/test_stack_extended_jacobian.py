"""Baillieul's extended Jacobian on stacks (``StackedExtendedJacobian``) against the kinematic loop, run by run,
and its pieces against the single-state step's."""

import numpy as np
import pytest

import torqueopt
from torqueopt import Circle, StraightLine
from torqueopt.errors import SingularJacobian
from torqueopt.resolvers.velocity import PostureDistance
from torqueopt.resolvers.velocity.extended_jacobian import (
    StackedExtendedJacobian,
    null_vector,
    signed_cofactors,
    signed_cofactors_rate,
    stacked_row_cofactors,
)
from torqueopt.robot_copies import RobotForest
from torqueopt.tasks import FrameTask, Kinematics, PostureTask

from .conftest import PAPER_Q0
from .test_batch import assert_stacks_equal_simulate
from .test_kinematic import assert_stacked_step_is_the_lu_reference
from .velocity_oracles import stacked_steps


@pytest.fixture(scope="module")
def panda4():
    """panda with its last three joints locked: four joints for the three rows of the position task (n − m = 1)."""
    return torqueopt.load_robot("panda", lock=["panda_joint5", "panda_joint6", "panda_joint7"])


def _planar_movements(count, seed, duration):
    rng = np.random.default_rng(seed)
    q0s = [*rng.uniform(-np.pi, np.pi, (count, 3)), PAPER_Q0, PAPER_Q0]
    lines = [StraightLine(direction, duration=duration) for direction in rng.normal(size=(count, 2))]
    # the paper's line, and the circle toward the base whose surface G = G(q0) folds (test_kinematic.py)
    return [*lines, StraightLine([1, 1], duration=duration), Circle(0.3, duration)], q0s


@pytest.mark.parametrize(
    ("options", "ceilings", "stops"),
    [
        ({}, {}, ("extended Jacobian is singular (an algorithmic singularity", "torque of joint")),
        ({}, {"max_joint_speed": 2.0}, ("speed of joint",)),
        ({"singular_tolerance": 0.2, "position_gain": 4.0}, {"max_torque_ratio": 2.0}, ("task Jacobian is singular",)),
        ({"algorithmic_tolerance": 0.3}, {}, ("extended Jacobian is singular (an algorithmic singularity",)),
    ],
)
def test_the_stack_equals_the_kinematic_loop_on_planar3(planar3, options, ceilings, stops):
    """Random lines, the paper's and a circle, through each of the loop's stops: J_ex singular (the alignment
    below its cutoff), J singular, the rates and the torques past their ceilings."""
    resolver = torqueopt.get_resolver("extended-jacobian", **options)
    lines, q0s = _planar_movements(8, seed=5, duration=1.5)
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, **ceilings)
    reasons = [single.stop_reason or "" for single in singles]
    for stop in stops:
        assert any(reason.startswith(stop) for reason in reasons), (stop, reasons)
    assert any(single.completed for single in singles)


def test_the_stack_stops_at_the_fold_as_the_loop_does(planar3):
    """At 5 ms the circle's run reaches the fold within one step (test_kinematic.py): the stage's refusal."""
    lines = [Circle(0.3, 2.0), StraightLine([0.3, -1.0], duration=2.0)]
    singles = assert_stacks_equal_simulate(planar3, "extended-jacobian", lines, [PAPER_Q0, [0.3, 1.4, -1.0]], dt=0.005)
    assert singles[0].stop_reason.startswith("extended Jacobian is singular (an algorithmic singularity")
    assert singles[1].completed


def test_the_stack_equals_the_kinematic_loop_with_a_posture_criterion(planar3):
    """G of Eq. (14) with p = ½‖q − q*‖² (its Hessian the identity), toward a posture. At 2e-9: one run ends in
    torques of 23,000 N·m, where τ from ``simulate``'s curvature by a central difference (round-off about 1e-10 of
    q̈) is 1.2e-9 relative from the stack's closed form (measured)."""
    resolver = torqueopt.get_resolver(
        "extended-jacobian", criterion=PostureDistance(PostureTask(target=[0.5, 1.2, -0.8]))
    )
    assert isinstance(resolver.stack_rate_function(planar3), StackedExtendedJacobian)
    lines, q0s = _planar_movements(4, seed=9, duration=1.0)
    assert_stacks_equal_simulate(planar3, resolver, lines, q0s, tolerance=2e-9)


@pytest.mark.parametrize("options", [{}, {"position_gain": 4.0}])
def test_the_stack_equals_the_kinematic_loop_on_panda_with_four_joints(panda4, options):
    """Three task rows, four joints, gravity on: J_ex is 4×4 (its cofactors from 3×3 determinants), the loop's
    step the general LU one."""
    resolver = torqueopt.get_resolver("extended-jacobian", **options)
    rng = np.random.default_rng(3)
    q0s = [panda4.default_configuration + rng.normal(scale=0.3, size=panda4.nv) for _ in range(4)]
    lines = [StraightLine(rng.normal(size=3), accel=0.5, duration=0.4) for _ in q0s]
    assert_stacks_equal_simulate(panda4, resolver, lines, q0s)


def test_the_stack_is_for_what_it_can_compute(planar3, panda_pose):
    """A callable criterion (derivatives by differences of its values), the pose task and a robot whose joints
    do not add: one movement at a time."""
    assert torqueopt.get_resolver("extended-jacobian").stack_rate_function(planar3) is not None
    callable_criterion = torqueopt.get_resolver("extended-jacobian", criterion=lambda angles: float(angles[0] ** 2))
    assert callable_criterion.stack_rate_function(planar3) is None
    assert torqueopt.get_resolver("extended-jacobian").stack_rate_function(panda_pose) is None
    kinova = torqueopt.load_robot("kinova", lock=["j2s6s200_joint_2", "j2s6s200_joint_3"])
    assert kinova.redundancy == 1 and not kinova.euclidean
    assert torqueopt.get_resolver("extended-jacobian").stack_rate_function(kinova) is None


def test_the_stacked_null_vectors_and_cofactors_are_their_definitions(rng):
    """:func:`null_vector` of a stack and of each of its matrices against the adjugate det(M)·M⁻¹ of M = [J; l]
    (its last column is (−1)^m n), and ``stacked_row_cofactors`` against its first m columns, for m = 2 (cross
    products) and m = 3 (determinants)."""
    for m in (2, 3):
        jacobian, last = rng.normal(size=(5, m, m + 1)), rng.normal(size=(5, m + 1))
        normals = null_vector(jacobian)
        cofactors = stacked_row_cofactors(jacobian, last)
        for row in range(5):
            np.testing.assert_allclose(normals[row], null_vector(jacobian[row]), rtol=0, atol=1e-14)
            matrix = np.vstack([jacobian[row], last[row]])
            adjugate = np.linalg.det(matrix) * np.linalg.inv(matrix)
            np.testing.assert_allclose(cofactors[row].T, adjugate[:, :m], rtol=0, atol=1e-12)
            np.testing.assert_allclose((-1.0) ** m * normals[row], adjugate[:, m], rtol=0, atol=1e-12)


def _lanes_kinematics(forest, robot, q, v=None, tip=None):
    """The forest's kinematics as the batch's lanes hand them to a stack: the task's rows, the frame's whole J, J̇."""
    found = forest.kinematics(q, v, tip)
    rows = robot.task_rows
    return found._replace(
        jacobian=found.jacobian[:, rows], rate=None if v is None else found.rate[:, rows],
        frame_jacobian=found.jacobian, frame_rate=found.rate,
    )  # fmt: skip


def _stacked_step(robot, resolver, q, command, command_rate):
    """The stack's (q̇, σmin/σmax, failures) and q̈ (at its q̇) at the rows of q, through the forest as the batch calls it."""
    stack, forest = resolver.stack_rate_function(robot), RobotForest(robot)
    found = _lanes_kinematics(forest, robot, q)
    velocity, conditions, failures, state = stack.rates(found.jacobian, command, q, found)
    moving = _lanes_kinematics(forest, robot, q, velocity, found.tip)
    acceleration = stack.acceleration(found.jacobian, moving.rate, velocity, command_rate, state, moving)
    return velocity, conditions, failures, acceleration


@pytest.mark.parametrize("name", ["planar3", "panda4"])
def test_the_stacked_step_is_the_single_state_one(name, planar3, panda4, rng):
    """At random states: q̇ and σmin/σmax at 1e-12 of the single-state step's (the LU reference, whose row comes
    from Pinocchio's kinematic Hessian), the same refusals in the same words (a strict alignment cutoff that many
    states miss, and planar3 stretched), and q̈ at 1e-9 (the reference's curvature is the row's central difference,
    whose round-off is about 1e-10 of q̈)."""
    robot = {"planar3": planar3, "panda4": panda4}[name]
    for options in ({}, {"algorithmic_tolerance": 0.3}):
        resolver = torqueopt.get_resolver("extended-jacobian", **options)
        rates, acceleration = resolver.lu_step_functions(robot, FrameTask.of_robot(robot))
        q = rng.uniform(-2.0, 2.0, (24, robot.nv))
        if robot is planar3:
            q[0] = [0.0, 1e-9, 0.0]
        command, command_rate = rng.normal(size=(24, robot.m)), rng.normal(size=(24, robot.m))
        velocity, conditions, failures, accelerations = _stacked_step(robot, resolver, q, command, command_rate)
        kinematics, refused = Kinematics(robot), 0
        for row in range(q.shape[0]):
            try:
                expected, condition = rates(kinematics.update(q[row]), command[row])
            except SingularJacobian as error:
                assert failures.get(row) == str(error)
                refused += 1
                continue
            assert row not in failures
            np.testing.assert_allclose(velocity[row], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
            assert conditions[row] == pytest.approx(condition, rel=1e-12)
            expected = acceleration(kinematics, velocity[row], command[row], command_rate[row])
            np.testing.assert_allclose(accelerations[row], expected, rtol=0, atol=1e-9 * np.abs(expected).max())
        assert refused >= (2 if options else 1) and refused < q.shape[0] - 8


def test_the_closed_form_curvature_is_a_five_point_difference_of_the_row(planar3, panda4, rng):
    r""":math:`\dot q^\top\nabla^2 G\,\dot q` of the stack's q̈ along any q̇ (read back through J_ex: a command
    rate of :math:`\dot J\dot q` leaves :math:`J_{ex}\ddot q = [0;\ -\dot q^\top\nabla^2 G\,\dot q]`) against a
    five-point difference of the single-state row :math:`\partial G/\partial q\cdot\dot q` (from Pinocchio's
    kinematic Hessian) along q̇, step 1e-3 rad (truncation and round-off near 1e-12), at 1e-10 of its scale."""
    for robot in (planar3, panda4):
        resolver, task = torqueopt.get_resolver("extended-jacobian"), FrameTask.of_robot(robot)
        stack, forest = resolver.stack_rate_function(robot), RobotForest(robot)
        kinematics, tested = Kinematics(robot), 0
        while tested < 6:
            q, velocity = rng.uniform(-2.0, 2.0, robot.nv), rng.normal(size=robot.nv)
            found = _lanes_kinematics(forest, robot, q[None])
            jacobian = found.jacobian
            _, _, failures, state = stack.rates(jacobian, np.zeros((1, robot.m)), q[None], found)
            if failures:
                continue
            tested += 1
            moving = _lanes_kinematics(forest, robot, q[None], velocity[None], found.tip)
            rate = moving.rate
            drift = np.einsum("bij,bj->bi", rate, velocity[None])
            acceleration = stack.acceleration(jacobian, rate, velocity[None], drift, state, moving)[0]
            _, row, _ = resolver.extended_row(kinematics.update(q), task)
            np.testing.assert_allclose(task.jacobian(kinematics).dot(acceleration), 0.0, atol=1e-12)
            got = -row.dot(acceleration)

            def slope(s, q=q, velocity=velocity):
                return resolver.extended_row(kinematics.update(q + s * velocity), task)[1].dot(velocity)

            h = 1e-3 / np.linalg.norm(velocity)
            expected = (-slope(2 * h) + 8 * slope(h) - 8 * slope(-h) + slope(-2 * h)) / (12 * h)
            scale = np.abs(row).max() * velocity.dot(velocity) + abs(expected)
            assert abs(got - expected) <= 1e-10 * scale, (got, expected)


def test_the_signed_cofactors_and_their_rate_are_their_definitions(rng):
    """``signed_cofactors`` of A against (−1)^m (−1)^(r+c) det(A without row r and column c) by LAPACK, and
    ``signed_cofactors_rate`` against a five-point difference of it along A + sȦ, for n = 3 (the cross products on
    floats) and n = 4, 5, 7 (the minors), A singular included (two equal columns: G = 0)."""
    for n in (3, 4, 5, 7):
        for singular in (False, True):
            matrix, rate = rng.normal(size=(n, n)), rng.normal(size=(n, n))
            if singular:
                matrix[:, 1] = matrix[:, 2]
            expected = np.array(
                [
                    [
                        (-1.0) ** (n - 1 + r + c) * np.linalg.det(np.delete(np.delete(matrix, r, 0), c, 1))
                        for c in range(n)
                    ]
                    for r in range(n)
                ]
            )
            np.testing.assert_allclose(signed_cofactors(matrix), expected, rtol=0, atol=1e-12 * np.abs(expected).max())
            h = 1e-3

            def along(s, matrix=matrix, rate=rate):
                return signed_cofactors(matrix + s * rate)

            difference = (8 * (along(h) - along(-h)) - (along(2 * h) - along(-2 * h))) / (12 * h)
            got = signed_cofactors_rate(matrix, rate)
            np.testing.assert_allclose(got, difference, rtol=0, atol=1e-9 * np.abs(difference).max())


def test_the_closed_form_curvature_of_the_single_state_step_is_a_five_point_difference(planar3, panda4, rng):
    r""":meth:`ExtendedJacobian.closed_curvature` (the cofactors' rates, the frame Jacobian's columns and rates)
    against a five-point difference of the row :math:`\partial G/\partial q\cdot\dot q` from Pinocchio's kinematic
    Hessian along q̇ (step 1e-3 rad, truncation near 1e-12) at 1e-10 of its scale, and against
    :meth:`ExtendedJacobian.differenced_curvature` (central, 1e-5 rad: round-off near 1e-10) at 1e-9, for the joint
    limits and a posture's distance; J̇ is Pinocchio's."""
    for robot in (planar3, panda4):
        task, kinematics = FrameTask.of_robot(robot), Kinematics(robot)
        posture = PostureDistance(PostureTask(target=rng.uniform(-1.0, 1.0, robot.nv)))
        for criterion in ("joint-limits", posture):
            resolver = torqueopt.get_resolver("extended-jacobian", criterion=criterion)
            for _ in range(6):
                q, velocity = rng.uniform(-2.0, 2.0, robot.nv), rng.normal(size=robot.nv)
                jacobian_rate, got = resolver.closed_curvature(kinematics.update(q), task, velocity)
                np.testing.assert_array_equal(jacobian_rate, task.jacobian_rate(kinematics, velocity))
                differenced = resolver.differenced_curvature(kinematics, task, velocity)
                row = resolver.extended_row(kinematics, task)[1]

                def slope(s, q=q, velocity=velocity, resolver=resolver):
                    return resolver.extended_row(kinematics.update(q + s * velocity), task)[1].dot(velocity)

                h = 1e-3 / np.linalg.norm(velocity)
                expected = (-slope(2 * h) + 8 * slope(h) - 8 * slope(-h) + slope(-2 * h)) / (12 * h)
                scale = np.abs(row).max() * velocity.dot(velocity) + abs(expected)
                assert abs(got - expected) <= 1e-10 * scale, (got, expected)
                assert abs(got - differenced) <= 1e-9 * scale, (got, differenced)


@pytest.mark.parametrize("gain", [0.0, 2.0])
def test_the_single_state_step_is_the_lu_reference_on_four_joints(panda4, rng, gain):
    """panda4's stacked form on a stack of one (the curvature in closed form) against its single-state step,
    ``lu_step_functions`` (Pinocchio's kinematic Hessian, the curvature by its central difference); a callable
    criterion has no stacked form."""
    resolver, task = torqueopt.get_resolver("extended-jacobian", position_gain=gain), FrameTask.of_robot(panda4)
    fast, reference = stacked_steps(resolver, panda4, task), resolver.step_functions(panda4, task)
    kinematics, tested = Kinematics(panda4), 0
    while tested < 8:
        q, velocity = rng.uniform(-2.0, 2.0, panda4.nv), rng.normal(size=panda4.nv)
        command, command_rate = rng.normal(size=panda4.m), rng.normal(size=panda4.m)
        try:
            expected_rates, condition = reference[0](kinematics.update(q), command)
        except SingularJacobian:
            continue
        tested += 1
        got_rates, got_condition = fast[0](kinematics, command)
        np.testing.assert_allclose(got_rates, expected_rates, rtol=0, atol=1e-12 * np.abs(expected_rates).max())
        assert got_condition == pytest.approx(condition, rel=1e-12)
        expected = reference[1](kinematics, velocity, command, command_rate)
        got = fast[1](kinematics.update(q), velocity, command, command_rate)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
        assert np.abs(got - expected).max() > 0.0  # two computations, not one
    callable_criterion = torqueopt.get_resolver("extended-jacobian", criterion=lambda angles: float(angles[0] ** 2))
    assert stacked_steps(callable_criterion, panda4, task) is None


@pytest.fixture(scope="module")
def panda3():
    """panda with its last four joints locked and the ``xy`` task: three joints for two rows (n − m = 1), the
    single-state step's 2×3 path on a spatial chain (joint axes along z, y and z again, none parallel to all)."""
    return torqueopt.load_robot(
        "panda", task="xy", lock=["panda_joint4", "panda_joint5", "panda_joint6", "panda_joint7"]
    )


def test_the_stacks_row_is_the_kinematic_hessians(planar3, panda3, rng):
    """The stack's row ∂G/∂q (Jacobi's formula from the frame's J alone) against
    :meth:`ExtendedJacobian.extended_row` (from Pinocchio's kinematic Hessian) at 1e-12 of the row's size, on
    planar3 and a spatial chain."""
    for robot in (planar3, panda3):
        resolver, task = torqueopt.get_resolver("extended-jacobian"), FrameTask.of_robot(robot)
        stack, forest, kinematics = resolver.stack_rate_function(robot), RobotForest(robot), Kinematics(robot)
        for _ in range(6):
            q = robot.default_configuration + rng.uniform(-1.0, 1.0, 3)
            found = _lanes_kinematics(forest, robot, q[None])
            row = stack.rates(found.jacobian, np.zeros((1, 2)), q[None], found)[3][8][:, 0]
            _, expected_row, _ = resolver.extended_row(kinematics.update(q), task)
            np.testing.assert_allclose(row, expected_row, rtol=0, atol=1e-12 * np.abs(expected_row).max())


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_the_step_is_the_lu_reference_on_a_spatial_chain(panda3, rng, gain):
    """The stacked form on a stack of one against the single-state step, ``lu_step_functions``, on a spatial
    chain (see ``assert_stacked_step_is_the_lu_reference``)."""
    resolver = torqueopt.get_resolver("extended-jacobian", position_gain=gain)
    task = FrameTask.of_robot(panda3)
    fast, reference = stacked_steps(resolver, panda3, task), resolver.step_functions(panda3, task)

    def draw_q():
        return panda3.default_configuration + rng.uniform(-1.0, 1.0, 3)

    assert_stacked_step_is_the_lu_reference(Kinematics(panda3), fast, reference, draw_q, rng, count=8)


def test_the_stack_equals_the_kinematic_loop_on_a_spatial_chain(panda3):
    """Two task rows, three joints whose axes are not parallel, gravity on."""
    resolver = torqueopt.get_resolver("extended-jacobian")
    rng = np.random.default_rng(4)
    q0s = [panda3.default_configuration + rng.normal(scale=0.3, size=3) for _ in range(4)]
    lines = [StraightLine(rng.normal(size=2), accel=0.5, duration=0.4) for _ in q0s]
    assert_stacks_equal_simulate(panda3, resolver, lines, q0s)
