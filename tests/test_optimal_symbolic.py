"""The CasADi twin of Pinocchio's RNEA and frame placement (torqueopt.optimal.symbolic), held to Pinocchio."""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import InvalidInput
from torqueopt.optimal.symbolic import configuration_expression, model_digest, symbolic_dynamics

casadi = pytest.importorskip("casadi")

ARMS = ("planar3", "panda", "xarm7", "tiago", "baxter", "kinova")  # kinova: continuous joints (cos, sin)


def _functions(robot):
    model = robot.model
    q, v, a = casadi.SX.sym("q", model.nq), casadi.SX.sym("v", model.nv), casadi.SX.sym("a", model.nv)
    tau, rotation, position = symbolic_dynamics(model, robot.frame_id, q, v, a)
    return casadi.Function("dynamics", [q, v, a], [tau, rotation, position]), (q, v, a, tau)


def _random_state(model, rng):
    q = pin.integrate(model, pin.neutral(model), rng.uniform(-np.pi, np.pi, model.nv))
    return q, rng.normal(scale=2.0, size=model.nv), rng.normal(scale=5.0, size=model.nv)


@pytest.mark.parametrize("name", ARMS)
def test_rnea_and_frame_equal_pinocchio(name):
    robot = torqueopt.load_robot(name)
    model = robot.model.copy()
    rng = np.random.default_rng(7)
    model.armature[:] = rng.uniform(0.0, 0.2, model.nv)  # pin.rnea adds armature·q̈: the twin must too
    data = model.createData()
    q_s, v_s, a_s = casadi.SX.sym("q", model.nq), casadi.SX.sym("v", model.nv), casadi.SX.sym("a", model.nv)
    function = casadi.Function("d", [q_s, v_s, a_s], list(symbolic_dynamics(model, robot.frame_id, q_s, v_s, a_s)))
    for _ in range(20):
        q, v, a = _random_state(model, rng)
        tau, rotation, position = (np.array(x) for x in function(q, v, a))
        np.testing.assert_allclose(tau.ravel(), pin.rnea(model, data, q, v, a), rtol=0, atol=1e-12)
        pin.forwardKinematics(model, data, q)
        placement = pin.updateFramePlacement(model, data, robot.frame_id)
        np.testing.assert_allclose(position.ravel(), placement.translation, rtol=0, atol=1e-12)
        np.testing.assert_allclose(rotation, placement.rotation, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ("planar3", "panda"))
def test_first_derivatives_equal_pinocchio(name):
    robot = torqueopt.load_robot(name)
    model, data = robot.model, robot.model.createData()
    _, (q, v, a, tau) = _functions(robot)
    jacobians = casadi.Function(
        "j", [q, v, a], [casadi.jacobian(tau, q), casadi.jacobian(tau, v), casadi.jacobian(tau, a)]
    )
    rng = np.random.default_rng(3)
    for _ in range(5):
        state = _random_state(model, rng)
        d_q, d_v, inertia = pin.computeRNEADerivatives(model, data, *state)
        ours = [np.array(x) for x in jacobians(*state)]
        np.testing.assert_allclose(ours[0], d_q, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ours[1], d_v, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ours[2], np.triu(inertia) + np.triu(inertia, 1).T, rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", ("planar3", "panda"))
def test_second_derivatives_equal_finite_differences(name):
    """The Hessian of μᵀτ in (q, v, a) against central differences of Pinocchio's first derivatives."""
    robot = torqueopt.load_robot(name)
    model, data = robot.model, robot.model.createData()
    n = model.nv
    _, (q, v, a, tau) = _functions(robot)
    weights = casadi.SX.sym("mu", n)
    state = casadi.vertcat(q, v, a)
    hessian = casadi.Function("h", [state, weights], [casadi.hessian(casadi.dot(weights, tau), state)[0]])
    rng = np.random.default_rng(5)
    point, mu = np.concatenate(_random_state(model, rng)), rng.normal(size=n)

    def gradient(x):
        d_q, d_v, inertia = pin.computeRNEADerivatives(model, data, x[:n], x[n : 2 * n], x[2 * n :])
        inertia = np.triu(inertia) + np.triu(inertia, 1).T
        return mu @ np.hstack([d_q, d_v, inertia])

    step = 1e-6
    differences = np.column_stack(
        [(gradient(point + step * e) - gradient(point - step * e)) / (2 * step) for e in np.eye(3 * n)]
    )
    ours = np.array(hessian(point, mu))
    np.testing.assert_allclose(ours, differences, rtol=0, atol=1e-6 * max(1.0, np.abs(ours).max()))


@pytest.mark.parametrize("name", ("kinova", "panda"))
def test_configuration_of_angles_equals_pinocchio_integrate(name):
    """The shooting transcription's q are angles: their configuration is pin.integrate(neutral, θ), windings too."""
    model = torqueopt.load_robot(name).model
    angles = casadi.SX.sym("angles", model.nv)
    function = casadi.Function("configuration", [angles], [configuration_expression(model, angles)])
    rng = np.random.default_rng(3)
    for _ in range(10):
        theta = rng.uniform(-3 * np.pi, 3 * np.pi, model.nv)
        expected = pin.integrate(model, pin.neutral(model), theta)
        np.testing.assert_allclose(np.array(function(theta)).ravel(), expected, rtol=0, atol=1e-12)


def test_digest_follows_the_model():
    robot = torqueopt.load_robot("planar3")
    model = robot.model.copy()
    before = model_digest(model, robot.frame_id)
    model.inertias[2].mass += 1e-9
    assert model_digest(model, robot.frame_id) != before


def test_unsupported_joint_is_named():
    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    q = casadi.SX.sym("q", model.nq)
    v = casadi.SX.sym("v", model.nv)
    with pytest.raises(InvalidInput, match="joint model 'JointModelSpherical' is not supported"):
        symbolic_dynamics(model, 0, q, v, v)
