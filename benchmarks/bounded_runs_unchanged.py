"""Check that a change to the bounded resolvers leaves their runs unchanged, bit for bit by default.

Runs ``bounded-torque``, ``minmax-torque`` and ``energy-bounded-torque`` with ``joint_limits`` on and off:
on planar3 with its own torque limits (the paper's movement and two seeded random lines, the default
policy) and with every torque limit lowered to 3 N·m under each ``infeasible`` policy ('scale',
'least-error', 'exceed', 'stop'); on panda (position task) along two 0.5 s lines; each as single runs
(:func:`torqueopt.simulate`) and the planar3 ones also as one batch (:func:`torqueopt.batch.simulate_batch`).
It saves or compares q, v, tau, task_error, infeasible, the ``limiting`` texts and the stop reasons::

    python benchmarks/bounded_runs_unchanged.py --save /tmp/bounded-before.npz      # before the change
    python benchmarks/bounded_runs_unchanged.py --compare /tmp/bounded-before.npz   # after it

``--compare`` prints the largest absolute difference of each array and exits with status 1 when one
passes ``--tolerance`` (0 by default: equal to the last bit), or a run's length, infeasible flags,
limiting texts or stop reason changed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

import torqueopt
from torqueopt.batch import simulate_batch
from torqueopt.resolvers import get_resolver

RESOLVERS = ("bounded-torque", "minmax-torque", "energy-bounded-torque")
POLICIES = ("scale", "least-error", "exceed", "stop")
#: The lowered torque limit of the infeasible cases [N·m].
LOW_LIMIT = 3.0
PAPER_START = (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4)


def planar3_movements():
    """(trajectory, q0, duration) of the paper's movement and two seeded random lines."""
    rng = np.random.default_rng(13)
    movements = [(torqueopt.StraightLine((1.0, 1.0), duration=2.0), PAPER_START, 2.0)]
    for _ in range(2):
        angle = rng.uniform(0.0, 2 * math.pi)
        start = (rng.uniform(-1.0, 1.0), rng.uniform(0.5, 2.5), rng.uniform(-2.5, -0.5))
        line = torqueopt.StraightLine((math.cos(angle), math.sin(angle)), accel=rng.uniform(0.5, 2.0), duration=1.0)
        movements.append((line, start, 1.0))
    return movements


def panda_movements():
    """(trajectory, q0, duration) of two 0.5 s lines from panda's SRDF configuration."""
    return [
        (torqueopt.StraightLine(direction, accel=0.3, duration=0.5), None, 0.5)
        for direction in ((1.0, 0.0, 0.0), (0.0, 0.6, 0.8))
    ]


def cases():
    """(label, robot, resolver options, movements, batched) of every case."""
    planar3 = torqueopt.load_robot("planar3")
    low = torqueopt.load_robot("planar3", torque_limit=LOW_LIMIT)
    panda = torqueopt.load_robot("panda", task="position")
    found = []
    for name in RESOLVERS:
        for joint_limits in ("on", "off"):
            options = {"joint_limits": joint_limits}
            found.append((f"{name} {joint_limits} planar3", planar3, name, options, planar3_movements(), True))
            for policy in POLICIES:
                low_options = {**options, "infeasible": policy}
                label = f"{name} {joint_limits} planar3 3Nm {policy}"
                found.append((label, low, name, low_options, planar3_movements(), True))
            panda_moves = [(line, panda.default_configuration, duration) for line, _, duration in panda_movements()]
            found.append((f"{name} {joint_limits} panda", panda, name, options, panda_moves, False))
    return found


def record(arrays: dict, label: str, result) -> None:
    """Store one run's arrays under ``label``."""
    for field in ("q", "v", "tau", "task_error", "infeasible"):
        arrays[f"{label}|{field}"] = np.asarray(getattr(result, field))
    arrays[f"{label}|limiting"] = np.array(json.dumps({str(k): v for k, v in sorted((result.limiting or {}).items())}))
    arrays[f"{label}|stop"] = np.array(str(result.stop_reason))


def collect() -> dict:
    """Every run's arrays, keyed ``label|field``."""
    arrays = {}
    for label, robot, name, options, movements, batched in cases():
        for index, (line, q0, duration) in enumerate(movements):
            result = torqueopt.simulate(robot, name, line, q0, duration=duration, resolver_options=options)
            record(arrays, f"{label} #{index} single", result)
        if batched:
            # One duration per batch: the paper's movement alone, then the two 1 s lines together.
            resolver = get_resolver(name, **options)
            groups = ([movements[0]], movements[1:])
            index = 0
            for group in groups:
                results = simulate_batch(robot, resolver, [line for line, _, _ in group], [q0 for _, q0, _ in group])
                for result in results:
                    record(arrays, f"{label} #{index} batch", result)
                    index += 1
    return arrays


def compare(saved, arrays: dict, tolerance: float) -> bool:
    """Print each run's differences; True when every run is unchanged within ``tolerance``."""
    labels = sorted({key.rsplit("|", 1)[0] for key in saved.files})
    if labels != sorted({key.rsplit("|", 1)[0] for key in arrays}):
        print("the set of runs changed")
        return False
    unchanged = True
    for label in labels:
        line = []
        for field in ("stop", "limiting", "infeasible"):
            before, after = saved[f"{label}|{field}"], arrays[f"{label}|{field}"]
            if before.shape != after.shape or not np.array_equal(before, after):
                line.append(f"{field} changed")
                unchanged = False
        for field in ("q", "v", "tau", "task_error"):
            before, after = saved[f"{label}|{field}"], arrays[f"{label}|{field}"]
            if before.shape != after.shape:
                line.append(f"{field} shape {before.shape} -> {after.shape}")
                unchanged = False
                continue
            same_nan = np.array_equal(np.isnan(before), np.isnan(after))
            difference = float(np.nanmax(np.abs(after - before), initial=0.0)) if same_nan else math.inf
            unchanged &= difference <= tolerance
            line.append(f"{field} {difference:.1e}")
        print(f"{label} ({len(saved[f'{label}|q'])} rows): " + ", ".join(line))
    return unchanged


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--save", metavar="FILE", help="write the runs to this .npz file")
    mode.add_argument("--compare", metavar="FILE", help="compare the runs with those saved in this .npz file")
    parser.add_argument("--tolerance", type=float, default=0.0, help="largest absolute difference (default 0)")
    arguments = parser.parse_args()
    arrays = collect()
    if arguments.save:
        np.savez(arguments.save, **arrays)
        print(f"saved {len({key.rsplit('|', 1)[0] for key in arrays})} runs to {arguments.save}")
        return
    sys.exit(0 if compare(np.load(arguments.compare), arrays, arguments.tolerance) else 1)


if __name__ == "__main__":
    main()
