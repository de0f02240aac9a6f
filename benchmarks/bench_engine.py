"""Time the engine's cases the atlas benchmark does not: the bounded resolvers batched, and the kinematic loop.

Interleaved round by round (the shared machine's load hits all alike), in
one process, trajectory-steps per second:

* ``bounded-torque``, ``minmax-torque`` and ``energy-bounded-torque`` on
  planar3 and panda (0.5 s movements from the atlas's population, seed 1,
  joint limits on, the resolvers' defaults): one :func:`torqueopt.simulate`
  run against :func:`torqueopt.batch.simulate_batch` of 16 movements (the
  vectorised step of :class:`torqueopt.resolvers.bounded.base.BoundedStackStep`);
* ``velocity-pinv`` against ``null-space`` in one ``simulate`` run each (the
  kinematic loop against the held-torque loop, per step).

Run::

    python benchmarks/bench_engine.py [--rounds 3] [--robots planar3,panda]
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


BOUNDED = ("bounded-torque", "minmax-torque", "energy-bounded-torque")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--robots", default="planar3,panda")
    arguments = parser.parse_args()
    cases = {}
    for robot_name in arguments.robots.split(","):
        robot = torqueopt.load_robot(robot_name)
        movements = draw_population(robot, PopulationSpec(paths=16, durations=(0.5,), seed=1))
        lines = [torqueopt.StraightLine(m.direction, duration=0.5, start=m.start) for m in movements]
        q0s = [m.q0 for m in movements]

        def one(name, robot=robot, lines=lines, q0s=q0s):
            return lambda: len(torqueopt.simulate(robot, name, lines[0], q0s[0]).t) - 1

        def batch(name, robot=robot, lines=lines, q0s=q0s):
            return lambda: sum(len(run.t) - 1 for run in simulate_batch(robot, name, lines, q0s))

        for name in BOUNDED:
            cases[f"{robot_name} {name} simulate"] = one(name)
            cases[f"{robot_name} {name} batch of 16"] = batch(name)
        if robot_name == "planar3":
            cases["planar3 null-space simulate"] = one("null-space")
            cases["planar3 velocity-pinv simulate"] = one("velocity-pinv")
    rates = {name: [] for name in cases}
    for _ in range(arguments.rounds):
        for name, function in cases.items():
            rates[name].append(_rate(function))
    print("| 0.5 s movements | trajectory-steps/s, median of rounds (range) | batch / simulate |")
    print("|---|---|---|")
    for name, values in rates.items():
        ratio = ""
        if name.endswith("batch of 16"):
            single = statistics.median(rates[name.replace("batch of 16", "simulate")])
            ratio = f"{statistics.median(values) / single:.1f}x"
        print(f"| {name} | {statistics.median(values):,.0f} ({min(values):,.0f}-{max(values):,.0f}) | {ratio} |")


if __name__ == "__main__":
    main()
