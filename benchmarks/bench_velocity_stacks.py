"""Time every velocity-level method in the batch against one ``simulate`` run, and against the torque batch.

Interleaved round by round in one process (the shared machine's load hits all
cases alike), trajectory-steps per second, on planar3 (0.3 s movements from
the atlas's population, seed 1):

* each velocity-level method, with the options that select its stacked form,
  through :func:`torqueopt.batch.simulate_batch` of ``--movements`` movements
  (on stacks when the method has a stacked form, else one movement at a time)
  and through one :func:`torqueopt.simulate` run;
* ``null-space``, the torque resolver, batched the same way: the yardstick of
  "within 2x of a torque resolver".

Run::

    python benchmarks/bench_velocity_stacks.py [--rounds 3] [--movements 64] [--duration 0.3]
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

#: (label, resolver name, options): every velocity-level method, with the options its benchmarks count.
METHODS = (
    ("velocity-pinv", "velocity-pinv", {}),
    ("gradient-projection (joint limits)", "gradient-projection", {}),
    ("gradient-projection (manipulability)", "gradient-projection", {"criterion": "manipulability"}),
    ("task-priority (posture)", "task-priority", {}),
    ("task-priority (frame link3)", "task-priority", {"secondary": "link3:0.5,-0.5"}),
    ("kinetic-energy-pinv", "kinetic-energy-pinv", {}),
    ("extended-jacobian", "extended-jacobian", {}),
    ("obstacle-avoidance", "obstacle-avoidance", {"obstacle": "1.2,0.3,0,0.1"}),
)


def _rate(function) -> float:
    started = time.perf_counter()
    steps = function()
    return steps / (time.perf_counter() - started)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--movements", type=int, default=64)
    parser.add_argument("--duration", type=float, default=0.3)
    arguments = parser.parse_args(argv)
    robot = torqueopt.load_robot("planar3")
    movements = draw_population(robot, PopulationSpec(paths=arguments.movements, durations=(2.0,), seed=1))
    lines = [torqueopt.StraightLine(m.direction, duration=arguments.duration, start=m.start) for m in movements]
    q0s = [m.q0 for m in movements]
    resolvers = {"null-space": torqueopt.get_resolver("null-space")}
    resolvers.update({label: torqueopt.get_resolver(name, **options) for label, name, options in METHODS})

    def batch(resolver):
        return lambda: sum(len(run.t) - 1 for run in simulate_batch(robot, resolver, lines, q0s))

    def one(resolver):
        return lambda: len(torqueopt.simulate(robot, resolver, lines[0], q0s[0]).t) - 1

    cases = {}
    for label, resolver in resolvers.items():
        stacked = label == "null-space" or resolver.stack_rate_function(robot) is not None
        cases[f"{label} batch{'' if stacked else ' (one at a time)'}"] = batch(resolver)
        cases[f"{label} simulate"] = one(resolver)
    rates = {name: [] for name in cases}
    for _ in range(arguments.rounds):
        for name, function in cases.items():
            rates[name].append(_rate(function))
    medians = {name: statistics.median(values) for name, values in rates.items()}
    yardstick = medians["null-space batch"]
    print(
        f"planar3, {arguments.movements} movements of {arguments.duration} s, {arguments.rounds} interleaved rounds, "
        f"load average {os.getloadavg()[0]:.1f} at the end; trajectory-steps/s (median), and how many times "
        "slower than the null-space batch:"
    )
    for name, value in medians.items():
        print(f"  {name:58s} {value:10,.0f}  {yardstick / value:6.2f}x")


if __name__ == "__main__":
    main()
