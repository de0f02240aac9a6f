"""The shooting transcription (torqueopt.optimal.shooting): its program equals the direct transcription's
(values and derivatives), its optimum equals the direct transcription's where both converge, its
constraints hold on the replay, and an infeasible problem is reported infeasible."""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import InvalidInput
from torqueopt.optimal import ShootingTranscription, optimize, weight_root
from torqueopt.paper import PAPER
from torqueopt.resolvers.null_space import torque_midpoint

casadi = pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def paper_arm():
    return PAPER.load_robot()


def small_problem(robot, q0, intervals=4, duration=0.2, torque_bounds=False):
    line = torqueopt.StraightLine([1.0, 1.0] if robot.m == 2 else [0.0, 1.0, 0.0], duration=duration)
    line = line.anchored(robot.task_position(q0)[: robot.m])
    nodes = np.linspace(0.0, duration, intervals + 1)
    return ShootingTranscription(
        robot,
        duration,
        intervals,
        line.sample(nodes).position,
        q0,
        weight_root(robot, "range" if torque_bounds else None),
        torque_midpoint(robot),
        torque_bounds=torque_bounds,
    )


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_program_equals_the_direct_transcription_with_pinocchio(name):
    """f, g and ∂g/∂w of the CasADi program against the numpy/Pinocchio transcription of the same problem."""
    robot = torqueopt.load_robot(name, task="position" if name == "panda" else None)
    q0 = robot.default_configuration if name == "panda" else robot.configuration(PAPER.q0)
    problem = small_problem(robot, q0, torque_bounds=True)
    nlp = problem.nlp()
    functions = casadi.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"], casadi.jacobian(nlp["g"], nlp["x"])])
    rng = np.random.default_rng(1)
    w = rng.normal(scale=0.3, size=problem.size)
    w[problem.q_index(0)] = q0
    f, g, jacobian = (np.array(x) for x in functions(w, problem.parameters()))
    assert f.item() == pytest.approx(problem.objective(w), rel=1e-12)
    np.testing.assert_allclose(g.ravel(), problem.constraints(w), rtol=0, atol=1e-10)
    np.testing.assert_allclose(jacobian, problem.jacobian(w), rtol=0, atol=1e-9)


def test_lagrangian_hessian_equals_finite_differences(paper_arm):
    """The exact Hessian IPOPT gets, ∇²(σf + λᵀg), against central differences of the Pinocchio gradient."""
    q0 = paper_arm.configuration(PAPER.q0)
    problem = small_problem(paper_arm, q0, torque_bounds=True)
    nlp = problem.nlp()
    sigma, multipliers = casadi.MX.sym("sigma"), casadi.MX.sym("lam", problem.constraint_count)
    lagrangian = sigma * nlp["f"] + casadi.dot(multipliers, nlp["g"])
    hessian = casadi.Function("h", [nlp["x"], nlp["p"], sigma, multipliers], [casadi.hessian(lagrangian, nlp["x"])[0]])
    rng = np.random.default_rng(2)
    w, lam = rng.normal(scale=0.3, size=problem.size), rng.normal(size=problem.constraint_count)

    def gradient(x):  # from Pinocchio's first derivatives (the direct transcription's)
        return 0.7 * problem.gradient(x) + problem.jacobian(x).T @ lam

    step = 1e-6
    differences = np.column_stack(
        [(gradient(w + step * e) - gradient(w - step * e)) / (2 * step) for e in np.eye(problem.size)]
    )
    ours = np.array(hessian(w, problem.parameters(), 0.7, lam))
    np.testing.assert_allclose(ours, differences, rtol=0, atol=2e-5 * np.abs(ours).max())


def test_optimum_equals_the_direct_transcription_where_both_converge(paper_arm):
    """Same program, other derivatives and Hessian: the same optimum (the short paper movement, no bounds)."""
    options = {"grid_step": 0.02, "tolerance": 1e-10}
    direct = optimize(paper_arm, PAPER.line("short"), PAPER.q0, transcription="direct", **options)
    shooting = optimize(paper_arm, PAPER.line("short"), PAPER.q0, transcription="shooting", **options)
    assert direct.optimal and shooting.optimal
    assert shooting.cost == pytest.approx(direct.cost, rel=1e-6)
    assert [start["warm_start"] for start in shooting.starts] == ["pinv", "damped-null-space"]
    assert all(start["status"] == "converged" for start in shooting.starts)
    assert shooting.grid_cost == min(start["grid_cost"] for start in shooting.starts)


def test_constraints_hold_on_the_replay(paper_arm):
    """Torque bounds active, joint limits on: the plan's torques on the 1 ms grid and its joints stay inside."""
    limit = np.array([2.0, 3.15, 4.2])  # below the unbounded optimum's peaks (2.09, 3.33, 4.39 N·m)
    robot = paper_arm.with_torque_limit(limit)
    result = optimize(
        robot,
        PAPER.line("short"),
        PAPER.q0,
        transcription="shooting",
        starts=("pinv",),
        grid_step=0.01,
        torque_bounds=True,
        joint_limits=True,
    )
    free = optimize(
        paper_arm,
        PAPER.line("short"),
        PAPER.q0,
        transcription="shooting",
        starts=("pinv",),
        grid_step=0.01,
    )
    assert result.optimal and free.optimal
    assert (free.peak_torque > limit * 1.01).any()  # the unbounded optimum passes the limits: the bounds are active
    assert result.constraint_violation < 1e-7  # IPOPT relaxes bounds by bound_relax_factor = 1e-8 × max(1, |bound|)
    # bounded at each interval's start, midpoint and end; between them, on the 1 ms grid, within a hair
    assert np.all(np.abs(result.tau[:-1]) <= limit * (1 + 1e-3))
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    assert np.all(result.q >= lower - 1e-8) and np.all(result.q <= upper + 1e-8)
    assert result.replay_tip_error < 1e-4
    assert result.cost >= free.cost * (1 - 1e-6)


def _excess_by_pinocchio(problem, w) -> float:
    """The largest |τ − c|/r − 1 over the bound points of ``w`` (c, r: each torque range's centre and half),
    from pin.rnea: the phase-1 figure computed without CasADi."""
    robot, data = problem.robot, problem.robot.model.createData()
    centre = 0.5 * (robot.torque_upper + robot.torque_lower)
    half = 0.5 * (robot.torque_upper - robot.torque_lower)
    q, v, a = problem.split(w)
    worst = -np.inf
    for k in range(problem.intervals):
        for fraction in problem.fractions:
            s = fraction * problem.h
            torque = pin.rnea(robot.model, data, q[k] + s * v[k] + 0.5 * s * s * a[k], v[k] + s * a[k], a[k])
            worst = max(worst, float(np.max(np.abs(torque - centre) / half)) - 1.0)
    return worst


@pytest.fixture(scope="module")
def too_weak(paper_arm):
    """Gravity in the arm's plane and torque limits of a tenth of its static torque at the start."""
    robot = paper_arm.with_gravity([0.0, -9.81, 0.0])
    q0 = robot.configuration(PAPER.q0)
    static = np.abs(pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q0))
    return robot.with_torque_limit(0.1 * static)


@pytest.mark.filterwarnings("ignore:holding the start against gravity")
def test_a_torque_bound_below_gravity_is_reported_infeasible(too_weak):
    """No motion exists: the status is infeasible (not an iteration limit), with the phase-1 problem's evidence."""
    result = optimize(
        too_weak,
        PAPER.line("short"),
        PAPER.q0,
        transcription="shooting",
        starts=("pinv",),
        grid_step=0.02,
        torque_bounds=True,
    )
    assert result.status == "infeasible", result.solver_message
    assert result.constraint_violation > 1e-3
    evidence = result.feasibility
    assert evidence["proves_infeasible"] and evidence["status"] == "converged"
    assert evidence["excess"] > 1.0  # the limits are a tenth of what holding the start needs
    assert evidence["evidence"].startswith("the least excess over the limits of a motion along the path is")
    assert "torque of joint" in evidence["binding"][0]
    # phase-1 from the limited start's run, then from pinv's point: the excess is set at t = 0, where q0 is given, so
    # both reach the same t*
    tries = evidence["tries"]
    assert [entry["from"] for entry in tries] == ["bounded-torque[joint_limits=off]", "pinv"]
    assert tries[0]["excess"] == pytest.approx(tries[1]["excess"], rel=1e-9)
    assert result.summary()["feasibility"] == evidence


@pytest.mark.slow
def test_phase_one_from_the_limited_start_rescues_starts_that_end_outside_the_limits(paper_arm, monkeypatch):
    """When every start ends outside the limits, phase-1 runs first from bounded-torque's run (which keeps them), and
    the motion within the limits it finds is solved to the optimum: the one a start that converges reaches (1e-6),
    within the torque bounds by pin.rnea and within the joint limits."""
    from torqueopt.optimal import whole_path

    robot = paper_arm.with_torque_limit(np.array([2.0, 3.15, 4.2]) * 1.12)

    def solve(**options):
        return optimize(
            robot, PAPER.line("short"), PAPER.q0, starts=("pinv",), grid_step=0.02, torque_bounds=True,
            joint_limits=True, **options,
        )  # fmt: skip

    reference = solve()
    assert reference.optimal and reference.feasibility == {}
    calls = []
    real = whole_path.solve_shooting

    def first_stops_early(*args, **options):  # the start's solve stops after one iteration, outside the limits
        calls.append(len(calls))
        return real(*args, **{**options, "max_iterations": 1} if len(calls) == 1 else options)

    monkeypatch.setattr(whole_path, "solve_shooting", first_stops_early)
    rescued = solve()
    assert [entry["warm_start"] for entry in rescued.starts] == ["pinv", "phase-1 from bounded-torque"]
    assert rescued.starts[0]["status"] == "iteration limit"
    assert rescued.feasibility["tries"][0]["from"] == "bounded-torque" and rescued.feasibility["excess"] <= 1e-6
    assert rescued.optimal and rescued.warm_start == "phase-1 from bounded-torque"
    assert rescued.grid_cost == pytest.approx(reference.grid_cost, rel=1e-6)
    problem = rescued.solution["problem"]
    assert _excess_by_pinocchio(problem, rescued.solution["w"]) <= 1e-6
    q, _, _ = problem.split(rescued.solution["w"])
    lower, upper, _ = robot.joint_limits
    assert np.all(q >= lower - 1e-8) and np.all(q <= upper + 1e-8)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:holding the start against gravity")
def test_least_excess_lies_between_independent_bounds(too_weak):
    """Phase-1's t*: its motion follows the path and exceeds the limits by exactly t* (by pin.rnea); no path-following
    motion does better (the unbounded optimum does worse); and at t = 0, at rest, M(q0)a + g(q0) with the task's
    first step already needs the excess of a linear program (scipy), a lower bound."""
    from scipy.optimize import linprog

    from torqueopt.optimal.shooting import least_excess

    bounded = optimize(
        too_weak, PAPER.line("short"), PAPER.q0, transcription="shooting", starts=("pinv",), grid_step=0.02,
        torque_bounds=True,
    )  # fmt: skip
    problem = bounded.solution["problem"]
    feasibility = least_excess(problem, bounded.solution["w"])
    assert feasibility.excess == pytest.approx(bounded.feasibility["excess"], rel=1e-12)
    excess = feasibility.excess
    assert _excess_by_pinocchio(problem, feasibility.w) == pytest.approx(excess, rel=1e-6)
    robot, data = too_weak, too_weak.model.createData()
    q, _, _ = problem.split(feasibility.w)
    tips = np.array([robot.frame_placement(row, data).translation[:2] for row in q[1:]])
    np.testing.assert_allclose(tips, problem.reference[1:], atol=1e-8)
    free = optimize(too_weak, PAPER.line("short"), PAPER.q0, transcription="shooting", starts=("pinv",), grid_step=0.02)
    assert free.optimal
    assert _excess_by_pinocchio(problem, free.solution["w"]) >= excess
    q0 = robot.configuration(PAPER.q0)
    inertia = pin.crba(robot.model, data, q0)
    inertia = np.triu(inertia) + np.triu(inertia, 1).T
    gravity = pin.computeGeneralizedGravity(robot.model, data, q0)
    jacobian = pin.computeFrameJacobian(robot.model, data, q0, robot.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    limit = robot.torque_upper[:, None]
    # variables (a, s): min s, J h²/2 a = x_ref(h) − x_ref(0) (linearised first step), |M a + g| ≤ (1 + s) limit
    answer = linprog(
        np.r_[np.zeros(3), 1.0],
        A_ub=np.block([[inertia, -limit], [-inertia, -limit]]),
        b_ub=np.r_[robot.torque_upper - gravity, robot.torque_upper + gravity],
        A_eq=np.c_[jacobian[:2] * problem.h**2 / 2, np.zeros(2)],
        b_eq=problem.reference[1] - problem.reference[0],
        bounds=[(None, None)] * 3 + [(0.0, None)],
    )
    assert answer.status == 0
    assert answer.x[-1] > 1.0 and excess >= answer.x[-1] * (1 - 1e-3)


@pytest.mark.slow
def test_least_excess_is_the_threshold_of_feasibility(paper_arm):
    """On a 20 ms grid the limits (2, 3.15, 4.2) N·m cannot be met (IPOPT stalls near them): phase-1's t* is where
    the problem turns feasible, by the solver itself: limits x (1 + t*) x 1.01 converge, x (1 + t*) x 0.99 do not;
    and from the free optimum (outside them) phase-1 finds t* = 0 where they can be met (a 10 ms grid)."""
    from torqueopt.optimal.shooting import least_excess

    limit = np.array([2.0, 3.15, 4.2])

    def solve(scale, grid_step=0.02):
        return optimize(
            paper_arm.with_torque_limit(limit * scale), PAPER.line("short"), PAPER.q0, transcription="shooting",
            starts=("pinv",), grid_step=grid_step, torque_bounds=True, joint_limits=True, max_iterations=150,
        )  # fmt: skip

    tight = solve(1.0)
    assert tight.status == "infeasible" and tight.feasibility["proves_infeasible"]
    excess = tight.feasibility["excess"]
    assert 0.01 < excess < 0.5 and tight.feasibility["binding"][0].startswith("torque of joint")
    assert solve((1 + excess) * 1.01).optimal
    assert solve((1 + excess) * 0.99).status == "infeasible"
    feasible = solve(1.0, grid_step=0.01)
    assert feasible.optimal and feasible.feasibility == {}  # a converged start needs no phase-1
    problem = feasible.solution["problem"]
    free = optimize(
        paper_arm, PAPER.line("short"), PAPER.q0, transcription="shooting", starts=("pinv",), grid_step=0.01
    )
    assert _excess_by_pinocchio(problem, free.solution["w"]) > 0.01  # phase-1 starts outside the limits
    found = least_excess(problem, free.solution["w"])
    assert found.status == "converged" and not found.proves_infeasible and found.binding == []
    assert _excess_by_pinocchio(problem, found.w) <= 1e-6


@pytest.mark.slow
def test_continuous_joints_give_the_optimum_of_their_revolute_twin(tmp_path):
    """kinova's three continuous joints ((cos, sin), no limits) are angles in the program: the optimum equals that of
    the same URDF with those joints revolute (limits ±2π, not imposed) on a line whose joint 4 winds past π."""
    from torqueopt.loading import find_robot

    kinova = torqueopt.load_robot("kinova")
    twin_urdf = tmp_path / "kinova_revolute.urdf"
    twin_urdf.write_text(find_robot("kinova").urdf.read_text().replace('type="continuous"', 'type="revolute"'))
    twin = torqueopt.load_robot(str(twin_urdf), frame=kinova.frame)
    assert kinova.nq == 9 and twin.nq == twin.nv == 6
    angles = kinova.joint_angles(kinova.default_configuration)
    line = torqueopt.StraightLine([0.0, 0.1, -0.05], duration=0.4)
    results = [
        optimize(robot, line, robot.configuration(angles), transcription="shooting", starts=("pinv",), grid_step=0.1)
        for robot in (kinova, twin)
    ]
    assert all(result.optimal for result in results)
    assert results[0].cost == pytest.approx(results[1].cost, rel=1e-6)
    assert results[0].replay_tip_error < 1e-3
    winding = np.angle(np.exp(1j * (results[0].joint_angles - results[1].joint_angles)))  # equal modulo 2π
    np.testing.assert_allclose(winding, 0.0, atol=1e-6)
    assert np.ptp(results[1].joint_angles[:, 3]) > 0.1 and results[1].joint_angles[:, 3].max() > np.pi  # past π


def test_unaligned_joints_built_in_python_solve_as_the_direct_transcription_does():
    """model.joints[i] of a model built in Python is Pinocchio's generic JointModel, whose axis is behind extract():
    three unaligned sliders (a QP, see test_optimal) give the direct transcription's optimum."""
    from .test_optimal import prismatic_arm

    arm = prismatic_arm()
    line = torqueopt.StraightLine([1.0, 0.5], duration=0.4).anchored([0.0, 0.0])
    direct = optimize(arm, line, np.zeros(3), grid_step=0.05, transcription="direct")
    shooting = optimize(arm, line, np.zeros(3), grid_step=0.05, transcription="shooting", starts=("pinv",))
    assert direct.optimal and shooting.optimal
    assert shooting.cost == pytest.approx(direct.cost, rel=1e-9)


def test_direct_transcription_refuses_continuous_joints():
    kinova = torqueopt.load_robot("kinova")
    line = torqueopt.StraightLine([0.0, 0.1, 0.0], duration=0.2)
    with pytest.raises(InvalidInput) as error:
        optimize(kinova, line, kinova.default_configuration, grid_step=0.1, transcription="direct")
    assert str(error.value) == (
        "the direct transcription needs revolute or prismatic joints only; robot 'kinova' has continuous or "
        "multi-coordinate joints: use transcription 'shooting', or lock them (--lock)"
    )


def test_shooting_refuses_another_hessian(paper_arm):
    with pytest.raises(InvalidInput, match="transcription 'shooting' uses the exact Hessian: give hessian 'auto'"):
        optimize(paper_arm, PAPER.line("short"), PAPER.q0, transcription="shooting", hessian="gauss-newton")
    with pytest.raises(InvalidInput, match="transcription 'collocation' is not one of direct, shooting"):
        optimize(paper_arm, PAPER.line("short"), PAPER.q0, transcription="collocation")


def test_without_a_compiler_the_virtual_machine_solves(paper_arm, tmp_path, monkeypatch):
    from torqueopt.optimal import shooting

    monkeypatch.setenv("TORQUEOPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(shooting.shutil, "which", lambda name: None)
    options = {"transcription": "shooting", "starts": ("pinv",), "grid_step": 0.05}
    compiled = optimize(paper_arm, PAPER.line("short"), PAPER.q0, compiled=True, **options)
    plain = optimize(paper_arm, PAPER.line("short"), PAPER.q0, **options)
    assert compiled.optimal and compiled.cost == plain.cost
    assert not (tmp_path / "cache").exists()


def test_a_time_limit_builds_no_solver_per_run(paper_arm, monkeypatch):
    """IPOPT's time limit is an option of the built solver: runs given what is left of a budget would each build
    and keep one (2 GB over a 1,000-path atlas); every run gets the whole budget, and the kept solvers are bounded."""
    from torqueopt.optimal import shooting

    monkeypatch.setattr(shooting, "_SOLVERS", shooting._KeptSolvers())  # what other tests kept is not counted
    options = {"transcription": "shooting", "grid_step": 0.05, "max_time": 600.0}
    optimize(paper_arm, PAPER.line("short"), PAPER.q0, **options)
    kept = len(shooting._SOLVERS)
    for line in ("medium", "short"):
        optimize(paper_arm, PAPER.line(line), PAPER.q0, **options)
    assert len(shooting._SOLVERS) == kept + 1  # the medium movement's program; nothing for a run's time left
    for key in range(3 * shooting.MAX_KEPT_SOLVERS):
        shooting._SOLVERS[("test", key)] = None
    assert len(shooting._SOLVERS) == shooting.MAX_KEPT_SOLVERS and ("test", 0) not in shooting._SOLVERS


@pytest.mark.slow
def test_compiled_functions_give_the_same_optimum_and_are_cached(paper_arm, tmp_path, monkeypatch):
    """The C code generated from the program and compiled (6 s on planar3, minutes on panda) solves as CasADi's VM does."""
    monkeypatch.setenv("TORQUEOPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    options = {"transcription": "shooting", "starts": ("pinv",), "grid_step": 0.05}
    compiled = optimize(paper_arm, PAPER.line("short"), PAPER.q0, compiled=True, **options)
    plain = optimize(paper_arm, PAPER.line("short"), PAPER.q0, **options)
    assert compiled.optimal and compiled.cost == pytest.approx(plain.cost, rel=1e-9)
    assert len(list((tmp_path / "cache").glob("shooting_*.so"))) == 1


@pytest.mark.slow
def test_the_command_prints_phase_ones_evidence(capsys):
    """torqueopt optimize on a line no motion within 0.5 N·m can follow: exit 3 (not optimal), IPOPT's word on each
    start, then phase-1's least excess and the limits it reaches."""
    from torqueopt.cli import main

    code = main(
        ["optimize", "--robot", "planar3", "--direction", "1,1", "--duration", "0.5", "--torque-limit", "0.5",
         "--torque-bounds", "--grid-step", "0.02", "--transcription", "shooting"]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert code == 3
    assert "  start pinv: infeasible (" in out
    assert "  phase-1: the least excess over the limits of a motion along the path is" in out
    assert "(torque of joint" in out
