"""RK4 with the torque held over each step, and RK4 of a velocity-level method's rates: the library's one
stepper (:class:`torqueopt.integrators.RK4`) held to the textbook stages written one by one here, fourth-order
convergence and conservation laws of the free planar arm."""

import numpy as np
import pinocchio as pin

import torqueopt
from torqueopt.integrators import RK4, HeldTorque, VelocityRates


def rk4_reference_step(robot, q, v, tau, dt, data=None):
    r"""One classical RK4 step of the forward dynamics with τ held, the textbook stages one by one (the oracle).

    .. math::

        k_1^q = v, && k_1^v = a(q, v),

        k_2^q = v + \tfrac{h}{2} k_1^v, && k_2^v = a(q \oplus \tfrac{h}{2} k_1^q,\ v + \tfrac{h}{2} k_1^v),

        k_3^q = v + \tfrac{h}{2} k_2^v, && k_3^v = a(q \oplus \tfrac{h}{2} k_2^q,\ v + \tfrac{h}{2} k_2^v),

        k_4^q = v + h k_3^v, && k_4^v = a(q \oplus h k_3^q,\ v + h k_3^v),

        q^+ = q \oplus \tfrac{h}{6}(k_1^q + 2k_2^q + 2k_3^q + k_4^q), &&
        v^+ = v + \tfrac{h}{6}(k_1^v + 2k_2^v + 2k_3^v + k_4^v),

    with :math:`a(q, v) = \mathrm{ABA}(q, v, \tau)`.
    """
    data = robot.model.createData() if data is None else data
    h = float(dt)

    def acceleration(configuration, velocity):
        return pin.aba(robot.model, data, configuration, velocity, tau)

    def integrate(configuration, increment):
        return pin.integrate(robot.model, configuration, increment)

    k1_q, k1_v = v, acceleration(q, v)
    k2_q, k2_v = v + h / 2 * k1_v, acceleration(integrate(q, h / 2 * k1_q), v + h / 2 * k1_v)
    k3_q, k3_v = v + h / 2 * k2_v, acceleration(integrate(q, h / 2 * k2_q), v + h / 2 * k2_v)
    k4_q, k4_v = v + h * k3_v, acceleration(integrate(q, h * k3_q), v + h * k3_v)
    q_next = integrate(q, h / 6 * (k1_q + 2 * k2_q + 2 * k3_q + k4_q))
    v_next = v + h / 6 * (k1_v + 2 * k2_v + 2 * k3_v + k4_v)
    return q_next, v_next


def velocity_reference_step(robot, f, q, index, dt):
    """One classical RK4 step of q̇ = f(q, sample) from half-step sample ``index``, stage by stage (the oracle)."""
    h = float(dt)

    def integrate(configuration, increment):
        return pin.integrate(robot.model, configuration, increment)

    k1 = f(q, index)
    k2 = f(integrate(q, h / 2 * k1), index + 1)
    k3 = f(integrate(q, h / 2 * k2), index + 1)
    k4 = f(integrate(q, h * k3), index + 2)
    return integrate(q, h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))


def integrate(robot, q, v, tau, dt, duration):
    for _ in range(round(duration / dt)):
        q, v = torqueopt.rk4_step(robot, q, v, tau, dt)
    return q, v


def assert_fourth_order(robot, q0, v0, tau, duration=0.4):
    """The RK4 error falls ~16x each time dt halves, against a dt = 1e-4 run."""
    q_fine, v_fine = integrate(robot, q0, v0, tau, 1e-4, duration)
    errors = []
    for dt in (0.02, 0.01, 0.005):
        q, v = integrate(robot, q0, v0, tau, dt, duration)
        errors.append(np.linalg.norm(np.concatenate([pin.difference(robot.model, q_fine, q), v - v_fine])))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    for ratio in ratios:
        assert 13.0 < ratio < 19.0, (errors, ratios)


def test_rk4_error_falls_sixteenfold_when_dt_halves(planar3):
    assert planar3.euclidean  # configurations add: the stepper folds q into its stage products
    assert_fourth_order(planar3, np.array([0.3, -1.1, 0.7]), np.array([1.5, -2.0, 3.0]), np.array([4.0, -2.0, 0.5]))


def test_rk4_is_fourth_order_with_continuous_joints_too():
    kinova = torqueopt.load_robot("kinova", gravity=False)
    assert not kinova.euclidean  # (cos, sin) joints: the stepper calls Pinocchio's integrate
    q0 = kinova.configuration([0.3, 2.5, 1.2, -0.4, 0.9, 0.2])
    v0 = np.array([1.5, -1.0, 0.8, 2.0, -1.5, 3.0])
    assert_fourth_order(kinova, q0, v0, np.array([0.5, -1.0, 0.3, 0.1, -0.05, 0.02]))


def test_both_rk4_paths_give_the_same_step(monkeypatch):
    """Folding q into the stage products (revolute joints) is the same step as integrate."""
    robot = torqueopt.load_robot("planar3")  # its own: the test switches its integrate path
    q, v, tau = np.array([0.3, -1.1, 0.7]), np.array([1.5, -2.0, 3.0]), np.array([4.0, -2.0, 0.5])
    folded = torqueopt.rk4_step(robot, q, v, tau, 1e-3)
    monkeypatch.setattr(robot, "euclidean", False)
    integrated = torqueopt.rk4_step(robot, q, v, tau, 1e-3)
    for a, b in zip(folded, integrated):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)


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


# -- the fast stepper against the textbook reference ------------------------------------


def _random_states(robot, count, seed):
    """Seeded states (q, v, τ) around the default configuration, drawn with numpy."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = robot.integrate(robot.default_configuration, rng.uniform(-1.0, 1.0, robot.nv))
        yield q, rng.uniform(-2.0, 2.0, robot.nv), rng.uniform(-5.0, 5.0, robot.nv)


def _robots():
    return [
        torqueopt.load_robot("planar3"),
        torqueopt.load_robot("panda", task="position"),
        torqueopt.load_robot("kinova", gravity=False),  # continuous joints: the integrate path
    ]


def test_fast_stepper_equals_the_reference_step_on_several_robots():
    for robot in _robots():
        for q, v, tau in _random_states(robot, 10, seed=7):
            fast_q, fast_v = torqueopt.rk4_step(robot, q, v, tau, 1e-3)
            ref_q, ref_v = rk4_reference_step(robot, q, v, tau, 1e-3)
            scale = 1.0 + np.abs(ref_v).max()
            np.testing.assert_allclose(fast_q, ref_q, rtol=0, atol=1e-12, err_msg=robot.name)
            np.testing.assert_allclose(fast_v, ref_v, rtol=0, atol=1e-12 * scale, err_msg=robot.name)


def test_every_step_of_a_run_is_the_reference_step():
    """Each recorded step (q_k, v_k, τ_k) -> (q_k+1, v_k+1) of the paper's long null-space run."""
    from torqueopt.paper import PAPER, run_movement

    result = run_movement(PAPER, "long", "null-space")
    robot = PAPER.load_robot()
    data = robot.model.createData()
    for k in range(0, len(result.t) - 1, 7):
        q, v = rk4_reference_step(robot, result.q[k], result.v[k], result.tau[k], result.dt, data)
        np.testing.assert_allclose(q, result.q[k + 1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(v, result.v[k + 1], rtol=0, atol=1e-12 * (1.0 + np.abs(v).max()))


def test_a_whole_run_replayed_by_the_reference_stays_on_the_simulated_one():
    """The short movement's torques, replayed open loop by the reference RK4, give the same motion."""
    from torqueopt.paper import PAPER, run_movement

    result = run_movement(PAPER, "short", "null-space")
    robot = PAPER.load_robot()
    q, v = result.q[0], result.v[0]
    for k in range(len(result.t) - 1):
        q, v = rk4_reference_step(robot, q, v, result.tau[k], result.dt)
    np.testing.assert_allclose(q, result.q[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(v, result.v[-1], rtol=0, atol=1e-9)


# -- the one stepper on one state and on stacks -----------------------------------------


def test_held_torque_rk4_on_stacks_equals_the_reference_step_row_by_row():
    """The stepper on a (B, n) stack (abaInParallel per stage) and on one state, against the textbook stages."""
    for robot in _robots():
        integrator = RK4(HeldTorque(robot), 1e-3)
        states = list(_random_states(robot, 6, seed=11))
        q, v, tau = (np.array(column) for column in zip(*states))
        k1 = np.array([robot.forward_dynamics(*state) for state in states])
        stack_q, stack_v = integrator.step(q, v, tau, k1)
        for row, (q_i, v_i, tau_i) in enumerate(states):
            ref_q, ref_v = rk4_reference_step(robot, q_i, v_i, tau_i, 1e-3)
            one_q, one_v = integrator.step(q_i, v_i, tau_i, k1[row])
            scale = 1.0 + np.abs(ref_v).max()
            for ours_q, ours_v in ((stack_q[row], stack_v[row]), (one_q, one_v)):
                np.testing.assert_allclose(ours_q, ref_q, rtol=0, atol=1e-12, err_msg=robot.name)
                np.testing.assert_allclose(ours_v, ref_v, rtol=0, atol=1e-12 * scale, err_msg=robot.name)


def test_the_stage_weights_are_rk4s_tableau_folded():
    """The weights of stage 3 and of the end, written out by hand from the stages above."""
    from torqueopt.integrators import stage_weights

    h = 0.01
    _, stage3, _, end = stage_weights(h, 2, True)
    np.testing.assert_array_equal(stage3, [[1.0, h / 2, h * h / 4, 0.0], [0.0, 1.0, 0.0, h / 2]])
    np.testing.assert_array_equal(
        end, [[1.0, h, h * h / 6, h * h / 6, h * h / 6, 0.0], [0, 1, h / 6, h / 3, h / 3, h / 6]]
    )
    np.testing.assert_array_equal(stage_weights(h, 1, False)[3], [h / 6, h / 3, h / 3, h / 6])


def _velocity_rates(robot, count):
    """Seeded rates of velocity-pinv, f(q, sample), for one state and for a stack of ``count`` (a loop of rows)."""
    from torqueopt.resolvers import get_resolver
    from torqueopt.tasks import FrameTask, Kinematics

    task = FrameTask.of_robot(robot, reference_rotation=np.eye(3))
    kinematics = Kinematics(robot)
    rates = get_resolver("velocity-pinv").rate_function(robot, task)
    commands = np.random.default_rng(2).normal(size=(3, count, robot.m))

    def one(q, index, row=0):
        kinematics.update(q)
        return rates(kinematics, commands[index, row])[0]

    def stack(q, index):
        return np.array([one(q_i, index, row) for row, q_i in enumerate(q)])

    return one, stack


def test_velocity_rk4_equals_its_reference_step_on_one_state_and_on_stacks(planar3, panda):
    """The velocity-level system's step (k1 given), single and stacked, against the textbook stages."""
    kinova = torqueopt.load_robot("kinova", task="position")
    assert not kinova.euclidean  # (cos, sin) joints: the folded stages give increments for integrate
    for robot in (planar3, panda, kinova):
        one, stack = _velocity_rates(robot, 5)
        states = np.array([q for q, _, _ in _random_states(robot, 5, seed=3)])
        single = RK4(VelocityRates(robot, one), 1e-2)
        stacked_q, none = RK4(VelocityRates(robot, stack), 1e-2).step(states, None, 0, stack(states, 0))
        assert none is None
        for row, q in enumerate(states):
            reference = velocity_reference_step(robot, lambda c, i, row=row: one(c, i, row), q, 0, 1e-2)
            if row == 0:
                np.testing.assert_allclose(single.step(q, None, 0, one(q, 0))[0], reference, rtol=0, atol=1e-12)
            np.testing.assert_allclose(stacked_q[row], reference, rtol=0, atol=1e-12, err_msg=robot.name)
            assert np.abs(reference - q).max() > 1e-4  # the step moved


def test_velocity_rates_torque_is_rnea_in_a_fresh_array(planar3):
    """The torque a row keeps is not overwritten by the next step's: Pinocchio's RNEA returns a new array."""
    system = VelocityRates(planar3, None)
    q, v, acceleration = np.array([0.3, -1.1, 0.7]), np.array([1.5, -2.0, 3.0]), np.array([4.0, -2.0, 0.5])
    torque = system.torque(q, v, acceleration)
    kept = torque.copy()
    system.torque(q + 0.1, -v, 2.0 * acceleration)
    np.testing.assert_array_equal(torque, kept)
    np.testing.assert_allclose(torque, pin.rnea(planar3.model, planar3.model.createData(), q, v, acceleration))
