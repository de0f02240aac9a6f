"""Cost of one receding-horizon solve (IPOPT on the window's shooting program, warm-started), per robot and horizon.

Cases, interleaved round by round so a noisy neighbour hits every case alike:

* planar3, the paper's long movement (2 s, xy task);
* panda, a 0.5 s straight line of 0.1 m along +y from its default configuration (position task, gravity on,
  the URDF's joint limits and torque limits);

each with windows of 0.1 and 0.5 s (knots 5 ms: N = 20 and 100), replanned every ``--replan-every`` steps of
1 ms. The first solve of a run starts from the path's inverse kinematics; the others from the previous plan
shifted: the table gives the median and largest wall time and IPOPT iterations of the warm solves, and the
one-time build of the window's NLP (the first run of each case, apart).

Run on one core: taskset -c 0 python benchmarks/bench_receding_horizon.py [--rounds 2] [--replan-every 20]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import torqueopt
from torqueopt.paper import PAPER
from torqueopt.resolvers.receding_horizon import RecedingHorizon


class Recording(RecedingHorizon):
    """receding-horizon keeping its run's step, to read the solves' times."""

    def solver_for_movement(self, robot, dt, trajectory):
        self.step = super().solver_for_movement(robot, dt, trajectory)
        return self.step


def cases(replan_every: int):
    planar = PAPER.load_robot()
    panda = torqueopt.load_robot("panda", task="position")
    panda_line = torqueopt.StraightLine([0.0, 1.0, 0.0], accel=1.6, duration=0.5)  # 0.1 m: a·T²/4
    for horizon in (0.1, 0.5):
        yield (f"planar3 long, window {horizon:g} s", planar, PAPER.line("long"), PAPER.q0, horizon)
        yield (f"panda 0.5 s line, window {horizon:g} s", panda, panda_line, panda.default_configuration, horizon)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--replan-every", type=int, default=20)
    arguments = parser.parse_args(argv)
    table = {}
    for round_index in range(arguments.rounds + 1):
        for name, robot, line, q0, horizon in cases(arguments.replan_every):
            resolver = Recording(horizon=horizon, replan_every=arguments.replan_every)
            began = time.perf_counter()
            run = torqueopt.simulate(robot, resolver, line, q0, dt=1e-3)
            seconds = time.perf_counter() - began
            solves = resolver.step.solves
            record = table.setdefault(name, {"warm": [], "iterations": [], "build": None, "failed": 0})
            if round_index == 0:  # the NLP is built in this run: kept apart
                record["build"] = seconds - sum(solve.seconds for solve in solves)
                continue
            record["warm"] += [solve.seconds for solve in solves[1:]]
            record["iterations"] += [solve.iterations for solve in solves[1:]]
            record["failed"] += sum(solve.status not in ("converged", "acceptable") for solve in solves)
            assert run.completed, (name, run.stop_reason)
    print(f"{'case':36s} {'build [s]':>10s} {'solve median [ms]':>18s} {'max [ms]':>9s} {'iterations':>11s} failed")
    for name, record in table.items():
        warm = np.array(record["warm"]) * 1e3
        print(
            f"{name:36s} {record['build']:10.2f} {statistics.median(warm):18.1f} {warm.max():9.1f} "
            f"{statistics.median(record['iterations']):6.0f} ({max(record['iterations'])}) {record['failed']:5d}"
        )


if __name__ == "__main__":
    main()
