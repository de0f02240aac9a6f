"""Joint limits inside the bounded resolvers (option ``joint_limits``, Del Prete, RA-L 2018).

The bounds on q̈ are checked against a direct simulation of what they
promise (the next state inside the limits and able to stop), the runs on
the four 7-joint arms against the URDF limits at every sample, and the
programs against SLSQP and HiGHS (scipy) built from H, b, J and the bounds.
"""

import numpy as np
import pytest
from scipy.linalg import null_space
from scipy.optimize import linprog, minimize, nnls

import torqueopt
from torqueopt import StraightLine
from torqueopt.errors import InvalidInput, TorqueBoundsInfeasible
from torqueopt.resolvers import get_resolver
from torqueopt.resolvers.bounded.joint_limits import APPROACH_STEPS, JointLimits, acceleration_bounds

DT = 1e-3

#: Per arm, a 1 s line (default start, √2 m/s²) on which bounded-torque without joint limits leaves them.
LINES = {"panda": (0.0, 1.0, 0.0), "xarm7": (0.0, 0.0, 1.0), "tiago": (1.0, 0.0, 0.0), "baxter": (0.0, 0.0, 1.0)}


@pytest.fixture(scope="module")
def arms():
    return {name: torqueopt.load_robot(name, task="position") for name in LINES}


def _run(robot, joint_limits, resolver="bounded-torque", **options):
    line = StraightLine(LINES[robot.name], duration=1.0)
    return torqueopt.simulate(
        robot, resolver, line, robot.default_configuration, resolver_options={"joint_limits": joint_limits, **options}
    )


def _excess(robot, result):
    """Largest position [rad] and velocity [rad/s] beyond the URDF limits over every sample (0 when inside)."""
    lower, upper, velocity = robot.joint_limits
    angles = result.joint_angles
    position = np.maximum(angles - upper, lower - angles).max()
    speed = (np.abs(result.v) - velocity).max()
    return max(position, 0.0), max(speed, 0.0)


# -- the bounds themselves ----------------------------------------------------------------------


def _stops_inside(q, v, a, dt, lower, upper, vmax, brake):
    """Hold a for dt, then brake at ``brake`` to rest: does every moment stay within [lower, upper], |v| <= vmax?"""
    times = np.linspace(0.0, dt, 201)
    path = q + v * times + 0.5 * a * times**2
    speeds = v + a * times
    q1, v1 = path[-1], speeds[-1]
    # Braking from (q1, v1) at constant deceleration: the turning point q1 + v1|v1|/(2 brake).
    stop = q1 + v1 * abs(v1) / (2.0 * brake)
    inside = lower - 1e-12 <= min(path.min(), stop) and max(path.max(), stop) <= upper + 1e-12
    return inside and np.abs(speeds).max() <= vmax + 1e-12


def _approach_curve(distance, brake, dt):
    """The largest speed [rad/s] towards a limit at ``distance`` [rad] the viability bound allows after a step:
    Del Prete's braking parabola √(2ā d), offset to √(2ā(d + d₀)) − w with w = ā·APPROACH_STEPS·δ, d₀ = w²/(2ā)."""
    offset = brake * APPROACH_STEPS * dt
    return np.sqrt(2.0 * brake * (np.maximum(distance, 0.0) + offset**2 / (2.0 * brake))) - offset


def test_the_bounds_keep_the_next_state_inside_and_able_to_stop_and_are_tight(rng):
    """At random viable states: a at either bound passes a direct simulation (the step, then braking at ā to rest)
    and ends on or below the approach curve; 1 % beyond the bound ends above the curve or outside a limit."""
    lower, upper, vmax, brake = -1.0, 1.5, 2.0, 20.0
    checked = 0
    while checked < 300:
        q = rng.uniform(lower, upper)
        v = rng.uniform(-vmax, vmax)
        # Viable: on or below the approach curve towards both limits.
        if v > _approach_curve(upper - q, brake, DT) or -v > _approach_curve(q - lower, brake, DT):
            continue
        bounds = acceleration_bounds([q], [v], DT, [lower], [upper], [vmax], [brake], [np.inf])
        low, high = bounds.lower[0], bounds.upper[0]
        assert low <= high

        def on_or_below(a, slack=1e-9):
            q1, v1 = q + v * DT + 0.5 * a * DT**2, v + a * DT
            return (
                v1 <= _approach_curve(upper - q1, brake, DT) + slack
                and -v1 <= _approach_curve(q1 - lower, brake, DT) + slack
            )

        for a in (low, high, 0.5 * (low + high)):
            assert _stops_inside(q, v, a, DT, lower, upper, vmax, brake), (q, v, a, low, high)
            assert on_or_below(a), (q, v, a, low, high)
        beyond_high = high + 0.01 * max(abs(high), 1.0)
        beyond_low = low - 0.01 * max(abs(low), 1.0)
        for beyond in (beyond_high, beyond_low):
            assert not (_stops_inside(q, v, beyond, DT, lower, upper, vmax, brake) and on_or_below(beyond, 0.0))
        checked += 1


def test_riding_the_approach_curve_needs_no_more_than_the_deceleration():
    """Following v = f(d) towards the limit decelerates at f(d)·f'(d) [rad/s²]: at most ā, by finite differences."""
    brake = 20.0
    distance = np.geomspace(1e-9, 1.0, 2001)
    speed = _approach_curve(distance, brake, DT)
    deceleration = speed * np.gradient(speed, distance)
    assert deceleration.max() <= brake * (1 + 1e-6)
    assert deceleration[-1] > 0.95 * brake  # far from the limit: Del Prete's parabola, braking at ā


@pytest.mark.parametrize("gain", [0.98, 1.02])
@pytest.mark.parametrize("approach", [True, False])
def test_a_joint_pushed_into_its_limit_comes_to_rest_without_rebounding(approach, gain):
    """One joint with a constant wish to accelerate into its upper limit, held to the bounds step by step, whose
    step realises ``gain`` times the bounded acceleration (a held torque's acceleration drifts inside the step: 2 %
    here). With the approach curve its speed falls to 0 without changing sign, its acceleration settles and it
    stays inside; Del Prete's parabola alone (approach=False) rebounds from the limit at most steps, with jumps
    of tens of rad/s² from one step to the next."""
    q, v, upper, brake = 0.0, 1.0, 0.2, 20.0
    accelerations, speeds, beyond = [], [], -np.inf
    for _ in range(2000):
        bounds = acceleration_bounds([q], [v], DT, [-1.0], [upper], [2.0], [brake], [np.inf], approach=approach)
        a = float(np.clip(50.0, bounds.lower[0], bounds.upper[0]))
        q, v = q + v * DT + 0.5 * gain * a * DT**2, v + gain * a * DT
        accelerations.append(a)
        speeds.append(v)
        beyond = max(beyond, q - upper)
    speeds, accelerations = np.array(speeds), np.array(accelerations)
    rebounds = int((speeds < -1e-9).sum())
    jumps = np.abs(np.diff(accelerations[-500:])).max()
    if approach:
        assert rebounds == 0 and jumps < 1e-6 and abs(speeds[-1]) < 1e-6 and beyond < 0, (rebounds, jumps, beyond)
    else:
        assert rebounds > 500 and jumps > 30.0, (rebounds, jumps)


def test_an_acceleration_limit_bounds_q_ddot_and_sets_the_deceleration():
    bounds = acceleration_bounds([0.0], [0.0], DT, [-1.0], [1.0], [np.inf], [3.0], [3.0])
    assert bounds.lower[0] == -3.0 and bounds.upper[0] == 3.0
    assert bounds.upper_kind[0] == 3  # the acceleration limit


def test_the_option_is_checked_by_name_and_value():
    assert get_resolver("bounded-torque", joint_limits="off").joint_limits == "off"
    assert get_resolver("minmax-torque", joint_limits=True).joint_limits == "on"
    with pytest.raises(
        InvalidInput, match=r"^option joint_limits=maybe of resolver 'bounded-torque' must be 'on' or 'off'$"
    ):
        get_resolver("bounded-torque", joint_limits="maybe")
    with pytest.raises(InvalidInput, match="joint_acceleration_limit=-1"):
        get_resolver("bounded-torque", joint_acceleration_limit=-1)


# -- runs on the four arms ------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(LINES))
def test_with_joint_limits_the_run_stays_inside_them_at_every_sample(arms, name):
    robot = arms[name]
    outside = _excess(robot, _run(robot, "off"))
    assert max(outside) > 0.05, outside  # the case matters: without them the run leaves the limits
    inside = _run(robot, "on")
    assert inside.completed
    assert _excess(robot, inside) == (0.0, 0.0)
    assert inside.first_position_violation is None and inside.first_velocity_violation is None


@pytest.mark.slow
@pytest.mark.parametrize("name", list(LINES))
def test_minmax_torque_with_joint_limits_stays_inside_them(arms, name):
    robot = arms[name]
    result = _run(robot, "on", resolver="minmax-torque")
    assert _excess(robot, result) == (0.0, 0.0)


def test_off_is_the_resolver_without_joint_rows(arms):
    """'off' equals 'on' on a copy of the arm whose URDF limits are removed (no rows are built), to the bit."""
    robot = arms["panda"]
    free = robot.with_gravity(robot.gravity)  # its own Pinocchio model
    free.model.lowerPositionLimit[:] = -1e308
    free.model.upperPositionLimit[:] = 1e308
    free.model.velocityLimit[:] = 0.0
    assert JointLimits(free, DT).count == 0 and JointLimits(robot, DT).count == robot.nv
    off = _run(robot, "off")
    np.testing.assert_array_equal(off.tau, _run(free, "on").tau)
    assert not np.array_equal(off.tau, _run(robot, "on").tau)


# -- the programs against general solvers ---------------------------------------------------------


def _states_on_joint_bounds(robot, count):
    """(terms, ẍ, bounds) at rows of the run with joint limits where the answer lies on a joint bound."""
    result = _run(robot, "on")
    line = StraightLine(LINES[robot.name], duration=1.0)
    commands = line.anchored(result.x[0]).sample(result.t).acceleration
    limits = JointLimits(robot, DT)
    step = get_resolver("bounded-torque").solver(robot, DT)
    found = []
    for row in range(0, len(result.t) - 1, 7):
        if result.infeasible[row]:
            continue
        terms = robot.terms(result.q[row], result.v[row])
        resolution = step(terms, commands[row])
        bounds = limits(terms)
        if not resolution.infeasible and limits.active(bounds, resolution.joint_acceleration):
            found.append((terms, commands[row], bounds))
        if len(found) == count:
            break
    return found, limits


def _problem(robot, terms, xdd, bounds, limits):
    """y ↦ q̈, τ with scipy's own null-space basis, and the torque and joint rows A y <= c."""
    H, b, J = terms.inertia, terms.bias_torque, terms.jacobian
    pinv = np.linalg.pinv(J)
    Z = null_space(J)
    particular = pinv @ (xdd - terms.drift)
    G = H @ Z
    tilde = H @ particular + b
    joints = limits.joints
    scale = limits.scale(bounds)
    Zj = Z[joints] / scale[:, None]
    rows = np.vstack([G, -G, Zj, -Zj])
    rhs = np.r_[
        robot.torque_upper - tilde,
        tilde - robot.torque_lower,
        (bounds.upper - particular[joints]) / scale,
        (particular[joints] - bounds.lower) / scale,
    ]
    finite = np.isfinite(rhs)
    return Z, G, tilde, particular, rows[finite], rhs[finite]


def test_bounded_torque_meets_kkt_and_agrees_with_slsqp_on_joint_bounds(arms):
    robot = arms["panda"]
    states, limits = _states_on_joint_bounds(robot, 4)
    assert len(states) == 4
    step = get_resolver("bounded-torque").solver(robot, DT)
    mid = np.zeros(robot.nv)
    for terms, xdd, bounds in states:
        Z, G, tilde, particular, rows, rhs = _problem(robot, terms, xdd, bounds, limits)
        mu2 = 0.5**2 * np.sum(G**2)
        damping_target = 10.0 * Z.T @ terms.joint_velocity

        def cost(y):
            return 0.5 * np.sum((tilde + G @ y - mid) ** 2) + 0.5 * mu2 * np.sum((y + damping_target) ** 2)

        def gradient(y):
            return G.T @ (tilde + G @ y - mid) + mu2 * (y + damping_target)

        resolution = step(terms, xdd)
        y = Z.T @ (resolution.joint_acceleration - particular)
        # Primal feasibility (DAQP's 1e-9 of each row's scale), then KKT by NNLS on the active rows.
        slack = rhs - rows @ y
        assert slack.min() >= -1e-8, slack.min()
        active = np.flatnonzero(slack <= 1e-7 * np.maximum(1.0, np.abs(rhs)))
        assert active.size
        _, residual = nnls(rows[active].T, -gradient(y))
        assert residual <= 1e-6 * (np.linalg.norm(G.T @ tilde) + 1.0), residual
        reference = minimize(
            cost,
            np.zeros(Z.shape[1]),
            jac=gradient,
            method="SLSQP",
            constraints=[{"type": "ineq", "fun": lambda z: rhs - rows @ z, "jac": lambda z: -rows}],
            options={"ftol": 1e-15, "maxiter": 1000},
        )
        assert reference.success
        np.testing.assert_allclose(Z @ y, Z @ reference.x, atol=1e-5 * max(1.0, np.abs(reference.x).max()))


def test_minmax_torque_agrees_with_highs_on_joint_bounds(arms):
    robot = arms["panda"]
    states, limits = _states_on_joint_bounds(robot, 4)
    step = get_resolver("minmax-torque").solver(robot, DT)
    spread = robot.torque_upper - robot.torque_lower
    for terms, xdd, bounds in states:
        Z, G, tilde, particular, rows, rhs = _problem(robot, terms, xdd, bounds, limits)
        joint_rows = rows[2 * robot.nv :]
        joint_rhs = rhs[2 * robot.nv :]
        r = Z.shape[1]
        # min t over (y, t): |τ̃ + G y| <= t (τ⁺ − τ⁻) per joint (midpoint 0), and the joint rows.
        torque_rows = np.vstack([np.hstack([G, -spread[:, None]]), np.hstack([-G, -spread[:, None]])])
        a_ub = np.vstack([torque_rows, np.hstack([joint_rows, np.zeros((joint_rows.shape[0], 1))])])
        b_ub = np.r_[-tilde, tilde, joint_rhs]
        lp = linprog(np.r_[np.zeros(r), 1.0], A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * (r + 1), method="highs")
        assert lp.status == 0
        resolution = step(terms, xdd)
        if lp.x[-1] > 0.5:
            assert resolution.infeasible
            continue
        found = np.max(np.abs(resolution.torque) / spread)
        assert found == pytest.approx(lp.x[-1], rel=1e-6, abs=1e-9)
        y = Z.T @ (resolution.joint_acceleration - particular)
        assert (joint_rhs - joint_rows @ y).min() >= -1e-8


# -- infeasible: torque bounds, joint bounds and the task in conflict ---------------------------


@pytest.fixture(scope="module")
def cornered():
    """panda with a tenth of its torque limits, joint 4 at 0.9 of its velocity limit, 0.02 rad from its upper limit."""
    robot = torqueopt.load_robot("panda", task="position")
    weak = robot.with_torque_limit(robot.urdf_effort_limit / 10.0)
    _, upper, velocity = weak.joint_limits
    angles = weak.joint_angles(weak.default_configuration)
    angles[3] = upper[3] - 0.02
    v = np.zeros(weak.nv)
    v[3] = 0.9 * velocity[3]
    return weak, weak.terms(weak.configuration(angles), v)


def test_an_infeasible_step_says_which_bounds_were_active(cornered):
    robot, terms = cornered
    resolution = get_resolver("bounded-torque").solver(robot, DT)(terms, np.zeros(3))
    assert resolution.infeasible
    assert "of joint panda_joint4" in resolution.limiting and "torque limit" in resolution.limiting
    with pytest.raises(TorqueBoundsInfeasible, match="within the joint limits"):
        get_resolver("bounded-torque", infeasible="stop").solver(robot, DT)(terms, np.zeros(3))
    # Torque bounds hold whatever the policy chose.
    assert np.all(np.abs(resolution.torque) <= robot.torque_upper)


def test_a_run_reports_its_first_infeasible_step_and_its_bounds(arms):
    result = _run(arms["tiago"], "on")  # the line is not possible within the torque and joint limits from there
    assert result.infeasible_steps
    time, limiting = result.first_infeasible_step
    assert result.t[np.argmax(result.infeasible)] == time
    assert "limit" in limiting and "of joint" in limiting
    assert result.summary()["first_infeasible_step"] == {"t": time, "limiting": limiting}
