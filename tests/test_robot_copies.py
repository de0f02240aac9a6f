"""The batch's fast pieces against Pinocchio's single-robot calls and numpy's QR.

:class:`torqueopt.robot_copies.RobotForest` computes a whole batch's task terms from
one forest model; each copy must give what Pinocchio's frame calls give for
that copy alone. The batch's closed-form two-row factorisation must agree
with the complete QR it replaces, and with the SVD's condition.
"""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import InvalidInput
from torqueopt.resolvers.stacks import complete_qr, two_row_qr
from torqueopt.robot_copies import RobotForest

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def _states(robot, count, seed):
    rng = np.random.default_rng(seed)
    low = np.maximum(robot.model.lowerPositionLimit, -3.0)
    high = np.minimum(robot.model.upperPositionLimit, 3.0)
    return rng.uniform(low, high, (count, robot.nv)), rng.uniform(-2.0, 2.0, (count, robot.nv))


def _relative(ours, theirs):
    return np.max(np.abs(ours - theirs)) / (1.0 + np.max(np.abs(theirs)))


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_each_copy_gets_what_pinocchio_gives_that_robot_alone(name, planar3, panda):
    """13 states through a forest of 5 copies: three passes, the last one partly filled.

    baxter is a branch of a larger tree (its other joints locked away): the
    columns of joints outside the tip's support must stay zero."""
    robot = {"planar3": planar3, "panda": panda}.get(name) or torqueopt.load_robot(name)
    q, v = _states(robot, 13, seed=3)
    inertia, bias, jacobian, drift, tip = RobotForest(robot, copies=5).terms(q, v)
    model, data = robot.model, robot.model.createData()
    for i in range(len(q)):
        pin.computeAllTerms(model, data, q[i], v[i])
        placement = pin.updateFramePlacement(model, data, robot.frame_id)
        assert _relative(inertia[i], data.M) < 1e-13
        assert _relative(bias[i], data.nle) < 1e-13
        assert _relative(jacobian[i], pin.getFrameJacobian(model, data, robot.frame_id, _LWA)) < 1e-13
        reference_drift = pin.getFrameClassicalAcceleration(model, data, robot.frame_id, _LWA).vector
        assert _relative(drift[i], reference_drift) < 1e-13
        assert _relative(tip[i], placement.translation) < 1e-15


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_passes_that_give_the_inverse_inertia_and_its_rate_give_the_same_kinematics(name, planar3, panda):
    """computeMinverse and computeCoriolisMatrix compute the joint Jacobians (and J̇) on their way: the forest
    reads J, J̇ and the tip from those passes, so they must be bit for bit those of the plain Jacobian passes."""
    robot = {"planar3": planar3, "panda": panda}[name]
    q, v = _states(robot, 13, seed=11)
    plain, moving = RobotForest(robot, copies=5).kinematics(q), RobotForest(robot, copies=5).kinematics(q, v)
    with_inverse = RobotForest(robot, copies=5).kinematics(q, inverse_inertia=True)
    with_rate = RobotForest(robot, copies=5).kinematics(q, v, inertia_rate=True)
    assert np.array_equal(with_inverse.jacobian, plain.jacobian) and np.array_equal(with_inverse.tip, plain.tip)
    assert with_inverse.rate is None and plain.inverse_inertia is None and moving.inertia_rate_velocity is None
    for field in ("jacobian", "rate", "tip"):
        assert np.array_equal(getattr(with_rate, field), getattr(moving, field)), field
    assert np.abs(with_rate.rate).max() > 1e-2  # the velocities enter J̇
    with pytest.raises(ValueError):
        RobotForest(robot, copies=5).kinematics(q, v, inverse_inertia=True)


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_forests_inverse_inertia_and_inertia_rate_are_each_robots(name, planar3, panda):
    """H⁻¹ against the inverse of the robot's own CRBA H, and Ḣv = (C + Cᵀ)v against a five-point difference of
    that H along v (independent of Pinocchio's Coriolis matrix), for 13 states through a forest of 5 copies."""
    robot = {"planar3": planar3, "panda": panda}[name]
    q, v = _states(robot, 13, seed=7)
    forest = RobotForest(robot, copies=5)
    inverse_inertia = forest.kinematics(q, inverse_inertia=True).inverse_inertia
    inertia_rate = forest.kinematics(q, v, inertia_rate=True).inertia_rate_velocity
    data = robot.model.createData()

    def inertia_at(configuration):
        upper = pin.crba(robot.model, data, configuration)
        return np.triu(upper) + np.triu(upper, 1).T

    h = 1e-4
    for i in range(len(q)):
        assert _relative(inverse_inertia[i], np.linalg.inv(inertia_at(q[i]))) < 1e-12

        def along(s, i=i):
            return inertia_at(q[i] + s * v[i]).dot(v[i])

        expected = (8 * (along(h) - along(-h)) - (along(2 * h) - along(-2 * h))) / (12 * h)
        assert _relative(inertia_rate[i], expected) < 1e-9


def test_every_copy_carries_the_armature():
    """A rotor's armature adds to the diagonal of H: each copy's block must have it, as computeAllTerms does."""
    robot = torqueopt.load_robot("planar3")  # its own copy: the shared fixture is not touched
    robot.model.armature = np.array([0.5, 0.2, 0.1])
    q, v = _states(robot, 7, seed=9)
    inertia, bias, _, _, _ = RobotForest(robot, copies=3).terms(q, v)
    data = robot.model.createData()
    for i in range(len(q)):
        pin.computeAllTerms(robot.model, data, q[i], v[i])
        assert _relative(inertia[i], data.M) < 1e-13
        assert _relative(bias[i], data.nle) < 1e-13


def test_the_copies_do_not_interact(planar3):
    """The forest's mass matrix is block-diagonal: no copy's acceleration loads another's joints."""
    forest = RobotForest(planar3, copies=4)
    q, v = _states(planar3, 4, seed=5)
    forest.terms(q, v)
    mass = forest._pool[0].data.M.copy()
    n = planar3.nv
    for i in range(4):
        mass[i * n : (i + 1) * n, i * n : (i + 1) * n] = 0.0
    assert np.max(np.abs(mass)) == 0.0


def test_a_forest_needs_joints_whose_configuration_adds():
    kinova = torqueopt.load_robot("kinova")  # continuous joints: nq = 2 per joint
    with pytest.raises(InvalidInput, match="kinova.*nq != nv"):
        RobotForest(kinova)


@pytest.mark.parametrize("joints", [2, 3])
def test_two_row_closed_form_equals_thecomplete_qr(joints):
    """Random 2×n Jacobians, from well conditioned to σmin/σmax = 1e-7 (below the batch's cutoff 1e-6)."""
    rng = np.random.default_rng(11)
    count = 400
    u = np.linalg.qr(rng.normal(size=(count, 2, 2)))[0]
    w = np.linalg.qr(rng.normal(size=(count, joints, joints)))[0][:, :, :2]
    conditions = 10.0 ** rng.uniform(-7, 0, count)
    singular_values = np.stack([np.full(count, 2.0), 2.0 * conditions], axis=1)
    jacobian = u @ (singular_values[:, :, None] * np.swapaxes(w, 1, 2))  # U Σ Wᵀ, known σ
    residual = rng.normal(size=(count, 2))
    redundant = joints > 2
    particular, basis, condition = two_row_qr(jacobian, residual, redundant)
    reference, reference_basis, _ = complete_qr(jacobian, residual, redundant)
    # The minimum-norm solution is amplified by 1/σmin: compare relative to its size, allowing κ·ε.
    scale = np.linalg.norm(reference, axis=1)
    assert np.all(np.linalg.norm(particular - reference, axis=1) <= 1e-15 * scale / conditions + 1e-14)
    np.testing.assert_allclose(condition, conditions, rtol=1e-9)
    np.testing.assert_allclose(np.einsum("bij,bj->bi", jacobian, particular), residual, atol=1e-8)
    if redundant:
        # A basis is unique up to sign: compare the projectors Z Zᵀ, and J Z = 0.
        projector = basis @ np.swapaxes(basis, 1, 2)
        reference_projector = reference_basis @ np.swapaxes(reference_basis, 1, 2)
        assert np.max(np.abs(projector - reference_projector)) < 1e-8
        assert np.max(np.abs(jacobian @ basis)) < 1e-14
    else:
        assert basis is None


def test_batches_in_threads_on_one_robot_give_the_serial_results(planar3):
    """Each thread computes in its own forest data, so two batches sharing a Robot cannot race."""
    import threading

    from torqueopt import StraightLine
    from torqueopt.batch import simulate_batch

    rng = np.random.default_rng(4)
    cases = [
        (name, [StraightLine(d, duration=0.3) for d in rng.normal(size=(20, 2))], rng.uniform(-2, 2, (20, 3)))
        for name in ("null-space", "inertia-pinv")
    ]
    serial = [simulate_batch(planar3, name, lines, q0s) for name, lines, q0s in cases]
    threaded = [None, None]
    barrier = threading.Barrier(len(cases))

    def run(index):
        barrier.wait()
        threaded[index] = simulate_batch(planar3, *cases[index])

    threads = [threading.Thread(target=run, args=(index,)) for index in range(len(cases))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for alone, together in zip(serial, threaded):
        for run_alone, run_together in zip(alone, together):
            for field in ("q", "v", "tau", "x"):
                np.testing.assert_array_equal(getattr(run_together, field), getattr(run_alone, field))


def test_the_two_terms_providers_give_the_same_terms(planar3, panda):
    """ForestTerms (the forest, B > 1) against PinocchioTerms (Pinocchio's frame calls on one data, row by row)."""
    from torqueopt.terms import ForestTerms, PinocchioTerms, terms_provider

    for robot in (planar3, panda):
        rng = np.random.default_rng(8)
        q = robot.default_configuration + rng.uniform(-1.0, 1.0, (9, robot.nv))
        v = rng.uniform(-2.0, 2.0, (9, robot.nv))
        forest_terms, forest_position = ForestTerms(robot).terms(q, v)
        pinocchio_terms, pinocchio_position = PinocchioTerms(robot).terms(q, v)
        for ours, theirs in zip((*forest_terms, forest_position), (*pinocchio_terms, pinocchio_position)):
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-11 * (1.0 + np.abs(theirs).max()))
        assert np.abs(pinocchio_terms.drift).max() > 1e-3  # the velocities enter the drift
        assert isinstance(terms_provider(robot, 9), ForestTerms)
        assert isinstance(terms_provider(robot, 1), PinocchioTerms)


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_the_forest_kinematics_and_inverse_dynamics_are_pinocchios_per_state(name):
    """J, J̇ along v and the tip of 13 states (three passes of 5 copies) against the frame calls on one data,
    and RNEA of the stack against pin.rnea state by state; J̇v against the frame's classical acceleration at zero
    q̈, and J̇ the same when the tip is handed in."""
    robot = torqueopt.load_robot(name, task="position" if name == "panda" else None)
    rng = np.random.default_rng(3)
    q = np.array([robot.configuration(rng.uniform(-1, 1, robot.nv)) for _ in range(13)])
    v, acceleration = rng.normal(size=(13, robot.nv)), rng.normal(size=(13, robot.nv))
    forest = RobotForest(robot, copies=5)
    jacobian, rate, tip, *_ = forest.kinematics(q, v)
    alone, none, *_ = forest.kinematics(q)
    assert np.array_equal(forest.kinematics(q, v, tip).rate, rate)
    torque = forest.inverse_dynamics(q, v, acceleration)
    assert none is None
    data = robot.model.createData()
    for row in range(13):
        pin.computeJointJacobiansTimeVariation(robot.model, data, q[row], v[row])
        pin.updateFramePlacements(robot.model, data)
        frame = robot.frame_id
        np.testing.assert_allclose(jacobian[row], pin.getFrameJacobian(robot.model, data, frame, _LWA), atol=1e-12)
        np.testing.assert_allclose(alone[row], jacobian[row], atol=1e-12)
        np.testing.assert_allclose(
            rate[row], pin.getFrameJacobianTimeVariation(robot.model, data, frame, _LWA), atol=1e-12
        )
        np.testing.assert_allclose(tip[row], data.oMf[frame].translation, atol=1e-12)
        pin.forwardKinematics(robot.model, data, q[row], v[row], np.zeros(robot.nv))
        drift = pin.getFrameClassicalAcceleration(robot.model, data, frame, _LWA).vector
        assert _relative(rate[row] @ v[row], drift) < 1e-13
        np.testing.assert_allclose(
            torque[row], pin.rnea(robot.model, data, q[row], v[row], acceleration[row]), atol=1e-10
        )


@pytest.mark.parametrize("name", ["planar3", "panda", "baxter"])
def test_every_frame_of_every_copy_from_the_joint_kinematics_is_pinocchios(name, planar3, panda):
    """Every frame of the robot (not only the task frame), through 13 states in passes of 5 copies, with and
    without v and in every pass kind: its position, Jacobian and Jacobian rate from the forest's joint kinematics
    (:func:`point_kinematics`, :meth:`RobotForest.frame_points`) against Pinocchio's frame calls on one data; the
    joints' placements against ``data.oMi``. baxter's branch sits in a larger tree: its support columns matter."""
    from torqueopt.robot_copies import point_kinematics

    robot = {"planar3": planar3, "panda": panda}.get(name) or torqueopt.load_robot(name)
    q, v = _states(robot, 13, seed=21)
    forest = RobotForest(robot, copies=5)
    still = forest.kinematics(q, joints=True)
    moving = forest.kinematics(q, v, joints=True)
    assert forest.kinematics(q).joints is None
    for found in (still, forest.kinematics(q, inverse_inertia=True, joints=True)):
        assert np.array_equal(found.joints.origins, moving.joints.origins) and found.joints.rate is None
    # the task frame's own kinematics are unchanged by asking for the joints'
    assert np.array_equal(moving.rate, forest.kinematics(q, v).rate)
    model, data = robot.model, robot.model.createData()
    frames = [f for f in range(1, model.nframes) if model.frames[f].parentJoint > 0]
    for row in range(13):
        pin.computeJointJacobiansTimeVariation(model, data, q[row], v[row])
        pin.updateFramePlacements(model, data)
        for joint in range(model.njoints):
            assert _relative(moving.joints.origins[row, joint], data.oMi[joint].translation) < 1e-15
            assert _relative(moving.joints.rotations[row, joint], data.oMi[joint].rotation) < 1e-15
        for frame in frames:
            columns = forest.support_columns(model.frames[frame].parentJoint)
            point = forest.frame_points(moving.joints, frame)
            jacobian, rate = point_kinematics(moving.joints, columns, point, v)
            alone, none = point_kinematics(still.joints, columns, point)
            assert none is None and np.array_equal(alone, jacobian)
            assert _relative(point[row], data.oMf[frame].translation) < 1e-14
            assert _relative(jacobian[row], pin.getFrameJacobian(model, data, frame, _LWA)) < 1e-13
            assert _relative(rate[row], pin.getFrameJacobianTimeVariation(model, data, frame, _LWA)) < 1e-13
    with pytest.raises(ValueError):
        point_kinematics(still.joints, columns, point, v)
