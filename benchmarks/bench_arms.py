"""Throughput of the atlas's runs on the seven-joint arms: trajectory-steps/s per resolver, batch against simulate.

For each arm (panda, xarm7, tiago, baxter; position task) and each resolver
(every torque resolver, the bounded ones with joint limits on and off), two
cases timed interleaved in each round so the shared machine's load hits both
alike:

* ``simulate``: one :func:`torqueopt.simulate` run of the population's first
  movement;
* ``batch``: :func:`torqueopt.batch.simulate_batch` on ``--movements`` movements
  of the atlas's population (seed 1, the arm's default acceleration), with the
  energy extras the atlas uses: what one chunk of the atlas does per resolver.

A trajectory-step is one RK4 step of one movement with one resolver. The
rounds go arm by arm, resolver by resolver, simulate then batch; the median
of the rounds is reported, with the 1-minute load average at each round's
start (the machine is shared: the load is part of the figure).

Run (a pilot sizes the atlas sweeps; the BENCHMARKS.md table is ``--write``)::

    python benchmarks/bench_arms.py [--arms panda,xarm7] [--resolvers pinv,null-space] [--movements 50]
        [--duration 0.5] [--rounds 1] [--json out.json] [--write BENCHMARKS.md]

``--write`` replaces only the block between the ``bench_arms:begin`` and
``bench_arms:end`` markers.
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import json
import platform
import statistics
import time
from datetime import datetime, timezone
from pathlib import Path

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population
from torqueopt.atlas.population import arm_reach, movement_trajectory
from torqueopt.atlas.sweep import resolvers_from
from torqueopt.batch import simulate_batch
from torqueopt.resolvers import resolver_names

BEGIN, END = "<!-- bench_arms:begin -->", "<!-- bench_arms:end -->"
ARMS = ("panda", "xarm7", "tiago", "baxter")
BOUNDED = ("bounded-torque", "minmax-torque", "energy-bounded-torque")


def all_resolvers() -> list[str]:
    """Every torque resolver, each bounded one with joint limits on and off."""
    labels = []
    for name in resolver_names("torque"):
        labels.append(name)
        if name in BOUNDED:
            labels.append(f"{name}[joint_limits=off]")
    return labels


def _load() -> float:
    return os.getloadavg()[0]


def measure(arms, labels, movements, duration, rounds, dt=1e-3) -> dict:
    results = {"arms": {}, "loads": [], "movements": movements, "duration": duration, "dt": dt}
    prepared = {}
    for arm in arms:
        robot = torqueopt.load_robot(arm, task="position")
        spec = PopulationSpec(paths=movements, durations=(duration,), seed=1).sized(arm_reach(robot)[1])
        population = draw_population(robot, spec)
        lines = [movement_trajectory(m) for m in population]
        prepared[arm] = (robot, lines, [m.q0 for m in population], spec.accel)
    steps = round(duration / dt)  # the steps a run takes (its rows are one more: the final state)
    for _ in range(rounds):
        results["loads"].append(_load())
        for arm in arms:
            robot, lines, q0s, accel = prepared[arm]
            entry = results["arms"].setdefault(arm, {"accel": accel, "resolvers": {}})
            for resolver in resolvers_from(labels):
                times = entry["resolvers"].setdefault(
                    resolver.label, {"simulate": [], "batch": [], "simulate_cpu": [], "batch_cpu": []}
                )
                started, cpu = time.perf_counter(), time.process_time()
                torqueopt.simulate(robot, resolver, lines[0], q0s[0], dt=dt)
                times["simulate"].append(steps / (time.perf_counter() - started))
                times["simulate_cpu"].append(steps / (time.process_time() - cpu))
                started, cpu = time.perf_counter(), time.process_time()
                simulate_batch(robot, resolver, lines, q0s, dt, extras=True)
                times["batch"].append(steps * len(lines) / (time.perf_counter() - started))
                times["batch_cpu"].append(steps * len(lines) / (time.process_time() - cpu))
    return results


def table(results: dict) -> str:
    lines = []
    for arm, entry in results["arms"].items():
        lines += [
            "",
            f"| {arm} (a = {entry['accel']:.3g} m/s², {results['duration']:g} s lines) | simulate, steps/s | "
            f"batch of {results['movements']}, steps/s | batch vs simulate | per CPU second: simulate, batch |",
            "|---|---|---|---|---|",
        ]
        for label, times in entry["resolvers"].items():
            single, batch = statistics.median(times["simulate"]), statistics.median(times["batch"])
            single_cpu, batch_cpu = statistics.median(times["simulate_cpu"]), statistics.median(times["batch_cpu"])
            lines.append(
                f"| {label} | {single:,.0f} | {batch:,.0f} | {batch / single:.2f}x | {single_cpu:,.0f}, {batch_cpu:,.0f} |"
            )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--arms", default=",".join(ARMS))
    parser.add_argument("--resolvers", help="comma-separated labels (default: every torque resolver, bounded on/off)")
    parser.add_argument("--movements", type=int, default=50)
    parser.add_argument("--duration", type=float, default=0.5)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--json", help="also write the raw figures here")
    parser.add_argument("--write", help="replace the bench_arms block of this Markdown file")
    args = parser.parse_args(argv)
    from torqueopt.resolvers.options import split_resolver_list

    labels = split_resolver_list(args.resolvers) if args.resolvers else all_resolvers()
    started = time.perf_counter()
    results = measure(args.arms.split(","), labels, args.movements, args.duration, args.rounds)
    wall = time.perf_counter() - started
    loads = ", ".join(f"{load:.1f}" for load in results["loads"])
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    header = (
        f"`python benchmarks/bench_arms.py --movements {args.movements} --duration {args.duration:g} --rounds "
        f"{args.rounds}` on {platform.node()} ({os.cpu_count()} cores), {stamp}, {wall:.0f} s of wall time; "
        f"1-minute load average at the rounds' starts {loads}. Medians of the rounds."
    )
    text = header + "\n" + table(results)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    if args.write:
        path = Path(args.write)
        document = path.read_text() if path.exists() else ""  # a new file gets the block alone
        if BEGIN in document and END in document:
            before, rest = document.split(BEGIN, 1)
            after = rest.split(END, 1)[1]
            document = f"{before}{BEGIN}\n{text}\n{END}{after}"
        else:
            document = document.rstrip() + f"\n\n{BEGIN}\n{text}\n{END}\n"
        path.write_text(document)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
