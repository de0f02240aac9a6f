"""The bounded resolvers (``bounded-torque`` QP, ``minmax-torque`` LP) against independent solves.

Every reference here is built from H, the bias torques, J and J̇q̇ alone,
with its own null-space basis (scipy.linalg.null_space) and pseudoinverse
(numpy): closed-form interval solutions for planar3's single null-space
coordinate, SLSQP for the 7-joint arm, HiGHS (scipy.optimize.linprog) for
the LPs and the feasibility checks, bounded least squares
(scipy.optimize.lsq_linear) for the least task error, and KKT multipliers
recovered by non-negative least squares on the active set.
"""

import re

import numpy as np
import pytest
from scipy.linalg import null_space
from scipy.optimize import linprog, lsq_linear, minimize, nnls

import torqueopt
from torqueopt.errors import InvalidInput, NoRedundancy, TorqueBoundsInfeasible
from torqueopt.resolvers import get_resolver
from torqueopt.resolvers.bounded import BOUND_MARGIN, torque_utilisation

from .conftest import PAPER_Q0

#: Bounds hold exactly: the resolvers pull the bounds DAQP sees in by its tolerance.
BOUND_SLACK = 0.0


@pytest.fixture(scope="module")
def tight_planar3():
    """The paper's arm with its own limits (54, 24, 6) N·m: random states hit them often."""
    return torqueopt.load_robot("planar3")


@pytest.fixture(scope="module")
def tight_panda():
    """Panda position task with a third of its URDF limits (29 and 4 N·m), gravity on."""
    robot = torqueopt.load_robot("panda", task="position")
    return robot.with_torque_limit(robot.urdf_effort_limit / 3.0)


def _step(name, robot, **options):
    resolver = get_resolver(name, **options)
    resolver.check(robot)
    return resolver.solver(robot)


def _states(robot, count, seed, speed, accel):
    """Seeded random (q, v, ẍ) away from singular Jacobians."""
    rng = np.random.default_rng(seed)
    states = []
    while len(states) < count:
        if robot.name == "planar3":
            angles = rng.uniform(-2.5, 2.5, robot.nv)
        else:
            angles = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
        q = robot.configuration(angles)
        terms = robot.terms(q, speed * rng.normal(size=robot.nv))
        singular = np.linalg.svd(terms.jacobian, compute_uv=False)
        if singular[-1] < 1e-2 * singular[0]:
            continue
        states.append((terms, accel * rng.normal(size=robot.m)))
    return states


class Reference:
    """The problem at one state, from scratch: τ = τ̃ + G y with G = H Z."""

    def __init__(self, robot, terms, task_acceleration):
        self.robot = robot
        self.H, self.b, self.J = terms.inertia, terms.bias_torque, terms.jacobian
        self.drift, self.v = terms.drift, terms.joint_velocity
        self.xdd = np.asarray(task_acceleration, float)
        self.pinv = np.linalg.pinv(self.J)
        self.Z = null_space(self.J)
        self.G = self.H @ self.Z
        self.lower, self.upper = robot.torque_lower, robot.torque_upper
        self.spread = self.upper - self.lower
        finite = np.isfinite(self.spread)
        self.mid = 0.5 * (np.where(finite, self.upper, 0.0) + np.where(finite, self.lower, 0.0))

    def tilde(self, task_acceleration=None):
        xdd = self.xdd if task_acceleration is None else task_acceleration
        return self.H @ self.pinv @ (xdd - self.drift) + self.b  # Eq. (28)

    def feasible(self, task_acceleration) -> bool:
        """Is there a y with τ̃ + G y within bounds? (HiGHS, zero objective.)"""
        tilde = self.tilde(task_acceleration)
        rows = np.vstack([self.G, -self.G]) / np.r_[self.spread, self.spread][:, None]
        rhs = np.r_[self.upper - tilde, tilde - self.lower] / np.r_[self.spread, self.spread]
        found = linprog(
            np.zeros(self.Z.shape[1]), A_ub=rows, b_ub=rhs, bounds=[(None, None)] * self.Z.shape[1], method="highs"
        )
        return found.status == 0

    def coordinates(self, resolution, task_acceleration=None):
        """y of a resolution in this basis: q̈ = J⁺(ẍ − J̇q̇) + Z y."""
        xdd = self.xdd if task_acceleration is None else task_acceleration
        return self.Z.T @ (resolution.joint_acceleration - self.pinv @ (xdd - self.drift))


def _qp_pieces(ref, root, mu, damping):
    """½‖S(τ − τ_mid)‖² + ½μ̄²‖y + K_D Zᵀq̇‖² with μ̄ = μ‖SHZ‖_F, and its gradient, as functions of y."""
    mu = mu * np.linalg.norm(root[:, None] * ref.G)

    def gradient(y):
        tau = ref.tilde() + ref.G @ y
        return ref.G.T @ (root**2 * (tau - ref.mid)) + mu**2 * (y + damping * ref.Z.T @ ref.v)

    def cost(y):
        tau = ref.tilde() + ref.G @ y
        return 0.5 * np.sum((root * (tau - ref.mid)) ** 2) + 0.5 * mu**2 * np.sum((y + damping * ref.Z.T @ ref.v) ** 2)

    return cost, gradient


def _slsqp(ref, cost, gradient, start):
    """SLSQP on the same criterion and bounds, from ``start``."""
    tilde = ref.tilde()
    rows = ref.G / ref.spread[:, None]
    constraints = [
        {"type": "ineq", "fun": lambda z: (ref.upper - tilde - ref.G @ z) / ref.spread, "jac": lambda z: -rows},
        {"type": "ineq", "fun": lambda z: (tilde + ref.G @ z - ref.lower) / ref.spread, "jac": lambda z: rows},
    ]
    options = {"ftol": 1e-14, "maxiter": 500}
    return minimize(cost, start, jac=gradient, constraints=constraints, method="SLSQP", options=options)


def _assert_kkt_qp(ref, y, gradient):
    """Primal feasibility, and multipliers λ ≥ 0 on the active rows only (NNLS) that make the Lagrangian stationary."""
    tau = ref.tilde() + ref.G @ y
    assert np.all(tau <= ref.upper + BOUND_SLACK * ref.spread)
    assert np.all(tau >= ref.lower - BOUND_SLACK * ref.spread)
    at_upper = np.flatnonzero(tau >= ref.upper - 1e-7 * ref.spread)
    at_lower = np.flatnonzero(tau <= ref.lower + 1e-7 * ref.spread)
    g = gradient(y)
    # Stationarity: ∇f + Σ λ⁺ G_i − Σ λ⁻ G_i = 0 with λ ≥ 0; complementary slackness: λ = 0 off the active set.
    columns = np.hstack([ref.G[at_upper].T, -ref.G[at_lower].T])
    if columns.shape[1] == 0:
        residual = np.linalg.norm(g)
    else:
        _, residual = nnls(columns, -g)
    scale = np.linalg.norm(ref.G.T @ np.abs(tau - ref.mid)) + 1.0
    assert residual <= 1e-7 * scale, (residual, scale, at_upper, at_lower)
    return at_upper.size + at_lower.size


# -- the QP -----------------------------------------------------------------------------------


def test_bounded_torque_equals_the_unbounded_resolvers_when_bounds_are_inactive():
    for name, task in (("planar3", "xy"), ("panda", "position")):
        wide = torqueopt.load_robot(name, task=task, torque_limit=1e5)
        pairs = [
            ({"kinematic_weight": 0.0}, "null-space", {}),
            ({"kinematic_weight": 0.0, "torque_weight": "range"}, "weighted-null-space", {}),
            ({}, "damped-null-space", {}),
            (
                {"torque_weight": "range", "damping": 3.0},
                "damped-null-space",
                {"torque_weight": "range", "damping": 3.0},
            ),
        ]
        for options, reference, reference_options in pairs:
            bounded = _step("bounded-torque", wide, **options)
            plain = get_resolver(reference, **reference_options).solver(wide)
            for terms, xdd in _states(wide, 5, 11, 0.5, 2.0):
                expected = plain(terms, xdd)[0]
                found = bounded(terms, xdd)
                assert not found.infeasible and found.task_error == 0.0
                np.testing.assert_allclose(found.torque, expected, rtol=0, atol=1e-8 * max(1.0, np.abs(expected).max()))


def test_bounded_torque_on_planar3_is_the_clipped_interval_optimum(tight_planar3):
    """One null-space coordinate: the feasible y form an interval, and the QP's optimum is the unconstrained one clipped to it."""
    robot = tight_planar3
    step = _step("bounded-torque", robot, kinematic_weight=0.0)
    active = 0
    checked = 0
    for terms, xdd in _states(robot, 40, 3, 0.3, 2.0):
        ref = Reference(robot, terms, xdd)
        g = ref.G[:, 0]
        tilde = ref.tilde()
        # g_i y within [τ⁻_i − τ̃_i, τ⁺_i − τ̃_i] for each joint i.
        ends = np.sort(np.vstack([(ref.lower - tilde) / g, (ref.upper - tilde) / g]), axis=0)
        low, high = ends[0].max(), ends[1].min()
        if low > high:
            continue
        unconstrained = -g @ (tilde - ref.mid) / (g @ g)
        expected_y = np.clip(unconstrained, low, high)
        found = step(terms, xdd)
        assert not found.infeasible
        checked += 1
        active += not (low < unconstrained < high)
        # The resolver keeps BOUND_MARGIN of each range inside the limits: an active bound moves y by that much.
        margin = 2 * BOUND_MARGIN * np.max(ref.spread / np.abs(g))
        np.testing.assert_allclose(ref.coordinates(found)[0], expected_y, rtol=1e-9, atol=margin)
        np.testing.assert_allclose(found.torque, tilde + g * expected_y, rtol=1e-9, atol=margin * np.abs(g).max())
    assert checked >= 10 and active >= 3, (checked, active)


@pytest.mark.parametrize(
    "options, accel",
    # The range weight keeps torques well inside their ranges (as the paper found): it needs harder tasks to hit them.
    [
        ({"kinematic_weight": 0.0}, 3.0),
        ({"kinematic_weight": 0.0, "torque_weight": "range"}, 8.0),
        ({}, 3.0),
        ({"kinematic_weight": 0.3, "damping": 2.0, "torque_weight": "range"}, 8.0),
    ],
)
def test_bounded_torque_meets_kkt_and_agrees_with_slsqp_on_panda(tight_panda, options, accel):
    robot = tight_panda
    step = _step("bounded-torque", robot, **options)
    resolver = get_resolver("bounded-torque", **options)
    root = resolver.weight_root(robot)
    mu, damping = resolver.kinematic_weight, resolver.damping
    active_states = 0
    for terms, xdd in _states(robot, 12, 7, 0.5, accel):
        ref = Reference(robot, terms, xdd)
        if not ref.feasible(xdd):
            continue
        found = step(terms, xdd)
        assert not found.infeasible and found.task_error == 0.0
        # The task is realised: J q̈ + J̇q̇ = ẍ, and τ = H q̈ + b.
        np.testing.assert_allclose(ref.J @ found.joint_acceleration + ref.drift, xdd, atol=1e-9)
        np.testing.assert_allclose(ref.H @ found.joint_acceleration + ref.b, found.torque, atol=1e-9)
        cost, gradient = _qp_pieces(ref, root, mu, damping)
        y = ref.coordinates(found)
        active_states += _assert_kkt_qp(ref, y, gradient) > 0
        # An independent general-purpose solve reaches the same cost.
        other = _slsqp(ref, cost, gradient, np.zeros_like(y))
        assert cost(y) <= cost(other.x) + 1e-7 * max(1.0, abs(cost(other.x)))
        np.testing.assert_allclose(y, other.x, atol=1e-4 * max(1.0, np.abs(y).max()))
    assert active_states >= 2, active_states


# -- the LP -----------------------------------------------------------------------------------


def _minmax_reference(ref):
    """HiGHS on min t s.t. ±(τ̃ + G y − τ_mid)/(τ⁺ − τ⁻) ≤ t."""
    r = ref.G.shape[1]
    normalised = ref.G / ref.spread[:, None]
    offset = (ref.tilde() - ref.mid) / ref.spread
    rows = np.vstack(
        [np.hstack([normalised, -np.ones((len(offset), 1))]), np.hstack([-normalised, -np.ones((len(offset), 1))])]
    )
    found = linprog(
        np.r_[np.zeros(r), 1.0], A_ub=rows, b_ub=np.r_[-offset, offset], bounds=[(None, None)] * (r + 1), method="highs"
    )
    assert found.status == 0
    return found.x[-1]


@pytest.mark.parametrize("robot_name", ["tight_planar3", "tight_panda"])
def test_minmax_torque_is_the_lp_optimum_with_kkt_multipliers(robot_name, request):
    robot = request.getfixturevalue(robot_name)
    step = _step("minmax-torque", robot, infeasible="exceed")
    for terms, xdd in _states(robot, 12, 5, 0.3, 2.0):
        ref = Reference(robot, terms, xdd)
        found = step(terms, xdd)
        np.testing.assert_allclose(ref.J @ found.joint_acceleration + ref.drift, xdd, atol=1e-9)
        utilisation = torque_utilisation(found.torque, ref.lower, ref.upper)
        expected = _minmax_reference(ref)
        np.testing.assert_allclose(utilisation, expected, rtol=1e-7, atol=1e-9)
        assert found.infeasible == (expected > 0.5 + 1e-6) or abs(expected - 0.5) < 1e-6
        # KKT of min t: multipliers λ ≥ 0 on the rows at |u_i| = t with Σλ = 1 and Σ ±λ_i G_i/R_i = 0.
        normalised = ref.G / ref.spread[:, None]
        u = (found.torque - ref.mid) / ref.spread
        plus = np.flatnonzero(u >= utilisation - 1e-7)
        minus = np.flatnonzero(-u >= utilisation - 1e-7)
        columns = np.vstack(
            [
                np.hstack([normalised[plus].T, -normalised[minus].T]),
                np.hstack([-np.ones(plus.size), -np.ones(minus.size)]),
            ]
        )
        target = np.r_[np.zeros(ref.G.shape[1]), -1.0]
        _, residual = nnls(columns, target)
        assert residual <= 1e-7, (residual, plus, minus)


def test_minmax_torque_within_bounds_when_a_feasible_torque_exists(tight_panda):
    step = _step("minmax-torque", tight_panda)
    for terms, xdd in _states(tight_panda, 12, 9, 0.5, 3.0):
        ref = Reference(tight_panda, terms, xdd)
        found = step(terms, xdd)
        if ref.feasible(xdd):
            assert not found.infeasible and found.task_error == 0.0
        assert torque_utilisation(found.torque, ref.lower, ref.upper) <= 0.5 + BOUND_SLACK


# -- infeasible tasks ---------------------------------------------------------------------------


def _largest_scaling(ref, tolerance=1e-10):
    """Bisection on s with the independent feasibility LP: the largest s in [0, 1] with a torque within bounds."""
    low, high = 0.0, 1.0
    assert ref.feasible(0.0 * ref.xdd)
    if ref.feasible(ref.xdd):
        return 1.0
    while high - low > tolerance:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if ref.feasible(middle * ref.xdd) else (low, middle)
    return low


# Each resolver on one arm in the quick selection (-m "not slow"), on both in the full suite.
@pytest.mark.parametrize(
    "robot_name, name",
    [
        pytest.param("tight_planar3", "bounded-torque", marks=pytest.mark.slow),
        ("tight_planar3", "minmax-torque"),
        ("tight_panda", "bounded-torque"),
        pytest.param("tight_panda", "minmax-torque", marks=pytest.mark.slow),
    ],
)
def test_scale_reports_the_true_largest_feasible_scaling(name, robot_name, request):
    robot = request.getfixturevalue(robot_name)
    step = _step(name, robot, infeasible="scale")
    seen = 0
    for terms, xdd in _states(robot, 10, 13, 0.2, 40.0):
        ref = Reference(robot, terms, xdd)
        if not ref.feasible(0.0 * xdd):
            continue
        expected = _largest_scaling(ref)
        found = step(terms, xdd)
        assert found.infeasible == (expected < 1.0)
        scaling = 1.0 - found.task_error / np.linalg.norm(xdd)
        np.testing.assert_allclose(scaling, expected, atol=1e-7)
        # The realised task acceleration is s ẍ, and the torque is within bounds.
        np.testing.assert_allclose(
            ref.J @ found.joint_acceleration + ref.drift, scaling * xdd, atol=1e-7 * np.abs(xdd).max()
        )
        assert torque_utilisation(found.torque, ref.lower, ref.upper) <= 0.5 + BOUND_SLACK
        seen += found.infeasible
    assert seen >= 3


@pytest.mark.parametrize("robot_name", ["tight_planar3", "tight_panda"])
def test_least_error_is_the_bounded_least_squares_task_acceleration(robot_name, request):
    robot = request.getfixturevalue(robot_name)
    step = _step("bounded-torque", robot, infeasible="least-error")
    seen = 0
    for terms, xdd in _states(robot, 8, 17, 0.2, 40.0):
        ref = Reference(robot, terms, xdd)
        # Independent: over torques in the box, min ‖J H⁻¹(τ − b) + J̇q̇ − ẍ‖ (bounded least squares).
        task_map = ref.J @ np.linalg.inv(ref.H)
        best = lsq_linear(
            task_map, xdd - ref.drift + task_map @ ref.b, bounds=(ref.lower, ref.upper), tol=1e-12, method="bvls"
        )
        least_error = np.linalg.norm(task_map @ best.x - (xdd - ref.drift + task_map @ ref.b))
        found = step(terms, xdd)
        realised = ref.J @ found.joint_acceleration + ref.drift
        np.testing.assert_allclose(found.task_error, np.linalg.norm(realised - xdd), rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(found.task_error, least_error, rtol=1e-5, atol=1e-7)
        assert found.infeasible == (least_error > 1e-6)
        assert torque_utilisation(found.torque, ref.lower, ref.upper) <= 0.5 + BOUND_SLACK
        seen += found.infeasible
    assert seen >= 3


def test_exceed_realises_the_task_with_the_least_largest_excess(tight_planar3):
    step = _step("bounded-torque", tight_planar3, infeasible="exceed")
    terms = tight_planar3.terms(PAPER_Q0, np.zeros(3))
    xdd = np.array([40.0, 40.0])
    ref = Reference(tight_planar3, terms, xdd)
    found = step(terms, xdd)
    assert found.infeasible and found.task_error == 0.0
    np.testing.assert_allclose(ref.J @ found.joint_acceleration + ref.drift, xdd, atol=1e-9)
    np.testing.assert_allclose(
        torque_utilisation(found.torque, ref.lower, ref.upper), _minmax_reference(ref), rtol=1e-8
    )
    assert torque_utilisation(found.torque, ref.lower, ref.upper) > 0.5


def test_stop_policy_raises_with_a_reason(tight_planar3):
    step = _step("bounded-torque", tight_planar3, infeasible="stop")
    terms = tight_planar3.terms(PAPER_Q0, np.zeros(3))
    with pytest.raises(TorqueBoundsInfeasible, match=r"infeasible='stop'.*no torque within bounds"):
        step(terms, np.array([40.0, 40.0]))
    assert not step(terms, np.array([1.0, 1.0])).infeasible


def test_scale_gives_the_least_error_when_even_zero_task_acceleration_has_no_torque_within_bounds(tight_planar3):
    """Fast joints: the velocity torques alone exceed the limits while the tip is held on its path (s = 0). (Joint
    limits off: at this state they conflict with the torque bounds too, and are exceeded least before the task
    gives way, tests/test_resolver_joint_limits.py.)"""
    terms = tight_planar3.terms(PAPER_Q0, np.array([4.0, -6.0, 8.0]))
    xdd = np.array([1.0, 1.0])
    ref = Reference(tight_planar3, terms, xdd)
    assert not ref.feasible(np.zeros(2))
    task_map = ref.J @ np.linalg.inv(ref.H)
    target = xdd - ref.drift + task_map @ ref.b
    best = lsq_linear(task_map, target, bounds=(ref.lower, ref.upper), tol=1e-12, method="bvls")
    least_error = np.linalg.norm(task_map @ best.x - target)
    for name in ("bounded-torque", "minmax-torque"):
        for policy in ("scale", "least-error"):
            found = _step(name, tight_planar3, infeasible=policy, joint_limits="off")(terms, xdd)
            assert found.infeasible
            np.testing.assert_allclose(found.task_error, least_error, rtol=1e-6)
            assert torque_utilisation(found.torque, ref.lower, ref.upper) <= 0.5 + BOUND_SLACK


# -- in simulate, and the interface ------------------------------------------------------------------


def test_simulation_records_infeasible_steps_and_task_error():
    robot = torqueopt.load_robot("planar3", torque_limit=[20.0, 10.0, 2.0])
    line = torqueopt.StraightLine(direction=(1.0, 1.0), duration=0.5)
    run = torqueopt.simulate(robot, "bounded-torque", line, PAPER_Q0)
    assert run.completed
    assert run.infeasible.any() and not run.infeasible.all()
    assert np.all(run.task_error[~run.infeasible] == 0.0) and np.all(run.task_error[run.infeasible] > 0)
    applied = np.isfinite(run.tau).all(axis=1)  # the last row, at t = T, applies no torque
    assert applied[:-1].all()
    assert np.all(torque_utilisation(run.tau[applied], run.torque_lower, run.torque_upper) <= 0.5 + BOUND_SLACK)
    # Each recorded step's task error is the true shortfall ‖J q̈ + J̇q̇ − ẍ_ref‖ of its joint acceleration.
    for k in np.flatnonzero(run.infeasible)[::25]:
        terms = robot.terms(run.q[k], run.v[k])
        command = line.anchored(run.x_ref[0]).sample(run.t[k : k + 1]).acceleration[0]
        shortfall = np.linalg.norm(terms.jacobian @ run.acceleration[k] + terms.drift - command)
        np.testing.assert_allclose(run.task_error[k], shortfall, rtol=1e-6)


def test_simulation_stops_with_the_reason_under_the_stop_policy():
    robot = torqueopt.load_robot("planar3", torque_limit=[20.0, 10.0, 2.0])
    line = torqueopt.StraightLine(direction=(1.0, 1.0), duration=0.5)
    run = torqueopt.simulate(robot, get_resolver("bounded-torque", infeasible="stop"), line, PAPER_Q0)
    assert not run.completed
    assert "no torque within bounds" in run.stop_reason and "at t = " in run.stop_reason


def test_bad_options_and_robots_without_limits_are_refused(planar3):
    message = "option infeasible=clip of resolver 'minmax-torque' must be one of scale, least-error, exceed, stop"
    with pytest.raises(InvalidInput, match=message):
        get_resolver("minmax-torque", infeasible="clip")
    with pytest.raises(
        InvalidInput,
        match=re.escape("option torque_weight=ranges of resolver 'bounded-torque' must be 'unit' | 'range'"),
    ):
        get_resolver("bounded-torque", torque_weight="ranges")
    with pytest.raises(
        InvalidInput, match="option damping=-1 of resolver 'bounded-torque' must be a number in \\[0, 1e\\+06\\]"
    ):
        get_resolver("bounded-torque", damping=-1)
    message = "option torque_weight=1,1 of resolver 'bounded-torque' must be 'unit', 'range' or 3 non-negative numbers, one per joint"
    with pytest.raises(InvalidInput, match=message):
        get_resolver("bounded-torque", torque_weight=[1.0, 1.0]).check(planar3)
    with pytest.raises(InvalidInput, match="unknown option 'kinematic_weight' for resolver 'minmax-torque'"):
        get_resolver("minmax-torque", kinematic_weight=1.0)
    unbounded = torqueopt.load_robot("planar3", torque_limit=np.inf)
    for name in ("bounded-torque", "minmax-torque"):
        with pytest.raises(NoRedundancy, match=f"resolver '{name}' bounds torques, but robot 'planar3' has no finite"):
            get_resolver(name).check(unbounded)


def test_unbounded_joints_are_left_out_of_the_max(planar3):
    robot = torqueopt.load_robot("planar3", torque_limit=[54.0, np.inf, 6.0])
    terms = robot.terms(PAPER_Q0, np.zeros(3))
    found = _step("minmax-torque", robot)(terms, np.array([1.0, 1.0]))
    ref = Reference(robot, terms, np.array([1.0, 1.0]))
    u = np.abs(found.torque - ref.mid) / ref.spread
    assert u[1] == 0.0  # infinite range
    np.testing.assert_allclose(torque_utilisation(found.torque, ref.lower, ref.upper), max(u[0], u[2]))


def test_cli_reports_steps_whose_torques_exceed_the_limits_and_refuses_a_bad_policy(capsys):
    from torqueopt.cli import main

    assert main(["run", "--robot", "planar3", "--resolver", "minmax-torque", "--option", "infeasible=exceed",
                 "--direction", "1,1", "--duration", "1.25"]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    robot = torqueopt.load_robot("planar3")
    line = torqueopt.StraightLine((1.0, 1.0), duration=1.25)
    run = torqueopt.simulate(robot, get_resolver("minmax-torque", infeasible="exceed"), line, PAPER_Q0)
    assert run.infeasible_steps > 0 and run.max_task_error == 0.0
    expected = f"task realised, but {run.infeasible_steps} steps found no torque within the limits that realises it"
    assert expected in printed
    assert main(["run", "--robot", "planar3", "--resolver", "bounded-torque", "--option", "infeasible=clip",
                 "--direction", "1,1"]) == 2  # fmt: skip
    message = capsys.readouterr().err.strip().splitlines()
    assert message == [
        "torqueopt run: error: option infeasible=clip of resolver 'bounded-torque' must be one of "
        "scale, least-error, exceed, stop"
    ]


# -- the step on stacks: simulate_batch against simulate -------------------------------------------

BOUNDED = ("bounded-torque", "minmax-torque", "energy-bounded-torque")


def _same_runs(robot, resolver, lines, q0s, tolerance=1e-9, **options):
    """simulate_batch's runs against one simulate run each: every array to ``tolerance``, the same stops, the
    same infeasible steps and the same bounds named on each (limiting); returns the simulate runs."""
    from torqueopt.batch import simulate_batch
    from torqueopt.resolvers.bounded.base import BoundedStackStep

    from .test_batch import assert_same_run

    assert isinstance(resolver.batch_solver(robot, 1e-3), BoundedStackStep)  # the vectorised step, not the loop
    runs = simulate_batch(robot, resolver, lines, q0s, **options)
    references = [torqueopt.simulate(robot, resolver, line, q0, **options) for line, q0 in zip(lines, q0s)]
    for run, reference in zip(runs, references):
        assert_same_run(run, reference, tolerance)
        assert run.limiting == reference.limiting
    return references


@pytest.mark.parametrize(
    "name, joint_limits",
    [
        (name, limits)
        if (name, limits) == ("bounded-torque", "on")
        else pytest.param(name, limits, marks=pytest.mark.slow)
        for name in BOUNDED
        for limits in ("on", "off")
    ],
)
def test_the_batch_equals_simulate_on_planar3(planar3, name, joint_limits):
    """Random starts and directions of 0.5 s and the paper's movement under the paper's limits, and the same
    with joint 2 unbounded (no torque rows for it): the vectorised step on the forest's stacks, row for row."""
    resolver = get_resolver(name, joint_limits=joint_limits)
    rng = np.random.default_rng(5)
    q0s = np.vstack([rng.uniform(-np.pi, np.pi, (4, 3)), PAPER_Q0])
    lines = [torqueopt.StraightLine(d, duration=0.5) for d in rng.normal(size=(4, 2))]
    lines.append(torqueopt.StraightLine((1.0, 1.0), duration=0.5))
    _same_runs(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    partly = torqueopt.load_robot("planar3", torque_limit=[54.0, np.inf, 6.0])
    _same_runs(partly, resolver, lines[3:], q0s[3:])


def _last_bit_sensitivity(robot, resolver, lines, q0s):
    """Largest difference, relative to (1 + |value|), between simulate runs from q0 and from q0 moved by one ulp."""
    from .test_batch import _ARRAYS

    largest = 0.0
    for line, q0 in zip(lines, q0s):
        a = torqueopt.simulate(robot, resolver, line, q0)
        b = torqueopt.simulate(robot, resolver, line, np.nextafter(q0, np.inf))
        for name in _ARRAYS:
            ours, theirs = getattr(a, name), getattr(b, name)
            finite = ~(np.isnan(ours) | np.isnan(theirs))
            if ours.shape == theirs.shape and finite.any():
                largest = max(largest, float(np.max(np.abs(ours - theirs)[finite] / (1.0 + np.abs(theirs[finite])))))
    return largest


@pytest.fixture(scope="module")
def panda_lines():
    """Three 0.5 s lines of panda's position task near its default start; on each the joint-velocity bounds of
    the joint-limit rows bind within the first half (and on the first line the run without them leaves a limit
    later, test_resolver_joint_limits)."""
    robot = torqueopt.load_robot("panda", task="position")
    rng = np.random.default_rng(4)
    q0s = [robot.default_configuration] + [
        robot.default_configuration + rng.normal(scale=0.3, size=7) for _ in range(2)
    ]
    lines = [torqueopt.StraightLine((0.0, 1.0, 0.0), duration=0.5)]
    lines += [torqueopt.StraightLine(rng.normal(size=3), accel=0.5, duration=0.5) for _ in range(2)]
    return robot, lines, q0s


@pytest.mark.parametrize(
    "name", [name if name == "bounded-torque" else pytest.param(name, marks=pytest.mark.slow) for name in BOUNDED]
)
def test_the_batch_equals_simulate_on_panda_with_and_without_joint_limits(panda_lines, name):
    """n = 7, gravity on, joint limits on (their rows bind: the runs differ from those without them) and off."""
    robot, lines, q0s = panda_lines
    on = _same_runs(robot, get_resolver(name, joint_limits="on"), lines, q0s)
    # Without joint limits minmax-torque meets infeasible steps late in these runs (18-61 of 500), whose
    # policy (the scaling LP, then the least-error QP, singular in z, by DAQP's proximal iterations) answers
    # states that agree to 1e-13 within about 3e-9 of each other. The batch and simulate sum in other orders,
    # so they may differ as much as two simulate runs whose starts differ in the last bit: that sensitivity is
    # measured here, on this machine's arithmetic (5e-9 in q̈ on one CPU, 1.3e-8 seen from a batch on another),
    # and the tolerance is ten times it.
    off_resolver = get_resolver(name, joint_limits="off")
    tolerance = 1e-9
    if name == "minmax-torque":
        tolerance = max(tolerance, 10 * _last_bit_sensitivity(robot, off_resolver, lines, q0s))
    off = _same_runs(robot, off_resolver, lines, q0s, tolerance)
    # The joint-limit rows decide these runs: a batch that dropped them would follow the 'off' runs.
    assert max(np.nanmax(np.abs(a.tau - b.tau)) for a, b in zip(on, off)) > 1.0


@pytest.mark.parametrize(
    "name, policy",
    [
        (name, policy) if name == "minmax-torque" else pytest.param(name, policy, marks=pytest.mark.slow)
        for name in BOUNDED
        for policy in ("scale", "least-error", "exceed", "stop")
    ],
)
def test_the_batch_keeps_each_infeasible_policy_and_its_stops(name, policy):
    """Limits of 3 N·m: the paper's movement and a third are infeasible at every step, the second never. The
    infeasible rows go through the single-state policy in the batch: task errors, flags, the bounds named and,
    under 'stop', the stop and its reason, as simulate's, while the feasible movement runs on."""
    from .conftest import PAPER_Q0 as start

    weak = torqueopt.load_robot("planar3", torque_limit=3.0)
    lines = [
        torqueopt.StraightLine((1.0, 1.0), duration=0.6),
        torqueopt.StraightLine((0.2, -1.0), accel=0.1, duration=0.6),
        torqueopt.StraightLine((-1.0, 0.3), duration=0.6),
    ]
    q0s = [start, [0.4, 1.1, -0.7], [1.0, -0.5, 0.8]]
    runs = _same_runs(weak, get_resolver(name, infeasible=policy), lines, q0s)
    assert runs[1].completed and not runs[1].infeasible.any()
    if policy == "stop":
        assert not runs[0].completed and "no torque within bounds" in runs[0].stop_reason
    else:
        assert runs[0].infeasible.all() or runs[0].infeasible[:-1].all()
        assert runs[0].limiting
        # 'exceed' keeps the task (and leaves the bounds), the others give part of it up.
        assert runs[0].task_error.max() == 0.0 if policy == "exceed" else runs[0].task_error.max() > 0.1


def test_a_torque_row_the_null_space_barely_moves_is_not_ignored(planar3):
    """A state of an atlas run (planar3, seed 2026, path 38 of 1 s, t = 0.857 s): joint 3's row of HZ is 5e-5 of
    the largest and the task holds that torque beyond its bound, so no y meets it.
    DAQP's warm-started workspace reported the QP optimal at the unconstrained minimiser, 23 % over joint 3's
    limit, unflagged; the answer is now checked against every row, and the step is infeasible."""
    q = np.array([7.2589171892533222e-02, -4.4058951335041783e-07, 2.7528701234034694e00])
    v = np.array([-0.01891796972520747, 0.06048436588736141, -0.02898020035582756])
    terms = planar3.terms(q, v)
    command = np.array([-0.6575764648592475, 1.2520356196463485])
    # Independently (HiGHS): no y puts τ̃ + HZ y within the bounds; joint 3's row of HZ is all but zero.
    ref = Reference(planar3, terms, command)
    assert not ref.feasible(command)
    assert abs(ref.G[2, 0]) < 1e-3 * np.abs(ref.G).max()
    for name in ("bounded-torque", "energy-bounded-torque"):
        found = get_resolver(name).solver(planar3, 1e-3)(terms, command)
        assert found.infeasible and "torque limit (lower) of joint joint3" in found.limiting
        assert torque_utilisation(found.torque, planar3.torque_lower, planar3.torque_upper) <= 0.5 + BOUND_SLACK


def test_the_command_line_starts_without_scipy_linalg():
    """scipy.linalg (0.3-0.6 s to import) loads on the bounded QP's first vertex step, not with the package."""
    import subprocess
    import sys

    code = "import sys, torqueopt.cli; print('scipy.linalg' in sys.modules)"
    completed = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert completed.stdout.strip() == "False"


# The policies' programs alone (torqueopt.resolvers.bounded.infeasible), each on seeded random numbers
# against HiGHS (scipy.optimize.linprog) or SLSQP on the same program written out here.


def _random_rows(rng, count, columns, point, spread=1.0):
    """``count`` random rows on ``columns`` variables with bounds around their values at ``point``."""
    rows = rng.normal(size=(count, columns))
    values = rows.dot(point)
    return rows, values + spread * rng.uniform(0.1, 1.0, count), values - spread * rng.uniform(0.1, 1.0, count)


@pytest.mark.parametrize("seed", range(4))
def test_largest_task_scaling_is_the_lp_optimum(seed):
    from torqueopt.resolvers.bounded.infeasible import largest_task_scaling, scaling_program

    rng = np.random.default_rng(seed)
    m, r, count = 2, 2, 6
    command = rng.normal(size=m) * 5.0
    # Bounds around a point at s = 0.3: s = 1 is usually beyond them.
    rows, upper, lower = _random_rows(rng, count, m + r, np.r_[0.3 * command, rng.normal(size=r)], spread=0.5)
    achieved, z = largest_task_scaling(scaling_program(count, r), rows, upper, lower, command)
    # max s over (s, z): rows · (s ẍ, z) within bounds, 0 <= s <= 1.
    columns = np.hstack([rows[:, :m].dot(command)[:, None], rows[:, m:]])
    reference = linprog(
        np.r_[-1.0, np.zeros(r)],
        A_ub=np.vstack([columns, -columns]),
        b_ub=np.r_[upper, -lower],
        bounds=[(0.0, 1.0)] + [(None, None)] * r,
        method="highs",
    )
    assert reference.status == 0
    scaling = achieved.dot(command) / command.dot(command)
    assert scaling == pytest.approx(reference.x[0], abs=1e-8)
    np.testing.assert_allclose(achieved, scaling * command, rtol=0, atol=1e-12)  # the direction kept
    values = rows.dot(np.r_[achieved, z])
    assert (values <= upper + 1e-8).all() and (values >= lower - 1e-8).all()


@pytest.mark.parametrize("seed", range(4))
def test_least_error_task_is_the_qp_optimum_and_says_when_there_is_none(seed):
    from torqueopt.resolvers.bounded.infeasible import least_error_program, least_error_task

    rng = np.random.default_rng(10 + seed)
    m, r, count = 2, 2, 6
    command = rng.normal(size=m) * 5.0
    rows, upper, lower = _random_rows(rng, count, m + r, np.r_[0.2 * command, rng.normal(size=r)], spread=0.5)
    program = least_error_program(count, m, r)
    achieved, z = least_error_task(program, rows, upper, lower, command)
    values = rows.dot(np.r_[achieved, z])
    assert (values <= upper + 1e-8).all() and (values >= lower - 1e-8).all()
    # KKT of min ½‖a − ẍ‖² over (a, z): (a − ẍ, 0) + Σ λᵢ rowᵢ = 0 with λ >= 0 on rows at their upper bound
    # and <= 0 at their lower one, the multipliers found by non-negative least squares on the active rows.
    on_upper, on_lower = np.abs(values - upper) <= 1e-7, np.abs(values - lower) <= 1e-7
    active = np.vstack([rows[on_upper], -rows[on_lower]])
    gradient = np.r_[achieved - command, np.zeros(r)]
    _, residual = nnls(active.T, -gradient) if active.size else (np.zeros(0), np.linalg.norm(gradient))
    assert residual <= 1e-7 * (1.0 + np.linalg.norm(command))
    # Two copies of one row with disjoint ranges: no (a, z) at all.
    clash = np.vstack([rows, rows[:1]])
    assert (
        least_error_task(
            least_error_program(count + 1, m, r), clash, np.r_[upper, lower[0] - 1.0], np.r_[lower, lower[0] - 2.0],
            command,
        )
        is None
    )  # fmt: skip


@pytest.mark.parametrize("seed", range(4))
def test_least_joint_excess_is_the_lp_optimum(seed):
    from torqueopt.resolvers.bounded.infeasible import excess_program, least_joint_excess

    rng = np.random.default_rng(20 + seed)
    m, r, nb, nj = 2, 2, 5, 3
    n = m + r
    torque = _random_rows(rng, nb, n, rng.normal(size=n))
    # Joint rows far from every torque-feasible point: some widening is needed; one side of one row unbounded.
    joint_rows = rng.normal(size=(nj, n))
    joint_upper = rng.normal(size=nj) - 20.0
    joint_lower = joint_upper - 1.0
    joint_upper[1] = np.inf
    widening, (achieved, z) = least_joint_excess(
        excess_program(nb, nj, n), torque, (joint_rows, joint_upper, joint_lower), m
    )
    # min Σ t over (t, x): torque rows within bounds, lower − t <= joint rows · x <= upper + t, t >= 0.
    finite = np.isfinite(joint_upper)
    above = np.hstack([-np.eye(nj)[finite], joint_rows[finite]])
    below = np.hstack([-np.eye(nj), -joint_rows])
    torque_rows = np.hstack([np.zeros((nb, nj)), torque[0]])
    reference = linprog(
        np.r_[np.ones(nj), np.zeros(n)],
        A_ub=np.vstack([torque_rows, -torque_rows, above, below]),
        b_ub=np.r_[torque[1], -torque[2], joint_upper[finite], -joint_lower],
        bounds=[(0.0, None)] * nj + [(None, None)] * n,
        method="highs",
    )
    assert reference.status == 0
    assert widening.sum() == pytest.approx(reference.fun, rel=1e-9)
    x = np.r_[achieved, z]
    values = torque[0].dot(x)
    assert (values <= torque[1] + 1e-8).all() and (values >= torque[2] - 1e-8).all()
    joint_values = joint_rows.dot(x)
    assert (joint_values <= joint_upper + widening + 1e-8).all()
    assert (joint_values >= joint_lower - widening - 1e-8).all()


def test_acceleration_rows_are_the_joint_limits_and_own_rows_on_the_coordinates():
    from types import SimpleNamespace

    from torqueopt.resolvers.bounded.infeasible import DROPPED, acceleration_rows

    rng = np.random.default_rng(30)
    n, columns = 5, 4
    joints = np.array([0, 2, 3])
    bounds = SimpleNamespace(upper=rng.uniform(1.0, 2.0, joints.size), lower=-rng.uniform(1.0, 2.0, joints.size))
    scale = rng.uniform(0.5, 3.0, joints.size)  # ā of each joint
    own = (rng.normal(size=(1, n)), rng.normal(size=1))  # G q̈ <= h
    offset, rows, x = rng.normal(size=n), rng.normal(size=(n, columns)), rng.normal(size=columns)
    acceleration = offset + rows.dot(x)  # q̈ = offset + rows · x
    widen = 0.25
    matrix, upper, lower = acceleration_rows(joints, bounds, scale, own, offset, rows, widen=widen)
    # Row i of the joint limits: q̈_j within [lower_j − w ā_j, upper_j + w ā_j], divided by ā_j.
    np.testing.assert_allclose(
        matrix[:3].dot(x) - upper[:3], (acceleration[joints] - bounds.upper) / scale - widen, atol=1e-13
    )
    np.testing.assert_allclose(
        matrix[:3].dot(x) - lower[:3], (acceleration[joints] - bounds.lower) / scale + widen, atol=1e-13
    )
    np.testing.assert_allclose(matrix[3:].dot(x) - upper[3:], own[0].dot(acceleration) - own[1], atol=1e-13)
    assert lower[3] == -np.inf
    # Raised: h replaced by the larger value; dropped and freed rows hold every x.
    _, raised_upper, _ = acceleration_rows(joints, bounds, scale, own, offset, rows, raised=own[1] + 1.0)
    assert raised_upper[3] == pytest.approx(upper[3] + 1.0, abs=1e-12)
    matrix, upper, lower = acceleration_rows(joints, bounds, scale, own, offset, rows, raised=DROPPED, free_joints=True)
    assert not matrix.any() and (upper == 1.0).all() and (lower == -1.0).all()


def test_each_policy_called_alone_on_a_state_without_an_optimum(tight_planar3):
    from torqueopt.resolvers.bounded.infeasible import BoundedStep

    robot = tight_planar3
    terms, xdd = robot.terms(PAPER_Q0, np.zeros(3)), np.array([40.0, 40.0])
    ref = Reference(robot, terms, xdd)
    steps = {
        policy: BoundedStep(get_resolver("bounded-torque", infeasible=policy), robot)
        for policy in ("scale", "least-error", "exceed", "stop")
    }
    state = steps["scale"].state(terms, xdd)
    assert steps["scale"].optimum(
        terms, state.basis, state.inertia_basis, state.tilde_torque, state.particular, steps["scale"].rows_at(state)
    ) is None  # fmt: skip

    def range_rows(policy):  # U of the range of HZ; each step's basis remembers its last G
        return steps[policy].range_basis(state.inertia_basis)

    joint_rows = steps["scale"].rows_at(state)  # the joint limits' rows on q̈ (not binding at this state)
    # scale: the largest s by bisection on HiGHS feasibility.
    scaled = steps["scale"].give_up_task(state, range_rows("scale"), joint_rows)
    np.testing.assert_allclose(1.0 - scaled.task_error / np.linalg.norm(xdd), _largest_scaling(ref), atol=1e-7)
    # least-error: bounded least squares over the torque box.
    task_map = ref.J @ np.linalg.inv(ref.H)
    target = xdd - ref.drift + task_map @ ref.b
    best = lsq_linear(task_map, target, bounds=(ref.lower, ref.upper), tol=1e-12, method="bvls")
    least = steps["least-error"].give_up_task(state, range_rows("least-error"), joint_rows)
    np.testing.assert_allclose(least.task_error, np.linalg.norm(task_map @ best.x - target), rtol=1e-5, atol=1e-7)
    for found in (scaled, least):
        assert found.infeasible and torque_utilisation(found.torque, ref.lower, ref.upper) <= 0.5
    # exceed: the min-max LP by HiGHS, the task realised.
    exceeded = steps["exceed"].exceed(state, range_rows("exceed"))
    np.testing.assert_allclose(
        torque_utilisation(exceeded.torque, ref.lower, ref.upper), _minmax_reference(ref), rtol=1e-8
    )
    np.testing.assert_allclose(ref.J @ exceeded.joint_acceleration + ref.drift, xdd, atol=1e-9)
    assert str(steps["stop"].stop_error(state)) == (
        "resolver 'bounded-torque' (infeasible='stop'): no torque within bounds realises the task acceleration "
        "[40.0, 40.0] within the joint limits"
    )
