"""Pinocchio's terms for planar3 against the closed-form dynamics of a planar
3-link arm of thin uniform rods (Eq. (20) of the paper), derived by hand here,
and the drift J̇q̇ of 7-DOF arms against finite differences."""

import numpy as np
import pinocchio as pin
import pytest

LENGTH = 1.0
MASS = 10.0
CENTRE = LENGTH / 2.0
ROD_INERTIA = MASS * LENGTH**2 / 12.0


def closed_form_inertia(q):
    """H(q) of the planar 3R arm of identical thin rods, expanded by hand."""
    l, m, r, inertia = LENGTH, MASS, CENTRE, ROD_INERTIA
    c2, c3, c23 = np.cos(q[1]), np.cos(q[2]), np.cos(q[1] + q[2])
    h11 = (
        3 * inertia
        + m * r**2
        + m * (l**2 + r**2 + 2 * l * r * c2)
        + m * (2 * l**2 + r**2 + 2 * l * l * c2 + 2 * l * r * c23 + 2 * l * r * c3)
    )
    h12 = 2 * inertia + m * (r**2 + l * r * c2) + m * (l**2 + r**2 + l * l * c2 + l * r * c23 + 2 * l * r * c3)
    h13 = inertia + m * (r**2 + l * r * c23 + l * r * c3)
    h22 = 2 * inertia + m * r**2 + m * (l**2 + r**2 + 2 * l * r * c3)
    h23 = inertia + m * (r**2 + l * r * c3)
    h33 = inertia + m * r**2
    return np.array([[h11, h12, h13], [h12, h22, h23], [h13, h23, h33]])


def closed_form_inertia_derivatives(q):
    """∂H/∂q_k for k = 1, 2, 3, differentiated by hand (H does not depend on q1)."""
    l, m, r = LENGTH, MASS, CENTRE
    s2, s3, s23 = np.sin(q[1]), np.sin(q[2]), np.sin(q[1] + q[2])
    d2 = np.array(
        [
            [
                -2 * m * l * r * s2 - m * (2 * l * l * s2 + 2 * l * r * s23),
                -m * l * r * s2 - m * (l * l * s2 + l * r * s23),
                -m * l * r * s23,
            ],
            [0, 0, 0],
            [0, 0, 0],
        ]
    )
    d2[1, 0], d2[2, 0] = d2[0, 1], d2[0, 2]
    d3 = np.array(
        [
            [
                -m * (2 * l * r * s23 + 2 * l * r * s3),
                -m * (l * r * s23 + 2 * l * r * s3),
                -m * (l * r * s23 + l * r * s3),
            ],
            [0, -2 * m * l * r * s3, -m * l * r * s3],
            [0, 0, 0],
        ]
    )
    d3[1, 0], d3[2, 0], d3[2, 1] = d3[0, 1], d3[0, 2], d3[1, 2]
    return [np.zeros((3, 3)), d2, d3]


def closed_form_coriolis(q, v):
    """v·C·v from the Christoffel symbols of the closed-form H."""
    derivatives = closed_form_inertia_derivatives(q)
    bias = np.zeros(3)
    for i in range(3):
        for j in range(3):
            for k in range(3):
                christoffel = 0.5 * (derivatives[k][i, j] + derivatives[j][i, k] - derivatives[i][j, k])
                bias[i] += christoffel * v[j] * v[k]
    return bias


def closed_form_gravity(q, gravity):
    """Joint torques that hold the arm against an in-plane gravity vector (gx, gy)."""
    angles = np.cumsum(q)
    torque = np.zeros(3)
    for link in range(3):
        for joint in range(link + 1):
            # Moment arm of link's centre of mass about joint, in the plane.
            arm = sum(LENGTH * np.array([np.cos(angles[j]), np.sin(angles[j])]) for j in range(joint, link))
            arm = arm + CENTRE * np.array([np.cos(angles[link]), np.sin(angles[link])])
            force = MASS * np.asarray(gravity[:2])
            torque[joint] -= arm[0] * force[1] - arm[1] * force[0]
    return torque


def closed_form_jacobian(q):
    a1, a12, a123 = q[0], q[0] + q[1], q[0] + q[1] + q[2]
    s = LENGTH * np.array([np.sin(a1), np.sin(a12), np.sin(a123)])
    c = LENGTH * np.array([np.cos(a1), np.cos(a12), np.cos(a123)])
    return np.array([[-s.sum(), -s[1] - s[2], -s[2]], [c.sum(), c[1] + c[2], c[2]]])


def closed_form_drift(q, v):
    angles = np.cumsum(q)
    rates = np.cumsum(v)
    return -LENGTH * np.array([np.sum(np.cos(angles) * rates**2), np.sum(np.sin(angles) * rates**2)])


def random_states(rng, count, n, speed=2.0):
    for _ in range(count):
        yield rng.uniform(-np.pi, np.pi, n), rng.uniform(-speed, speed, n)


def assert_closed_form_terms(terms, q, v):
    np.testing.assert_allclose(terms.inertia, closed_form_inertia(q), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(terms.inertia, terms.inertia.T, atol=0)
    np.testing.assert_allclose(terms.bias_torque, closed_form_coriolis(q, v), rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(terms.jacobian, closed_form_jacobian(q), atol=1e-12)
    np.testing.assert_allclose(terms.drift, closed_form_drift(q, v), atol=1e-12)


def test_planar3_inertia_bias_jacobian_drift_match_closed_form(planar3, rng):
    """Both ways to the terms: the loop's (views of Pinocchio's data, checked
    before the next call) and :meth:`Robot.terms` (copies, which a later
    state must leave alone)."""
    terms_at = planar3.terms_function()
    kept = []
    for q, v in random_states(rng, 25, 3):
        assert_closed_form_terms(terms_at(q, v), q, v)
        kept.append((planar3.terms(q, v), q, v))
        tip = LENGTH * np.array([np.cos(np.cumsum(q)).sum(), np.sin(np.cumsum(q)).sum()])
        np.testing.assert_allclose(planar3.task_position(q), tip, atol=1e-12)
    for terms, q, v in kept:
        assert_closed_form_terms(terms, q, v)


def test_planar3_gravity_torque_matches_closed_form(rng):
    import torqueopt

    robot = torqueopt.load_robot("planar3", gravity=[3.0, -4.0, 0.0])
    for q, _ in random_states(rng, 10, 3):
        terms = robot.terms(q, np.zeros(3))
        np.testing.assert_allclose(terms.bias_torque, closed_form_gravity(q, [3.0, -4.0]), atol=1e-10)


def test_planar3_arm_parameters(planar3):
    assert planar3.nv == 3 and planar3.m == 2 and planar3.redundancy == 1
    np.testing.assert_array_equal(planar3.torque_limit, [54.0, 24.0, 6.0])
    np.testing.assert_array_equal(planar3.gravity, [0.0, 0.0, 0.0])
    masses = [inertia.mass for inertia in planar3.model.inertias[1:]]
    np.testing.assert_allclose(masses, [10.0, 10.0, 10.0])


@pytest.mark.parametrize("robot_name", ["panda", "panda_pose", "xarm7"])
def test_drift_matches_finite_differences_on_7dof_arms(robot_name, request, rng):
    robot = request.getfixturevalue(robot_name)
    step = 1e-6
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    for _ in range(5):
        q = pin.randomConfiguration(robot.model)
        v = rng.uniform(-1.5, 1.5, robot.nv)
        terms = robot.terms(q, v)
        # J̇q̇ = d/dt (J(q(t)) q̇) along q(t) = q + t q̇, by central differences.
        ahead = robot.terms(pin.integrate(robot.model, q, step * v), v).jacobian.dot(v)
        behind = robot.terms(pin.integrate(robot.model, q, -step * v), v).jacobian.dot(v)
        np.testing.assert_allclose(terms.drift, (ahead - behind) / (2 * step), atol=2e-6, rtol=1e-6)

        # The position rows are also the second derivative of the frame origin.
        def origin(t):
            return robot.frame_placement(pin.integrate(robot.model, q, t * v)).translation

        second = (origin(1e-4) - 2 * origin(0.0) + origin(-1e-4)) / 1e-8
        np.testing.assert_allclose(terms.drift[:3], second, atol=5e-5)


def test_jacobian_matches_finite_differences_of_task_position(panda_pose, rng):
    robot = panda_pose
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    q = pin.randomConfiguration(robot.model)
    rotation = robot.frame_placement(q).rotation
    jacobian = robot.terms(q, np.zeros(robot.nv)).jacobian
    step = 1e-7
    for joint in range(robot.nv):
        dq = np.zeros(robot.nv)
        dq[joint] = step
        ahead = robot.task_position(pin.integrate(robot.model, q, dq), rotation)
        behind = robot.task_position(pin.integrate(robot.model, q, -dq), rotation)
        np.testing.assert_allclose(jacobian[:, joint], (ahead - behind) / (2 * step), atol=1e-6)
