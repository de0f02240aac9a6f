"""Time the dexterity measures along a run: the cost per row, batched and pointwise, beside the simulation.

Cases, on the paper's long movement (planar3, 2001 rows) and a 0.5 s line on
panda (501 rows), resolver pinv:

* ``simulate``: the run alone (``dexterity=False``, the default);
* ``simulate+dexterity``: the run with ``dexterity=True``;
* ``dexterity_along``: the measures of the stored rows, batched (what ``dexterity=True`` adds);
* ``pointwise``: ``torqueopt.dexterity(robot, q)`` row by row (the reference it is tested against).

After one warm-up, ``--repeats`` rounds time every case once each,
interleaved; the table gives the median wall time per row [µs]. One thread.

Run::

    python benchmarks/bench_dexterity.py
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import statistics
import time
from functools import partial

import numpy as np

import torqueopt
from torqueopt.dexterity import dexterity_along


def cases():
    planar3 = torqueopt.load_robot("planar3")
    panda = torqueopt.load_robot("panda")
    yield "planar3", planar3, torqueopt.StraightLine([1, 1], duration=2.0), np.radians([-45.0, 135.0, -135.0])
    yield "panda", panda, torqueopt.StraightLine([1, 0, 0], accel=0.5, duration=0.5), panda.default_configuration


def pointwise(robot, rows):
    return [torqueopt.dexterity(robot, q) for q in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    print(
        f"{'robot':<9}{'rows':>6}{'simulate':>11}{'sim+dext':>11}{'batched':>11}{'pointwise':>11}   [µs per row, median]"
    )
    for name, robot, line, q0 in cases():
        result = torqueopt.simulate(robot, "pinv", line, q0)
        rows = len(result.t)
        work = {
            "simulate": partial(torqueopt.simulate, robot, "pinv", line, q0),
            "simulate+dexterity": partial(torqueopt.simulate, robot, "pinv", line, q0, dexterity=True),
            "dexterity_along": partial(dexterity_along, robot, result.q),
            "pointwise": partial(pointwise, robot, result.q),
        }
        for job in work.values():
            job()
        times = {case: [] for case in work}
        for _ in range(args.repeats):
            for case, job in work.items():
                start = time.perf_counter()
                job()
                times[case].append(time.perf_counter() - start)
        medians = [statistics.median(times[case]) / rows * 1e6 for case in work]
        print(f"{name:<9}{rows:>6}" + "".join(f"{value:11.1f}" for value in medians))


if __name__ == "__main__":
    main()
