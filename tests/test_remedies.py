"""The remedies: damped-null-space, self-motion-damping, inverse-inertia-torque and
inverse-inertia-squared-torque, at seeded random states on the planar arm and on
panda's position task, each held to something independent of its own code:

* the optimality conditions of its criterion, and a general-purpose solve of it
  (scipy's minimiser over the null-space coordinates, or the KKT system over q̈
  with the task as an equality, assembled here with numpy);
* the limits of the blend: μ = 0 is null-space / weighted-null-space, μ → ∞ is
  self-motion damping, written out here from its formula;
* self-motion damping makes the kinetic energy of a free null-space motion decay.
"""

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import minimize

import torqueopt
from torqueopt.cli import main
from torqueopt.resolvers.null_space import torque_midpoint

from .conftest import PAPER_Q0

ROBOTS = ["planar3", "panda"]


def states(robot, rng, count=5):
    """Seeded random (q, q̇, ẍ, terms) away from singular Jacobians, drawn with numpy only."""
    lower = np.where(np.isfinite(robot.model.lowerPositionLimit), robot.model.lowerPositionLimit, -np.pi)
    upper = np.where(np.isfinite(robot.model.upperPositionLimit), robot.model.upperPositionLimit, np.pi)
    found = 0
    while found < count:
        angles = (
            rng.uniform(lower[: robot.nv], upper[: robot.nv])
            if robot.nq == robot.nv
            else rng.uniform(-np.pi, np.pi, robot.nv)
        )
        q = robot.configuration(angles)
        v = rng.uniform(-1.5, 1.5, robot.nv)
        terms = robot.terms(q, v)
        singular_values = np.linalg.svd(terms.jacobian, compute_uv=False)
        if singular_values[-1] < 1e-2 * singular_values[0]:
            continue
        found += 1
        yield q, v, rng.uniform(-2.0, 2.0, robot.m), terms


def null_basis(jacobian):
    """An orthonormal basis of the null space of J from numpy's SVD (not the package's)."""
    return np.linalg.svd(jacobian)[2][jacobian.shape[0] :].T


def particular(terms, xdd):
    return np.linalg.pinv(terms.jacobian).dot(xdd - terms.drift)


def range_root(robot):
    return 1.0 / (robot.torque_upper - robot.torque_lower)


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("torque_weight", ["unit", "range"])
def test_damped_null_space_is_the_optimum_of_its_criterion(robot_name, torque_weight, request, rng):
    """Stationarity, ZᵀHSᵀS(τ − τ_mid) + μ̄²(y + K_D Zᵀq̇) = 0 with y = Zᵀq̈ and μ̄ = μ‖SHZ‖_F;
    no lower value found by scipy's BFGS on the criterion written out over y; and numpy's least
    squares of the stacked system, in a null-space basis of numpy's own SVD."""
    robot = request.getfixturevalue(robot_name)
    mu, damping = 0.7, 4.0
    resolver = torqueopt.get_resolver(
        "damped-null-space", kinematic_weight=mu, damping=damping, torque_weight=torque_weight
    )
    root = np.ones(robot.nv) if torque_weight == "unit" else range_root(robot)
    midpoint = torque_midpoint(robot)
    step = resolver.solver(robot)
    for q, v, xdd, terms in states(robot, rng, count=3):
        resolution = step(terms, xdd)
        Z = null_basis(terms.jacobian)
        H, b = terms.inertia, terms.bias_torque
        weight = mu * np.linalg.norm(root[:, None] * H.dot(Z))
        p = particular(terms, xdd)
        y = Z.T.dot(resolution.joint_acceleration)
        np.testing.assert_allclose(resolution.joint_acceleration, p + Z.dot(y), atol=1e-9)  # on the task's affine set
        torque_residual = root * (resolution.torque - midpoint)
        gradient = (root[:, None] * H.dot(Z)).T.dot(torque_residual) + weight**2 * (y + damping * Z.T.dot(v))
        scale = np.linalg.norm(root[:, None] * H.dot(Z)) * (
            np.linalg.norm(torque_residual) + weight * np.linalg.norm(y)
        )
        assert np.abs(gradient).max() < 1e-9 * scale

        def criterion(coordinates, H=H, b=b, p=p, Z=Z, v=v, weight=weight):
            torque = H.dot(p + Z.dot(coordinates)) + b
            return float(
                np.sum((root * (torque - midpoint)) ** 2)
                + weight**2 * np.sum((coordinates + damping * Z.T.dot(v)) ** 2)
            )

        best = minimize(criterion, np.zeros(robot.redundancy), method="BFGS", options={"gtol": 1e-10})
        assert criterion(y) <= best.fun + 1e-9 * (1 + best.fun)  # no general-purpose search does better
        # The same optimum as numpy's least squares of the stacked system [SHZ; μ̄I] y ≈ [S(τ_mid − τ̃); −μ̄K_D Zᵀq̇].
        stacked = np.vstack([root[:, None] * H.dot(Z), weight * np.eye(robot.redundancy)])
        target = np.concatenate([root * (midpoint - H.dot(p) - b), -weight * damping * Z.T.dot(v)])
        expected = np.linalg.lstsq(stacked, target, rcond=None)[0]
        np.testing.assert_allclose(y, expected, rtol=1e-8, atol=1e-9 * (1 + np.abs(expected).max()))


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_kinematic_weight_zero_is_the_papers_null_space_methods(robot_name, request, rng):
    robot = request.getfixturevalue(robot_name)
    pairs = [
        ({"torque_weight": "unit"}, torqueopt.get_resolver("null-space")),
        ({"torque_weight": "range"}, torqueopt.get_resolver("weighted-null-space")),
        ({"torque_weight": np.arange(1.0, robot.nv + 1)}, torqueopt.get_resolver("weighted-null-space", weight=np.arange(1.0, robot.nv + 1))),
    ]  # fmt: skip
    for options, paper_resolver in pairs:
        blend = torqueopt.get_resolver("damped-null-space", kinematic_weight=0.0, damping=7.0, **options).solver(robot)
        paper = paper_resolver.solver(robot)
        for q, v, xdd, terms in states(robot, rng, count=3):
            expected = paper(terms, xdd).torque
            np.testing.assert_allclose(
                blend(terms, xdd).torque, expected, rtol=0, atol=1e-10 * (1 + np.abs(expected).max())
            )


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_large_kinematic_weight_approaches_self_motion_damping(robot_name, request, rng):
    """As μ grows, the blend's q̈ tends to J⁺(ẍ − J̇q̇) − K_D (I − J⁺J) q̇, with a gap shrinking like 1/μ²."""
    robot = request.getfixturevalue(robot_name)
    damping = 6.0
    for q, v, xdd, terms in states(robot, rng, count=3):
        J_pinv = np.linalg.pinv(terms.jacobian)
        formula = J_pinv.dot(xdd - terms.drift) - damping * (np.eye(robot.nv) - J_pinv.dot(terms.jacobian)).dot(v)
        damped = torqueopt.get_resolver("self-motion-damping", damping=damping).resolve(robot, terms, xdd)
        np.testing.assert_allclose(damped.joint_acceleration, formula, atol=1e-9 * (1 + np.abs(formula).max()))
        gaps = []
        for mu in (1e2, 1e3, 1e4):
            blend = torqueopt.get_resolver("damped-null-space", kinematic_weight=mu, damping=damping).resolve(
                robot, terms, xdd
            )
            gaps.append(np.abs(blend.joint_acceleration - formula).max())
        assert gaps[2] < 1e-6 * (1 + np.abs(formula).max())
        assert gaps[1] < 2e-2 * gaps[0] and gaps[2] < 2e-2 * gaps[1]


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("name", ["inverse-inertia-torque", "inverse-inertia-squared-torque"])
def test_inverse_inertia_resolvers_solve_their_kkt_systems(name, robot_name, request, rng):
    """min (Hq̈ + b)ᵀ M (Hq̈ + b) with M = H⁻ᵏ (k = 1, 2) subject to J q̈ = ẍ − J̇q̇, by its KKT
    system over (q̈, λ): [[2 HᵀMH, Jᵀ], [J, 0]] [q̈; λ] = [−2 HᵀM b; ẍ − J̇q̇], solved here with numpy;
    and the stationarity the docstrings state: Zᵀτ = 0 (k = 1), Zᵀ H⁻¹τ = 0 (k = 2)."""
    robot = request.getfixturevalue(robot_name)
    power = 1 if name == "inverse-inertia-torque" else 2
    step = torqueopt.get_resolver(name).solver(robot)
    n, m = robot.nv, robot.m
    for q, v, xdd, terms in states(robot, rng, count=4):
        H, b, J = terms.inertia, terms.bias_torque, terms.jacobian
        metric = np.linalg.matrix_power(np.linalg.inv(H), power)
        kkt = np.block([[2 * H.T.dot(metric).dot(H), J.T], [J, np.zeros((m, m))]])
        rhs = np.concatenate([-2 * H.T.dot(metric).dot(b), xdd - terms.drift])
        expected = np.linalg.solve(kkt, rhs)[:n]
        resolution = step(terms, xdd)
        np.testing.assert_allclose(
            resolution.joint_acceleration, expected, rtol=1e-7, atol=1e-8 * (1 + np.abs(expected).max())
        )
        Z = null_basis(J)
        stationary = Z.T.dot(resolution.torque if power == 1 else np.linalg.solve(H, resolution.torque))
        assert np.abs(stationary).max() < 1e-8 * (1 + np.abs(resolution.torque).max())


def test_inverse_inertia_resolvers_reduce_to_the_pseudoinverses_at_rest(planar3, rng):
    """With q̇ = 0 and no gravity (b = 0): τᵀH⁻¹τ = q̈ᵀHq̈ (inertia-pinv) and τᵀH⁻²τ = ‖q̈‖² (pinv)."""
    for q, v, xdd, terms in states(planar3, rng, count=3):
        rest = planar3.terms(q, np.zeros(3))
        for remedy, classic in (("inverse-inertia-torque", "inertia-pinv"), ("inverse-inertia-squared-torque", "pinv")):
            got = torqueopt.get_resolver(remedy).resolve(planar3, rest, xdd).torque
            np.testing.assert_allclose(
                got, torqueopt.get_resolver(classic).resolve(planar3, rest, xdd).torque, atol=1e-9
            )


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_self_motion_damping_makes_a_free_self_motion_decay(robot_name, request, rng):
    """Start with a pure self-motion (q̇ in the null space of J) and ask for ẍ = 0: the tip stays put
    and all the kinetic energy ½q̇ᵀHq̇ is self-motion. Under self-motion-damping it decays about as
    exp(−2 K_D t); under pinv, which does not act on the self-motion, it does not."""
    robot = request.getfixturevalue(robot_name)
    damping, dt, steps = 5.0, 1e-3, 300
    q = robot.configuration(PAPER_Q0) if robot.nv == 3 else robot.default_configuration
    Z = null_basis(robot.terms(q, np.zeros(robot.nv)).jacobian)
    v0 = Z.dot(rng.normal(size=robot.redundancy))
    v0 *= 0.5 / np.linalg.norm(v0)
    energies = {}
    for name in ("self-motion-damping", "pinv"):
        step = torqueopt.get_resolver(name, **({"damping": damping} if name == "self-motion-damping" else {})).solver(
            robot
        )
        state_q, state_v = q.copy(), v0.copy()
        start_tip = robot.task_position(q)
        for _ in range(steps):
            terms = robot.terms(state_q, state_v)
            resolution = step(terms, np.zeros(robot.m))
            state_q, state_v = torqueopt.rk4_step(robot, state_q, state_v, resolution.torque, dt)
        terms = robot.terms(state_q, state_v)
        np.testing.assert_allclose(robot.task_position(state_q), start_tip, atol=2e-3)
        energies[name] = 0.5 * state_v.dot(terms.inertia).dot(state_v)
    initial = 0.5 * v0.dot(robot.terms(q, v0).inertia).dot(v0)
    decay = np.exp(-2 * damping * dt * steps)  # 0.05
    assert energies["self-motion-damping"] < 3 * decay * initial
    assert energies["pinv"] > 0.3 * initial


def test_new_option_values_are_checked_with_one_line_messages(planar3):
    cases = [
        ({"damping": -1}, "option damping=-1 of resolver 'damped-null-space' must be a number in [0, 1e+06] [1/s]"),
        ({"kinematic_weight": "lots"}, "option kinematic_weight=lots of resolver 'damped-null-space' is not a number; give a number in [0, 1e+06]"),
        ({"torque_weight": "ranges"}, "option torque_weight=ranges of resolver 'damped-null-space' must be 'unit' | 'range' or a vector of numbers [1/(N·m)² for a vector]"),
        ({"kinematic_wieght": 1.0}, "unknown option 'kinematic_wieght' for resolver 'damped-null-space' (did you mean 'kinematic_weight'?); valid options: kinematic_weight, damping, torque_weight, singular_tolerance"),
    ]  # fmt: skip
    for options, message in cases:
        with pytest.raises(torqueopt.InvalidInput) as error:
            torqueopt.get_resolver("damped-null-space", **options)
        assert str(error.value) == message
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.get_resolver("damped-null-space", torque_weight=[1.0, 2.0]).check(planar3)
    assert str(error.value) == (
        "option torque_weight=1,2 of resolver 'damped-null-space' must be 'unit', 'range' or 3 non-negative numbers, "
        "one per joint of robot 'planar3' (the diagonal of W)"
    )
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.get_resolver("self-motion-damping", kinematic_weight=1.0)
    assert str(error.value) == (
        "unknown option 'kinematic_weight' for resolver 'self-motion-damping'; valid options: damping, singular_tolerance"
    )


def test_remedies_run_from_the_cli_with_their_options(tmp_path, capsys):
    out = tmp_path / "run.npz"
    code = main(["run", "--robot", "planar3", "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1",
                 "--duration", "0.3", "--resolver", "damped-null-space", "--option", "kinematic_weight=0.25",
                 "--option", "torque_weight=range", "--out", str(out)])  # fmt: skip
    assert code == 0
    result = torqueopt.load_result(out)
    assert result.resolver == "damped-null-space"
    assert result.resolver_options == {
        "kinematic_weight": 0.25,
        "damping": 10.0,
        "torque_weight": "range",
        "singular_tolerance": 1e-6,
    }
    expected = torqueopt.simulate(torqueopt.load_robot("planar3"), "damped-null-space", torqueopt.StraightLine([1, 1], duration=0.3),
                                  PAPER_Q0, resolver_options={"kinematic_weight": 0.25, "torque_weight": "range"})  # fmt: skip
    np.testing.assert_allclose(result.tau, expected.tau, rtol=1e-9, atol=1e-9)
    capsys.readouterr()
    assert main(["run", "--robot", "planar3", "--direction", "1,1", "--resolver", "self-motion-damping",
                 "--option", "damping=abc"]) == 2  # fmt: skip
    assert capsys.readouterr().err.strip() == (
        "torqueopt run: error: option damping=abc of resolver 'self-motion-damping' is not a number; "
        "give a number in [0, 1e+06] [1/s]"
    )


def test_remedies_realise_the_task_through_pinocchio_dynamics(panda, rng):
    """Independent of Resolution's own joint acceleration: ABA from the torque alone realises ẍ."""
    data = panda.model.createData()
    for name in (
        "damped-null-space",
        "self-motion-damping",
        "inverse-inertia-torque",
        "inverse-inertia-squared-torque",
    ):
        step = torqueopt.get_resolver(name).solver(panda)
        for q, v, xdd, terms in states(panda, rng, count=2):
            resolution = step(terms, xdd)
            acceleration = pin.aba(panda.model, data, q, v, resolution.torque)
            np.testing.assert_allclose(terms.jacobian.dot(acceleration) + terms.drift, xdd, atol=1e-8)
            assert resolution.task_error == 0.0 and not resolution.infeasible
