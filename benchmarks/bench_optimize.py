"""Wall time of the whole-path torque optimisation (torqueopt.optimize), and of the solvers it was chosen over.

Cases (interleaved round by round, so a noisy neighbour hits every case alike):

* planar3, the paper's long movement (2 s), grids of 10 and 5 ms, Gauss-Newton and L-BFGS Hessians,
  with and without torque bounds;
* panda, a 0.5 s straight line along +y from its default configuration (position task, gravity on),
  10 ms grid, with the URDF's joint limits (and once without, to show why they are needed);
* the same transcription of the short planar movement solved by scipy's SLSQP and trust-constr
  (--scipy), the alternatives to IPOPT.

Run on one core: taskset -c 0 python benchmarks/bench_optimize.py [--rounds 3] [--scipy]

``--shooting PATHS``: the shooting transcription (transcription="shooting") on the atlas's population
(torqueopt.atlas.population, seed 0) of PATHS random 2 s panda lines and PATHS random 1 s panda circles,
torque bounds and joint limits on, both default starts (and the phase-1 problem where no start ends within
the limits), compiled (the one-time compile is timed apart):
convergence, iterations and time per solve. ``--grid-step`` sets the transcription grid (default 0.02 s),
``--starts`` the warm starts (e.g. ``pinv``). ``--out FILE`` appends one JSON line per path (status, cost, every
start's record, phase-1's evidence, wall and CPU seconds of the optimize call) and skips the paths already in it,
so a long run resumes; ``--only 3,13`` solves those paths alone. CPU time is the process's
(``time.process_time``): under ``taskset -c 0`` it is the time on one core, whatever the load.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt.optimal import Transcription, optimize, weight_root
from torqueopt.paper import PAPER
from torqueopt.resolvers.null_space import torque_midpoint


def planar_case(grid_step, hessian, bounds):
    robot = PAPER.load_robot()

    def run():
        return optimize(
            robot,
            PAPER.line("long"),
            PAPER.q0,
            grid_step=grid_step,
            transcription="direct",
            hessian=hessian,
            torque_bounds=bounds,
        )

    return f"planar3 long, {grid_step * 1e3:g} ms, {hessian}{', bounds' if bounds else ''}", run


def panda_case(hessian, limits):
    robot = torqueopt.load_robot("panda", task="position")
    line = torqueopt.StraightLine([0.0, 1.0, 0.0], duration=0.5)

    def run():
        return optimize(
            robot, line, robot.default_configuration, transcription="direct", hessian=hessian, joint_limits=limits
        )

    return f"panda 0.5 s, 10 ms, {hessian}{', joint limits' if limits else ', no joint limits'}", run


def scipy_case(method):
    from scipy.optimize import NonlinearConstraint, minimize

    robot = PAPER.load_robot()
    q0 = robot.configuration(PAPER.q0)
    line = PAPER.line("short").anchored(robot.task_position(q0))
    intervals = 50
    nodes = np.linspace(0.0, line.duration, intervals + 1)
    problem = Transcription(
        robot, line.duration, intervals, line.sample(nodes).position, q0, weight_root(robot), torque_midpoint(robot)
    )
    run_pinv = torqueopt.simulate(robot, "pinv", line, q0)

    def run():
        from torqueopt.optimal.whole_path import _warm_start

        w0 = _warm_start(problem, run_pinv)
        lower, upper = problem.variable_bounds()
        constraint = NonlinearConstraint(problem.constraints, 0.0, 0.0, jac=problem.jacobian)
        began = time.perf_counter()
        answer = minimize(
            problem.objective,
            w0,
            jac=problem.gradient,
            method=method,
            constraints=[constraint],
            bounds=list(zip(lower, upper)),
            options={"maxiter": 500},
        )
        return answer, problem.objective(answer.x), time.perf_counter() - began

    return f"planar3 short, 10 ms, scipy {method}", run


def shooting_population(
    paths: int, grid_step: float, kinds: tuple[str, ...], starts=None, out: Path | None = None, only=None
) -> None:
    from torqueopt.atlas.population import PopulationSpec, draw_population, movement_trajectory

    robot = torqueopt.load_robot("panda", task="position")
    done = {}
    if out is not None and out.exists():
        for line in out.read_text().splitlines():
            record = json.loads(line)
            done[(record["kind"], record["path"])] = record
    records = []
    for kind, duration in (("line", 2.0), ("circle", 1.0)):
        if kind not in kinds:
            continue
        movements = draw_population(robot, PopulationSpec(paths=paths, durations=(duration,), path=kind, seed=0))
        for index, movement in enumerate(movements):
            if only is not None and index not in only:
                continue
            if (kind, index) in done:
                records.append(done[(kind, index)])
                continue
            began, cpu = time.perf_counter(), time.process_time()
            result = optimize(
                robot,
                movement_trajectory(movement),
                movement.q0,
                transcription="shooting",
                grid_step=grid_step,
                torque_bounds=True,
                joint_limits=True,
                compiled=True,
                starts=starts,
            )
            record = {
                "kind": kind,
                "path": index,
                "status": result.status,
                "cost": result.cost,
                "grid_cost": result.grid_cost,
                "pinv_cost": result.warm_start_cost,
                "warm_start": result.warm_start,
                "wall": time.perf_counter() - began,
                "cpu": time.process_time() - cpu,
                "starts": result.starts,
                "feasibility": result.feasibility,
            }
            records.append(record)
            if out is not None:
                with out.open("a") as stream:
                    stream.write(json.dumps(record, default=float) + "\n")
            tried = "; ".join(
                f"{s['warm_start']}: {s['status']} {s['iterations']} it {s['grid_cost']:.6g} ({s['seconds']:.2f} s)"
                for s in result.starts
            )
            evidence = f" | phase-1: {result.feasibility['evidence']}" if result.feasibility else ""
            print(
                f"{kind} {index:3d} {result.status:>16} cost {result.cost:12.6g} pinv {result.warm_start_cost:12.6g} "
                f"wall {record['wall']:7.2f} s cpu {record['cpu']:7.2f} s | {tried}{evidence}",
                flush=True,
            )
    for kind in kinds:
        chosen = [record for record in records if record["kind"] == kind]
        if not chosen:
            continue
        counts = {}
        for record in chosen:
            counts[record["status"]] = counts.get(record["status"], 0) + 1
        cpu = [record["cpu"] for record in chosen]
        converged_cpu = [record["cpu"] for record in chosen if record["status"] == "converged"]
        iterations = [s["iterations"] for record in chosen for s in record["starts"]]
        print(
            f"{kind}: {len(chosen)} paths, "
            + ", ".join(f"{status} {count}" for status, count in sorted(counts.items()))
            + f"; CPU per optimize call median {statistics.median(cpu):.2f} s, max {max(cpu):.2f} s"
            + (
                f" (converged: median {statistics.median(converged_cpu):.2f} s, "
                f"{sum(c <= 5.0 for c in converged_cpu)}/{len(converged_cpu)} within 5 s)"
                if converged_cpu
                else ""
            )
            + f"; iterations per start median {statistics.median(iterations):g}, max {max(iterations)}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--scipy", action="store_true", help="also time scipy's SLSQP and trust-constr (slow)")
    parser.add_argument("--shooting", type=int, default=0, metavar="PATHS")
    parser.add_argument("--grid-step", type=float, default=0.02)
    parser.add_argument("--kinds", default="line,circle", help="of --shooting: line, circle or both")
    parser.add_argument(
        "--starts", default=None, help="of --shooting: comma-separated warm starts (default: optimize's)"
    )
    parser.add_argument("--out", type=Path, default=None, help="of --shooting: JSON lines, appended, resumed")
    parser.add_argument("--only", default=None, help="of --shooting: comma-separated path indices")
    args = parser.parse_args()
    if args.shooting:
        starts = tuple(args.starts.split(",")) if args.starts else None
        only = {int(index) for index in args.only.split(",")} if args.only else None
        shooting_population(args.shooting, args.grid_step, tuple(args.kinds.split(",")), starts, args.out, only)
        return
    cases = [
        planar_case(0.01, "gauss-newton", False),
        planar_case(0.01, "limited-memory", False),
        planar_case(0.005, "gauss-newton", False),
        planar_case(0.005, "limited-memory", False),
        planar_case(0.01, "gauss-newton", True),
        panda_case("gauss-newton", True),
        panda_case("limited-memory", True),
        panda_case("gauss-newton", False),
    ]
    times = {name: [] for name, _ in cases}
    outcomes = {}
    for _ in range(args.rounds):
        for name, run in cases:
            began = time.perf_counter()
            result = run()
            times[name].append(time.perf_counter() - began)
            outcomes[name] = result
    print(f"{'case':<52}{'median [s]':>11}{'min [s]':>9}{'status':>17}{'iters':>7}{'cost':>12}")
    for name, _ in cases:
        result = outcomes[name]
        print(
            f"{name:<52}{statistics.median(times[name]):11.2f}{min(times[name]):9.2f}{result.status:>17}"
            f"{result.iterations:7d}{result.cost:12.4f}"
        )
    if args.scipy:
        optimum = optimize(PAPER.load_robot(), PAPER.line("short"), PAPER.q0, grid_step=0.01, transcription="direct")
        print(
            f"\nIPOPT on the same short-movement transcription: {optimum.solve_seconds:.2f} s, grid cost {optimum.grid_cost:.4f}"
        )
        for method in ("SLSQP", "trust-constr"):
            name, run = scipy_case(method)
            answer, cost, seconds = run()
            print(f"{name:<52}{seconds:11.2f}  success={answer.success} ({answer.message}) cost {cost:.4f}")


if __name__ == "__main__":
    main()
