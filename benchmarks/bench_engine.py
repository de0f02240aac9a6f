"""Time the engine's cases the atlas benchmark does not: resolvers without a vectorised step, batched.

Interleaved round by round (the shared machine's load hits all alike), in
one process, trajectory-steps per second:

* ``bounded-torque`` and ``minmax-torque`` on planar3 (0.5 s movements from
  the atlas's population, seed 1): one :func:`torqueopt.simulate` run against
  :func:`torqueopt.batch.simulate_batch` of 16 movements (the single-state
  step looped on stacks);
* ``velocity-pinv`` against ``null-space`` in one ``simulate`` run each (the
  kinematic loop against the held-torque loop, per step).

Run::

    python benchmarks/bench_engine.py [--rounds 3]
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import statistics
import time

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population
from torqueopt.batch import simulate_batch


def _rate(function) -> float:
    started = time.perf_counter()
    steps = function()
    return steps / (time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=3)
    arguments = parser.parse_args()
    robot = torqueopt.load_robot("planar3")
    movements = draw_population(robot, PopulationSpec(paths=16, durations=(0.5,), seed=1))
    lines = [torqueopt.StraightLine(m.direction, duration=0.5, start=m.start) for m in movements]
    q0s = [m.q0 for m in movements]

    def one(name):
        return lambda: len(torqueopt.simulate(robot, name, lines[0], q0s[0]).t) - 1

    def batch(name):
        return lambda: sum(len(run.t) - 1 for run in simulate_batch(robot, name, lines, q0s))

    cases = {
        "bounded-torque simulate": one("bounded-torque"),
        "bounded-torque batch of 16": batch("bounded-torque"),
        "minmax-torque simulate": one("minmax-torque"),
        "minmax-torque batch of 16": batch("minmax-torque"),
        "null-space simulate": one("null-space"),
        "velocity-pinv simulate": one("velocity-pinv"),
    }
    rates = {name: [] for name in cases}
    for _ in range(arguments.rounds):
        for name, function in cases.items():
            rates[name].append(_rate(function))
    print("| planar3, 0.5 s movements | trajectory-steps/s, median of rounds (range) |")
    print("|---|---|")
    for name, values in rates.items():
        print(f"| {name} | {statistics.median(values):,.0f} ({min(values):,.0f}-{max(values):,.0f}) |")


if __name__ == "__main__":
    main()
