"""receding-horizon: at its two ends the whole-movement optimum and (to first order in the step) the local
bounded optimum, IPOPT's KKT conditions at its solves (Pinocchio's derivatives), a failed solve that falls back
and says so, the terminal conditions, stacks equal to single runs, and the resolver contract."""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import InvalidInput, NoRedundancy
from torqueopt.optimal import optimize, run_cost
from torqueopt.optimal.transcription import Transcription
from torqueopt.paper import PAPER
from torqueopt.resolvers import receding_horizon
from torqueopt.resolvers.receding_horizon import HorizonProgram, RecedingHorizon, plan_state, plan_states
from torqueopt.self_motion import self_motion_energy
from torqueopt.testing import check_resolver

casadi = pytest.importorskip("casadi")

#: Below the unbounded optimum's peaks on the short paper movement (2.09, 3.33, 4.39 N·m): the bounds act.
TIGHT_LIMIT = np.array([2.0, 3.15, 4.2])


@pytest.fixture(scope="module")
def paper_arm():
    return PAPER.load_robot()


class Capturing(RecedingHorizon):
    """receding-horizon keeping the steps it makes, so a test can read their solves."""

    def __init__(self, **options):
        super().__init__(**options)
        self.steps = []

    def solver_for_movement(self, robot, dt, trajectory):
        step = super().solver_for_movement(robot, dt, trajectory)
        self.steps.append(step)
        return step


@pytest.mark.slow
def test_a_horizon_of_the_whole_movement_planned_once_is_the_whole_movement_optimum(paper_arm, tmp_path, monkeypatch):
    """Same program (knots 10 ms, torque bounds and joint limits of the URDF, end free), solved once from the
    start: the run's torques are the optimum's on the 1 ms grid, so are their costs (1e-6; measured 3e-12). The
    window (N = 50) evaluates compiled C, the optimum CasADi's virtual machine."""
    monkeypatch.setenv("TORQUEOPT_CACHE", str(tmp_path / "cache"))
    line = PAPER.line("short")
    optimum = optimize(
        paper_arm, line, PAPER.q0, transcription="shooting", end="free", torque_bounds=True, joint_limits=True,
        grid_step=0.01,
    )  # fmt: skip
    resolver = f"receding-horizon[horizon={line.duration},horizon_dt=0.01,replan_every=1000]"
    run = torqueopt.simulate(paper_arm, resolver, line, PAPER.q0, dt=1e-3)
    assert optimum.optimal and run.completed
    assert run_cost(run, paper_arm) == pytest.approx(optimum.cost, rel=1e-6)
    np.testing.assert_allclose(run.tau[:-1], optimum.tau[:-1], rtol=0, atol=1e-6)


def on_path_state(robot, line, t):
    """A state exactly on the path at t: q by Newton onto x_ref(t) from the bounded run's, J q̇ = ẋ_ref(t)."""
    run = torqueopt.simulate(robot, "bounded-torque[kinematic_weight=0]", line, PAPER.q0, duration=t)
    q, v = run.q[-1].copy(), run.v[-1].copy()
    sample = line.sample(np.array([t]))
    for _ in range(5):
        terms = robot.terms(q, v)
        q = q + np.linalg.pinv(terms.jacobian) @ (sample.position[0] - robot.task_position(q)[: robot.m])
    jacobian = robot.terms(q, v).jacobian
    v = v + np.linalg.pinv(jacobian) @ (sample.velocity[0] - jacobian @ v)
    return q, v, sample.acceleration[0]


def test_a_one_step_horizon_tends_to_bounded_torque_at_first_order(paper_arm):
    """One interval of the window's program asks the tip to be on the path at t + Δt and charges the torque at
    t + Δt/2; bounded-torque[kinematic_weight=0] (a QP solved by DAQP) asks the task acceleration at t and charges
    the torque at t. The same criterion and bounds, so the two torques differ by O(Δt): tenfold less for a tenfold
    smaller step (measured 9.4e-4 and 9.3e-5 of the largest torque)."""
    line = PAPER.line("short").anchored(paper_arm.task_position(paper_arm.configuration(PAPER.q0))[:2])
    t = 0.2
    q, v, task_acceleration = on_path_state(paper_arm, line, t)
    local = torqueopt.resolve(paper_arm, "bounded-torque", q, v, task_acceleration, kinematic_weight=0.0).torque
    differences = []
    for dt in (1e-3, 1e-4):
        program = HorizonProgram(RecedingHorizon(horizon=dt), paper_arm, dt)
        assert program.intervals == 1
        solved = program.solve(t, q, v, line.sample(np.array([t, t + dt])).position, None)
        assert solved.status == "converged"
        state = plan_state(solved, dt, 0.5 * dt)
        torque = pin.rnea(paper_arm.model, paper_arm.model.createData(), *state)
        differences.append(np.abs(torque - local).max() / np.abs(local).max())
    assert differences[0] < 1e-2
    assert 5.0 < differences[0] / differences[1] < 20.0


@pytest.mark.parametrize(
    "compiled, options", [(False, "warm"), pytest.param(True, "warm", marks=pytest.mark.slow), (False, "at bounds")]
)
def test_kkt_conditions_hold_at_every_solve(paper_arm, compiled, options, tmp_path, monkeypatch):
    """At each window's solve (its functions in CasADi's virtual machine, or compiled to C), from the state measured there, with IPOPT's multipliers: ∇f + ∂gᵀλ_g + λ_x = 0 with f, g and their derivatives from
    Pinocchio (the direct transcription's, not CasADi's), g within its bounds, and a multiplier only on an active
    bound, of the right sign; the torque bounds act at some solves. The warm solves start from WARM_OPTIONS, or
    (``at bounds``) all from WARM_AT_BOUNDS_OPTIONS, which planar3's plans (no variable at a bound) never choose
    themselves."""
    monkeypatch.setenv("TORQUEOPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(receding_horizon, "COMPILE_FROM", 0 if compiled else receding_horizon.COMPILE_FROM)
    robot = paper_arm.with_torque_limit(TIGHT_LIMIT)
    if options == "at bounds":
        monkeypatch.setattr(receding_horizon, "WARM_OPTIONS", receding_horizon.WARM_AT_BOUNDS_OPTIONS)
    resolver = Capturing(horizon=0.04, horizon_dt=0.01, replan_every=10)
    run = torqueopt.simulate(robot, resolver, PAPER.line("short"), PAPER.q0, dt=2e-3, duration=0.3)
    assert run.completed
    (step,) = resolver.steps
    assert step.program.compiled == compiled
    problem = step.program.problem
    assert len(step.solves) == 15
    lower, upper = problem.constraint_bounds()
    torque_rows = slice((2 * problem.n + problem.m) * problem.intervals, None)
    active = 0
    for solved in step.solves:
        assert solved.status == "converged"
        row = round(solved.time / 2e-3)  # each window starts at the state measured there
        np.testing.assert_allclose(solved.q[0], run.q[row], rtol=0, atol=1e-12)
        np.testing.assert_allclose(solved.v[0], run.v[row], rtol=0, atol=1e-12)
        problem.reference = solved.reference
        gradient, jacobian = problem.gradient(solved.w), problem.jacobian(solved.w)
        stationarity = gradient + jacobian.T @ solved.lam_g + solved.lam_x
        assert np.abs(stationarity).max() < 1e-6 * (1.0 + np.abs(gradient).max())
        g = problem.constraints(solved.w)
        assert np.all(g >= lower - 1e-7) and np.all(g <= upper + 1e-7)
        multipliers, values = solved.lam_g[torque_rows], g[torque_rows]
        # Complementarity with IPOPT's signs (λ > 0 on an upper bound, λ < 0 on a lower one): λ times the distance
        # to its bound vanishes, to the barrier parameter IPOPT stops at
        assert (multipliers.clip(min=0.0) * (upper[torque_rows] - values)).max() < 1e-7
        assert (-multipliers.clip(max=0.0) * (values - lower[torque_rows])).max() < 1e-7
        active += int((np.abs(multipliers) > 1e-3).any())
    assert active >= 2
    assert np.all(np.abs(run.tau[:-1]) <= TIGHT_LIMIT * (1 + 1e-3))
    n = problem.n  # no plan's variable after the fixed start is at a bound: warm_options keeps WARM_OPTIONS
    assert all(np.abs(solved.lam_x[2 * n :]).max() <= receding_horizon.ACTIVE_MULTIPLIER for solved in step.solves)
    if options == "warm":
        assert all(step.program.warm_options(solved) is receding_horizon.WARM_OPTIONS for solved in step.solves)


def test_a_window_computes_its_start_and_bounds_as_the_plain_functions(paper_arm):
    """The window's shift evaluates every knot at once, its bounds are kept between solves: the same numbers as
    plan_state knot by knot and as Transcription's bounds for each new start (exactly)."""
    robot = paper_arm
    q = robot.configuration(PAPER.q0)
    line = torqueopt.StraightLine([0.05, 0.02], duration=0.1).anchored(robot.task_position(q)[:2])
    program = HorizonProgram(RecedingHorizon(horizon=0.05), robot, 0.01)
    plan = program.solve(0.0, q, np.zeros(3), line.sample(0.01 * np.arange(6)).position, None)
    times = np.array([-0.003, 0.0, 0.0137, 0.02, 0.0499, 0.05, 0.07])
    states = plan_states(plan, 0.01, times)
    for index, s in enumerate(times):
        for part, expected in zip(states, plan_state(plan, 0.01, s)):
            np.testing.assert_array_equal(part[index], expected)
    problem = program.problem
    for start, speed in ((q + 0.1, np.full(3, 0.2)), (q - 0.3, np.full(3, -1.0))):
        problem.q0, problem.v0 = start, speed
        for cached, plain in zip(problem.variable_bounds(), Transcription.variable_bounds(problem)):
            np.testing.assert_array_equal(cached, plain)


def test_a_window_without_a_writable_cache_runs_uncompiled(paper_arm, tmp_path, monkeypatch):
    """A compiled window whose cache directory cannot be made (here: under a file) falls back to CasADi's virtual
    machine: the solve is the uncompiled one's, bit for bit."""
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("TORQUEOPT_CACHE", str(tmp_path / "file" / "cache"))
    monkeypatch.setattr(receding_horizon, "COMPILE_FROM", 0)
    q = paper_arm.configuration(PAPER.q0)
    line = torqueopt.StraightLine([0.05, 0.02], duration=0.1).anchored(paper_arm.task_position(q)[:2])
    reference = line.sample(0.01 * np.arange(3)).position
    compiled = HorizonProgram(RecedingHorizon(horizon=0.02), paper_arm, 0.01)
    assert compiled.compiled
    plain = HorizonProgram(RecedingHorizon(horizon=0.02), paper_arm, 0.01)
    plain.compiled = False
    solved = compiled.solve(0.0, q, np.zeros(3), reference, None)
    assert solved.status == "converged"
    np.testing.assert_array_equal(solved.w, plain.solve(0.0, q, np.zeros(3), reference, None).w)


@pytest.mark.filterwarnings("ignore:holding the start against gravity")
def test_a_failed_solve_falls_back_and_says_so(paper_arm):
    """Gravity in the arm's plane, limits at a tenth of its static torque: no window is feasible; each step is
    the fallback's, and its row says why; with fallback 'none' the run stops at the first."""
    robot = paper_arm.with_gravity([0.0, -9.81, 0.0])
    q0 = robot.configuration(PAPER.q0)
    static = np.abs(pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q0))
    weak = robot.with_torque_limit(0.1 * static)
    options = {"horizon": 0.01, "horizon_dt": 0.005}
    run = torqueopt.simulate(
        weak, "receding-horizon", PAPER.line("short"), q0, duration=0.005,
        resolver_options={**options, "fallback": "pinv"},
    )  # fmt: skip
    pinv = torqueopt.simulate(weak, "pinv", PAPER.line("short"), q0, duration=0.005)
    assert run.completed
    np.testing.assert_array_equal(run.tau, pinv.tau)
    assert run.infeasible[:-1].all()
    assert run.limiting[0].startswith("receding-horizon solve at t = 0 s ended infeasible (")
    assert run.limiting[0].endswith("): torque of pinv")
    assert sorted(run.limiting) == list(range(5))
    stopped = torqueopt.simulate(
        weak,
        "receding-horizon",
        PAPER.line("short"),
        q0,
        duration=0.005,
        resolver_options={**options, "fallback": "none"},
    )
    assert not stopped.completed and len(stopped.t) == 1
    assert "receding-horizon solve at t = 0 s ended infeasible" in stopped.stop_reason
    assert "fallback 'none' stops the run" in stopped.stop_reason


def test_terminal_conditions_hold_at_the_windows_end(paper_arm):
    """terminal='rest' ends the plan at rest (from rest, along a rest-to-rest line of the window's length: with the
    path at every knot the tip's knot velocities follow from the path, and only such a window lets them end at 0,
    see the module docstring); a number bounds its self-motion energy at the end, computed here
    from Pinocchio's CRBA and Jacobian (torqueopt.self_motion), where the free window's end exceeds it."""
    q = paper_arm.configuration(PAPER.q0)
    jacobian = paper_arm.terms(q, np.zeros(3)).jacobian
    v = 0.3 * np.linalg.svd(jacobian)[2][-1]  # a self-motion (0.25 J): the tip at rest, as the line starts
    line = torqueopt.StraightLine([0.02, 0.0], duration=0.1).anchored(paper_arm.task_position(q)[:2])

    def end_energy(terminal, v=v):
        program = HorizonProgram(RecedingHorizon(horizon=0.1, terminal=terminal), paper_arm, 0.01)
        solved = program.solve(0.0, q, v, line.sample(program.h * np.arange(11)).position, None)
        assert solved.status in ("converged", "acceptable"), (terminal, solved.message)
        terms = paper_arm.terms(solved.q[-1], solved.v[-1])
        inertia = pin.crba(paper_arm.model, paper_arm.model.createData(), solved.q[-1])
        inertia = np.triu(inertia) + np.triu(inertia, 1).T
        _, energy = self_motion_energy(inertia[None], solved.v[-1][None], jacobian=terms.jacobian[None])
        return float(energy[0]), solved.v[-1]

    free, _ = end_energy("free")
    assert free > 0.15
    bounded, _ = end_energy(0.05)
    assert 0.05 * (1 - 1e-3) < bounded <= 0.05 * (1 + 1e-6)
    free_velocity = end_energy("free", np.zeros(3))[1]
    _, end_velocity = end_energy("rest", np.zeros(3))
    assert np.abs(free_velocity).max() > 1e-5
    np.testing.assert_allclose(end_velocity, 0.0, atol=1e-12)


def test_stacks_equal_single_runs(paper_arm):
    """The batch loops the step per movement along its own path: each movement's run equals simulate's."""
    lines = [torqueopt.StraightLine([1.0, 1.0], duration=0.04), torqueopt.StraightLine([-1.0, 0.5], duration=0.04)]
    q0s = [PAPER.q0, [0.3, 1.4, -1.0]]
    resolver = "receding-horizon[horizon=0.02,horizon_dt=0.01,replan_every=5]"
    batch = torqueopt.batch.simulate_batch(paper_arm, resolver, lines, q0s, dt=1e-3)
    for line, q0, stacked in zip(lines, q0s, batch):
        single = torqueopt.simulate(paper_arm, resolver, line, q0, dt=1e-3)
        np.testing.assert_allclose(stacked.tau, single.tau, rtol=0, atol=1e-12)
    assert np.abs(batch[0].tau[:-1] - batch[1].tau[:-1]).max() > 1.0


@pytest.mark.slow
def test_the_resolver_contract(paper_arm):
    """check_resolver on a single state: the command's path over the window, the task realised exactly.
    replan_every and fallback act only along a run (tested above); planar3's joint limits are far from the
    contract's states."""
    report = check_resolver(
        "receding-horizon[horizon=0.02]",
        paper_arm,
        options={"horizon": 0.04, "horizon_dt": 0.005, "replan_every": None, "fallback": None, "joint_limits": None},
    )
    assert report.options == ("horizon=0.04", "horizon_dt=0.005", "terminal=rest")


def test_bad_options_and_tasks_are_one_line(paper_arm):
    with pytest.raises(InvalidInput, match=r"terminal=stop .*must be 'free', 'rest' or a number >= 0"):
        torqueopt.get_resolver("receding-horizon[terminal=stop]")
    with pytest.raises(InvalidInput, match=r"fallback=spline .*must be 'none' or a local torque resolver: pinv, "):
        torqueopt.get_resolver("receding-horizon[fallback=spline]")
    with pytest.raises(InvalidInput, match=r"replan_every=0.5 .*must be a whole number >= 1"):
        torqueopt.get_resolver("receding-horizon[replan_every=0.5]")
    unbounded = paper_arm.with_torque_limit(np.inf)
    with pytest.raises(
        NoRedundancy, match="^resolver 'receding-horizon' falls back to 'bounded-torque', which refuses: "
    ):
        torqueopt.get_resolver("receding-horizon").check(unbounded)
    torqueopt.get_resolver("receding-horizon[fallback=pinv]").check(unbounded)
    panda_pose = torqueopt.load_robot("panda", task="pose")
    with pytest.raises(InvalidInput, match="^resolver 'receding-horizon' supports tasks xy and position, not 'pose'$"):
        torqueopt.simulate(
            panda_pose,
            "receding-horizon",
            torqueopt.StraightLine([0, 1, 0], duration=0.1),
            panda_pose.default_configuration,
        )


def second_window(paper_arm):
    """The program of 50 ms windows on a short planar3 line, the state and path of its second window (after 10 ms)
    and that window's warm start, shifted from the first window's plan."""
    q = paper_arm.configuration(PAPER.q0)
    line = torqueopt.StraightLine([0.05, 0.02], duration=0.1).anchored(paper_arm.task_position(q)[:2])
    program = HorizonProgram(RecedingHorizon(horizon=0.05), paper_arm, 0.01)
    first = program.solve(0.0, q, np.zeros(3), line.sample(0.01 * np.arange(6)).position, None)
    later = first.q[1], first.v[1], line.sample(0.01 + 0.01 * np.arange(6)).position
    return program, later, program.shifted_start(first, 0.01)


def test_a_failed_warm_window_is_solved_again_cold(paper_arm, monkeypatch):
    """A warm window that ends short of an optimum (here: one IPOPT iteration allowed) is solved again from the same
    point with IPOPT's default start: the plan is that cold solve's, and the iterations of both are counted."""
    from torqueopt.optimal.shooting import solve_shooting
    from torqueopt.resolvers import receding_horizon

    program, later, start = second_window(paper_arm)
    monkeypatch.setattr(receding_horizon, "WARM_OPTIONS", {"ipopt.max_iter": 1})
    solved = program.solve(0.01, *later, start)
    cold = solve_shooting(program.problem, start, tolerance=receding_horizon.TOLERANCE)
    assert solved.status == cold.status == "converged"
    np.testing.assert_array_equal(solved.w, cold.w)
    assert solved.iterations == cold.iterations + 1


def test_a_shifted_start_of_a_plan_meets_its_integration_rows(paper_arm):
    """The warm start is the plan at the new knots t + kh: where those fall on the plan's own knots (a shift by
    whole knots of 20 ms, which t + kh − t_plan reaches a rounding error either side), each knot takes its own
    interval's acceleration, so the start meets the shooting rows q_{k+1} = q_k + h q̇_k + h²q̈_k/2,
    q̇_{k+1} = q̇_k + h q̈_k (up to rounding) but in the intervals beyond the plan."""
    q = paper_arm.configuration(PAPER.q0)
    line = torqueopt.StraightLine([0.05, 0.02], duration=0.6).anchored(paper_arm.task_position(q)[:2])
    h = 0.02
    program = HorizonProgram(RecedingHorizon(horizon=0.2, horizon_dt=h), paper_arm, h)
    plan = program.solve(0.0, q, np.zeros(3), line.sample(h * np.arange(11)).position, None)
    assert plan.status == "converged"
    for planned in (0.02, 0.04, 0.2, 0.34):
        for shift in (1, 2):
            start = program.shifted_start(plan._replace(time=planned), planned + shift * h)
            knots, speeds, accelerations = program.problem.split(start)
            defect_q = knots[1:] - knots[:-1] - h * speeds[:-1] - 0.5 * h * h * accelerations
            defect_v = speeds[1:] - speeds[:-1] - h * accelerations
            assert np.abs(defect_q[:-shift]).max() < 1e-12 and np.abs(defect_v[:-shift]).max() < 1e-12
            np.testing.assert_array_equal(accelerations[:-shift], plan.a[shift:])


def test_a_warm_window_found_infeasible_is_not_solved_again(paper_arm, monkeypatch):
    """A warm window IPOPT finds infeasible (here: its answer relabelled so) is reported as it ended, without the
    cold retry that an iteration limit gets (the test above)."""
    from torqueopt.optimal import shooting
    from torqueopt.resolvers import receding_horizon

    program, later, start = second_window(paper_arm)
    calls = []
    solve = shooting.solve_shooting

    def infeasible(problem, w0, **settings):
        calls.append(settings.get("ipopt_options"))
        out = solve(problem, w0, **settings)
        out.status, out.message = "infeasible", receding_horizon.PROVEN_INFEASIBLE
        return out

    monkeypatch.setattr(shooting, "solve_shooting", infeasible)
    solved = program.solve(0.01, *later, start)
    assert solved.status == "infeasible" and solved.message == "Infeasible_Problem_Detected"
    assert len(calls) == 1 and calls[0] is not None  # the warm solve only
