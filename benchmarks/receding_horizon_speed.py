"""CPU per receding-horizon solve, its NLP's functions in CasADi's virtual machine against compiled C, per robot and window.

Cases, interleaved round by round so a noisy neighbour hits both alike:

* ``solves``: planar3 on the paper's long movement (2 s, xy task) and panda on a 0.5 s straight line of 0.1 m
  along +y from its default configuration (position task, gravity, the URDF's joint and torque limits), windows
  of 0.1, 0.5 and 1 s (knots ``--knots`` apart, by default ``horizon_dt='auto'``), replanned every 20 steps of
  1 ms over the first ``--planar-duration`` / ``--panda-duration`` seconds; each with the window's functions
  ``vm`` (expanded to SX, CasADi's virtual machine) and ``compiled`` (C, compiled once per robot, N and options,
  kept on disk), or those of ``--modes``. Per case: the median and largest CPU time of the warm solves (the
  first, from the path's inverse kinematics, apart), IPOPT's iterations, the CPU per iteration, and the run's
  cost (∫‖τ‖² dt over the part run) and largest tip error, to weigh a knot spacing's speed against its answer.
* ``line``: planar3's whole 2 s long movement with a 0.5 s window replanned every 1, 5 and 20 steps: the CPU per
  control step of the whole run (solves, the steps between them and the simulation), ``vm`` and ``compiled``.

* ``count``: the instructions of one warm solve under valgrind's callgrind, repeatable where CPU time is not:
  planar3's long movement with a ``--window`` window replanned every 20 steps, run for 0.1 s and for 0.3 s
  (5 and 15 solves) in two processes; the difference of the totals over the 10 solves (and their 200 steps)
  is one solve's count, imports, builds and compiles cancelled out (the compile itself runs outside valgrind).

CPU time (``time.process_time``) rather than wall time: the machine is shared. The one-time builds and compiles
happen in a round 0 that is not counted.

    taskset -c 0 python benchmarks/receding_horizon_speed.py solves [--rounds 1] [--knots 0.005 0.01 0.02 --modes compiled]
    taskset -c 0 python benchmarks/receding_horizon_speed.py line
    python benchmarks/receding_horizon_speed.py count --window 0.5
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import torqueopt
from torqueopt.paper import PAPER
from torqueopt.resolvers.receding_horizon import RecedingHorizon

MODES = ("vm", "compiled")


class Timed(RecedingHorizon):
    """receding-horizon whose window program is compiled or not (``mode``), recording each solve's CPU time."""

    def __init__(self, mode: str, **options):
        super().__init__(**options)
        self.mode, self.cpu, self.solves = mode, [], []

    def solver_for_movement(self, robot, dt, trajectory):
        step = super().solver_for_movement(robot, dt, trajectory)
        program = step.program
        program.compiled = self.mode == "compiled"
        solve = program.solve

        def timed(*arguments, **keywords):
            began = time.process_time()
            solved = solve(*arguments, **keywords)
            self.cpu.append(time.process_time() - began)
            self.solves.append(solved)
            return solved

        program.solve = timed
        return step


def arms(planar_duration: float, panda_duration: float):
    planar = PAPER.load_robot()
    panda = torqueopt.load_robot("panda", task="position")
    panda_line = torqueopt.StraightLine([0.0, 1.0, 0.0], accel=1.6, duration=0.5)  # 0.1 m: a·T²/4
    return {
        "planar3": (planar, PAPER.line("long"), PAPER.q0, planar_duration),
        "panda": (panda, panda_line, panda.default_configuration, panda_duration),
    }


def solves(arguments) -> None:
    from torqueopt.optimal import run_cost

    robots = arms(arguments.planar_duration, arguments.panda_duration)
    table = {}
    for round_index in range(arguments.rounds + 1):
        for window in arguments.windows:
            for name in arguments.robots:
                robot, line, q0, duration = robots[name]
                for mode, knots in ((mode, knots) for knots in arguments.knots for mode in arguments.modes):
                    resolver = Timed(mode, horizon=window, horizon_dt=knots, replan_every=20)
                    run = torqueopt.simulate(robot, resolver, line, q0, dt=1e-3, duration=duration)
                    assert run.completed, (name, window, mode, run.stop_reason)
                    if round_index == 0:  # builds and compiles
                        continue
                    h = resolver.knot_spacing(1e-3)
                    record = table.setdefault(
                        (name, window, round(window / h), mode),
                        {
                            "cpu": [],
                            "iterations": [],
                            "failed": 0,
                            "cost": run_cost(run, robot),
                            "tip": run.max_tip_error,
                        },
                    )
                    record["cpu"] += resolver.cpu[1:]
                    record["iterations"] += [solved.iterations for solved in resolver.solves[1:]]
                    record["failed"] += sum(s.status not in ("converged", "acceptable") for s in resolver.solves)
                    print(f"round {round_index} {name} {window:g} s {mode}: {1e3 * np.median(resolver.cpu[1:]):.1f} ms",
                          flush=True)  # fmt: skip
    print(
        "\n| robot | window [s] | N | functions | CPU per solve, median (max) [ms] | iterations | CPU per iteration [ms] "
        "| failed | run cost | tip error [m] |"
    )
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|")
    for (name, window, intervals, mode), record in table.items():
        cpu = np.array(record["cpu"]) * 1e3
        iterations = np.array(record["iterations"])
        print(
            f"| {name} | {window:g} | {intervals} | {mode} | {statistics.median(cpu):.1f} ({cpu.max():.1f}) "
            f"| {statistics.median(iterations):.0f} | {cpu.sum() / iterations.sum():.2f} | {record['failed']} "
            f"| {record['cost']:.6g} | {record['tip']:.2g} |"
        )


def line(arguments) -> None:
    robot, movement, q0, _ = arms(2.0, 0.5)["planar3"]
    table = {}
    for round_index in range(arguments.rounds + 1):
        for every in (1, 5, 20):
            for mode in MODES:
                resolver = Timed(mode, horizon=0.5, replan_every=every)
                began = time.process_time()
                run = torqueopt.simulate(robot, resolver, movement, q0, dt=1e-3)
                seconds = time.process_time() - began
                assert run.completed, (every, mode, run.stop_reason)
                if round_index == 0:
                    continue
                steps = len(run.t) - 1
                table.setdefault((every, mode), []).append(
                    (seconds / steps, sum(resolver.cpu) / steps, len(resolver.cpu))
                )
                print(
                    f"round {round_index} replan_every={every} {mode}: {1e3 * seconds / steps:.2f} ms/step", flush=True
                )
    print("\n| replan_every | functions | solves | CPU per control step [ms] | of which solves [ms] |")
    print("|---:|---|---:|---:|---:|")
    for (every, mode), entries in table.items():
        per_step = statistics.median(entry[0] for entry in entries)
        in_solves = statistics.median(entry[1] for entry in entries)
        print(f"| {every} | {mode} | {entries[0][2]} | {1e3 * per_step:.2f} | {1e3 * in_solves:.2f} |")


COUNT_RUN = """
import gc, sys
sys.path.insert(0, {folder!r})
import torqueopt
from torqueopt.paper import PAPER
from receding_horizon_speed import Timed
mode, window, duration = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
robot = PAPER.load_robot()
torqueopt.simulate(robot, Timed(mode, horizon=window, replan_every=20), PAPER.line("long"), PAPER.q0, dt=1e-3, duration=0.04)
gc.collect()
gc.freeze()
run = torqueopt.simulate(robot, Timed(mode, horizon=window, replan_every=20), PAPER.line("long"), PAPER.q0, dt=1e-3,
                         duration=duration)
assert run.completed
"""


def count(arguments) -> None:
    folder = os.path.dirname(os.path.abspath(__file__))
    totals = {}
    for mode in MODES:
        for duration in (0.1, 0.3):
            # warm the builds and the on-disk compile outside valgrind: the counted process loads them
            subprocess.run([sys.executable, "-c", COUNT_RUN.format(folder=folder), mode, str(arguments.window), "0.05"],
                           check=True, capture_output=True)  # fmt: skip
            with tempfile.TemporaryDirectory() as scratch:
                script = os.path.join(scratch, "run.py")
                with open(script, "w") as handle:
                    handle.write(COUNT_RUN.format(folder=folder))
                completed = subprocess.run(
                    ["valgrind", "--tool=callgrind", f"--callgrind-out-file={scratch}/out", sys.executable, script,
                     mode, str(arguments.window), str(duration)],
                    capture_output=True, text=True, check=False,
                    env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"},
                )  # fmt: skip
            match = re.search(r"Collected\s*:\s*(\d+)", completed.stderr)
            if completed.returncode != 0 or match is None:
                sys.exit(f"valgrind run failed ({mode}, {duration} s):\n{completed.stderr[-2000:]}")
            totals[mode, duration] = int(match.group(1))
    print(f"| functions | instructions per warm solve, planar3, window {arguments.window:g} s |")
    print("|---|---:|")
    for mode in MODES:
        print(f"| {mode} | {(totals[mode, 0.3] - totals[mode, 0.1]) / 10:,.0f} |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("what", choices=("solves", "line", "count"))
    parser.add_argument("--window", type=float, default=0.5, help="count: the window [s]")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--robots", nargs="+", default=["planar3", "panda"], choices=("planar3", "panda"))
    parser.add_argument("--windows", nargs="+", type=float, default=[0.1, 0.5, 1.0])
    parser.add_argument("--knots", nargs="+", default=["auto"], help="solves: knot spacings [s] or 'auto'")
    parser.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES, help="solves: the functions")
    parser.add_argument("--planar-duration", type=float, default=0.5, help="seconds of planar3's movement run [s]")
    parser.add_argument("--panda-duration", type=float, default=0.1, help="seconds of panda's line run [s]")
    arguments = parser.parse_args(argv)
    {"solves": solves, "line": line, "count": count}[arguments.what](arguments)


if __name__ == "__main__":
    main()
