"""Task objects against closed-form planar kinematics and central differences."""

import eigenpy
import numpy as np
import pinocchio as pin
import pytest

from torqueopt.errors import FrameNotFound, InvalidInput, TaskNotFound
from torqueopt.tasks import (
    FrameTask,
    Kinematics,
    ObstacleTask,
    PerConfiguration,
    PostureTask,
    TaskStack,
    prioritised_accelerations,
    prioritised_rates,
    pseudoinverse,
    pseudoinverse_rate,
    pseudoinverse_workspace,
    undamped_pseudoinverse,
)

THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV


def test_per_configuration_computes_once_per_update_and_per_kinematics(planar3):
    """What a velocity-level step's rates compute at q and its q̈ reuses: recomputed after every update (even to
    the same q, which another configuration may have come between) and for another Kinematics, never on an
    exception."""
    calls = []

    def jacobian(kinematics):
        calls.append(kinematics.q)
        if not np.all(np.isfinite(kinematics.q)):
            raise InvalidInput("not finite")
        return FrameTask.of_robot(planar3).jacobian(kinematics)

    cached = PerConfiguration(jacobian)
    first, second = Kinematics(planar3), Kinematics(planar3)
    q, other = np.array([0.1, 0.2, 0.3]), np.array([-0.4, 0.5, 0.6])
    value = cached(first.update(q))
    assert cached(first) is value and len(calls) == 1
    np.testing.assert_array_equal(
        cached(first.update(other)), FrameTask.of_robot(planar3).jacobian(second.update(other))
    )
    assert len(calls) == 2
    cached(second)
    cached(first.update(other))
    assert len(calls) == 4
    with pytest.raises(InvalidInput):
        cached(first.update(np.array([np.nan, 0.0, 0.0])))
    with pytest.raises(InvalidInput):
        cached(first)
    assert len(calls) == 6
    # a call that raises forgets the value held, even for another kinematics: what the function left elsewhere
    # (a solver's decomposition) now stands for the configuration that failed
    cached(second.update(q))
    with pytest.raises(InvalidInput):
        cached(first.update(np.array([np.nan, 0.0, 0.0])))
    cached(second)
    assert len(calls) == 9


def test_a_frame_position_is_its_placements_translation_after_every_update(planar3, panda, rng):
    """Kinematics.frame_position reads a view of Pinocchio's frame placements kept from the first read: it follows
    each update, and what it returned is the caller's own."""
    pin.seed(int(rng.integers(2**31)))
    for robot in (planar3, panda):
        kinematics = Kinematics(robot)
        earlier = None
        for _ in range(3):
            q = pin.randomConfiguration(robot.model)
            position = kinematics.update(q).frame_position(robot.frame_id)
            np.testing.assert_array_equal(position, robot.frame_placement(q).translation)
            np.testing.assert_array_equal(FrameTask.of_robot(robot).value(kinematics), robot.task_position(q))
            if earlier is not None:
                kept = earlier.copy()
                assert not np.array_equal(earlier, position)
                np.testing.assert_array_equal(earlier, kept)  # not moved by the update after it
            earlier = position


def test_the_joint_origins_and_a_frame_position_view_follow_every_update(planar3, panda, rng):
    """Kinematics.joint_origins and frame_position_view are views of Pinocchio's placements: each row is its joint's
    translation after every update, and they cannot be written."""
    pin.seed(int(rng.integers(2**31)))
    for robot in (planar3, panda):
        kinematics = Kinematics(robot)
        origins, tip = kinematics.joint_origins(), kinematics.frame_position_view(robot.frame_id)
        for _ in range(3):
            kinematics.update(pin.randomConfiguration(robot.model))
            np.testing.assert_array_equal(origins, [placement.translation for placement in kinematics.data.oMi])
            np.testing.assert_array_equal(tip, kinematics.data.oMf[robot.frame_id].translation)
        assert kinematics.joint_origins() is origins
        for view in (origins, tip):
            with pytest.raises(ValueError, match="read-only"):
                view[0] = 1.0


def planar_points(q):
    """Joint origins and tip of the paper's arm (unit links), closed form."""
    angles = np.cumsum(q)
    steps = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])


def planar_jacobian(q):
    """Closed-form 2×3 Jacobian of the paper's arm tip."""
    angles = np.cumsum(q)
    jacobian = np.zeros((2, 3))
    for i in range(3):
        jacobian[0, i] = -np.sin(angles[i:]).sum()
        jacobian[1, i] = np.cos(angles[i:]).sum()
    return jacobian


def central(function, q, step=1e-6):
    columns = []
    for k in range(q.size):
        e = np.zeros(q.size)
        e[k] = step
        columns.append((np.asarray(function(q + e)) - np.asarray(function(q - e))) / (2 * step))
    return np.stack(columns, axis=-1)


def test_frame_task_matches_closed_form_planar_kinematics(planar3, rng):
    task, kinematics = FrameTask("tip", "xy"), Kinematics(planar3)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 3)
        kinematics.update(q)
        np.testing.assert_allclose(task.value(kinematics), planar_points(q)[-1], atol=1e-12)
        np.testing.assert_allclose(task.jacobian(kinematics), planar_jacobian(q), atol=1e-12)


@pytest.mark.parametrize("robot_name, kind", [("planar3", "xy"), ("panda", "position"), ("panda", "pose")])
def test_frame_task_jacobian_drift_and_hessian_match_central_differences(robot_name, kind, request, rng):
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    robot = request.getfixturevalue(robot_name)
    task = FrameTask(robot.frame, kind)
    kinematics = Kinematics(robot)

    def jacobian_at(q):
        return task.jacobian(Kinematics(robot).update(q)).copy()

    for _ in range(3):
        q = pin.randomConfiguration(robot.model) if robot_name == "panda" else rng.uniform(-np.pi, np.pi, 3)
        v = rng.normal(size=robot.nv)
        kinematics.update(q, v)
        derivative = task.jacobian_derivative(kinematics)
        np.testing.assert_allclose(derivative, central(jacobian_at, q), atol=1e-7)
        # J̇q̇ = Σ_k ∂J/∂q_k v_k v: the drift against the Hessian and against differences along v
        np.testing.assert_allclose(task.drift(kinematics), np.einsum("aik,i,k->a", derivative, v, v), atol=1e-9)
        along = (jacobian_at(q + 1e-6 * v) - jacobian_at(q - 1e-6 * v)) / 2e-6
        np.testing.assert_allclose(task.drift(kinematics), along.dot(v), atol=1e-7)
        if kind != "pose":
            np.testing.assert_allclose(
                task.jacobian(kinematics), central(lambda x: task.value(Kinematics(robot).update(x)), q), atol=1e-7
            )


@pytest.mark.parametrize("robot_name, kind", [("planar3", "xy"), ("panda", "position"), ("panda", "pose")])
def test_the_jacobian_derivative_traces_are_the_contraction_with_the_readable_derivative(
    robot_name, kind, request, rng
):
    """tr(W ∂J/∂q_k) by one product of Pinocchio's layout against Σ_ij W_ij D[j, i, k] with D of
    jacobian_derivative, for several W and scales on one task (its buffer reused), and that layout against D."""
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    robot = request.getfixturevalue(robot_name)
    task = FrameTask(robot.frame, kind)
    for _ in range(3):
        kinematics = Kinematics(robot).update(pin.randomConfiguration(robot.model))
        derivative = kinematics.frame_jacobian_derivative(task.frame_id(kinematics))
        rows = kinematics.frame_jacobian_derivative_rows(task.frame_id(kinematics))
        np.testing.assert_array_equal(rows.reshape(robot.nv, robot.nv, 6), derivative.transpose(2, 1, 0))
        for scale in (1.0, -2.5):
            weights = rng.normal(size=(robot.nv, task.dimension))
            expected = scale * np.einsum("ij,jik->k", weights, task.jacobian_derivative(kinematics))
            got = task.jacobian_derivative_traces(kinematics, weights, scale)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())


def test_frame_task_regulates_to_its_target(planar3):
    q = np.array([0.3, 1.0, -0.5])
    task = FrameTask("tip", "xy", target=[1.0, 1.0], gain=2.0)
    kinematics = Kinematics(planar3).update(q)
    np.testing.assert_allclose(task.desired_velocity(kinematics), 2.0 * (np.array([1.0, 1.0]) - planar_points(q)[-1]))
    assert np.all(FrameTask("tip", "xy").desired_velocity(kinematics) == 0.0)


def test_frame_task_desired_velocity_is_the_gain_times_the_error(planar3, panda, rng):
    """k(x* − x) read from the frame's position (xy, position) and through the error (pose): k times error(),
    bit for bit."""
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    for robot, kind, target in (
        (planar3, "xy", [1.0, 1.0]),
        (panda, "position", [0.3, 0.0, 0.6]),
        (panda, "pose", [0.3, 0.0, 0.6, 0.1, -0.2, 0.3]),
    ):
        task = FrameTask(robot.frame, kind, target=target, gain=1.7)
        kinematics = Kinematics(robot).update(pin.randomConfiguration(robot.model))
        np.testing.assert_array_equal(task.desired_velocity(kinematics), 1.7 * task.error(kinematics))


def test_frame_task_errors_name_the_bad_value(planar3):
    with pytest.raises(TaskNotFound, match="unknown task kind 'orientation': choose one of xy, position, pose"):
        FrameTask("tip", "orientation")
    with pytest.raises(FrameNotFound, match="robot 'planar3' has no frame 'hand': choose one of"):
        FrameTask("hand", "xy").check(planar3)
    with pytest.raises(InvalidInput, match=r"task target \[1.0\] must be 2 finite numbers"):
        FrameTask("tip", "xy", target=[1.0])


def closest_by_sampling(q, center, radius):
    points = planar_points(q)
    fractions = np.linspace(0.0, 1.0, 20001)[:, None]
    samples = np.vstack([a + fractions * (b - a) for a, b in zip(points[:-1], points[1:])])
    distances = np.linalg.norm(samples - center, axis=1)
    best = int(np.argmin(distances))
    return samples[best], distances[best] - radius


def test_obstacle_closest_point_matches_dense_sampling(planar3, rng):
    kinematics = Kinematics(planar3)
    for _ in range(8):
        q = rng.uniform(-np.pi, np.pi, 3)
        center = rng.uniform(-2.0, 2.0, 2)
        obstacle = ObstacleTask(center, radius=0.1)
        closest = obstacle.closest_point(kinematics.update(q))
        point, clearance = closest_by_sampling(q, center, 0.1)
        assert abs(closest.clearance - clearance) < 1e-6
        np.testing.assert_allclose(closest.point[:2], point, atol=2e-4)
        assert closest.point[2] == 0.0
        np.testing.assert_allclose(np.linalg.norm(closest.normal), 1.0)


def closest_by_vectors(obstacle, kinematics):
    """The closest point (point, normal, clearance, joint, segment) by a plain loop over the segments on numpy
    3-vectors, the reference for ObstacleTask.closest_point's arithmetic on floats."""
    model, data = kinematics.model, kinematics.data
    frame_id = model.getFrameId(obstacle.frame or kinematics.robot.frame)
    joints = [j for j in model.supports[model.frames[frame_id].parentJoint] if j > 0]
    origins = [data.oMi[joint].translation.copy() for joint in joints] + [data.oMf[frame_id].translation.copy()]
    best = None
    for index, joint in enumerate(joints):
        start, axis = origins[index], origins[index + 1] - origins[index]
        length_squared = axis.dot(axis)
        fraction = (
            0.0 if length_squared == 0.0 else min(1.0, max(0.0, (obstacle.center - start).dot(axis) / length_squared))
        )
        point = start + fraction * axis
        distance = np.linalg.norm(point - obstacle.center)
        if best is None or distance < best[0]:
            best = (distance, point, joint, index)
    distance, point, joint, index = best
    return point, (point - obstacle.center) / distance, distance - obstacle.radius, joint, index


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
def test_obstacle_closest_point_is_the_loop_on_vectors(robot_name, request, rng):
    """The closest point on floats is the plain loop on numpy vectors to round-off, on every segment (obstacles
    near the base, the middle and the tip, and beyond the ends of segments)."""
    pin.seed(int(rng.integers(2**31)))
    robot = request.getfixturevalue(robot_name)
    kinematics = Kinematics(robot)
    segments = set()
    for _ in range(40):
        kinematics.update(pin.randomConfiguration(robot.model))
        obstacle = ObstacleTask(rng.uniform(-1.5, 1.5, 3), rng.uniform(0.0, 0.2))
        closest = obstacle.closest_point(kinematics)
        point, normal, clearance, joint, segment = closest_by_vectors(obstacle, kinematics)
        np.testing.assert_allclose(closest.point, point, rtol=0, atol=1e-12)
        np.testing.assert_allclose(closest.normal, normal, rtol=0, atol=1e-12)
        assert abs(closest.clearance - clearance) < 1e-12
        assert (closest.joint_id, closest.segment) == (joint, segment)
        segments.add(segment)
    assert len(segments) >= 3


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
def test_obstacle_point_jacobian_is_pinocchios_at_the_point(robot_name, request, rng):
    """J_o (the joint's Jacobian moved to the point) equals Pinocchio's Jacobian of a frame placed there."""
    pin.seed(int(rng.integers(2**31)))
    robot = request.getfixturevalue(robot_name)
    kinematics = Kinematics(robot)
    for _ in range(10):
        kinematics.update(pin.randomConfiguration(robot.model))
        obstacle = ObstacleTask(rng.uniform(-1.5, 1.5, 3), 0.05)
        closest = obstacle.closest_point(kinematics)
        joint = kinematics.data.oMi[closest.joint_id]
        placement = pin.SE3(np.eye(3), joint.rotation.T.dot(closest.point - joint.translation))
        expected = pin.getFrameJacobian(
            robot.model, kinematics.data, closest.joint_id, placement, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )[:3]
        np.testing.assert_allclose(obstacle.point_jacobian(kinematics, closest), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
def test_obstacle_point_jacobian_is_the_velocity_of_the_material_point(robot_name, request, rng):
    """J_o q̇ equals the central difference of the world position of the point fixed on its link."""
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    robot = request.getfixturevalue(robot_name)
    kinematics = Kinematics(robot)
    for _ in range(3):
        q = pin.randomConfiguration(robot.model) if robot_name == "panda" else rng.uniform(-np.pi, np.pi, 3)
        kinematics.update(q)
        placement = robot.frame_placement(q)
        obstacle = ObstacleTask(placement.translation + rng.normal(scale=0.3, size=3), 0.05)
        closest = obstacle.closest_point(kinematics)
        local = kinematics.data.oMi[closest.joint_id].actInv(closest.point)

        def material_point(x, joint=closest.joint_id, local=local):
            data = robot.model.createData()
            pin.forwardKinematics(robot.model, data, x)
            return data.oMi[joint].act(local)

        jacobian = obstacle.point_jacobian(kinematics, closest)
        np.testing.assert_allclose(jacobian, central(material_point, q), atol=1e-7)
        v = rng.normal(size=robot.nv)
        kinematics.update(q, v)
        along = (central(material_point, q + 1e-5 * v) - central(material_point, q - 1e-5 * v)) / 2e-5
        np.testing.assert_allclose(obstacle.drift(kinematics), along.dot(v), atol=1e-4)


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
def test_obstacle_point_rates_are_the_derivatives_of_the_closest_point(robot_name, request, rng):
    """ẋ_o, the normal's rate and J̇_o of ObstacleTask.point_rates against central differences of closest_point and
    point_jacobian along v, where the closest point stays on one segment, inside it or at its end."""
    pin.seed(int(rng.integers(2**31)))
    robot = request.getfixturevalue(robot_name)
    kinematics, h, tested = Kinematics(robot), 1e-6, 0
    while tested < 10:
        q, v = pin.randomConfiguration(robot.model), rng.normal(size=robot.nv)
        obstacle = ObstacleTask(rng.uniform(-1.0, 1.0, 3), 0.05)
        closest = obstacle.closest_point(kinematics.update(q))
        point_velocity, normal_rate, point_jacobian_rate = obstacle.point_rates(kinematics, closest, v)
        after, before = (obstacle.closest_point(kinematics.update(q + sign * h * v)) for sign in (1.0, -1.0))
        if after.segment != closest.segment or before.segment != closest.segment:
            continue
        after_jacobian = obstacle.point_jacobian(kinematics.update(q + h * v), after)
        before_jacobian = obstacle.point_jacobian(kinematics.update(q - h * v), before)
        np.testing.assert_allclose(point_velocity, (after.point - before.point) / (2 * h), rtol=0, atol=1e-8)
        np.testing.assert_allclose(normal_rate, (after.normal - before.normal) / (2 * h), rtol=0, atol=1e-7)
        np.testing.assert_allclose(point_jacobian_rate, (after_jacobian - before_jacobian) / (2 * h), rtol=0, atol=1e-8)
        tested += 1


def test_obstacle_from_numbers_and_bad_numbers():
    assert ObstacleTask.from_spec([1.0, 2.0, 0.0, 0.3]).radius == 0.3
    np.testing.assert_allclose(ObstacleTask.from_spec([1.0, 2.0]).center, [1.0, 2.0, 0.0])
    with pytest.raises(InvalidInput, match=r"obstacle centre \[1.0\] must be 2 or 3 finite numbers"):
        ObstacleTask([1.0])
    with pytest.raises(InvalidInput, match="obstacle radius=-1 must be a finite number >= 0"):
        ObstacleTask([1.0, 2.0], radius=-1)


def test_the_identity_b_cb_pinv_is_cb_pinv(rng):
    """B[CB]⁺ = [CB]⁺ for B = I − J_h⁺J_h, Hermitian and idempotent (Maciejewski & Klein), used by Eq. (11)."""
    for rows_h, rows_l, n in ((2, 1, 3), (3, 2, 7), (3, 3, 7), (2, 3, 4)):
        high, low = rng.normal(size=(rows_h, n)), rng.normal(size=(rows_l, n))
        projector = np.eye(n) - np.linalg.pinv(high).dot(high)
        np.testing.assert_allclose(projector, projector.T, atol=1e-12)
        np.testing.assert_allclose(projector.dot(projector), projector, atol=1e-12)
        projected_inverse = np.linalg.pinv(low.dot(projector), rcond=1e-10)
        np.testing.assert_allclose(projector.dot(projected_inverse), projected_inverse, atol=1e-10)


def test_prioritised_rates_are_eq_11_built_from_eqs_9_and_10(rng):
    for n in (3, 5, 7):
        high, low = rng.normal(size=(2, n)), rng.normal(size=(2, n))
        x_high, x_low = rng.normal(size=2), rng.normal(size=2)
        high_pinv = np.linalg.pinv(high)
        projector = np.eye(n) - high_pinv.dot(high)
        # J_l(I − J_h⁺J_h) has rank min(2, n − 2): the cutoff drops the round-off singular values
        phi = np.linalg.pinv(low.dot(projector), rcond=1e-10).dot(x_low - low.dot(high_pinv).dot(x_high))  # Eq. (10)
        expected = high_pinv.dot(x_high) + projector.dot(phi)  # Eq. (9)
        rates, _ = prioritised_rates([high, low], [x_high, x_low])
        np.testing.assert_allclose(rates, expected, atol=1e-10)
        np.testing.assert_allclose(high.dot(rates), x_high, atol=1e-10)  # the high-priority task exactly
        if n >= 4:  # room for both: the low-priority task exactly too
            np.testing.assert_allclose(low.dot(rates), x_low, atol=1e-9)


def test_a_three_level_stack_keeps_each_task_out_of_the_ones_above(rng):
    jacobians = [rng.normal(size=(2, 6)), rng.normal(size=(2, 6)), rng.normal(size=(3, 6))]
    velocities = [rng.normal(size=2), rng.normal(size=2), rng.normal(size=3)]
    rates, projector = prioritised_rates(jacobians, velocities)
    np.testing.assert_allclose(jacobians[0].dot(rates), velocities[0], atol=1e-10)
    np.testing.assert_allclose(jacobians[1].dot(rates), velocities[1], atol=1e-10)
    # the third gets the least-squares best within the 2 remaining freedoms
    top = np.vstack(jacobians[:2])
    basis = np.linalg.svd(top)[2][4:].T
    best = np.linalg.lstsq(
        jacobians[2].dot(basis),
        velocities[2] - jacobians[2].dot(np.linalg.pinv(top).dot(np.concatenate(velocities[:2]))),
        rcond=None,
    )[0]
    np.testing.assert_allclose(
        rates, np.linalg.pinv(top).dot(np.concatenate(velocities[:2])) + basis.dot(best), atol=1e-9
    )
    np.testing.assert_allclose(projector, np.zeros((6, 6)), atol=1e-9)  # 2 + 2 + 3 rows use all 6 freedoms


def test_pseudoinverse_cutoff_and_damping(rng):
    matrix = rng.normal(size=(3, 5))
    np.testing.assert_allclose(pseudoinverse(matrix), np.linalg.pinv(matrix), atol=1e-12)
    damping = 0.3
    np.testing.assert_allclose(
        pseudoinverse(matrix, damping=damping),
        matrix.T.dot(np.linalg.inv(matrix.dot(matrix.T) + damping**2 * np.eye(3))),
        atol=1e-12,
    )
    rank_one = np.outer([1.0, 2.0], [1.0, 0.0, 1.0])
    np.testing.assert_allclose(pseudoinverse(rank_one), np.linalg.pinv(rank_one), atol=1e-12)


@pytest.mark.parametrize(
    "shape, rank", [((2, 3), 2), ((2, 3), 1), ((3, 7), 2), ((6, 7), 6), ((1, 3), 1), ((3, 1), 1), ((3, 2), 2)]
)
def test_the_undamped_pseudoinverse_by_the_svds_solve_is_the_readable_one(rng, shape, rank):
    """undamped_pseudoinverse (Eigen's solve with the cutoff as its rank threshold) against pseudoinverse, full
    rank and rank-deficient, with round-off directions such as those of J_l(I − J⁺J) for a point the null space
    cannot move; and a zero matrix."""
    rows, columns = shape
    workspace = eigenpy.HhJacobiSVD(rows, columns, THIN_UV)
    for _ in range(10):
        matrix = rng.normal(size=(rows, rank)).dot(rng.normal(size=(rank, columns)))
        expected = pseudoinverse(matrix)
        np.testing.assert_allclose(
            undamped_pseudoinverse(matrix), expected, rtol=0, atol=1e-14 * np.abs(expected).max()
        )
        # decomposed into a kept SVD object: the same, bit for bit
        np.testing.assert_array_equal(undamped_pseudoinverse(matrix, svd=workspace), undamped_pseudoinverse(matrix))
    jacobian = rng.normal(size=(2, 3))
    projector = np.eye(3) - np.linalg.pinv(jacobian).dot(jacobian)
    tip = jacobian.dot(projector)  # round-off only: every singular value below the absolute floor
    np.testing.assert_array_equal(undamped_pseudoinverse(tip), pseudoinverse(tip))
    np.testing.assert_array_equal(undamped_pseudoinverse(np.zeros((2, 3))), np.zeros((3, 2)))
    workspace = pseudoinverse_workspace(2, 3)
    for matrix in (tip, np.zeros((2, 3)), rng.normal(size=(2, 3)), tip):
        np.testing.assert_array_equal(undamped_pseudoinverse(matrix, svd=workspace), undamped_pseudoinverse(matrix))


def five_point(function, h=1e-4):
    """d/ds function(s) at s = 0 by the five-point difference (error ~h⁴)."""
    return (8 * (function(h) - function(-h)) - (function(2 * h) - function(-2 * h))) / (12 * h)


@pytest.mark.parametrize("shape, rank", [((2, 3), 2), ((3, 7), 3), ((2, 3), 1), ((3, 5), 2), ((4, 3), 2)])
def test_the_pseudoinverse_rate_is_the_derivative_of_the_pseudoinverse_at_constant_rank(rng, shape, rank):
    """d/dt A⁺ against a five-point difference of numpy's pinv along A(t) = L(t) R(t), of rank ``rank`` for every t
    (full row rank, and rank-deficient as the projected Jacobians J_l(I − J⁺J) are)."""
    rows, columns = shape
    left, left_rate = rng.normal(size=(rows, rank)), rng.normal(size=(rows, rank))
    right, right_rate = rng.normal(size=(rank, columns)), rng.normal(size=(rank, columns))

    def matrix_at(s):
        return (left + s * left_rate).dot(right + s * right_rate)

    matrix = matrix_at(0.0)
    matrix_rate = left_rate.dot(right) + left.dot(right_rate)
    inverse = np.linalg.pinv(matrix, rcond=1e-10)
    expected = five_point(lambda s: np.linalg.pinv(matrix_at(s), rcond=1e-10))
    got = pseudoinverse_rate(matrix, matrix_rate, inverse)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_the_prioritised_accelerations_are_the_derivative_of_the_prioritised_rates(rng):
    """Three levels on six joints (the last with fewer freedoms than rows) and two on three (the lower one
    rank-deficient once projected), moving along J_k(s) = J_k + sJ̇_k, ẋ_k(s) = ẋ_k + sẍ_k."""
    for sizes, n in (((2, 2, 3), 6), ((2, 2), 3)):
        jacobians = [rng.normal(size=(rows, n)) for rows in sizes]
        jacobian_rates = [rng.normal(size=(rows, n)) for rows in sizes]
        velocities = [rng.normal(size=rows) for rows in sizes]
        velocity_rates = [rng.normal(size=rows) for rows in sizes]

        def rates_at(s, jacobians=jacobians, jacobian_rates=jacobian_rates, velocities=velocities,
                     velocity_rates=velocity_rates):  # fmt: skip
            return prioritised_rates(
                [J + s * dJ for J, dJ in zip(jacobians, jacobian_rates)],
                [x + s * dx for x, dx in zip(velocities, velocity_rates)],
            )[0]

        rates, accelerations = prioritised_accelerations(jacobians, jacobian_rates, velocities, velocity_rates)
        np.testing.assert_allclose(rates, rates_at(0.0), rtol=0, atol=1e-12)
        expected = five_point(rates_at)
        np.testing.assert_allclose(accelerations, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_a_posture_task_and_a_frame_task_give_their_rates_in_closed_form(panda, rng):
    """J̇ and the rate of ẋ_d = k(x* − x) along q(s) = q + sv, against five-point differences of J and ẋ_d."""
    pin.seed(int(rng.integers(2**31)))
    frame = FrameTask("panda_link4", "position", target=[0.3, 0.0, 0.6], gain=2.0)
    posture = PostureTask(gain=3.0)
    posture.check(panda)
    kinematics = Kinematics(panda)
    assert frame.closed_form_rates and posture.closed_form_rates
    assert not FrameTask("panda_link4", "pose").closed_form_rates
    assert not ObstacleTask([0.4, 0.2, 0.5]).closed_form_rates
    for _ in range(3):
        q, v = pin.randomConfiguration(panda.model), rng.normal(size=panda.nv)
        for task in (frame, posture):
            got_jacobian_rate = task.jacobian_rate(kinematics.update(q), v)
            got_velocity_rate = task.desired_velocity_rate(kinematics.update(q), v)
            expected_jacobian_rate = five_point(lambda s, task=task: task.jacobian(kinematics.update(q + s * v)))
            expected_velocity_rate = five_point(
                lambda s, task=task: task.desired_velocity(kinematics.update(q + s * v))
            )
            np.testing.assert_allclose(got_jacobian_rate, expected_jacobian_rate, rtol=0, atol=1e-9)
            np.testing.assert_allclose(got_velocity_rate, expected_velocity_rate, rtol=0, atol=1e-9)


def test_task_stack_takes_tasks_and_refuses_the_rest():
    task = FrameTask("tip", "xy", target=[1, 1])
    assert len(TaskStack.of(task)) == 1 and TaskStack.of([task, task]).dimension == 4
    with pytest.raises(InvalidInput, match="a task stack needs one or more Task objects"):
        TaskStack([])
    with pytest.raises(InvalidInput, match="a task stack needs one or more Task objects"):
        TaskStack(["tip"])


@pytest.mark.parametrize("damping", [1e-6, 1e-8, 1e-12, 1e-300])
def test_a_tiny_damping_keeps_the_cutoff_and_acts_like_none(rng, damping):
    """Damped least squares replaces 1/σ by σ/(σ² + λ²) on the singular values the cutoff keeps; the
    round-off ones (a projected Jacobian J_l(I − J⁺J) of rank n − m) stay dropped, so λ → 0 is the plain
    pseudoinverse, whatever the round-off."""
    jacobian = rng.normal(size=(2, 3))
    projected = np.eye(3) - np.linalg.pinv(jacobian).dot(jacobian)  # rank 1, two singular values ~1e-16
    plain = pseudoinverse(projected)
    np.testing.assert_allclose(plain, np.linalg.pinv(projected, rcond=1e-10), atol=1e-12)
    np.testing.assert_allclose(pseudoinverse(projected, damping=damping), plain, atol=1e-9)
