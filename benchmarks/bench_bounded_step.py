"""Wall-clock cost per RK4 step of ``simulate`` for the bounded resolvers beside ``null-space``, interleaved.

Cases: planar3 on the paper's movement (q0 = (-45°, 135°, -135°), direction
(1, 1), √2 m/s²) for 0.55 s, where every resolver here realises its task
within the limits (``minmax-torque`` meets its first infeasible step at
0.594 s); panda (position task, URDF limits) on a 0.2 m/s² line along world
x from its SRDF configuration, 0.3 s. Each round times every resolver once
on each robot; the figure is the median over ``--repeats`` rounds of the
wall time per step [µs], and its ratio to ``null-space`` in the same rounds.
One thread (OpenBLAS/OpenMP set to 1 before numpy loads).

Run::

    python benchmarks/bench_bounded_step.py
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import math
import statistics
import time

import torqueopt

RESOLVERS = ("null-space", "damped-null-space", "bounded-torque", "minmax-torque")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--repeats", type=int, default=9, help="interleaved rounds (default 9)")
    args = parser.parse_args(argv)
    planar3 = torqueopt.load_robot("planar3")
    panda = torqueopt.load_robot("panda", task="position")
    cases = {
        "planar3": (
            planar3,
            torqueopt.StraightLine((1.0, 1.0), duration=2.0),
            (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4),
            0.55,
        ),
        "panda": (
            panda,
            torqueopt.StraightLine((1.0, 0.0, 0.0), accel=0.2, duration=2.0),
            panda.default_configuration,
            0.3,
        ),
    }
    times = {(robot, name): [] for robot in cases for name in RESOLVERS}
    for round_ in range(args.repeats + 1):  # the first round warms up
        for robot_name, (robot, line, q0, duration) in cases.items():
            for name in RESOLVERS:
                start = time.perf_counter()
                run = torqueopt.simulate(robot, name, line, q0, duration=duration)
                elapsed = time.perf_counter() - start
                if run.infeasible.any() or not run.completed:
                    raise SystemExit(f"{name} on {robot_name} did not realise its task within bounds at every step")
                if round_:
                    times[robot_name, name].append(elapsed / (len(run.t) - 1) * 1e6)
    print(f"| resolver | planar3 µs/step | × null-space | panda µs/step | × null-space |  (median of {args.repeats})")
    print("|---|---:|---:|---:|---:|")
    for name in RESOLVERS:
        cells = []
        for robot_name in cases:
            median = statistics.median(times[robot_name, name])
            ratios = [a / b for a, b in zip(times[robot_name, name], times[robot_name, "null-space"])]
            cells += [f"{median:.1f}", f"{statistics.median(ratios):.2f}"]
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
