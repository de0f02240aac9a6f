"""The atlas as a user runs it, with its default outputs and without figures, against one ``simulate`` run.

Each round runs, one after another so that the machine's load hits all alike:

* ``simulate``: one :func:`torqueopt.simulate` run of ``pinv`` on the population's first movement (a 2 s line of
  the atlas's own population), timed three times in a fresh interpreter (its imports and a warm-up run untimed);
* ``atlas``: ``torqueopt atlas --robot R --paths N --durations 2 --resolvers pinv --workers 2 --seed 1
  --no-progress`` into a fresh folder, wall time of the whole command (its imports, the cluster's start, the
  sweep, the report, the figures and explorer.html);
* ``atlas --no-figures``: the same without the figures and the explorer;
* with ``--before DIR``, the atlas with figures again from the torqueopt source tree at ``DIR`` (a checkout of
  another commit, put first on PYTHONPATH), for a before/after in the same minutes;

then ``simulate`` again. Trajectory-steps (RK4 steps of one movement) are counted from the atlas's rows; an
atlas's rate over the median of the round's ``simulate`` timings is its ratio, the issue's measure. The load
average is printed with each round: on a shared machine, read the ratios, not the rates.

``--trace-cost ATLAS`` instead measures (ATLAS: random lines, as the command above writes them), in this process and in CPU seconds (which a loaded machine moves
less than wall time), what the report of the atlas folder ``ATLAS`` (written with figures) spends on the
explorer's traces: read from its chunks, against simulating the chosen paths again as the report did before
the chunks kept them; and checks that the two give the same numbers.

Run::

    python benchmarks/bench_atlas_outputs.py [--robot planar3] [--paths 1000] [--rounds 2] [--before DIR]
    python benchmarks/bench_atlas_outputs.py --trace-cost ATLAS
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The longest an atlas command may take [s] before the benchmark gives up on it (a cluster whose workers died).
TIMEOUT = 1800

_SIMULATE = """
import os, sys, time
os.environ["OMP_NUM_THREADS"] = os.environ["OPENBLAS_NUM_THREADS"] = "1"
import torqueopt
from torqueopt.atlas import AtlasSettings, _load_and_draw
from torqueopt.atlas.population import movement_trajectory
settings = AtlasSettings.from_keywords(robot=sys.argv[1], paths=1, durations=(2.0,), seed=1, resolvers=("pinv",),
                                       out=sys.argv[2], progress=False)
robot, _, movements = _load_and_draw(settings)
line, q0 = movement_trajectory(movements[0]), movements[0].q0
torqueopt.simulate(robot, "pinv", line, q0)  # warm-up
for _ in range(3):
    started = time.perf_counter()
    run = torqueopt.simulate(robot, "pinv", line, q0)
    print((len(run.t) - 1) / (time.perf_counter() - started))
"""


def environment(source: Path | None) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    if source is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(source), *filter(None, [env.get("PYTHONPATH")])])
    return env


def simulate_rates(robot: str, scratch: Path) -> list[float]:
    """Trajectory-steps/s of three ``simulate`` runs in a fresh interpreter."""
    done = subprocess.run(
        [sys.executable, "-c", _SIMULATE, robot, str(scratch / "unused")],
        capture_output=True, text=True, check=True, env=environment(None),
    )  # fmt: skip
    return [float(rate) for rate in done.stdout.split()[-3:]]


def atlas_rate(robot: str, paths: int, out: Path, figures: bool, source: Path | None) -> tuple[float, float, float]:
    """(trajectory-steps/s, wall [s], CPU of the command's own process [s]) of one ``torqueopt atlas`` command into
    a fresh ``out``. The CPU counts the main process (imports, population, report, figures, page), not the
    workers (the fork server's children, which it does not wait for): on a loaded machine it moves less than
    the wall time."""
    import pandas

    shutil.rmtree(out, ignore_errors=True)
    command = [
        sys.executable, "-m", "torqueopt", "atlas", "--robot", robot, "--paths", str(paths), "--durations", "2",
        "--resolvers", "pinv", "--workers", "2", "--seed", "1", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    if not figures:
        command.append("--no-figures")
    started = time.perf_counter()
    # stderr passes through: a stuck or failed command says why where the benchmark's output goes.
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, env=environment(source))
    while True:  # reaped by wait4, which also gives the process's resource usage
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() - started > TIMEOUT:
            process.kill()
        time.sleep(0.02)
    wall = time.perf_counter() - started
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({process.returncode})")
    steps = int((pandas.read_parquet(out / "results.parquet", columns=["steps"])["steps"] - 1).sum())
    shutil.rmtree(out, ignore_errors=True)
    return steps / wall, wall, usage.ru_utime + usage.ru_stime


def trace_cost(folder: Path, repeats: int = 2) -> None:
    """CPU seconds of the explorer's traces of the atlas in ``folder``: from its chunks, and simulated again."""
    import functools
    import json

    import numpy as np
    import pandas

    from torqueopt.atlas import AtlasSettings, _chunks, _load_and_draw, _stored_traces, explorer
    from torqueopt.atlas.sweep import config_digest

    config = json.loads((folder / "atlas-config.json").read_text())
    population = config["population"]  # an atlas of random lines, as this benchmark's command writes
    settings = AtlasSettings.from_keywords(
        robot=config["robot"]["source"], paths=population["paths"], durations=tuple(population["durations"]),
        seed=population["seed"], resolvers=tuple(r.get("label", r["name"]) for r in config["resolvers"]),
        dt=config["dt"], chunk_size=config["chunk_size"], batch=config["batch"], out=folder, progress=False,
    )  # fmt: skip
    robot, _, movements = _load_and_draw(settings)
    table = pandas.read_parquet(folder / "results.parquet")
    stored = functools.partial(_stored_traces, folder, _chunks(movements, config["chunk_size"]), config_digest(config))
    common = {"dt": config["dt"], "batch": config["batch"], "keep": explorer.DEFAULT_KEEP_TRACES}
    resolvers = list(settings.resolvers)
    for _ in range(repeats):
        started = time.process_time()
        kept = explorer.page_traces(robot, table, movements, resolvers, stored, **common)
        from_chunks = time.process_time() - started
        started = time.process_time()
        again = explorer.keep_traces(robot, table, movements, resolvers, **common)
        simulated = time.process_time() - started
        same = kept.keys() == again.keys() and all(
            np.array_equal(kept[p][r][key], again[p][r][key])
            for p in kept for r in kept[p] for key in ("t", "tau", "arm", "start_arm")
        )  # fmt: skip
        print(
            f"{config['robot_name']}: {len(kept)} kept paths' traces from the chunks {from_chunks:.3f} s CPU, "
            f"simulated again {simulated:.2f} s CPU; the same numbers: {same}"
        )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--robot", default="planar3")
    parser.add_argument("--paths", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--before", type=Path, help="a torqueopt source tree to time the atlas with figures of too")
    parser.add_argument("--trace-cost", type=Path, metavar="ATLAS", help="the explorer traces' CPU of an atlas folder")
    args = parser.parse_args(argv)
    if args.trace_cost is not None:
        trace_cost(args.trace_cost)
        return
    cases = [("atlas", True, None), ("atlas --no-figures", False, None)]
    if args.before is not None:
        cases.append((f"atlas of {args.before}", True, args.before.resolve()))
    print(f"{args.robot}, {args.paths} random 2 s pinv paths, 2 workers, {os.cpu_count()} cores")
    print("| round | load (1 min) | simulate, median of 6 | " + " | ".join(name for name, _, _ in cases) + " |")
    print("|---|---:|---:|" + "---:|" * len(cases))
    ratios: dict[str, list[float]] = {name: [] for name, _, _ in cases}
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for round_ in range(args.rounds):
            load = os.getloadavg()[0]
            simulate = simulate_rates(args.robot, scratch)
            atlases = {}
            for name, figures, source in cases:
                atlases[name] = atlas_rate(args.robot, args.paths, scratch / "atlas", figures, source)
            simulate += simulate_rates(args.robot, scratch)
            reference = statistics.median(simulate)
            cells = []
            for name, (rate, wall, cpu) in atlases.items():
                ratios[name].append(rate / reference)
                cells.append(f"{rate:,.0f}/s, {wall:.1f} s (main CPU {cpu:.1f} s), **{rate / reference:.2f}x**")
            load = f"{load:.1f}-{os.getloadavg()[0]:.1f}"
            print(f"| {round_ + 1} | {load} | {reference:,.0f}/s | " + " | ".join(cells) + " |", flush=True)
    print("median ratios: " + ", ".join(f"{name} {statistics.median(r):.2f}x" for name, r in ratios.items()))


if __name__ == "__main__":
    main()
