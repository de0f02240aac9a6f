"""Time the atlas: trajectory-steps per second of one simulate run, the batched path, and Dask sweeps.

A trajectory-step is one RK4 step of one movement with one resolver
(resolver evaluation, three ABA stages, the step's records). Cases, timed
interleaved round by round so the shared machine's load hits all alike:

* ``simulate``: one :func:`torqueopt.simulate` run, planar3, null-space, the
  paper's long movement (2 s, 2001 rows), in the benchmark's own process;
* ``simulate (own process)``: the same run timed three times in a fresh
  interpreter of its own each round (its imports and a warm-up run untimed;
  one run of panda's 0.5 s line lasts about 30 ms, so one timing a round
  spread 1.7-2.2x), as ``torqueopt run`` would run it: the benchmark's process also hosts the two idle Dask clusters (their
  schedulers and clients run event loops in threads of that process), and its
  ``simulate`` rounds ran up to 1.9x slower than the same call alone;
* ``batch``: :func:`torqueopt.batch.simulate_batch` in this process, 256
  movements of 2 s (the atlas's default chunk) from the atlas's population
  (seed 1), null-space, with the energy extras the atlas uses;
* ``sweep 1 worker`` / ``sweep 2 workers``: the atlas's chunks (``run_chunk``:
  batch, verdicts, rows; pinv and null-space on 2 x 256 movements of 2 s)
  through ``distributed.as_completed`` on a LocalCluster of 1 and of 2
  worker processes started before the rounds (startup is not timed);
  trajectory-steps counted from the rows.

Also measured once: the task terms per movement by simulate's own calls (one
movement at a time) against the batch's forest
(:class:`torqueopt.robot_copies.RobotForest`), and the batch against simulate on
panda (n = 7) to show how the cost grows with the number of joints.

``--panda-sweep`` adds the same sweeps on panda (its default position task,
pinv and null-space on 2 x 256 random 0.5 s lines of the atlas's population,
seed 1, the acceleration sized to the arm), interleaved with one ``simulate``
run of null-space on the first of those lines, round by round.

``--count`` instead counts instructions with valgrind's callgrind (figures
that do not move with the host's load): one process per case and length,
the difference between a 150-step and a 50-step run divided by the
trajectory-steps between them, for the batch (256 movements or ``--movements N``, null-space,
with the energy extras) and for one ``simulate`` run (null-space), on
planar3 or (``--robot panda``) panda's position task, each with the part
spent inside Pinocchio's library.

Run::

    python benchmarks/bench_atlas.py [--rounds 3] [--write BENCHMARKS.md]
    python benchmarks/bench_atlas.py --count [--robot panda]

``--write`` replaces only the block between the ``bench_atlas:begin`` and
``bench_atlas:end`` markers.
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import dataclasses
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population
from torqueopt.atlas.jobs import ResolverChunk, RobotSpec
from torqueopt.atlas.sweep import resolvers_from, run_chunk
from torqueopt.atlas.verdicts import Thresholds
from torqueopt.batch import simulate_batch
from torqueopt.robot_copies import RobotForest

BEGIN, END = "<!-- bench_atlas:begin -->", "<!-- bench_atlas:end -->"
PAPER_Q0 = np.radians([-45.0, 135.0, -135.0])
PAPER_ACCEL = float(np.sqrt(2.0))  # the paper's line [m/s²]


def _cpu_ticks():
    try:
        fields = [int(x) for x in Path("/proc/stat").read_text().splitlines()[0].split()[1:9]]
    except (OSError, ValueError):
        return None
    return fields[7], sum(fields)


def _jobs(robot_name, movements, resolvers, chunk, accel=PAPER_ACCEL):
    lines = tuple(dataclasses.replace(m, accel=accel) for m in movements)  # the lines at the acceleration given
    resolvers = tuple(resolvers_from(resolvers))
    return [
        ResolverChunk(RobotSpec(robot_name), resolvers, lines[i : i + chunk], 1e-3, Thresholds(), True, "bench")
        for i in range(0, len(lines), chunk)
    ]


def _sweep(client, jobs, distributed):
    started = time.perf_counter()
    futures = [client.submit(run_chunk, job, pure=False) for job in jobs]
    steps = 0
    for future in distributed.as_completed(futures):
        steps += sum(row["steps"] - 1 for row in future.result())
    return steps / (time.perf_counter() - started)


_OWN_PROCESS_RUN = """
import os, sys, time
os.environ["OMP_NUM_THREADS"] = os.environ["OPENBLAS_NUM_THREADS"] = "1"
import numpy as np
import torqueopt
robot_name, direction, accel, duration, start, q0 = sys.argv[1], *map(eval, sys.argv[2:])
robot = torqueopt.load_robot(robot_name)
line = torqueopt.StraightLine(direction, accel=accel, duration=duration, start=start)
torqueopt.simulate(robot, "null-space", line, np.array(q0))  # warm-up
for _ in range(3):
    started = time.perf_counter()
    run = torqueopt.simulate(robot, "null-space", line, np.array(q0))
    print((len(run.t) - 1) / (time.perf_counter() - started))
"""


def _simulate_in_own_process(robot_name, direction, accel, duration, q0, start=None) -> list[float]:
    """Trajectory-steps/s of three null-space ``simulate`` runs timed one after another in a fresh interpreter
    (imports and a warm-up run untimed)."""
    import subprocess
    import sys

    arguments = [repr(list(map(float, direction))), repr(float(accel)), repr(float(duration))]
    arguments += [repr(None if start is None else list(map(float, start))), repr(list(map(float, q0)))]
    done = subprocess.run(
        [sys.executable, "-c", _OWN_PROCESS_RUN, robot_name, *arguments], capture_output=True, text=True, check=True
    )
    return [float(rate) for rate in done.stdout.split()[-3:]]


def _terms_comparison(robot, count=256, repeats=30):
    """µs per movement to get H, b, J, J̇q̇ and the tip: simulate's per-movement calls vs one forest pass per copies."""
    rng = np.random.default_rng(0)
    q = np.array([robot.configuration(rng.uniform(-1, 1, robot.nv)) for _ in range(count)])
    v = rng.normal(size=(count, robot.nv))
    n = robot.nv
    terms = robot.terms_function()
    inertia, bias = np.empty((count, n, n)), np.empty((count, n))
    jacobian, drift = np.empty((count, robot.m, n)), np.empty((count, robot.m))

    def per_movement():
        for row in range(count):
            step = terms(q[row], v[row])
            inertia[row], bias[row] = step.inertia, step.bias_torque
            jacobian[row], drift[row] = step.jacobian, step.drift

    forest = RobotForest(robot)
    timings = {"per movement": [], "forest": []}
    for _ in range(repeats):
        for name, function in (("per movement", per_movement), ("forest", lambda: forest.terms(q, v))):
            started = time.perf_counter()
            function()
            timings[name].append((time.perf_counter() - started) / count * 1e6)
    return {name: statistics.median(values) for name, values in timings.items()}


_COUNT_RUN = """
import gc, json, os, sys
os.environ["OMP_NUM_THREADS"] = os.environ["OPENBLAS_NUM_THREADS"] = "1"
import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population
from torqueopt.batch import simulate_batch
robot_name, mode, steps, count, name = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
robot = torqueopt.load_robot(robot_name, task=None if robot_name == "planar3" else "position")
resolver = torqueopt.get_resolver(name, **json.loads(sys.argv[6]))
movements = draw_population(robot, PopulationSpec(paths=count, durations=(2.0,), seed=1))
lines = [torqueopt.StraightLine(m.direction, duration=steps * 1e-3, start=m.start) for m in movements]
# What the imports and the set-up made is frozen: a full collection that happens to land in one of the two runs
# would otherwise scan all of it, some 16 million instructions that the difference of the runs then counts.
gc.collect()
gc.freeze()
if mode == "batch":
    simulate_batch(robot, resolver, lines, [m.q0 for m in movements], extras=True)
else:
    torqueopt.simulate(robot, resolver, lines[0], movements[0].q0)
"""


def count_instructions(
    robot: str = "planar3",
    steps: tuple[int, int] = (150, 50),
    cases=("batch", "simulate"),
    resolver: str = "null-space",
    options: dict | None = None,
    movements: int = 256,
) -> dict:
    """Instructions per trajectory-step of the batch (256 movements) and of one simulate run, by callgrind.

    ``steps`` are the (long, short) run lengths whose difference is counted; ``cases`` which of the two to count;
    ``resolver`` the resolver of both, ``options`` its options as on ``torqueopt run``'s command line (text values);
    ``movements`` the batch's size (a smaller batch shows the fixed cost of each call).

    Each figure is (total, Pinocchio's own): the second sums the instructions
    spent inside Pinocchio's library (its functions' self cost, by
    ``callgrind_annotate``), the floor no Python or numpy change can go under.
    """
    import re
    import subprocess
    import sys
    import tempfile
    from concurrent.futures import ThreadPoolExecutor

    def total(mode, steps, count):
        with tempfile.TemporaryDirectory() as folder:
            script = Path(folder) / "run.py"
            script.write_text(_COUNT_RUN)
            done = subprocess.run(
                ["valgrind", "--tool=callgrind", f"--callgrind-out-file={folder}/out", sys.executable, str(script),
                 robot, mode, str(steps), str(count), resolver, json.dumps(options or {})],
                capture_output=True, text=True, check=True,
                env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"},
            )  # fmt: skip
            annotated = subprocess.run(
                ["callgrind_annotate", "--inclusive=no", "--threshold=100", f"{folder}/out"],
                capture_output=True,
                text=True,
                check=True,
            ).stdout
        pinocchio = 0
        for line in annotated.splitlines():
            # "count (share) file:function [object]": the object is Pinocchio's library or its bindings
            match = re.match(r"\s*([\d,]+)\s.*\[([^\]]*)\]\s*$", line)
            if match and "pinocchio" in match.group(2):
                pinocchio += int(match.group(1).replace(",", ""))
        return int(re.search(r"Collected : (\d+)", done.stderr).group(1)), pinocchio

    long, short = steps
    runs = [(mode, length, movements if mode == "batch" else 1) for mode in cases for length in (long, short)]
    with ThreadPoolExecutor(max_workers=2) as pool:
        totals = list(pool.map(lambda case: total(*case), runs))
    names = {"batch": f"batch of {movements}", "simulate": "simulate"}
    return {
        names[mode]: [(a - b) / ((long - short) * count) for a, b in zip(totals[2 * i], totals[2 * i + 1])]
        for i, (mode, _, count) in enumerate(runs[::2])
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--write", metavar="FILE")
    parser.add_argument("--panda-sweep", action="store_true", help="also time the sweeps on panda")
    parser.add_argument("--count", action="store_true", help="count instructions with callgrind instead of timing")
    parser.add_argument("--robot", default="planar3", choices=["planar3", "panda"], help="robot of --count")
    parser.add_argument(
        "--steps", type=int, nargs=2, default=(150, 50), metavar=("LONG", "SHORT"), help="run lengths of --count"
    )
    parser.add_argument("--resolver", default="null-space", help="resolver of --count (default null-space)")
    parser.add_argument(
        "--option", action="append", default=[], metavar="NAME=VALUE",
        help="an option of --resolver as on torqueopt run's command line, repeatable",
    )  # fmt: skip
    parser.add_argument(
        "--cases", choices=["batch", "simulate", "both"], default="both", help="what --count counts (default both)"
    )
    parser.add_argument("--movements", type=int, default=256, help="the batch's size in --count (default 256)")
    args = parser.parse_args(argv)
    if args.count:
        cases = ("batch", "simulate") if args.cases == "both" else (args.cases,)
        options = {}
        for text in args.option:
            name, equals, value = text.partition("=")
            if not equals or not name.strip():
                parser.error(f"--option {text!r} must be NAME=VALUE")
            options[name.strip()] = value.strip()
        if args.movements < 1:
            parser.error(f"--movements {args.movements} must be at least 1")
        counts = count_instructions(args.robot, tuple(args.steps), cases, args.resolver, options, args.movements)
        print(
            f"instructions per trajectory-step ({args.robot}, {args.resolver}{''.join(f' {o}' for o in args.option)}, the batch with the energy extras, "
            f"{args.steps[0]} against {args.steps[1]} steps):"
        )
        for name, (value, pinocchio) in counts.items():
            ratio = f" ({counts['simulate'][0] / value:.2f}x fewer than simulate)" if "simulate" in counts else ""
            print(f"  {name}: {value:,.0f}{ratio}, of which inside Pinocchio {pinocchio:,.0f}")
        return

    import distributed

    planar3 = torqueopt.load_robot("planar3")
    movements = draw_population(planar3, PopulationSpec(paths=512, durations=(2.0,), seed=1))
    lines = [torqueopt.StraightLine(m.direction, duration=2.0, start=m.start) for m in movements[:256]]
    q0s = [m.q0 for m in movements[:256]]
    jobs = _jobs("planar3", movements, ["pinv", "null-space"], 256)  # the atlas's default chunk size
    paper_line = torqueopt.StraightLine([1, 1], duration=2.0)

    clusters = {}
    for workers in (1, 2):
        cluster = distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0"
        )
        client = distributed.Client(cluster)
        client.gather(
            [client.submit(run_chunk, job, pure=False) for job in _jobs("planar3", movements[:8], ["pinv"], 4)]
        )
        clusters[workers] = (cluster, client)

    results = {"simulate": [], "simulate (own process)": [], "batch": [], "sweep 1 worker": [], "sweep 2 workers": []}
    loads = []
    ticks_before = _cpu_ticks()
    torqueopt.simulate(planar3, "null-space", paper_line, PAPER_Q0)  # warm-up
    for _ in range(args.rounds):
        loads.append(os.getloadavg()[0])
        started = time.perf_counter()
        run = torqueopt.simulate(planar3, "null-space", paper_line, PAPER_Q0)
        results["simulate"].append((len(run.t) - 1) / (time.perf_counter() - started))
        results["simulate (own process)"].extend(
            _simulate_in_own_process("planar3", [1.0, 1.0], PAPER_ACCEL, 2.0, PAPER_Q0)
        )
        started = time.perf_counter()
        runs, _ = simulate_batch(planar3, "null-space", lines, q0s, extras=True)
        results["batch"].append(sum(len(r.t) - 1 for r in runs) / (time.perf_counter() - started))
        for workers in (1, 2):
            results[f"sweep {workers} worker{'s' if workers > 1 else ''}"].append(
                _sweep(clusters[workers][1], jobs, distributed)
            )
    ticks_after = _cpu_ticks()
    panda_sweeps = {"simulate": [], "simulate (own process)": [], "sweep 1 worker": [], "sweep 2 workers": []}
    panda_loads = []
    if args.panda_sweep:
        from torqueopt.atlas.population import arm_reach, default_accel

        sweep_panda = torqueopt.load_robot("panda")
        accel = default_accel(arm_reach(sweep_panda)[1])
        spec = PopulationSpec(paths=512, durations=(0.5,), seed=1, accel=accel)
        panda_movements = draw_population(sweep_panda, spec)
        panda_jobs = _jobs("panda", panda_movements, ["pinv", "null-space"], 256, accel)
        first = panda_movements[0]
        first_line = torqueopt.StraightLine(first.direction, accel=accel, duration=0.5, start=first.start)
        for _, client in clusters.values():
            client.gather(
                [
                    client.submit(run_chunk, job, pure=False)
                    for job in _jobs("panda", panda_movements[:8], ["pinv"], 4, accel)
                ]
            )
        torqueopt.simulate(sweep_panda, "null-space", first_line, first.q0)  # warm-up
        for _ in range(args.rounds):
            panda_loads.append(os.getloadavg()[0])
            started = time.perf_counter()
            run = torqueopt.simulate(sweep_panda, "null-space", first_line, first.q0)
            panda_sweeps["simulate"].append((len(run.t) - 1) / (time.perf_counter() - started))
            panda_sweeps["simulate (own process)"].extend(
                _simulate_in_own_process("panda", first.direction, accel, 0.5, first.q0, first.start)
            )
            for workers in (1, 2):
                panda_sweeps[f"sweep {workers} worker{'s' if workers > 1 else ''}"].append(
                    _sweep(clusters[workers][1], panda_jobs, distributed)
                )
    for cluster, client in clusters.values():
        client.close()
        cluster.close()

    steal = "n/a"
    if ticks_before and ticks_after and ticks_after[1] > ticks_before[1]:
        steal = f"{100 * (ticks_after[0] - ticks_before[0]) / (ticks_after[1] - ticks_before[1]):.1f} %"
    terms = {name: _terms_comparison(torqueopt.load_robot(name)) for name in ("planar3", "panda")}

    panda = torqueopt.load_robot("panda")
    rng = np.random.default_rng(2)
    panda_q0s = [panda.default_configuration + rng.normal(scale=0.2, size=panda.nv) for _ in range(128)]
    panda_lines = [torqueopt.StraightLine(rng.normal(size=3), accel=0.5, duration=0.5) for _ in panda_q0s]
    panda_rates = {"simulate": [], "batch": []}
    for _ in range(args.rounds):
        started = time.perf_counter()
        run = torqueopt.simulate(panda, "null-space", panda_lines[0], panda_q0s[0])
        panda_rates["simulate"].append((len(run.t) - 1) / (time.perf_counter() - started))
        started = time.perf_counter()
        runs, _ = simulate_batch(panda, "null-space", panda_lines, panda_q0s, extras=True)
        panda_rates["batch"].append(sum(len(r.t) - 1 for r in runs) / (time.perf_counter() - started))

    def cell(values):
        return f"{statistics.median(values):,.0f} (range {min(values):,.0f}-{max(values):,.0f})"

    simulate_median = statistics.median(results["simulate"])
    lines_out = [
        BEGIN,
        (
            f"`python benchmarks/bench_atlas.py --rounds {args.rounds}` on {platform.node()} ({os.cpu_count()} cores), "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; 1-minute load average at the rounds' starts "
            f"{', '.join(f'{x:.1f}' for x in loads)}; CPU time stolen by the hypervisor during the rounds {steal}."
        ),
        "",
        "| planar3, null-space, 2 s movements | trajectory-steps/s, median of rounds | vs one simulate run |",
        "|---|---|---|",
    ]
    own_median = statistics.median(results["simulate (own process)"])
    lines_out[-2:] = [
        "| planar3, null-space, 2 s movements | trajectory-steps/s, median of rounds | vs one simulate run "
        "| vs one simulate run in its own process |",
        "|---|---|---|---|",
    ]
    for name, values in results.items():
        lines_out.append(
            f"| {name} | {cell(values)} | {statistics.median(values) / simulate_median:.2f}x "
            f"| {statistics.median(values) / own_median:.2f}x |"
        )
    one, two = statistics.median(results["sweep 1 worker"]), statistics.median(results["sweep 2 workers"])
    lines_out += [
        "",
        f"Scaling from 1 to 2 workers: {two / one:.2f}x.",
        "",
        "| robot | H, b, J, J̇q̇, tip per movement: simulate's calls, one movement at a time | the batch's forest |",
        "|---|---|---|",
    ]
    for name, timing in terms.items():
        lines_out.append(f"| {name} | {timing['per movement']:.2f} µs | {timing['forest']:.2f} µs |")
    lines_out += [
        "",
        "| panda (n = 7, position task), null-space, 0.5 s | trajectory-steps/s |",
        "|---|---|",
        f"| simulate | {cell(panda_rates['simulate'])} |",
        f"| batch (128 movements) | {cell(panda_rates['batch'])} |",
    ]
    if args.panda_sweep:
        panda_median = statistics.median(panda_sweeps["simulate"])
        lines_out += [
            "",
            "1-minute load average at the panda rounds' starts " + ", ".join(f"{x:.1f}" for x in panda_loads) + ".",
            "",
            "| panda, pinv and null-space, 0.5 s movements | trajectory-steps/s, median of rounds | vs one simulate run "
            "| vs one simulate run in its own process |",
            "|---|---|---|---|",
        ]
        panda_own = statistics.median(panda_sweeps["simulate (own process)"])
        for name, values in panda_sweeps.items():
            lines_out.append(
                f"| {name} | {cell(values)} | {statistics.median(values) / panda_median:.2f}x "
                f"| {statistics.median(values) / panda_own:.2f}x |"
            )
    lines_out.append(END)
    text = "\n".join(lines_out)
    print(text)
    if args.write:
        path = Path(args.write)
        content = path.read_text() if path.exists() else ""
        if BEGIN in content and END in content:
            content = content[: content.index(BEGIN)] + text + content[content.index(END) + len(END) :]
        else:
            content = content.rstrip() + "\n\n## The atlas: batched path and sweeps\n\n" + text + "\n"
        path.write_text(content)


if __name__ == "__main__":
    main()
