"""Count the instructions one RK4 step of :func:`torqueopt.simulate` costs, with valgrind's callgrind.

Wall-clock figures on a shared machine move with the host's load;
instruction counts do not (the same count for the same code, inputs and
libraries). Each resolver is simulated on ``planar3`` over the paper's
movement twice, for ``--short`` and ``--long`` steps, each in its own
process under ``valgrind --tool=callgrind``; the difference of the two totals
divided by the difference of the step counts is the cost of one step, with
imports, loading and set-up cancelled out.

Run::

    python benchmarks/count_instructions.py                 # every registered resolver
    python benchmarks/count_instructions.py --resolver pinv
    python benchmarks/count_instructions.py --robot panda --task position
    python benchmarks/count_instructions.py --resolver obstacle-avoidance --option obstacle=1.2,0.3,0,0.1

Needs ``valgrind`` (Debian package ``valgrind``). Each process takes about a
minute under valgrind.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import torqueopt

RUN = """
import gc, json, math, sys
import torqueopt
robot_name, task, resolver, steps = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
options = json.loads(sys.argv[5])
robot = torqueopt.load_robot(robot_name, task=None if task == "-" else task)
if robot_name == "planar3":
    q0, direction = (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4), (1.0, 1.0)
else:
    q0, direction = robot.default_configuration, (1.0, 0.0, 0.0)[: min(robot.m, 3)]
trajectory = torqueopt.StraightLine(direction, accel=0.2 if robot_name != "planar3" else math.sqrt(2), duration=2.0)
# What the imports and the set-up made is frozen: a full collection that happens to land in one of the two runs
# would otherwise scan all of it, some 16 million instructions that the difference of the runs then counts.
gc.collect()
gc.freeze()
result = torqueopt.simulate(robot, resolver, trajectory, q0, duration=steps * 1e-3, resolver_options=options)
assert result.stop_reason is None, result.stop_reason
"""


def instructions(robot: str, task: str, resolver: str, options: dict, steps: int) -> int:
    """Instructions callgrind counts for one process simulating ``steps`` steps (``options`` the resolver's, as text)."""
    with tempfile.TemporaryDirectory() as folder:
        script = os.path.join(folder, "run.py")
        with open(script, "w") as handle:
            handle.write(RUN)
        completed = subprocess.run(
            [
                "valgrind",
                "--tool=callgrind",
                f"--callgrind-out-file={folder}/out",
                sys.executable,
                script,
                robot,
                task,
                resolver,
                str(steps),
                json.dumps(options),
            ],
            capture_output=True,
            text=True,
            check=False,
            env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"},
        )
    match = re.search(r"Collected\s*:\s*(\d+)", completed.stderr)
    if completed.returncode != 0 or match is None:
        sys.exit(f"valgrind run failed ({resolver}, {steps} steps):\n{completed.stderr[-2000:]}")
    return int(match.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--robot", default="planar3")
    parser.add_argument("--task", default="-", help="task for the robot (its default when omitted)")
    parser.add_argument("--resolver", action="append", help="resolver (repeatable); every registered one by default")
    parser.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a resolver option as on torqueopt run's command line, repeatable; given to every --resolver",
    )
    parser.add_argument("--short", type=int, default=200, help="steps of the shorter run (default 200)")
    parser.add_argument("--long", type=int, default=700, help="steps of the longer run (default 700)")
    arguments = parser.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("valgrind not found; install it (Debian: apt-get install valgrind)")
    known = torqueopt.resolver_names()
    resolvers = arguments.resolver or known
    unknown = [name for name in resolvers if name not in known]
    if unknown:
        parser.error(f"unknown resolver {unknown[0]!r}: choose from {', '.join(known)}")
    options = {}
    for text in arguments.option:
        name, separator, value = text.partition("=")
        if not separator or not name.strip():
            parser.error(f"--option {text!r} must be NAME=VALUE")
        options[name.strip()] = value.strip()
    if not 0 < arguments.short < arguments.long:
        parser.error(f"need 0 < --short < --long, got --short {arguments.short} and --long {arguments.long}")
    jobs = [(name, steps) for name in resolvers for steps in (arguments.short, arguments.long)]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        counts = list(
            pool.map(lambda job: instructions(arguments.robot, arguments.task, job[0], options, job[1]), jobs)
        )
    print(f"| resolver | instructions per RK4 step ({arguments.robot}) |")
    print("|---|---:|")
    settings = "".join(f" {name}={value}" for name, value in options.items())
    for index, name in enumerate(resolvers):
        short, long = counts[2 * index], counts[2 * index + 1]
        print(f"| {name}{settings} | {(long - short) / (arguments.long - arguments.short):,.0f} |")


if __name__ == "__main__":
    main()
