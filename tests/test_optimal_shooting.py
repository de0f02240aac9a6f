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
    direct = optimize(paper_arm, PAPER.line("short"), PAPER.q0, **options)
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


@pytest.mark.filterwarnings("ignore:holding the start against gravity")
def test_a_torque_bound_below_gravity_is_reported_infeasible(paper_arm):
    """Gravity in the arm's plane and limits below its static torque at the start: no motion exists."""
    robot = paper_arm.with_gravity([0.0, -9.81, 0.0])
    q0 = robot.configuration(PAPER.q0)
    static = np.abs(pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q0))
    weak = robot.with_torque_limit(0.1 * static)
    result = optimize(
        weak,
        PAPER.line("short"),
        PAPER.q0,
        transcription="shooting",
        starts=("pinv",),
        grid_step=0.02,
        torque_bounds=True,
    )
    assert result.status == "infeasible", result.solver_message
    assert result.solver_message in ("Infeasible_Problem_Detected", "Local_Infeasibility", "Restoration_Failed")
    assert result.constraint_violation > 1e-3


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
