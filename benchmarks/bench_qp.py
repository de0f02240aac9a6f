"""Time the small QP/LP solvers on the bounded resolvers' own problems, and compare two formulations.

Problems (collected once, then solved by every solver in turn):

* ``planar3``: the states of the paper's long movement (q0 = (-45°, 135°, -135°),
  direction (1, 1), T = 2 s, ``null-space`` run, every 10th step, the feasible ones) with the paper's limits
  (54, 24, 6) N·m: the null-space QP has 1 variable and 3 two-sided rows (6 inequalities);
* ``panda`` (position task): seeded random states and task accelerations with a
  third of the URDF limits: 4 variables and 7 two-sided rows (14 inequalities).

About a third of the problems have active bounds. Solvers, each through its
own direct API:

* DAQP, ``daqp.solve`` from scratch, and a ``daqp.Model`` set up once and
  updated per problem (warm start from the previous active set: what the
  resolver does);
* proxsuite, dense ``proxqp.dense.QP`` initialised once, updated per problem,
  warm start from the previous result, ``eps_abs = 1e-9``;
* quadprog, ``solve_qp`` (no warm start; the one-sided form Cᵀx >= b, so 2n rows);
* for the LP (``minmax-torque``): DAQP's Model against HiGHS (``highspy``,
  model passed per problem, presolve off).

Formulation: the same QP in null-space coordinates y (n − m variables, the
resolver's choice) and in joint accelerations q̈ with the task as m equality
rows (n variables), both on DAQP's Model: time, Hessian condition number, and
the largest torque difference between the two answers.

Method: the cases are timed interleaved, ``--repeats`` rounds of one pass
over every problem per case; the figure is the median over rounds of the mean
time per solve [µs]. One thread (OpenBLAS/OpenMP set to 1 before numpy loads).

Run::

    python benchmarks/bench_qp.py
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import statistics
import time

import daqp
import highspy
import numpy as np
import proxsuite
import quadprog
from scipy.linalg import null_space

import torqueopt


class Problem:
    """One state's QP in null-space coordinates and in q̈, with its LP."""

    def __init__(self, robot, terms, task_acceleration):
        H, b, J = terms.inertia.copy(), terms.bias_torque.copy(), terms.jacobian.copy()
        lower, upper = robot.torque_lower, robot.torque_upper
        spread = upper - lower
        mid = 0.5 * (upper + lower)
        pinv = np.linalg.pinv(J)
        Z = null_space(J)
        G = H @ Z
        w = task_acceleration - terms.drift
        tilde = H @ pinv @ w + b
        n, r = H.shape[0], Z.shape[1]
        self.n, self.r, self.m = n, r, n - r
        # Null space: min ½yᵀ(GᵀG)y + (Gᵀ(τ̃ − mid))ᵀy, (τ⁻ − τ̃)/R <= (G/R) y <= (τ⁺ − τ̃)/R.
        self.hessian = G.T @ G
        self.cost = G.T @ (tilde - mid)
        self.rows = G / spread[:, None]
        self.upper = (upper - tilde) / spread
        self.lower = (lower - tilde) / spread
        self.tilde, self.G = tilde, G
        # q̈: min ½‖H q̈ + b − mid‖², J q̈ = w, (τ⁻ − b)/R <= (H/R) q̈ <= (τ⁺ − b)/R.
        self.acc_hessian = H @ H
        self.acc_cost = H @ (b - mid)
        self.acc_rows = np.vstack([J, H / spread[:, None]])
        self.acc_upper = np.r_[w, (upper - b) / spread]
        self.acc_lower = np.r_[w, (lower - b) / spread]
        self.H, self.b = H, b
        # LP: min t, ±((G/R) y + (τ̃ − mid)/R) <= t.
        offset = (tilde - mid) / spread
        self.lp_rows = np.vstack([np.hstack([self.rows, -np.ones((n, 1))]), np.hstack([self.rows, np.ones((n, 1))])])
        self.lp_upper = np.r_[-offset, np.full(n, np.inf)]
        self.lp_lower = np.r_[np.full(n, -np.inf), -offset]


def collect(robot_name: str, count: int, seed: int):
    if robot_name == "planar3":
        robot = torqueopt.load_robot("planar3")
        line = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
        # null-space's own states: past 0.86 s its least-squares optimum leaves the limits.
        run = torqueopt.simulate(robot, "null-space", line, np.radians([-45.0, 135.0, -135.0]))
        problems = []
        for k in range(0, len(run.t) - 1, 10):
            terms = robot.terms(run.q[k], run.v[k])
            problem = Problem(robot, terms, run.acceleration[k] @ terms.jacobian.T + terms.drift)
            if _feasible(problem):
                problems.append(problem)
        return problems[:count]
    robot = torqueopt.load_robot("panda", task="position")
    robot = robot.with_torque_limit(robot.urdf_effort_limit / 3.0)
    rng = np.random.default_rng(seed)
    problems = []
    while len(problems) < count:
        q = robot.configuration(rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit))
        terms = robot.terms(q, 0.5 * rng.normal(size=robot.nv))
        singular = np.linalg.svd(terms.jacobian, compute_uv=False)
        if singular[-1] < 1e-2 * singular[0]:
            continue
        problem = Problem(robot, terms, 3.0 * rng.normal(size=3))
        if _feasible(problem):
            problems.append(problem)
    return problems


def _feasible(problem) -> bool:
    """Feasible problems only: every solver answers the same question."""
    return daqp.solve(problem.hessian, problem.cost, problem.rows, problem.upper, problem.lower)[2] == 1


def _sense(size):
    return np.zeros(size, dtype=np.int32)


def daqp_fresh(problems):
    out = []
    for p in problems:
        x = daqp.solve(p.hessian, p.cost, p.rows, p.upper, p.lower, _sense(p.n))[0]
        out.append(x)
    return out


def daqp_model_factory(problems):
    p = problems[0]
    model = daqp.Model()
    model.settings = {"primal_tol": 1e-9}
    model.setup(p.hessian, p.cost, p.rows, p.upper, p.lower, _sense(p.n))

    def run(problems):
        out = []
        for p in problems:
            model.update(H=p.hessian, f=p.cost, A=p.rows, bupper=p.upper, blower=p.lower)
            out.append(model.solve()[0])
        return out

    return run


def daqp_acceleration_factory(problems):
    p = problems[0]
    sense = np.r_[np.full(p.m, 5), np.zeros(p.n)].astype(np.int32)  # 5: equality rows
    model = daqp.Model()
    model.settings = {"primal_tol": 1e-9}
    model.setup(p.acc_hessian, p.acc_cost, p.acc_rows, p.acc_upper, p.acc_lower, sense)

    def run(problems):
        out = []
        for p in problems:
            model.update(
                H=p.acc_hessian, f=p.acc_cost, A=p.acc_rows, bupper=p.acc_upper, blower=p.acc_lower, sense=sense
            )
            out.append(model.solve()[0])
        return out

    return run


def proxsuite_factory(problems):
    p = problems[0]
    qp = proxsuite.proxqp.dense.QP(p.r, 0, p.n)
    qp.settings.eps_abs = 1e-9
    qp.settings.eps_rel = 0.0
    qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
    qp.init(p.hessian, p.cost, None, None, p.rows, p.lower, p.upper)

    def run(problems):
        out = []
        for p in problems:
            qp.update(H=p.hessian, g=p.cost, C=p.rows, l=p.lower, u=p.upper)
            qp.solve()
            out.append(qp.results.x.copy())
            if qp.results.info.status != proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED:
                unsolved[0] += 1
        return out

    unsolved = [0]
    run.unsolved = unsolved

    return run


def quadprog_run(problems):
    out = []
    for p in problems:
        # min ½xᵀGx − aᵀx s.t. Cᵀx >= b: rows/R y <= upper and >= lower as 2n one-sided rows.
        constraint = np.hstack([-p.rows.T, p.rows.T])
        bound = np.r_[-p.upper, p.lower]
        out.append(quadprog.solve_qp(p.hessian, -p.cost, constraint, bound, 0)[0])
    return out


def daqp_lp_factory(problems):
    p = problems[0]
    model = daqp.Model()
    model.settings = {"primal_tol": 1e-9, "eta_prox": 1e-12}
    model.setup(
        np.zeros((p.r + 1, p.r + 1)), np.r_[np.zeros(p.r), 1.0], p.lp_rows, p.lp_upper, p.lp_lower, _sense(2 * p.n)
    )

    def run(problems):
        out = []
        for p in problems:
            model.update(A=p.lp_rows, bupper=p.lp_upper, blower=p.lp_lower)
            out.append(model.solve()[0])
        return out

    return run


def highs_lp_factory(problems):
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("presolve", "off")
    inf = highspy.kHighsInf

    def run(problems):
        out = []
        for p in problems:
            lp = highspy.HighsLp()
            columns = p.r + 1
            lp.num_col_ = columns
            lp.num_row_ = 2 * p.n
            lp.col_cost_ = np.r_[np.zeros(p.r), 1.0]
            lp.col_lower_ = np.full(columns, -inf)
            lp.col_upper_ = np.full(columns, inf)
            lp.row_lower_ = np.where(np.isfinite(p.lp_lower), p.lp_lower, -inf)
            lp.row_upper_ = np.where(np.isfinite(p.lp_upper), p.lp_upper, inf)
            dense = p.lp_rows
            lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
            lp.a_matrix_.start_ = np.arange(0, dense.size + 1, dense.shape[0], dtype=np.int32)
            lp.a_matrix_.index_ = np.tile(np.arange(dense.shape[0], dtype=np.int32), columns)
            lp.a_matrix_.value_ = dense.T.reshape(-1)
            h.passModel(lp)
            h.run()
            out.append(np.array(h.getSolution().col_value))
        return out

    return run


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--count", type=int, default=200, help="problems per robot (default 200)")
    parser.add_argument("--repeats", type=int, default=7, help="interleaved rounds (default 7)")
    args = parser.parse_args(argv)

    for robot_name in ("planar3", "panda"):
        problems = collect(robot_name, args.count, 20261201)
        p0 = problems[0]
        reference = daqp_fresh(problems)
        active = sum(
            bool(np.any(np.minimum(p.upper - p.rows @ x, p.rows @ x - p.lower) < 1e-9))
            for p, x in zip(problems, reference)
        )
        qp_cases = {
            "DAQP daqp.solve (fresh)": daqp_fresh,
            "DAQP Model (update, warm)": daqp_model_factory(problems),
            "proxsuite dense (update, warm, eps 1e-9)": proxsuite_factory(problems),
            "quadprog solve_qp": quadprog_run,
            "DAQP Model, q̈ with task equality": daqp_acceleration_factory(problems),
        }
        lp_cases = {
            "DAQP Model LP (warm, eta_prox 1e-12)": daqp_lp_factory(problems),
            "HiGHS (highspy)": highs_lp_factory(problems),
        }
        cases = {**qp_cases, **lp_cases}
        times = {name: [] for name in cases}
        answers = {}
        for name, run in cases.items():
            answers[name] = run(problems)  # warm-up, and the answers to compare
        for _ in range(args.repeats):
            for name, run in cases.items():
                start = time.perf_counter()
                run(problems)
                times[name].append((time.perf_counter() - start) / len(problems) * 1e6)
        print(
            f"\n{robot_name}: {len(problems)} problems, {p0.r} variables, {2 * p0.n} inequalities "
            f"({active} with an active bound)"
        )
        print(f"| case | µs per solve (median of {args.repeats}) | largest torque difference to daqp.solve [N·m] |")
        print("|---|---:|---:|")
        for name in qp_cases:
            if "q̈" in name:
                torques = [p.H @ x + p.b for p, x in zip(problems, answers[name])]
            else:
                torques = [p.tilde + p.G @ x for p, x in zip(problems, answers[name])]
            difference = max(np.abs(t - (p.tilde + p.G @ y)).max() for t, p, y in zip(torques, problems, reference))
            unsolved = getattr(cases[name], "unsolved", None)
            passes = args.repeats + 1
            note = f" ({unsolved[0] / passes:g} of {len(problems)} not converged)" if unsolved and unsolved[0] else ""
            print(f"| {name}{note} | {statistics.median(times[name]):.1f} | {difference:.1e} |")
        lp_reference = [x[-1] for x in answers["HiGHS (highspy)"]]
        for name in lp_cases:
            difference = max(abs(x[-1] - t) for x, t in zip(answers[name], lp_reference))
            print(
                f"| LP: {name} | {statistics.median(times[name]):.1f} | utilisation difference to HiGHS {difference:.1e} |"
            )
        null_condition = [np.linalg.cond(p.hessian) for p in problems]
        acc_condition = [np.linalg.cond(p.acc_hessian) for p in problems]
        print(
            f"Hessian condition, median / max: null space ZᵀH²Z {statistics.median(null_condition):.3g} / "
            f"{max(null_condition):.3g}; q̈ H² {statistics.median(acc_condition):.3g} / {max(acc_condition):.3g}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
