"""Joint limits inside the bounded resolvers (option ``joint_limits``, Del Prete, RA-L 2018).

The bounds on q̈ are checked against a direct simulation of what they
promise (the next state inside the limits and able to stop), the runs on
the four 7-joint arms against the URDF limits at every sample, and the
programs against SLSQP and HiGHS (scipy) built from H, b, J and the bounds.
"""

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space
from scipy.optimize import linprog, minimize, nnls

import torqueopt
from torqueopt import StraightLine
from torqueopt.batch import simulate_batch
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


def test_a_state_above_the_curve_rides_the_curve_through_it_not_back_in_one_step(rng):
    """At random states above ā's approach curve towards the upper limit (a bias torque that grew, or an ā that fell,
    since the curve was ridden), yet with a curve of some larger deceleration ā* through them: the bound asks for no
    more braking than ā* (found here by root-finding on the curve, not by its closed form), a at the bound passes a
    direct simulation braking at ā* to rest, and it is tight (1 % less braking ends above ā*'s curve). The curve of ā
    alone would ask the state back under it within one step: hundreds of rad/s², far more than ā."""
    from scipy.optimize import brentq

    lower, upper, vmax, brake = -1.0, 1.5, 5.0, 2.0
    checked = 0
    while checked < 200:
        q = rng.uniform(lower, upper)
        v = rng.uniform(0.0, vmax)
        if v <= _approach_curve(upper - q, brake, DT) or v >= _approach_curve(upper - q, 1e9, DT):
            continue
        through = brentq(lambda a: _approach_curve(upper - q, a, DT) - v, brake, 1e9, xtol=1e-12, rtol=1e-14)
        bounds = acceleration_bounds([q], [v], DT, [lower], [upper], [vmax], [brake], [np.inf])
        high = bounds.upper[0]
        assert high >= -through * (1 + 1e-6) - 1e-9, (q, v, high, through)
        assert _stops_inside(q, v, high, DT, lower, upper, vmax, through * (1 + 1e-9)), (q, v, high, through)
        tighter = high + 0.01 * max(abs(high), 1.0)
        q1, v1 = q + v * DT + 0.5 * tighter * DT**2, v + tighter * DT
        assert v1 > _approach_curve(upper - q1, through, DT), (q, v, high, through)
        checked += 1


def test_a_state_above_the_curve_comes_back_in_one_step_where_the_torque_box_gives_that(rng):
    """States above ā's approach curve, as above, with the range of accelerations the torque box gives the joint
    (``box_range``). Where the box brakes harder than the return under ā's curve within one step asks, the bound is
    that return: a direct step at it ends on ā's own curve (as before the ride-through). Where it does not, the bound
    rides the curve through the state, as without a box. Mirrored towards the lower limit, the same."""
    lower, upper, vmax, brake = -1.0, 1.5, 5.0, 2.0
    checked = 0
    while checked < 100:
        q = rng.uniform(lower, upper)
        v = rng.uniform(0.0, vmax)
        if v <= _approach_curve(upper - q, brake, DT) or v >= _approach_curve(upper - q, 1e9, DT):
            continue
        ride = acceleration_bounds([q], [v], DT, [lower], [upper], [vmax], [brake], [np.inf]).upper[0]
        wide = ([-1e9], [1e9])
        back = acceleration_bounds([q], [v], DT, [lower], [upper], [vmax], [brake], [np.inf], box_range=wide).upper[0]
        assert back < ride, (q, v, back, ride)
        if back > -v / DT:  # not a stop within the step: the next state lies on ā's curve
            q1, v1 = q + v * DT + 0.5 * back * DT**2, v + back * DT
            assert v1 == pytest.approx(_approach_curve(upper - q1, brake, DT), rel=1e-7, abs=1e-9), (q, v, back)
        short = ([0.5 * back], [1e9])
        bounds = acceleration_bounds([q], [v], DT, [lower], [upper], [vmax], [brake], [np.inf], box_range=short)
        assert bounds.upper[0] == ride
        mirrored = acceleration_bounds(
            [-q], [-v], DT, [-upper], [-lower], [vmax], [np.inf], [np.inf], lower_deceleration=[brake],
            box_range=([-1e9], [1e9]),
        )  # fmt: skip
        assert mirrored.lower[0] == pytest.approx(-back, rel=1e-12)
        checked += 1


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


# -- the atlas paths that left a limit before the approach curve ------------------------------------

#: Movements of the four arms' 0.5 s atlases (seed 19, docs/atlas/<arm>.md): (q0, direction) of the lines at the
#: arm's acceleration [m/s²]. With joint limits on, every one but xarm7's left a position or velocity limit in
#: the atlas (the run drifted out of Del Prete's viable set by about 5e-8 rad, next to a position limit at a few
#: mm/s, where his turning-point bound asks for 1700-2000 rad/s²; the step then gave up every joint limit, the
#: velocity ones too). xarm7 left none: its three paths with the most infeasible steps.
ATLAS_PATHS = {
    ("panda", "bounded-torque", 0.40410877188615857): {
        181: ([2.5084842759516097, -0.5753655121292893, -2.8681414605912368, -0.8166491355622529, -0.9634956945597464, 1.3267535839728961, -0.9901464384053345], [0.7313700363611394, -0.0006310348537844023, 0.6819805508283349]),  # position 0.472 s, velocity 0.471 s
        264: ([-0.12129020124141254, -1.0287215126225044, -2.2032720459029953, -0.4583116905899809, -2.5761064084928846, 0.6261890280250023, 1.6310654296455582], [-0.9030075571733706, 0.4290678145767151, -0.02186691981381111]),  # position 0.349 s, velocity 0.406 s
        432: ([-1.882579862421904, -0.8530658044926396, 2.518467875273465, -1.8180161414496019, 1.9179783591825657, 0.27309850790455487, 0.9577677161582803], [-0.05684986490497412, -0.9067774762508904, -0.41775914283753474]),  # velocity 0.279 s
        721: ([-2.209614027728453, -0.9458608351048781, 1.3466477830535948, -1.4685086815536421, 2.4028585547378074, 1.6163447718816324, -1.9298595088287427], [-0.16432931010725857, 0.4509601708901749, 0.8772860434945815]),  # velocity 0.239 s
        883: ([0.21795362780380367, 1.0955633930799893, 0.9487216450728893, -1.2364154367408866, -1.9331859613334095, 0.44180717798338803, 2.3602841969990966], [-0.35950029363751745, -0.12791098080091287, 0.9243366918310055]),  # velocity 0.425 s
    },
    ("panda", "minmax-torque", 0.40410877188615857): {
        1: ([-0.37054815828766197, 1.708671616458771, 0.543876711690519, -2.347644356218571, -1.511075150440768, 2.480300938271837, -1.4501223100516951], [-0.37518443776784455, -0.048634142354710544, -0.9256734617856601]),  # velocity 0.371 s
        158: ([2.0274175661263247, 1.6601341865692727, 2.777556478568298, -0.5230394720406708, -0.9062916101410636, 1.3230330370564012, 2.874039676840155], [0.055359470238871535, -0.7724641364517357, 0.6326408830851399]),  # position 0.08 s, velocity 0.08 s
        775: ([0.5631093201007911, -0.583301294249909, 2.1357531750718644, -0.7738638216268598, 2.436378829757279, 0.603171934704594, 2.5557783974374284], [-0.6857633468824214, 0.391146132971401, 0.6137860659335131]),  # position 0.353 s, velocity 0.341 s
    },
    ("tiago", "bounded-torque", 0.37674961801481927): {
        105: ([2.2115246193248566, 1.0351565378927408, -3.0537864534385872, -0.12863712026190532, -0.7649382252974091, 0.8312569267228846, -1.8516675533517255], [0.5782522313002678, 0.6262835211169602, -0.522870259408205]),  # velocity 0.361 s
        555: ([2.031505040860857, -0.2956295367486905, 1.128648103902755, 1.5515916556120153, -1.6210205744446455, -0.18512564032855128, -1.954952326736759], [-0.6998078757700749, -0.06805018587807063, 0.711082350513733]),  # position 0.386 s
        796: ([1.6602996460112809, 0.8384235229033465, 1.2714994680200897, 0.5867778566726156, -0.5428197411894911, 1.3962942707422916, 0.6612424652999116], [-0.7262739332114272, -0.5974194790669427, 0.34002373442009337]),  # position and velocity 0.235 s
    },
    ("baxter", "bounded-torque", 0.6640135914214277): {
        51: ([1.6684038669163983, -0.951456405667974, 1.6274297444744343, 1.8150416386190944, 2.657274518442696, 0.5327546425602723, 2.3181875627230664], [0.6868834525801922, -0.47531061343849673, 0.5497917272242596]),  # velocity 0.133 s
        389: ([-0.8935056693542126, -2.011814668155757, 0.32062328960391673, 0.2582911191449445, -1.1364899158745727, 2.0699791568528076, 2.674971296339164], [-0.08334312867622028, 0.9317449094758904, -0.35341950507608333]),  # position 0.497 s
        670: ([-1.10467585539056, 0.07311332567868956, 2.694438463321374, 0.31248943479942454, 1.9905225493628853, -1.4918114534600722, 2.097176973830181], [0.5883851087392409, 0.5881363386390561, 0.5548861243409832]),  # position 0.494 s, velocity 0.49 s
        751: ([-0.9232730819642925, -0.43324531406119937, -0.8423549616547206, 1.2844014803811115, 2.0455004896780187, 0.8554240823745363, -0.7339250464658655], [0.6355616284310591, 0.30794309784157553, -0.7079777291396913]),  # velocity 0.454 s
    },
    ("xarm7", "bounded-torque", 0.36385376445276046): {
        603: ([-1.7136455689717947, 0.6449752716659609, 1.1919716932601805, 1.5841262941551661, -1.2689350200127392, 2.8269445186762674, -3.018915404662803], [0.7311248418483032, -0.6302233073667298, 0.26129494538554365]),  # 53 infeasible steps
        559: ([-2.7944807579742275, 1.536035476925842, -0.05512061240542376, 1.688495100986344, -3.0153134430049517, -1.379069380079903, 1.9341399723433579], [-0.9402039096013868, -0.030718520774299627, 0.339224086485182]),  # 47 infeasible steps
        911: ([-0.5488467269264654, -0.364852998302285, 2.261467407401703, 0.7471188493649544, -2.342771968394767, -1.5790280931046852, 0.14431914074093388], [-0.7758681708273478, 0.6263991671985938, -0.07518420598725262]),  # 20 infeasible steps
    },
}  # fmt: skip


@pytest.mark.parametrize("case", list(ATLAS_PATHS), ids=lambda case: f"{case[0]}-{case[1]}")
def test_the_atlas_paths_that_left_a_limit_stay_inside_every_limit_at_every_sample(arms, case):
    """The batch, as the atlas runs them: inside the URDF's position and velocity limits at every sample; with
    bounded-torque (a strictly convex QP: one answer) equal to simulate's run of the first path to 1e-9 (minmax-torque's
    LP leaves the torques below the largest free: its vertex may differ between the two by 3e-7 N·m)."""
    name, resolver, accel = case
    robot = arms[name]
    movements = ATLAS_PATHS[case]
    lines = [StraightLine(direction, accel=accel, duration=0.5) for _, direction in movements.values()]
    q0s = [np.asarray(q0) for q0, _ in movements.values()]
    runs = simulate_batch(robot, resolver, lines, q0s, DT)
    for path, run in zip(movements, runs):
        assert run.completed, path
        assert _excess(robot, run) == (0.0, 0.0), path
    if resolver != "bounded-torque":
        return
    single = torqueopt.simulate(robot, resolver, lines[0], q0s[0], dt=DT)
    np.testing.assert_allclose(runs[0].q, single.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(runs[0].tau[:-1], single.tau[:-1], rtol=1e-9, atol=1e-9 * robot.torque_upper.max())


def test_where_torque_and_joint_limits_conflict_the_step_exceeds_the_joint_limits_least_and_says_which(cornered):
    """At states of panda with a tenth of its torque limits, joint 4 riding fast towards its upper limit, where no
    q̈ within the joint limits has a torque within bounds (it would have to stop within the 1-2 cm left from 0.6-0.9
    of its velocity limit, at more than the box's −96 rad/s²): the torque stays within its bounds, the answer exceeds
    the joint rows (in units of each joint's ā) by their least sum (HiGHS over q̈ and the excesses, built from H, b
    and the bounds), and the step names each bound it exceeds."""
    robot, _ = cornered
    _, upper, velocity = robot.joint_limits
    states = []
    for distance, speed in ((0.02, 0.9), (0.015, 0.9), (0.01, 0.6), (0.012, 0.7)):
        angles = robot.joint_angles(robot.default_configuration)
        angles[3] = upper[3] - distance
        v = np.zeros(robot.nv)
        v[3] = speed * velocity[3]
        states.append(robot.terms(robot.configuration(angles), v))
    limits = JointLimits(robot, DT)
    step = get_resolver("bounded-torque").solver(robot, DT)
    lower_box, upper_box = robot.torque_lower, robot.torque_upper
    margin = 1e-8 * (upper_box - lower_box)
    checked = 0
    for terms in states:
        resolution = step(terms, np.zeros(3))
        assert resolution.limiting.startswith("joint limits exceeded least"), resolution.limiting
        bounds = limits(terms)
        scale = limits.scale(bounds)
        n = robot.nv
        # HiGHS: min Σ t over (q̈, t), τ = H q̈ + b in the box, lower − t ā <= q̈ <= upper + t ā, t >= 0.
        finite_upper, finite_lower = np.isfinite(bounds.upper), np.isfinite(bounds.lower)
        a_ub = np.vstack(
            [
                np.hstack([terms.inertia, np.zeros((n, n))]),
                np.hstack([-terms.inertia, np.zeros((n, n))]),
                np.hstack([np.eye(n)[finite_upper], -np.diag(scale)[finite_upper]]),
                np.hstack([-np.eye(n)[finite_lower], -np.diag(scale)[finite_lower]]),
            ]
        )
        b_ub = np.r_[
            upper_box - margin - terms.bias_torque,
            terms.bias_torque - lower_box - margin,
            bounds.upper[finite_upper],
            -bounds.lower[finite_lower],
        ]
        lp = linprog(np.r_[np.zeros(n), np.ones(n)], A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * n + [(0, None)] * n)
        assert lp.status == 0
        a = resolution.joint_acceleration
        excess = np.maximum(np.maximum(a - bounds.upper, bounds.lower - a), 0.0) / scale
        assert lp.fun > 1e-3  # a conflict: no q̈ within the joint bounds has a torque within the box
        assert lp.fun - 1e-7 <= excess.sum() <= lp.fun * (1 + 1e-3) + 1e-5 * n, (excess.sum(), lp.fun)
        assert np.all(resolution.torque <= upper_box) and np.all(resolution.torque >= lower_box)
        for joint in np.flatnonzero(excess > 1e-6 + 1e-3 * lp.fun):
            assert f"of joint {robot.joint_names[joint]} by " in resolution.limiting, resolution.limiting
        checked += 1
    assert checked == len(states)


def test_the_batch_of_minmax_torque_on_tiago_solves_the_rows_daqp_cycles_on(arms):
    """tiago's 1 s line: DAQP cycles on the stacked LP of a row at 0.505 s (the batch stopped there); that row goes
    through the single-state step, and the batch completes, equal to simulate's run to 1e-9 rad."""
    robot = arms["tiago"]
    line = StraightLine(LINES["tiago"], duration=1.0)
    batch = simulate_batch(robot, "minmax-torque", [line], [robot.default_configuration], DT)[0]
    single = torqueopt.simulate(robot, "minmax-torque", line, robot.default_configuration, dt=DT)
    assert batch.completed and single.completed, batch.stop_reason
    np.testing.assert_allclose(batch.q, single.q, rtol=0, atol=1e-9)


#: Atlas paths (seed 19, 0.5 s, the arm's default acceleration) on which DAQP failed on minmax-torque's LP in the
#: batch and in the single-state step, so that the run stopped: (q0, direction, start, acceleration, DAQP's failure).
DAQP_FAILURES = {
    ("tiago", 363): (
        [1.8571391228566956, 0.8836258362626874, -2.0934367578483606, -0.3330998438145831, 1.2978599504963637, 1.34847504559915, -1.3215185448687237],
        [-0.669630325658708, -0.3099503708387178, -0.6749266586638536],
        [0.6540940517987175, 0.05749896346370469, 1.1273820435575592], 0.37674961801481927, "cycling (-2)",
    ),
    ("baxter", 423): (
        [-1.6527181706349372, -1.7638914134170987, 0.2693956012988039, 2.4495743816549167, -0.3482879303375217, 1.96446303076364, -1.8443651102811542],
        [-0.0525431869209743, -0.39966326957993126, 0.9151548964283953],
        [-0.0670790409023932, -0.19316109500590817, 0.36724860241545665], 0.6640135914214277, "iteration limit (-4)",
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", list(DAQP_FAILURES), ids=lambda case: f"{case[0]}-{case[1]}")
def test_minmax_torque_runs_on_which_daqp_fails_are_finished_within_every_limit(arms, case, monkeypatch):
    """The two atlas runs that stopped on a DAQP failure (tiago's 363 at 0.255 s, baxter's 423 at 0.124 s) complete:
    each failed LP is solved again from a cold start (and by HiGHS where DAQP fails there too), and the run stays
    within every torque, position and velocity limit."""
    import torqueopt.resolvers.bounded.programs as programs

    q0, direction, start, accel, failure = DAQP_FAILURES[case]
    cold, highs = [], []
    cold_solve, highs_lp = programs._Program._cold_solve, programs._highs_lp
    monkeypatch.setattr(programs._Program, "_cold_solve", lambda self: cold.append(1) or cold_solve(self))
    monkeypatch.setattr(programs, "_highs_lp", lambda *args: highs.append(args[-1]) or highs_lp(*args))
    robot = arms[case[0]]
    line = StraightLine(direction, accel=accel, duration=0.5, start=start)
    run = torqueopt.simulate(robot, "minmax-torque", line, np.array(q0), dt=DT)
    assert run.completed, run.stop_reason
    assert cold, f"DAQP no longer fails on this run ({failure} before)"
    assert all(text.startswith("DAQP failed: ") for text in highs)
    assert np.nanmax(run.peak_torque_ratio) <= 1 + 1e-6
    assert np.all(np.abs(run.v) <= run.velocity_limit)
    assert np.all((run.joint_angles >= run.position_lower) & (run.joint_angles <= run.position_upper))


def test_an_lp_daqp_fails_on_twice_goes_to_highs(monkeypatch):
    """The last resort of an LP: DAQP failing from the warm and the cold start alike (forced here), HiGHS's answer
    is the one used, equal to DAQP's on the same LP."""
    import torqueopt.resolvers.bounded.programs as programs

    rng = np.random.default_rng(3)
    rows = rng.normal(size=(8, 3))
    upper, lower = np.r_[rng.uniform(0.5, 2, 8)], -np.r_[rng.uniform(0.5, 2, 8)]
    cost = rng.normal(size=3)
    expected = programs._Program(np.zeros((3, 3)), cost, rows, upper, lower, linear=True).solve()[0]
    program = programs._Program(np.zeros((3, 3)), cost, rows, upper, lower, linear=True)

    class Cycling:  # DAQP's workspace, as it answers when it cycles
        def update(self, **numbers):
            pass

        def solve(self):
            return np.zeros(3), 0.0, -2, {"lam": np.zeros(8)}

    program._model = Cycling()
    monkeypatch.setattr(programs._Program, "_cold_solve", lambda self: (np.zeros(3), -2, {"lam": np.zeros(8)}))
    x, flag, _ = program.solve(f=cost)
    assert flag == programs._EXIT_OPTIMAL
    np.testing.assert_allclose(x, expected, atol=1e-7)


def test_highs_answers_daqps_lp_form_with_daqps_multipliers():
    """On random LPs of DAQP's form (box bounds on the first variables, two-sided rows, some one-sided), HiGHS's
    answer is DAQP's, and its multipliers, mapped to DAQP's signs, are DAQP's and meet c + [I; A]ᵀλ = 0."""
    from torqueopt.resolvers.bounded.programs import _EXIT_OPTIMAL, _highs_lp, _Program

    rng = np.random.default_rng(7)
    compared = 0
    for _ in range(20):
        variables, bounds, count = 4, 2, 8
        rows = rng.normal(size=(count, variables))
        middle = rng.normal(size=count)
        upper = np.r_[rng.uniform(0.5, 2, bounds), middle + rng.uniform(0.5, 2, count)]
        lower = np.r_[-rng.uniform(0.5, 2, bounds), middle - rng.uniform(0.5, 2, count)]
        upper[bounds + 1], lower[bounds + 2] = np.inf, -np.inf  # one-sided rows
        cost = rng.normal(size=variables)
        program = _Program(np.zeros((variables, variables)), cost, rows, upper, lower, bounds=bounds, linear=True)
        x, flag, multipliers = program.solve()
        if flag != _EXIT_OPTIMAL:
            continue
        other, other_flag, other_multipliers = _highs_lp(cost, rows, upper, lower, bounds, "test")
        assert other_flag == _EXIT_OPTIMAL
        np.testing.assert_allclose(other, x, atol=1e-7)
        np.testing.assert_allclose(other_multipliers, multipliers, atol=1e-7)
        stationarity = cost + rows.T @ other_multipliers[bounds:]
        stationarity[:bounds] += other_multipliers[:bounds]
        assert np.abs(stationarity).max() <= 1e-9
        compared += 1
    assert compared >= 10


def test_an_energy_bounded_qp_daqp_cycles_on_even_from_a_cold_start_is_solved_by_highs(arms, monkeypatch):
    """A tiago circle of the atlas (seed 19, 1 s, path 536) with panda's energy setting: DAQP cycles on the QP at
    0.918 s, again from a cold start, and the run used to stop there; HiGHS's QP solver answers, and the run
    completes within every torque, position and velocity limit."""
    import torqueopt.resolvers.bounded.programs as programs
    from torqueopt import Circle

    failures = []
    fallback = programs._casadi_qp
    monkeypatch.setattr(programs, "_casadi_qp", lambda *args: failures.append(args[-1]) or fallback(*args))
    q0 = [2.6995195239610528, -1.5086065171612988, 0.000558835972180205, 2.2091661081704594, 1.620180831989226, 0.6222102247342536, 0.8539200770121926]  # fmt: skip
    start = np.array([-0.002166823401331775, -0.1556305007014348, 0.5454842858416378])
    centre = np.array([-0.008191778701149552, -0.16124060475062368, 0.5357463855278153])
    circle = Circle(0.012751472712180063, 1.0, normal=[0.3402437815532044, -0.8903730340997635, 0.30244012508653095],
                    centre_direction=centre - start, start=start)  # fmt: skip
    resolver = get_resolver("energy-bounded-torque", energy_limit=0.01, joint_acceleration_limit=10.0)
    run = torqueopt.simulate(arms["tiago"], resolver, circle, np.array(q0), dt=DT)
    assert run.completed, run.stop_reason
    assert any(failure.startswith("DAQP failed: cycling (-2), and from a cold start: cycling") for failure in failures)
    assert np.nanmax(run.peak_torque_ratio) <= 1 + 1e-6
    assert np.all(np.abs(run.v) <= run.velocity_limit)
    assert np.all((run.joint_angles >= run.position_lower) & (run.joint_angles <= run.position_upper))


def test_highs_answers_daqps_qp_form_with_daqps_multipliers():
    """On random strictly convex QPs of DAQP's form, HiGHS's QP solver (through CasADi) gives DAQP's answer and its
    multipliers, which meet Hx + f + [I; A]ᵀλ = 0."""
    from torqueopt.resolvers.bounded.programs import _EXIT_OPTIMAL, _casadi_qp, _Program

    rng = np.random.default_rng(11)
    compared = 0
    for _ in range(20):
        variables, bounds, count = 4, 2, 6
        factor = rng.normal(size=(variables, variables))
        hessian = factor @ factor.T + 0.1 * np.eye(variables)
        rows = rng.normal(size=(count, variables))
        upper = np.r_[rng.uniform(0.1, 1, bounds), rng.uniform(0.1, 1, count)]
        lower = np.r_[-rng.uniform(0.1, 1, bounds), -rng.uniform(0.1, 1, count)]
        upper[bounds + 1], lower[bounds + 2] = np.inf, -np.inf  # one-sided rows
        linear_term = 3 * rng.normal(size=variables)  # far enough out that some rows bind
        x, flag, multipliers = _Program(hessian, linear_term, rows, upper, lower, bounds=bounds).solve()
        assert flag == _EXIT_OPTIMAL
        other, other_flag, other_multipliers = _casadi_qp(hessian, linear_term, rows, upper, lower, bounds, "test")
        assert other_flag == _EXIT_OPTIMAL
        np.testing.assert_allclose(other, x, atol=1e-6)
        np.testing.assert_allclose(other_multipliers, multipliers, atol=1e-5)
        stationarity = hessian @ other + linear_term + rows.T @ other_multipliers[bounds:]
        stationarity[:bounds] += other_multipliers[:bounds]
        assert np.abs(stationarity).max() <= 1e-6
        compared += np.abs(multipliers).max() > 1e-6
    assert compared >= 10  # with bounds active, not only unconstrained minima


# -- a start on a position limit -----------------------------------------------------------------

BOUNDED = ["bounded-torque", "minmax-torque", "energy-bounded-torque"]


def _sliders():
    """Three prismatic joints (point-like masses, no gravity), slider1 within [0, 1] m."""
    from .test_optimal import prismatic_arm

    return prismatic_arm(limits=True)


@pytest.mark.parametrize("resolver", BOUNDED)
def test_a_start_on_a_position_limit_keeps_the_task(planar3, resolver):
    """planar3 from the paper's start with q1 on its URDF limit 2π, a 0.5 s line (√2 m/s², direction (1, 1)): the
    start is within the limits, and the line is possible with q1 <= 2π (the other two joints move). The
    bounds used to ask q1 back inside the 1e-4 rad margin in one step (200 rad/s²), and the step gave up the task
    from t = 0 (9.4 mm off the line). Now no step is infeasible, the tip stays on the line and q1 never passes
    2π."""
    q0 = planar3.default_configuration.copy()
    q0[0] = 2.0 * np.pi
    run = torqueopt.simulate(planar3, resolver, StraightLine((1.0, 1.0), duration=0.5), q0, dt=DT)
    assert run.completed and not run.infeasible.any(), run.first_infeasible_step
    assert run.max_tip_error < 1e-4, run.max_tip_error
    assert run.joint_angles[:, 0].max() <= 2.0 * np.pi
    assert run.first_position_violation is None and run.first_velocity_violation is None


@pytest.mark.parametrize("resolver", BOUNDED)
def test_a_prismatic_joint_starting_at_its_lower_limit_keeps_the_task(resolver):
    """Three sliders from 0, slider1 on its lower limit 0 m, a 0.5 s line towards −x, which slider1 cannot follow
    (its limit) and sliders 2 and 3 can (x = q1 + q3/√2, y = q2 + q3/√2: q3 < 0, q2 > 0). The tip stays on the
    line (a straight line for a linear arm: to round-off), slider1 never goes below 0 m."""
    robot = _sliders()
    run = torqueopt.simulate(robot, resolver, StraightLine((-1.0, 0.0), duration=0.5), np.zeros(3), dt=DT)
    assert run.completed and not run.infeasible.any(), run.first_infeasible_step
    assert run.max_tip_error < 1e-9, run.max_tip_error
    assert run.joint_angles[:, 0].min() >= -1e-12
    assert run.joint_angles[-1, 2] < -0.05  # the diagonal slider did the −x
    assert run.first_position_violation is None


def test_a_joint_beyond_its_pulled_in_limit_is_sent_back_at_its_deceleration_not_in_one_step():
    """slider1 on its URDF limit 0 m, 1e-4 m beyond the limit the bounds use: the position bound used to ask for the
    whole 1e-4 m back in one step (2·1e-4/δ² = 200 m/s²); now it asks the joint to stop within the step and come
    back at ā⁻ (half its 100 N over the 6 kg it moves, 8.3 m/s²), and no more. A drift-size excess (2e-8 m) is still
    taken back in one step (0.04 m/s², less than ā⁻)."""
    robot = _sliders()
    limits = JointLimits(robot, DT)
    terms = robot.terms(np.zeros(3), np.zeros(3))
    deceleration = 0.5 * 100.0 / 6.0
    assert terms.inertia[0, 0] == pytest.approx(6.0, rel=1e-12)
    at_rest = limits(terms)
    assert at_rest.lower[0] == pytest.approx(deceleration, rel=1e-12)
    assert at_rest.upper[0] > 1e3  # moving inside is free
    outward = limits(robot.terms(np.zeros(3), np.array([-0.01, 0.0, 0.0])))
    assert outward.lower[0] == pytest.approx(0.01 / DT + deceleration, rel=1e-12)
    drift = limits(robot.terms(np.array([1e-4 - 2e-8, 0.0, 0.0]), np.zeros(3)))
    assert drift.lower[0] == pytest.approx(2 * 2e-8 / DT**2, rel=1e-6)


# -- the deceleration the torque box gives --------------------------------------------------------


def _box_lp(inertia, bias, upper, lower, joint, sign):
    """sign · the extreme of q̈_joint = [H⁻¹(τ − b)]_joint over τ in [lower, upper], by HiGHS (unbounded: ±inf)."""
    row = np.linalg.solve(inertia, np.eye(len(bias))[joint])  # (H⁻¹)_joint· (H symmetric)
    box = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lower, upper)]
    answer = linprog(-sign * row, bounds=box, method="highs")
    if answer.status == 3:
        return np.inf
    assert answer.status == 0
    return -answer.fun - sign * row.dot(bias)


def test_the_acceleration_range_is_the_box_lp(arms, rng):
    """At random panda and baxter states (gravity on), asymmetric torque boxes that leave some joints less than their
    bias torque, one joint unbounded: the closed form of each joint's extreme accelerations over the box equals
    HiGHS's LP, per joint and each way (the unbounded joint: ±inf, and 0 N·m in the others' ranges). The deceleration
    the bounds count on is ½·max(τmax − |b|, 0.1 τmax)/Hᵢᵢ with the smaller side of an asymmetric box, and at least
    ½·max(τmax − |g|, 0.1 τmax)/Hᵢᵢ where the velocity terms b − g alone take more than nine tenths of τmax, the same
    both ways."""
    from torqueopt.resolvers.bounded.joint_limits import acceleration_range, stopping_deceleration

    checked = 0
    pin.seed(5)
    for name in ("panda", "baxter"):
        robot = arms[name]
        for case in range(3):
            q = pin.randomConfiguration(robot.model)
            terms = robot.terms(q, rng.uniform(-1.0, 1.0, robot.nv))
            bias = np.abs(terms.bias_torque)
            upper = np.where(rng.uniform(size=robot.nv) < 0.5, 0.8, 3.0) * bias + 1.0
            lower = -upper * rng.uniform(0.8, 1.2, robot.nv)
            if case == 2:
                upper[1], lower[1] = np.inf, -np.inf
            lowest, highest = acceleration_range(terms, upper, lower)
            gravity = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q)
            before_upper, before_lower = stopping_deceleration(terms, upper, lower, gravity)
            limit = np.minimum(upper, -lower)
            beyond_bias = np.maximum(limit - np.abs(terms.bias_torque), 0.1 * limit)
            taken = np.abs(terms.bias_torque - gravity) > 0.9 * limit
            beyond_gravity = np.maximum(limit - np.abs(gravity), 0.1 * limit)
            available = np.where(taken, np.maximum(beyond_bias, beyond_gravity), beyond_bias)
            expected = 0.5 * available / np.diagonal(terms.inertia)
            np.testing.assert_allclose(before_upper, expected, rtol=1e-12)
            np.testing.assert_array_equal(before_upper, before_lower)
            box_upper, box_lower = np.where(np.isfinite(upper), upper, 0.0), np.where(np.isfinite(lower), lower, 0.0)
            for joint in range(robot.nv):
                if case == 2 and joint == 1:
                    assert lowest[joint] == -np.inf and highest[joint] == np.inf
                    continue
                expected_high = _box_lp(terms.inertia, terms.bias_torque, box_upper, box_lower, joint, 1.0)
                expected_low = -_box_lp(terms.inertia, terms.bias_torque, box_upper, box_lower, joint, -1.0)
                scale = highest[joint] - lowest[joint]
                assert highest[joint] == pytest.approx(expected_high, abs=1e-9 * scale)
                assert lowest[joint] == pytest.approx(expected_low, abs=1e-9 * scale)
                checked += 1
    assert checked == 2 * (3 * 7 - 1)


def test_the_issue_s_state_eight_radians_from_every_limit_keeps_the_task(planar3):
    """planar3 at q = (−0.91, 2.19, 0.24) rad, q̇ = (1.31, −1.1, −1.26) rad/s, 8.5 rad from every limit. The ā that
    counted the whole bias torque took joint2's Coriolis torque (25.3 N·m, more than its 24 N·m) as lasting the whole
    stop: ā = ½·0.1·24 N·m/H₂₂ = 0.045 rad/s², the state was not viable and the step gave up the task ("position
    limit (stopping distance) (lower) of joint joint2 by 229 rad/s²"). Where the velocity terms (Pinocchio's RNEA) alone
    take more than nine tenths of the limit (joint2, and joint3: 5.66 of 6 N·m), ā counts gravity (none here):
    ā₂ = ½·24 N·m/H₂₂ = 0.45 rad/s², within the 6.4 rad/s² the torque box gives joint2 (HiGHS); joint1 counts its
    bias (21.2 of 54 N·m). Stopping from 1.1 rad/s takes 1.3 rad, no joint row binds and every bounded resolver's
    step is the one it takes with joint_limits=off (bounded-torque and minmax-torque keep the task)."""
    q, v = np.array([-0.91, 2.19, 0.24]), np.array([1.31, -1.1, -1.26])
    terms = planar3.terms(q, v)
    highest = _box_lp(terms.inertia, terms.bias_torque, planar3.torque_upper, planar3.torque_lower, 1, 1.0)
    assert 6.0 < highest < 7.0, highest
    bounds = JointLimits(planar3, DT)(terms)
    bias = pin.rnea(planar3.model, planar3.model.createData(), q, v, np.zeros(3))
    limit = planar3.torque_upper
    assert list(np.abs(bias) > 0.9 * limit) == [False, True, True]
    available = np.array([limit[0] - abs(bias[0]), limit[1], limit[2]])
    np.testing.assert_allclose(bounds.deceleration, 0.5 * available / np.diagonal(terms.inertia), rtol=1e-12)
    assert bounds.deceleration[1] < highest
    for resolver in BOUNDED:
        on = get_resolver(resolver).solver(planar3, DT)(terms, np.zeros(2))
        off = get_resolver(resolver, joint_limits="off").solver(planar3, DT)(terms, np.zeros(2))
        np.testing.assert_allclose(on.joint_acceleration, off.joint_acceleration, atol=1e-9)
        assert on.infeasible == off.infeasible, on.limiting
        # energy-bounded-torque's own energy bound gives the task up here, with or without joint limits.
        assert resolver == "energy-bounded-torque" or (not on.infeasible and on.task_error == 0.0), on.limiting


def test_random_planar3_states_far_from_its_limits_keep_the_task(planar3):
    """30 random planar3 states, drawn as ``benchmarks/bounded_atlas_sample.py planar3`` draws them (seed 0: q in
    [−π, π]³ rad, q̇ in [−1.5, 1.5]³ rad/s, ẍ = √2 m/s² in a random direction), each at least 3.1 rad from planar3's
    ±2π limits: wherever the step without joint limits keeps the task, the step with them keeps it too (the ā that
    counted the whole bias torque everywhere gave it up at 5 of them), but at state 21 (a regression pin): joint1 turns
    at 1.48 rad/s 3.9 rad from its limit, its Coriolis torque (11 of 54 N·m) counts, and ā = 0.26 rad/s² needs
    4.2 rad to stop, where the torque box gives 16.6 rad/s²."""
    generator = np.random.default_rng(0)
    states = [
        (generator.uniform(-np.pi, np.pi, 3), generator.uniform(-1.5, 1.5, 3), generator.normal(size=2))
        for _ in range(30)
    ]
    for resolver in ("bounded-torque", "minmax-torque"):
        on = get_resolver(resolver).solver(planar3, DT)
        off = get_resolver(resolver, joint_limits="off").solver(planar3, DT)
        given_up = []
        for index, (q, v, direction) in enumerate(states):
            terms = planar3.terms(q, v)
            command = np.sqrt(2.0) * direction / np.linalg.norm(direction)
            if on(terms, command).task_error > 1e-9 and off(terms, command).task_error <= 1e-9:
                given_up.append(index)
        assert given_up == [21], (resolver, given_up)


def test_the_deceleration_counts_the_bias_and_gravity_alone_where_the_velocity_terms_take_the_limit(arms, rng):
    """At random panda and baxter states, at q̇ and at 4 q̇: ā = ½·max(τmax − |b|, 0.1 τmax)/Hᵢᵢ with b Pinocchio's RNEA at
    (q, q̇), and at least ½·max(τmax − |g|, 0.1 τmax)/Hᵢᵢ (g the RNEA at rest) where the velocity terms b − g alone take
    more than nine tenths of τmax (they fall as the joints slow). Both cases occur, and a stack of the same states
    gives the same numbers."""
    from torqueopt.resolvers.stacks import StackTerms

    pin.seed(7)
    cases = {True: 0, False: 0}
    for name in ("panda", "baxter"):
        robot = arms[name]
        limits = JointLimits(robot, DT)
        data = robot.model.createData()
        limit = np.minimum(robot.torque_upper, -robot.torque_lower)
        single, states = [], []
        for _ in range(4):
            q = pin.randomConfiguration(robot.model)
            for scale in (1.0, 4.0):
                v = scale * rng.uniform(-2.0, 2.0, robot.nv)
                bias = pin.rnea(robot.model, data, q, v, np.zeros(robot.nv))
                gravity = pin.rnea(robot.model, data, q, np.zeros(robot.nv), np.zeros(robot.nv))
                taken = np.abs(bias - gravity) > 0.9 * limit
                with_bias = np.maximum(limit - np.abs(bias), 0.1 * limit)
                available = np.where(taken, np.maximum(with_bias, limit - np.abs(gravity)), with_bias)
                terms = robot.terms(q, v)
                found = limits(terms).deceleration
                np.testing.assert_allclose(
                    found, (0.5 * available / np.diagonal(terms.inertia))[limits.joints], rtol=1e-12
                )
                for flag in (True, False):
                    cases[flag] += int((taken == flag).sum())
                single.append(found)
                states.append(terms)
        stack = StackTerms(*(np.stack([getattr(state, field) for state in states]) for field in StackTerms._fields))
        np.testing.assert_allclose(limits(stack).deceleration, np.array(single), rtol=1e-12)
    assert cases[True] >= 3 and cases[False] >= 30, cases
