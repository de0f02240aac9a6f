"""RK4 with the torque held over each step: fourth-order convergence and
conservation laws of the free planar arm."""

import numpy as np
import pinocchio as pin

import torqueopt


def integrate(robot, q, v, tau, dt, duration):
    for _ in range(int(round(duration / dt))):
        q, v = torqueopt.rk4_step(robot, q, v, tau, dt)
    return q, v


def test_rk4_error_falls_sixteenfold_when_dt_halves(planar3):
    q0 = np.array([0.3, -1.1, 0.7])
    v0 = np.array([1.5, -2.0, 3.0])
    tau = np.array([4.0, -2.0, 0.5])
    q_fine, v_fine = integrate(planar3, q0, v0, tau, 1e-4, 0.4)
    errors = []
    for dt in (0.02, 0.01, 0.005):
        q, v = integrate(planar3, q0, v0, tau, dt, 0.4)
        errors.append(np.linalg.norm(np.concatenate([q - q_fine, v - v_fine])))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    for ratio in ratios:
        assert 13.0 < ratio < 19.0, (errors, ratios)


def test_free_arm_conserves_energy_and_joint1_momentum(planar3):
    """No gravity, no torque: kinetic energy is conserved; with torque at
    joints 2 and 3 only, q1 stays cyclic and its momentum (H q̇)_1 (the arm's
    angular momentum about the base axis) is conserved."""
    model, data = planar3.model, planar3.model.createData()
    q = np.array([0.2, 1.0, -0.5])
    v = np.array([0.5, -1.0, 2.0])
    energy0 = pin.computeKineticEnergy(model, data, q, v)
    q1, v1 = integrate(planar3, q, v, np.zeros(3), 1e-3, 1.0)
    assert abs(pin.computeKineticEnergy(model, data, q1, v1) - energy0) < 1e-9 * energy0

    momentum0 = pin.crba(model, data, q).dot(v)[0]
    q2, v2 = integrate(planar3, q, v, np.array([0.0, 3.0, -1.0]), 1e-3, 1.0)
    momentum = pin.crba(model, data, q2).dot(v2)[0]
    assert abs(momentum - momentum0) < 1e-9
    # The work done by the torque shows up as kinetic energy: the energy changed.
    assert abs(pin.computeKineticEnergy(model, data, q2, v2) - energy0) > 0.1


def test_continuous_joints_stay_on_their_circle():
    kinova = torqueopt.load_robot("kinova", gravity=False)
    assert kinova.nq > kinova.nv  # continuous joints: (cos, sin) pairs
    q = kinova.default_configuration
    v = np.full(kinova.nv, 0.5)
    q1, _ = integrate(kinova, q, v, np.zeros(kinova.nv), 1e-3, 0.2)
    for joint in kinova.model.joints[1:]:
        if joint.nq == 2:
            cos_sin = q1[joint.idx_q : joint.idx_q + 2]
            assert abs(np.hypot(*cos_sin) - 1.0) < 1e-12
