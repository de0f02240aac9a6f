"""The batched simulation path against the readable reference, torqueopt.simulate, run by run."""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.batch import batch_supports, simulate_batch, simulate_many
from torqueopt.errors import InvalidInput, NoRedundancy
from torqueopt.resolvers import RESOLVERS
from torqueopt.resolvers.stacks import LoopedStackStep
from torqueopt.tasks import FrameTask, PostureTask

from .conftest import PAPER_Q0

PAPER_RESOLVERS = ["pinv", "inertia-pinv", "null-space", "weighted-null-space"]
REMEDIES = ["damped-null-space", "self-motion-damping", "inverse-inertia-torque", "inverse-inertia-squared-torque"]
BOUNDED = ["bounded-torque", "minmax-torque", "energy-bounded-torque"]
_ARRAYS = (
    "t", "q", "joint_angles", "v", "acceleration", "tau", "x", "x_ref", "jacobian_inverse_condition", "task_error",
)  # fmt: skip


def assert_same_run(batched, reference, tolerance=1e-9):
    """Same rows, same stop, and every array equal to ``tolerance`` relative to (1 + |value|)."""
    assert batched.stop_reason == reference.stop_reason
    assert batched.stop_time == reference.stop_time
    assert batched.trajectory == reference.trajectory
    assert batched.resolver_options == reference.resolver_options
    assert np.array_equal(batched.infeasible, reference.infeasible)
    assert (batched.robot, batched.resolver, batched.duration, batched.dt) == (
        reference.robot, reference.resolver, reference.duration, reference.dt
    )  # fmt: skip
    for name in _ARRAYS:
        ours, theirs = getattr(batched, name), getattr(reference, name)
        assert ours.shape == theirs.shape, name
        # Rows that hold no torque (the final state, a singular stop) are NaN in both.
        np.testing.assert_array_equal(np.isnan(ours), np.isnan(theirs), err_msg=name)
        finite = ~np.isnan(theirs)
        if finite.any():
            assert np.max(np.abs(ours - theirs)[finite] / (1.0 + np.abs(theirs[finite]))) <= tolerance, name


def batch_on_stacks(robot, resolver, lines, q0s, **ceilings):
    """``simulate_batch``'s runs, checking that it ran the movements on stacks (the velocity level's lanes,
    ``KinematicStack``), not one at a time through the kinematic loop."""
    from torqueopt.batch import KinematicStack
    from torqueopt.engine import run_movements

    seen = []

    def watching(lanes, steps):
        seen.append(type(lanes))
        run_movements(lanes, steps)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(torqueopt.batch, "run_movements", watching)
        runs = simulate_batch(robot, resolver, lines, q0s, **ceilings)
    assert seen == [KinematicStack]
    return runs


def assert_stacks_equal_simulate(robot, resolver, lines, q0s, tolerance=1e-9, **ceilings):
    """The batch's runs on stacks (:func:`batch_on_stacks`) equal ``simulate``'s run by run
    (:func:`assert_same_run` at ``tolerance``); ``simulate``'s runs returned, for the caller to check what they
    cover."""
    runs = batch_on_stacks(robot, resolver, lines, q0s, **ceilings)
    singles = [torqueopt.simulate(robot, resolver, line, q0, **ceilings) for line, q0 in zip(lines, q0s)]
    for run, single in zip(runs, singles):
        assert_same_run(run, single, tolerance)
    return singles


def _population(robot, count, seed):
    rng = np.random.default_rng(seed)
    q0s = rng.uniform(-np.pi, np.pi, (count, robot.nv))
    directions = rng.normal(size=(count, min(robot.m, 3)))
    return q0s, directions


# null-space, whose long runs whip and stop early, stays in the quick selection (-m "not slow");
# the panda test below holds all four resolvers there.
@pytest.mark.parametrize(
    "name",
    [
        name if name in ("null-space", "damped-null-space") else pytest.param(name, marks=pytest.mark.slow)
        for name in PAPER_RESOLVERS + REMEDIES
    ],
)
def test_batch_equals_simulate_on_planar3(planar3, name):
    """Random starts and directions plus the paper's movement: the long
    null-space runs whip and (with a ceiling of 20x the limits) stop early,
    so the batch loses members mid-way and the others must not notice."""
    q0s, directions = _population(planar3, 10, seed=7)
    q0s = np.vstack([q0s, PAPER_Q0])
    directions = np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.6) for d in directions]
    runs = simulate_batch(planar3, name, lines, q0s, max_torque_ratio=20.0)
    references = [torqueopt.simulate(planar3, name, line, q0, max_torque_ratio=20.0) for line, q0 in zip(lines, q0s)]
    for run, reference in zip(runs, references):
        assert_same_run(run, reference)
    if name != "pinv":
        assert any(not run.completed for run in runs)  # the test exercises early stops
    assert any(run.completed for run in runs)


def _assert_batch_equals_simulate_on_panda(panda, resolver, seed: int, count: int, duration: float) -> None:
    """``count`` random panda lines (0.5 m/s², from starts 0.3 rad about the default): the batch is simulate."""
    rng = np.random.default_rng(seed)
    q0s = [panda.default_configuration + rng.normal(scale=0.3, size=panda.nv) for _ in range(count)]
    lines = [StraightLine(rng.normal(size=3), accel=0.5, duration=duration) for _ in q0s]
    runs = simulate_batch(panda, resolver, lines, q0s)
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(panda, resolver, line, q0))


@pytest.mark.parametrize("name", PAPER_RESOLVERS + REMEDIES)
def test_batch_equals_simulate_on_panda(panda, name):
    """Seven joints, three task rows, gravity on: a null space of dimension 4."""
    if name == "weighted-null-space" and not np.isfinite(panda.torque_upper).all():
        pytest.skip("panda has joints without torque limit")
    _assert_batch_equals_simulate_on_panda(panda, name, seed=3, count=3, duration=0.4)


@pytest.mark.slow
def test_weighted_with_a_user_weight_and_a_singular_stop(planar3):
    """A user weight vector and a matrix go through the batch as through the
    resolver; a run that straightens the arm stops at the singular cutoff with
    simulate's message, while its batch-mates finish."""
    weights = [np.array([1.0, 4.0, 9.0]), np.diag([2.0, 1.0, 5.0]) + 0.5]
    for weight in weights:
        resolver = torqueopt.get_resolver("weighted-null-space", weight=weight)
        lines = [StraightLine([1, 1], duration=1.0), StraightLine([0.3, -1], duration=1.0)]
        q0s = [PAPER_Q0, [0.4, 1.1, -0.7]]
        for run, line, q0 in zip(simulate_batch(planar3, resolver, lines, q0s), lines, q0s):
            assert_same_run(run, torqueopt.simulate(planar3, resolver, line, q0))
    resolver = torqueopt.get_resolver("pinv", singular_tolerance=0.02)
    lines = [StraightLine([1, 0], accel=1.0, duration=3.0), StraightLine([0, 1], accel=0.2, duration=3.0)]
    q0s = [[0.0, 1.0, -1.0], PAPER_Q0]
    runs = simulate_batch(planar3, resolver, lines, q0s)
    assert runs[0].stop_reason.startswith("task Jacobian is singular") and runs[1].completed
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, resolver, line, q0))


def test_speed_stop_matches_simulate(planar3):
    """A low joint-speed ceiling stops the whipping runs after a step, as simulate does."""
    lines = [StraightLine([1, 1], duration=2.0), StraightLine([1, 1], duration=2.0)]
    q0s = [PAPER_Q0, [0.2, 0.9, 0.6]]
    runs = simulate_batch(planar3, "null-space", lines, q0s, max_joint_speed=3.0)
    assert runs[0].stop_reason.startswith("speed of joint")
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, "null-space", line, q0, max_joint_speed=3.0))


def test_simulate_many_batches_by_duration_and_falls_back(planar3, panda_pose):
    lines = [
        StraightLine([1, 1], duration=0.3),
        StraightLine([1, -1], duration=0.5),
        StraightLine([0, 1], duration=0.3),
    ]
    q0s = [PAPER_Q0, PAPER_Q0, [0.3, 1.2, -0.4]]
    for run, line, q0 in zip(simulate_many(planar3, "null-space", lines, q0s), lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, "null-space", line, q0))
    # The pose task is not batched: simulate_many calls simulate, so the runs are identical.
    assert not batch_supports(panda_pose, "pinv")
    line = StraightLine([0, 0, 1], accel=0.3, duration=0.1)
    (run,) = simulate_many(panda_pose, "pinv", [line], [panda_pose.default_configuration])
    assert_same_run(run, torqueopt.simulate(panda_pose, "pinv", line, panda_pose.default_configuration), tolerance=0.0)


def test_batch_leaves_the_robot_data_alone_and_refuses_what_it_cannot_do(planar3, panda_pose):
    gravity, limit = planar3.gravity, planar3.torque_limit.copy()
    simulate_batch(planar3, "pinv", [StraightLine([1, 1], duration=0.05)], [PAPER_Q0])
    # A Robot holds no Pinocchio data (each run makes its own); its description is unchanged.
    assert not hasattr(planar3, "data")
    assert np.array_equal(planar3.gravity, gravity) and np.array_equal(planar3.torque_limit, limit)
    with pytest.raises(InvalidInput, match="the batched path does not support task 'pose' \\(robot 'panda'\\)"):
        simulate_batch(panda_pose, "pinv", [StraightLine([0, 0, 1], duration=0.1)], [panda_pose.default_configuration])
    with pytest.raises(InvalidInput, match=r"a batch needs movements of one duration, got \[0.1, 0.2\] s"):
        simulate_batch(planar3, "pinv", [StraightLine([1, 1], duration=d) for d in (0.1, 0.2)], [PAPER_Q0] * 2)
    # The registry is the only list: every resolver has a step on stacks; the paper's, the remedies' and the
    # bounded resolvers' are vectorised.
    vectorised = {
        name for name, cls in RESOLVERS.items() if not isinstance(cls().batch_solver(planar3, 1e-3), LoopedStackStep)
    }
    assert vectorised == set(PAPER_RESOLVERS + REMEDIES + BOUNDED)


@pytest.mark.parametrize("name", ["null-space", "velocity-pinv", "task-priority"])
def test_batch_energies_against_their_definition(planar3, name):
    """Kinetic energy ½ q̇ᵀHq̇ from Pinocchio's CRBA at the recorded states, and
    the self-motion energy T − ½ẋᵀΛẋ against a direct minimisation: the
    least kinetic energy of any q̇' with Jq̇' = Jq̇ is at q̇' = J_H⁺ J q̇; for the
    torque batch and the velocity-level stacks (whose energies come from their steps)."""
    lines = [StraightLine([1, 1], duration=1.2), StraightLine([-1, 0.2], duration=1.2)]
    q0s = [PAPER_Q0, [0.5, 1.0, -2.0]]
    runs, extras = simulate_batch(planar3, name, lines, q0s, extras=True)
    assert [len(extra.kinetic_energy) for extra in extras] == [len(run.t) for run in runs]
    assert all(extra.self_motion_energy.max() > 1e-6 for extra in extras)  # the lines move the null space
    data = planar3.model.createData()
    for run, extra in zip(runs, extras):
        for row in range(0, len(run.t), 97):
            q, v = run.q[row], run.v[row]
            inertia = pin.crba(planar3.model, data, q)
            inertia = np.triu(inertia) + np.triu(inertia, 1).T
            jacobian = pin.computeFrameJacobian(planar3.model, data, q, planar3.frame_id, pin.LOCAL_WORLD_ALIGNED)[:2]
            kinetic = 0.5 * v @ inertia @ v
            # Minimum-energy velocity with the same tip velocity, by a KKT solve.
            kkt = np.block([[inertia, jacobian.T], [jacobian, np.zeros((2, 2))]])
            least = np.linalg.solve(kkt, np.concatenate([np.zeros(3), jacobian @ v]))[:3]
            assert extra.kinetic_energy[row] == pytest.approx(kinetic, rel=1e-9)
            assert extra.self_motion_energy[row] == pytest.approx(
                kinetic - 0.5 * least @ inertia @ least, rel=1e-7, abs=1e-9
            )


def test_batch_takes_any_trajectory(planar3):
    """The trajectory protocol: a minimum-jerk line and a circle, batched together."""
    from torqueopt.trajectory import Circle, MinimumJerkLine

    lines = [
        MinimumJerkLine([1, 0.5], length=0.6, duration=0.8),
        Circle(radius=0.3, duration=0.8, centre_direction=[0, 1]),
    ]
    q0s = [PAPER_Q0, [0.3, 1.4, -1.0]]
    for run, line, q0 in zip(simulate_batch(planar3, "inertia-pinv", lines, q0s), lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, "inertia-pinv", line, q0))


@pytest.mark.parametrize(
    "options", [{"torque_weight": "range", "kinematic_weight": 2.0}, {"kinematic_weight": 0.0, "damping": 3.0}]
)
def test_damped_null_space_options_match_simulate(planar3, options):
    """The range weight with a heavy kinematic term, and μ = 0 (the paper's least squares exactly)."""
    resolver = torqueopt.get_resolver("damped-null-space", **options)
    q0s, directions = _population(planar3, 6, seed=12)
    lines = [StraightLine(d, duration=1.2) for d in directions]
    runs = simulate_batch(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, resolver, line, q0, max_torque_ratio=20.0))


# -- every registered resolver through the batch ---------------------------------------------

#: Options a resolver needs before it can run at all (the rest run with their defaults).
_NEEDED_OPTIONS = {
    "obstacle-avoidance": {"obstacle": "1.2,0.3,0.0,0.1"},
    # an NLP per solve: a short window, replanned every 50 steps (its own tests run it along whole movements)
    "receding-horizon": {"horizon": 0.05, "replan_every": 50},
}
#: Resolvers whose single steps are costly (programs per step, or several pseudoinverses and closed-form or differenced
#: q̈ per velocity-level step): quick on planar3 only.
_COSTLY = {
    "bounded-torque", "minmax-torque", "energy-bounded-torque", "task-priority", "extended-jacobian",
    "kinetic-energy-pinv", "obstacle-avoidance", "gradient-projection", "receding-horizon",
}  # fmt: skip


def _registered(name):
    return torqueopt.get_resolver(name, **_NEEDED_OPTIONS.get(name, {}))


@pytest.mark.parametrize(
    "name", [pytest.param(name, marks=pytest.mark.slow) if name == "receding-horizon" else name for name in RESOLVERS]
)
def test_every_registered_resolver_batched_equals_simulate_on_planar3(planar3, name):
    """B movements through simulate_batch equal B simulate runs (1e-9, same stops, same shortfalls), for
    every resolver of the registry: the vectorised steps and the single-state steps looped on stacks."""
    resolver = _registered(name)
    q0s, directions = _population(planar3, 4, seed=21)
    q0s = np.vstack([q0s, PAPER_Q0])
    directions = np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=0.5 if name in _COSTLY else 1.2) for d in directions]
    runs = simulate_batch(planar3, resolver, lines, q0s, max_torque_ratio=20.0)
    assert len(runs) == len(lines)
    # The extended Jacobian's single-state q̈ takes its curvature by a central difference (δ = 1e-5 rad), its
    # stack in closed form: τ differs by the difference's own error (2.1e-9 of it measured; q and q̇ far less).
    tolerance = 1e-8 if name == "extended-jacobian" else 1e-9
    for run, line, q0 in zip(runs, lines, q0s):
        assert_same_run(run, torqueopt.simulate(planar3, resolver, line, q0, max_torque_ratio=20.0), tolerance)


@pytest.mark.parametrize(
    "name", [pytest.param(name, marks=pytest.mark.slow) if name in _COSTLY else name for name in RESOLVERS]
)
def test_every_registered_resolver_batched_equals_simulate_on_panda(panda, name):
    """The same on panda (n = 7, position task, gravity on): the forest's terms and the stacked RK4 for the
    vectorised steps, the single-state ones row by row."""
    resolver = _registered(name)
    try:
        resolver.check(panda)
    except (InvalidInput, NoRedundancy) as error:  # extended-jacobian needs n − m = 1
        pytest.skip(str(error))
    _assert_batch_equals_simulate_on_panda(panda, resolver, seed=4, count=3, duration=0.25)


@pytest.mark.parametrize(
    ("options", "ceilings", "stop"),
    [
        ({"singular_tolerance": 0.15}, {}, "task Jacobian is singular"),
        ({}, {"max_joint_speed": 2.0}, "speed of joint"),
        ({}, {"max_torque_ratio": 1.0}, "torque of joint"),
        ({"position_gain": 3.0, "singular_tolerance": 0.1}, {"max_torque_ratio": 3.0}, "task Jacobian is singular"),
    ],
)
@pytest.mark.parametrize("name", ["velocity-pinv", "gradient-projection", "kinetic-energy-pinv", "task-priority"])
def test_velocity_level_stacks_stop_where_the_kinematic_loop_does(planar3, name, options, ceilings, stop):
    """velocity-pinv's, gradient projection's, the kinetic-energy pseudoinverse's and task priority's (below a
    posture task) stacked forms (forest kinematics, closed-form q̈, RK4 on the stack) equal their kinematic loop
    run by run, through each of its stops: the method undefined, its rates and its torques past a ceiling."""
    resolver = torqueopt.get_resolver(name, **options)
    q0s, directions = _population(planar3, 8, seed=5)
    q0s, directions = np.vstack([q0s, PAPER_Q0]), np.vstack([directions, [1.0, 1.0]])
    lines = [StraightLine(d, duration=1.5) for d in directions]
    singles = assert_stacks_equal_simulate(planar3, resolver, lines, q0s, **ceilings)
    assert any(single.stop_reason and single.stop_reason.startswith(stop) for single in singles)
    assert any(single.stop_reason is None for single in singles)


@pytest.mark.parametrize("options", [{}, {"k": 40.0, "position_gain": 4.0}])
def test_gradient_projection_on_stacks_equals_the_kinematic_loop_on_panda(panda, options):
    """Seven joints with limits, three task rows: the stacked Eq. (4) and its closed-form q̈ run by run."""
    resolver = torqueopt.get_resolver("gradient-projection", **options)
    assert resolver.stack_rate_function(panda) is not None  # the stacked form, not one movement at a time
    _assert_batch_equals_simulate_on_panda(panda, resolver, seed=8, count=4, duration=0.3)


@pytest.mark.parametrize("options", [{}, {"position_gain": 4.0}])
def test_the_kinetic_energy_pseudoinverse_on_stacks_equals_the_kinematic_loop_on_panda(panda, options):
    """Seven joints with gravity, three task rows: the stacked Eq. (16) with W = H (H⁻¹ and Ḣq̇ from the forest)
    and its closed-form q̈ run by run."""
    resolver = torqueopt.get_resolver("kinetic-energy-pinv", **options)
    assert resolver.stack_rate_function(panda) is not None  # the stacked form, not one movement at a time
    _assert_batch_equals_simulate_on_panda(panda, resolver, seed=8, count=4, duration=0.3)


@pytest.mark.parametrize(
    "options",
    [
        {"position_gain": 4.0},
        # two postures: the second has no freedom left (Eq. (11)'s recursion), only the first acts
        {"secondary": [PostureTask([0.3, -0.2, 0.1, -2.0, 0.0, 1.8, 0.5], gain=3.0), PostureTask(gain=5.0)]},
    ],
)
def test_task_priority_on_stacks_equals_the_kinematic_loop_on_panda(panda, options):
    """Seven joints: Eq. (11) below posture tasks (the general recursion, SVD pseudoinverses, in simulate) equals
    its stacked form as gradient projection toward the posture target, run by run."""
    resolver = torqueopt.get_resolver("task-priority", **options)
    assert resolver.stack_rate_function(panda) is not None  # the stacked form, not one movement at a time
    _assert_batch_equals_simulate_on_panda(panda, resolver, seed=8, count=4, duration=0.3)


def test_task_priority_with_damping_runs_one_movement_at_a_time(planar3):
    """Damping needs the damped inverses' derivative, and continuous joints a posture in joint angles: no stacked
    form; the batch takes them through the kinematic loop, equal to simulate (a frame task below has a stacked
    form, tests/test_stack_task_priority.py, and equals simulate here too)."""
    elbow = torqueopt.get_resolver("task-priority", secondary=FrameTask("link3", "xy", target=[0.5, -0.5]))
    damped = torqueopt.get_resolver("task-priority", damping=0.1)
    assert elbow.stack_rate_function(planar3) is not None and damped.stack_rate_function(planar3) is None
    # kinova's continuous joints (nq = 9, nv = 6): its configuration is not its joint angles plus a constant
    assert torqueopt.get_resolver("task-priority").stack_rate_function(torqueopt.load_robot("kinova")) is None
    q0s, directions = _population(planar3, 2, seed=5)
    lines = [StraightLine(d, duration=0.3) for d in directions]
    for resolver in (elbow, damped):
        for run, line, q0 in zip(simulate_batch(planar3, resolver, lines, q0s), lines, q0s):
            assert_same_run(run, torqueopt.simulate(planar3, resolver, line, q0))


def test_a_bounded_resolver_in_the_batch_keeps_its_shortfalls_and_stops(planar3):
    """bounded-torque under limits of 3 N·m gives up part of the paper's movement (infeasible rows, task errors,
    the bounds they lay on): the batch records them row for row as simulate does, beside an easier movement."""
    weak = planar3.with_torque_limit(3.0)
    lines = [StraightLine([1, 1], duration=0.6), StraightLine([0.2, -1], accel=0.1, duration=0.6)]
    q0s = [PAPER_Q0, [0.4, 1.1, -0.7]]
    runs = simulate_batch(weak, "bounded-torque", lines, q0s)
    references = [torqueopt.simulate(weak, "bounded-torque", line, q0) for line, q0 in zip(lines, q0s)]
    assert references[0].infeasible.any() and references[0].task_error.max() > 0.1 and references[0].limiting
    for run, reference in zip(runs, references):
        assert_same_run(run, reference)
        assert run.limiting == reference.limiting


def test_the_batch_memory_follows_the_steps_taken(planar3):
    """duration 1e5 s (1e8 steps) and no step limit, every movement stopped within a second by the speed
    ceiling: the batch's logs and reference grow by blocks, so it holds a few blocks, not the duration."""
    import tracemalloc

    lines = [StraightLine([1, 1], duration=1e5), StraightLine([1, -0.5], duration=1e5)]
    tracemalloc.start()
    try:
        runs = simulate_batch(planar3, "null-space", lines, [PAPER_Q0, PAPER_Q0], max_steps=10**30, max_joint_speed=1.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert all(not run.completed and len(run.t) < 2000 for run in runs)
    assert peak < 30e6, peak
