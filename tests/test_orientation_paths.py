"""Orientation paths for pose tasks: the SO(3) interpolant, its exact rates, the CSV columns and runs on panda."""

import json
import math

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt import InvalidInput, WaypointPath
from torqueopt.cli import main
from torqueopt.run_records import task_reference
from torqueopt.trajectory import minimum_jerk
from torqueopt.trajectory.orientation import OrientationSpline, cumulative_weights

TIMES = np.array([0.0, 0.3, 0.7, 1.2, 2.0])
# The 1 s movement of the issue: 30° about a tilted axis while the frame moves 10 cm.
TURN_AXIS = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
TURN_ANGLE = math.radians(30.0)
SHIFT = np.array([0.08, 0.0, 0.06])


def random_rotations(count, seed=0, spread=1.0):
    generator = np.random.default_rng(seed)
    return np.array([pin.exp3(spread * generator.normal(size=3)) for _ in range(count)])


def world_rate(rotations_after, rotations_before, step):
    """Central difference of rotations, world axes: log(R(t + h) R(t − h)ᵀ) / 2h."""
    return np.array([pin.log3(after.dot(before.T)) for after, before in zip(rotations_after, rotations_before)]) / (
        2.0 * step
    )


def test_the_interpolant_passes_through_its_rotations_and_rests_at_both_ends():
    rotations = random_rotations(TIMES.size)
    sample = OrientationSpline(TIMES, rotations).sample(TIMES)
    np.testing.assert_allclose(sample.rotation, rotations, atol=1e-13)
    np.testing.assert_array_equal(sample.angular_velocity[[0, -1]], 0.0)
    np.testing.assert_allclose(sample.angular_acceleration[[0, -1]], 0.0, atol=1e-12)
    outside = OrientationSpline(TIMES, rotations).sample(np.array([-1.0, 3.0]))
    np.testing.assert_allclose(outside.rotation, rotations[[0, -1]], atol=1e-13)
    np.testing.assert_array_equal(outside.angular_velocity, 0.0)
    np.testing.assert_array_equal(outside.angular_acceleration, 0.0)


def test_two_rotations_give_the_geodesic_on_the_minimum_jerk_profile():
    start = pin.exp3(np.array([0.3, -0.2, 0.5]))
    increment = TURN_ANGLE * TURN_AXIS
    spline = OrientationSpline(np.array([0.0, 1.3]), np.array([start, start.dot(pin.exp3(increment))]))
    times = np.linspace(0.0, 1.3, 27)
    s, s_dot, s_ddot = minimum_jerk(times, 1.3)
    sample = spline.sample(times)
    axis = start.dot(increment)  # the world axis of a turn about a body axis that does not move
    for k, time in enumerate(times):
        np.testing.assert_allclose(sample.rotation[k], start.dot(pin.exp3(s[k] * increment)), atol=1e-14)
    np.testing.assert_allclose(sample.angular_velocity, s_dot[:, None] * axis, atol=1e-13)
    np.testing.assert_allclose(sample.angular_acceleration, s_ddot[:, None] * axis, atol=1e-12)


@pytest.mark.parametrize("spread", [0.5, 1.5])
def test_angular_velocity_and_acceleration_are_the_derivatives_of_the_interpolated_rotations(spread):
    """ω = log(R(t+h) R(t−h)ᵀ)/2h and ω̇ = (ω(t+h) − ω(t−h))/2h to O(h²): exact rates of the interpolant."""
    spline = OrientationSpline(TIMES, random_rotations(TIMES.size, seed=3, spread=spread))
    times = np.linspace(0.01, 1.99, 45)
    step = 1e-5
    sample, after, before = spline.sample(times), spline.sample(times + step), spline.sample(times - step)
    scale = np.abs(sample.angular_velocity).max()
    assert scale > 1.0  # the movement turns fast enough for a wrong term to show
    np.testing.assert_allclose(world_rate(after.rotation, before.rotation, step), sample.angular_velocity, atol=1e-7)
    acceleration = (after.angular_velocity - before.angular_velocity) / (2.0 * step)
    np.testing.assert_allclose(acceleration, sample.angular_acceleration, atol=1e-5)


def test_the_rate_of_the_rotations_log_is_pinocchios_jlog3_of_the_angular_velocity():
    """d/dt log(R(t)) = Jlog3(R) Rᵀ ω (Pinocchio's Jacobian of log3, body axes), by central differences of log3."""
    spline = OrientationSpline(TIMES, random_rotations(TIMES.size, seed=11, spread=0.4))
    times = np.linspace(0.05, 1.95, 20)
    step = 1e-6
    sample, after, before = spline.sample(times), spline.sample(times + step), spline.sample(times - step)
    for k in range(times.size):
        rate = (pin.log3(after.rotation[k]) - pin.log3(before.rotation[k])) / (2.0 * step)
        expected = pin.Jlog3(sample.rotation[k]).dot(sample.rotation[k].T.dot(sample.angular_velocity[k]))
        np.testing.assert_allclose(rate, expected, atol=1e-8)


def test_the_rotation_weights_are_the_position_splines_time_scaling():
    """p(t) = p₀ + Σ S_k(t)(p_k − p_{k−1}): the same weights advance the position steps and the rotation steps."""
    points = np.random.default_rng(5).normal(size=(TIMES.size, 3))
    path = WaypointPath(TIMES, points, start=points[0])
    times = np.linspace(0.0, 2.0, 81)
    weights = cumulative_weights(TIMES)
    for order in range(3):
        rebuilt = weights(times, order).dot(np.diff(points, axis=0)) + (points[0] if order == 0 else 0.0)
        expected = [path.sample(times).position, path.sample(times).velocity, path.sample(times).acceleration][order]
        np.testing.assert_allclose(rebuilt, expected, atol=1e-11)


def write(tmp_path, text, name="path.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def quaternion_row(time, point, rotation, sign=1.0):
    quaternion = pin.Quaternion(rotation)
    values = [time, *point, *(sign * np.array([quaternion.w, quaternion.x, quaternion.y, quaternion.z]))]
    return ",".join(repr(float(value)) for value in values)


def test_quaternion_columns_give_the_rotations_and_a_sign_flip_changes_nothing(tmp_path):
    rotations = random_rotations(3, seed=7, spread=0.8)
    points = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.02], [0.1, 0.01, 0.0]])
    times = [0.0, 0.5, 1.0]
    rows = [quaternion_row(t, p, r) for t, p, r in zip(times, points, rotations)]
    flipped = [
        quaternion_row(t, p, r, sign=-1.0 if k == 1 else 1.0)
        for k, (t, p, r) in enumerate(zip(times, points, rotations))
    ]
    header = "t,x,y,z,qw,qx,qy,qz\n"
    path = WaypointPath.from_csv(write(tmp_path, header + "\n".join(rows) + "\n"), absolute=True)
    twin = WaypointPath.from_csv(write(tmp_path, header + "\n".join(flipped) + "\n", "flipped.csv"), absolute=True)
    np.testing.assert_allclose(path.rotations, rotations, atol=1e-15)
    probe = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(
        twin.sample_orientation(probe, np.eye(3)).position,
        path.sample_orientation(probe, np.eye(3)).position,
        atol=1e-14,
    )
    assert (
        path.describe()["orientation"] == "absolute"
        and WaypointPath.from_csv(tmp_path / "path.csv").describe()["orientation"] == "relative"
    )


def test_roll_pitch_yaw_columns_in_radians_and_degrees(tmp_path):
    angles = np.array([[0.0, 0.0, 0.0], [0.2, -0.3, 0.5]])
    body = "".join(f"{t},{0.1 * t},0,0,{r},{p},{y}\n" for t, (r, p, y) in zip([0.0, 1.0], angles))
    radians = WaypointPath.from_csv(write(tmp_path, "t,x,y,z,roll,pitch,yaw\n" + body), rpy=True)
    body = "".join(f"{t},{0.1 * t},0,0,{r},{p},{y}\n" for t, (r, p, y) in zip([0.0, 1.0], np.degrees(angles)))
    degrees = WaypointPath.from_csv(
        write(tmp_path, "t,x,y,z,roll,pitch,yaw\n" + body, "deg.csv"), rpy=True, degrees=True
    )
    # R = Rz(yaw) Ry(pitch) Rx(roll), built here from single-axis turns
    roll, pitch, yaw = angles[1]
    expected = (
        pin.exp3(np.array([0.0, 0.0, yaw]))
        @ pin.exp3(np.array([0.0, pitch, 0.0]))
        @ pin.exp3(np.array([roll, 0.0, 0.0]))
    )
    np.testing.assert_allclose(radians.rotations[1], expected, atol=1e-15)
    np.testing.assert_allclose(degrees.rotations[1], expected, atol=1e-14)


def test_a_quaternion_rounded_in_the_file_is_normalised(tmp_path):
    text = "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1.0004,0,0,0\n1,0.1,0,0,0.9659,0,0,0.2588\n"
    path = WaypointPath.from_csv(write(tmp_path, text))
    np.testing.assert_allclose(path.rotations[0], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(path.rotations[1]), 1.0, atol=1e-14)
    np.testing.assert_allclose(path.rotations[1].T @ path.rotations[1], np.eye(3), atol=1e-15)


@pytest.mark.parametrize(
    "text, options, message",
    [
        (
            "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,0,0,0,0\n1,0.1,0,0,1,0,0,0\n",
            {},
            "row 2: quaternion qw,qx,qy,qz = 0,0,0,0 has norm 0; give a unit quaternion, scalar first",
        ),
        (
            "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0.1,0,0,2,0,0,0\n",
            {},
            "row 3: quaternion qw,qx,qy,qz = 2,0,0,0 has norm 2; give a unit quaternion",
        ),
        (
            "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0.1,0,0,nan,0,0,0\n",
            {},
            "row 3: '1,0.1,0,0,nan,0,0,0' has a non-finite value; give finite numbers",
        ),
        (
            "t,x,y,z,qw,qx,qy\n0,0,0,0,1,0,0\n1,0.1,0,0,1,0,0\n",
            {},
            "row 1: header 't,x,y,z,qw,qx,qy' must be t,x,y or t,x,y,z (position), t,x,y,z,qw,qx,qy,qz or "
            "t,x,y,z,roll,pitch,yaw (pose)",
        ),
        ("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0.1,0,0,1,0,0\n", {}, "row 3: 7 values, the header has 8"),
        (
            "t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n1,0.1,0,0,0,0,1\n",
            {},
            "row 1: roll,pitch,yaw columns are read with --rpy (rpy=True); give it, or quaternion columns qw,qx,qy,qz",
        ),
        (
            "t,x,y,z\n0,0,0,0\n1,0.1,0,0\n",
            {"rpy": True},
            "row 1: --rpy (rpy=True) reads roll,pitch,yaw columns, but the header is 't,x,y,z'; give the header "
            "t,x,y,z,roll,pitch,yaw",
        ),
        (
            "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0.1,0,0,0,0,0,1\n",
            {},
            "waypoint rotations at t=0 s and t=1 s are 180° apart, half a turn: which way round is undecided; add a "
            "waypoint between them",
        ),
    ],
)
def test_bad_orientation_files_are_one_line_naming_the_value(text, options, message, tmp_path):
    with pytest.raises(InvalidInput, match="^waypoint file '.*bad.csv'") as error:
        WaypointPath.from_csv(write(tmp_path, text, "bad.csv"), **options)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_bad_rotations_from_python_are_named():
    with pytest.raises(InvalidInput, match=r"waypoint rotations 2 .* is not a rotation \(RᵀR − I up to"):
        WaypointPath([0.0, 1.0], np.zeros((2, 3)), rotations=[np.eye(3), 2.0 * np.eye(3)])
    with pytest.raises(InvalidInput, match=r"waypoint rotations need 3-D waypoints \(a pose task\), got 2"):
        WaypointPath([0.0, 1.0], np.zeros((2, 2)), rotations=[np.eye(3), np.eye(3)])
    with pytest.raises(InvalidInput, match="rotation_start places the waypoint rotations, and this path has none"):
        WaypointPath([0.0, 1.0], np.zeros((2, 3)), rotation_start=np.eye(3))


def turning_path():
    return WaypointPath([0.0, 1.0], [np.zeros(3), SHIFT], rotations=[np.eye(3), pin.exp3(TURN_ANGLE * TURN_AXIS)])


def test_a_path_with_rotations_needs_a_pose_task(panda):
    with pytest.raises(
        InvalidInput, match="carries rotations but task 'position' has no orientation; give the task pose"
    ):
        torqueopt.simulate(panda, "pinv", turning_path(), panda.default_configuration)


def test_the_pose_reference_rows_turn_the_start_rotation_about_world_axes(panda_pose):
    """Relative rotations turn the frame's start rotation R_s about the world axes: R_ref = exp(s θ a) R_s."""
    start = pin.exp3(np.array([0.4, 0.1, -0.7]))
    times = np.linspace(0.0, 1.0, 21)
    path = turning_path().anchored(np.zeros(3))
    sample = task_reference(panda_pose, path, times, start)
    s, s_dot, s_ddot = minimum_jerk(times, 1.0)
    np.testing.assert_allclose(sample.position[:, 3:], s[:, None] * TURN_ANGLE * TURN_AXIS, atol=1e-14)
    np.testing.assert_allclose(sample.velocity[:, 3:], s_dot[:, None] * TURN_ANGLE * TURN_AXIS, atol=1e-13)
    np.testing.assert_allclose(sample.acceleration[:, 3:], s_ddot[:, None] * TURN_ANGLE * TURN_AXIS, atol=1e-12)
    # absolute: the rows measure the given rotations from R_s
    fixed = WaypointPath(
        [0.0, 1.0], [np.zeros(3), SHIFT], start=np.zeros(3), rotations=[np.eye(3), start], rotation_start=np.eye(3)
    )
    end = task_reference(panda_pose, fixed, np.array([0.0, 1.0]), start).position[:, 3:]
    np.testing.assert_allclose(end[1], 0.0, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(end[0]), np.linalg.norm(pin.log3(start)), atol=1e-14)


def closed_form_errors(robot, result):
    """Largest distance [m] and angle [rad] between the frame and exp(s θ a) R_s, p_s + s Δp (minimum-jerk s)."""
    start = robot.frame_placement(result.q[0])
    s, _, _ = minimum_jerk(result.t, 1.0)
    position, angle = 0.0, 0.0
    for k, q in enumerate(result.q):
        placement = robot.frame_placement(q)
        position = max(position, np.linalg.norm(placement.translation - start.translation - s[k] * SHIFT))
        reference = pin.exp3(s[k] * TURN_ANGLE * TURN_AXIS).dot(start.rotation)
        angle = max(angle, np.linalg.norm(pin.log3(reference.dot(placement.rotation.T))))
    return position, angle


@pytest.mark.slow
def test_panda_follows_a_turning_pose_path_within_a_micrometre_and_a_microradian(panda_pose):
    """30° about a tilted axis while moving 10 cm in 1 s, against the closed-form pose exp(s θ a) R_s, p_s + s Δp.

    The velocity level integrates q̇ = J⁺[ṗ; ω] by RK4: it stays on the path only if ω is the world angular
    velocity of the reference rotations, and the frame's acceleration J q̈ + J̇ q̇ along that motion (Pinocchio's
    classical acceleration) is then the reference's [p̈; ω̇]. The torque level holds each torque over a step,
    so it keeps to the path with task feedback, whose rotation rows are log(R_ref Rᵀ).
    """
    q0 = panda_pose.default_configuration
    path = turning_path()
    kinematic = torqueopt.simulate(panda_pose, "velocity-pinv", path, q0)
    torque = torqueopt.simulate(panda_pose, "null-space", path, q0, dt=5e-4, feedback=(1e5, 632.0))
    for result in (kinematic, torque):
        assert result.completed
        position, angle = closed_form_errors(panda_pose, result)
        assert position < 1e-6 and angle < 1e-6
        assert result.max_tip_error == pytest.approx(position, abs=1e-12)
        assert result.max_orientation_error == pytest.approx(angle, abs=1e-12)
    assert closed_form_errors(panda_pose, kinematic)[1] < 1e-11  # the rates are the reference's own
    reference = task_reference(panda_pose, path.anchored(kinematic.x_ref[0, :3]), kinematic.t, None)
    for row in range(10, len(kinematic.t) - 10, 97):
        terms = panda_pose.terms(kinematic.q[row], kinematic.v[row])
        frame_acceleration = terms.jacobian.dot(kinematic.acceleration[row]) + terms.drift
        np.testing.assert_allclose(frame_acceleration, reference.acceleration[row], atol=1e-6)


@pytest.mark.slow
def test_open_loop_the_torque_level_converges_to_the_turning_path_as_the_step_shrinks(panda_pose):
    """Without feedback only the held torque parts the frame from the path, an O(dt) error: halving dt halves it,
    in position and orientation alike, which holds only if the reference's ω̇ is the acceleration of its rotations
    (a wrong ω̇ leaves an error that no step removes)."""
    q0 = panda_pose.default_configuration
    errors = [
        closed_form_errors(
            panda_pose, torqueopt.simulate(panda_pose, "null-space", turning_path(), q0, dt=dt, duration=0.6)
        )
        for dt in (1e-3, 5e-4)
    ]
    assert errors[0][1] > 1e-4  # open loop, the held torque shows
    assert errors[0][0] / errors[1][0] == pytest.approx(2.0, rel=0.05)
    assert errors[0][1] / errors[1][1] == pytest.approx(2.0, rel=0.05)


#: What a resolver needs to run on panda's pose task: obstacle avoidance an obstacle (here far from the arm).
RESOLVER_OPTIONS = {"obstacle-avoidance": {"obstacle": [3.0, 3.0, 3.0]}}
#: Resolvers that take the xy and position tasks only (they refuse a pose task in one line, tested below).
POSITION_ONLY = {"receding-horizon"}


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(name, marks=pytest.mark.slow if name == "extended-jacobian" else ())
        for name in torqueopt.resolver_names()
        if name not in POSITION_ONLY
    ],
)
def test_every_resolver_follows_a_turning_pose_path(panda_pose, name):
    """8° and 2.5 cm in 0.25 s: the velocity level follows it to integration accuracy, the torque level (held
    torque, task feedback) to a few microradians; a resolver that refused a pose task would fail here."""
    path = WaypointPath(
        [0.0, 0.25], [np.zeros(3), 0.25 * SHIFT], rotations=[np.eye(3), pin.exp3(math.radians(8.0) * TURN_AXIS)]
    )
    resolver = torqueopt.get_resolver(name, **RESOLVER_OPTIONS.get(name, {}))
    velocity_level = getattr(resolver, "level", None) == "velocity"
    feedback = None if velocity_level else (1e5, 632.0)
    result = torqueopt.simulate(panda_pose, resolver, path, panda_pose.default_configuration, feedback=feedback)
    assert result.completed
    bound = 1e-10 if velocity_level else 1e-5
    assert result.max_tip_error < bound and result.max_orientation_error < bound
    assert np.abs(result.x_ref[-1, 3:] - math.radians(8.0) * TURN_AXIS).max() < 1e-12


@pytest.mark.parametrize("name", sorted(POSITION_ONLY))
def test_a_resolver_of_position_tasks_refuses_a_pose_path_in_one_line(panda_pose, name):
    with pytest.raises(InvalidInput, match=f"resolver '{name}' supports tasks xy and position, not 'pose'"):
        torqueopt.simulate(panda_pose, name, WaypointPath([0.0, 0.25], [np.zeros(3), 0.25 * SHIFT]),
                           panda_pose.default_configuration)  # fmt: skip


@pytest.mark.slow
def test_a_turn_past_half_a_turn_is_followed_through_the_wrap_of_the_rotation_vector(panda_pose):
    """200° about the hand's axis in 1 s: the task's rotation vector about the start wraps at 180°, where a feedback
    on the difference of rotation vectors would kick by 2π; log(R_ref Rᵀ) does not see the wrap."""
    q0 = panda_pose.default_configuration
    axis = panda_pose.frame_placement(q0).rotation[:, 2]
    rotations = [np.eye(3), pin.exp3(math.radians(100.0) * axis), pin.exp3(math.radians(200.0) * axis)]
    path = WaypointPath([0.0, 0.5, 1.0], np.zeros((3, 3)), rotations=rotations)
    result = torqueopt.simulate(panda_pose, "null-space", path, q0, dt=5e-4, feedback=(1e5, 632.0))
    assert result.completed
    # the reference's rotation vector wraps: it jumps by nearly 2π from one row to the next
    assert np.linalg.norm(np.diff(result.x_ref[:, 3:], axis=0), axis=1).max() > 6.0
    assert result.max_orientation_error < 1e-5 and result.max_tip_error < 1e-6
    end = panda_pose.frame_placement(result.q[-1]).rotation
    start = panda_pose.frame_placement(q0).rotation
    np.testing.assert_allclose(pin.log3(start.T.dot(end)), [0.0, 0.0, math.radians(200.0) - 2.0 * math.pi], atol=1e-5)


@pytest.mark.slow
def test_velocity_level_feedback_turns_the_frame_onto_the_reference_at_its_gain(panda_pose):
    """From 3.4° and 1 cm off, q̇ = J⁺(ẋ_ref + K e) with e's rotation rows log(R_ref Rᵀ): as J_log(e) e = e, the
    angle decays exactly as exp(−K t), and q̈ (with ∂e/∂t = J_log(E) Eᵀ ω_ref) is the derivative of the motion."""
    q0 = panda_pose.default_configuration
    placement = panda_pose.frame_placement(q0)
    offset = pin.exp3(np.array([0.05, -0.03, 0.02]))
    rotations = [offset.dot(placement.rotation), offset.dot(pin.exp3(TURN_ANGLE * TURN_AXIS)).dot(placement.rotation)]
    start = placement.translation + np.array([0.01, 0.0, 0.0])
    path = WaypointPath(
        [0.0, 1.0], [start, start + SHIFT], start=start, rotations=rotations, rotation_start=rotations[0]
    )
    gain, dt = 20.0, 1e-3
    result = torqueopt.simulate(panda_pose, "velocity-pinv", path, q0, dt=dt, resolver_options={"position_gain": gain})
    reference = task_reference(panda_pose, path, result.t, placement.rotation)
    for row in (100, 300, 500):
        rotation = panda_pose.frame_placement(result.q[row]).rotation
        turn = pin.exp3(reference.position[row, 3:]).dot(placement.rotation).dot(rotation.T)
        angle = np.linalg.norm(pin.log3(turn))
        assert angle == pytest.approx(np.linalg.norm(pin.log3(offset)) * math.exp(-gain * result.t[row]), rel=1e-6)
        distance = np.linalg.norm(result.x[row, :3] - reference.position[row, :3])
        assert distance == pytest.approx(0.01 * math.exp(-gain * result.t[row]), rel=1e-6)
    difference = (result.v[2:] - result.v[:-2]) / (2.0 * dt)
    assert np.abs(difference - result.acceleration[1:-1]).max() < 5e-3 * np.abs(result.acceleration).max() / 10.0


@pytest.mark.slow
def test_cli_runs_a_pose_path_from_roll_pitch_yaw_in_degrees(tmp_path, capsys):
    waypoints = write(tmp_path, "t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n0.2,0.01,0,0.01,0,0,10\n")
    out = tmp_path / "run.csv"
    run = ["run", "--robot", "panda", "--task", "pose", "--resolver", "pinv", "--path", f"csv:{waypoints}", "--rpy"]
    assert main([*run, "--degrees", "--feedback", "100000,632", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    record = json.loads((tmp_path / "run.csv.json").read_text())["trajectory"]
    assert record["orientation"] == "relative" and record["waypoints"] == 2
    loaded = torqueopt.load_result(out)
    # the reference's rotation rows end 10° about the world z axis from the start
    np.testing.assert_allclose(loaded.x_ref[-1, 3:], [0.0, 0.0, math.radians(10.0)], atol=1e-12)
    # 10° in 0.2 s, ω̇ up to 25 rad/s²: the feedback holds the frame within a few microradians
    assert loaded.max_orientation_error < 1e-5
    assert f"max orientation error: {math.degrees(loaded.max_orientation_error):.4f} deg" in printed


@pytest.mark.parametrize(
    "options, message",
    [
        (
            ["--path", "line", "--direction", "1,0,0", "--task", "pose", "--rpy"],
            "--rpy applies to --path csv, not to --path line",
        ),
        (["--path", "csv:{quaternions}", "--task", "pose", "--rpy"], "reads roll,pitch,yaw columns, but the header is"),
        (
            ["--path", "csv:{quaternions}"],
            "carries rotations but task 'position' has no orientation; give the task pose",
        ),
    ],
)
def test_cli_bad_orientation_paths_are_one_line_exit_2(options, message, tmp_path, capsys):
    quaternions = write(tmp_path, "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.2,0.01,0,0,1,0,0,0\n")
    options = [option.format(quaternions=quaternions) for option in options]
    assert main(["run", "--robot", "panda", "--resolver", "pinv", *options]) == 2
    error = capsys.readouterr().err
    assert message in error and error.count("\n") == 1
