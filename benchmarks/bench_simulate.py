"""Time :func:`torqueopt.simulate`: RK4 steps per second for every resolver.

Cases:

* ``planar3`` (task ``xy``): the paper's movement, q0 = (-45°, 135°, -135°),
  direction (1, 1), 2.0 s at dt = 1 ms (2000 RK4 steps);
* ``panda`` (tasks ``position`` and ``pose``): a 0.5 s straight line along
  world x from the SRDF default configuration, dt = 1 ms (500 RK4 steps).

Each case runs once to warm up, then ``--repeats`` rounds time every case
once each (interleaved, so the host's load changes hit all cases alike);
the figure is the median wall time of ``simulate`` (the robot is loaded once,
outside the timing), reported as RK4 steps per second. Each step includes
one resolver evaluation and three ABA calls (the first stage reuses the
resolver's acceleration).

The process runs on one thread (OpenBLAS / OpenMP thread counts set to 1
before numpy loads); ``--cpu N`` also pins it to one CPU, which on a shared
machine can put it next to a busy process, so it is off by default.

Run::

    python benchmarks/bench_simulate.py                    # print the table
    python benchmarks/bench_simulate.py --write BENCHMARKS.md
    python benchmarks/bench_simulate.py --openblas-env unset   # also time with OPENBLAS_CORETYPE/L2_SIZE unset

``--write`` replaces only the block between the ``bench:begin`` and
``bench:end`` markers of the file, so hand-written notes around it stay.
"""

from __future__ import annotations

import os

# One thread, set before numpy is imported; this process only.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse
import ctypes
import glob
import json
import math
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import torqueopt

PAPER_Q0 = (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4)
OPENBLAS_TUNING = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")
BEGIN, END = "<!-- bench:begin -->", "<!-- bench:end -->"


def cases(panda_tasks):
    """(label, robot, trajectory, q0, duration) for every benchmarked movement."""
    planar3 = torqueopt.load_robot("planar3")
    yield "planar3 xy 2.0 s", planar3, torqueopt.StraightLine((1.0, 1.0), duration=2.0), PAPER_Q0
    for task in panda_tasks:
        panda = torqueopt.load_robot("panda", task=task)
        yield (
            f"panda {task} 0.5 s",
            panda,
            torqueopt.StraightLine((1.0, 0.0, 0.0), duration=0.5),
            panda.default_configuration,
        )


def numpy_call_cost(calls: int = 20000) -> float:
    """Seconds per ``a + b`` on two 3-vectors: a yardstick of how fast the machine ran just then.

    The simulation's cost is mostly such calls, so when this figure rises
    (other load on the host) the steps per second fall in proportion.
    """
    a, b = np.ones(3), np.ones(3)
    start = time.perf_counter()
    for _ in range(calls):
        a + b
    return (time.perf_counter() - start) / calls


def timed_run(robot, resolver, trajectory, q0) -> tuple[float, float]:
    """Wall and CPU time [s] of one ``simulate`` call."""
    start, start_cpu = time.perf_counter(), time.process_time()
    torqueopt.simulate(robot, resolver, trajectory, q0)
    return time.perf_counter() - start, time.process_time() - start_cpu


def openblas_core() -> str:
    """The OpenBLAS kernel numpy's BLAS selected at load time (``unknown`` if not found)."""
    pattern = os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs", "libscipy_openblas*")
    for path in glob.glob(pattern):
        library = ctypes.CDLL(path)
        for symbol in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename"):
            function = getattr(library, symbol, None)
            if function is not None:
                function.restype = ctypes.c_char_p
                return function().decode()
    return "unknown"


def cpu_ticks() -> tuple[int, int] | None:
    """(steal, total) clock ticks of all CPUs from /proc/stat, or None where it is not readable.

    Steal is the time the hypervisor ran another guest while this VM had
    work: the part of a busy host that the VM can see.
    """
    try:
        fields = [int(value) for value in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return None
    # user nice system idle iowait irq softirq steal [guest guest_nice, already counted in user and nice]
    return (fields[7], sum(fields[:8])) if len(fields) >= 8 else None


def machine() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "logical_cpus": os.cpu_count(),
        "os": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pin": pin.__version__,
        "torqueopt": torqueopt.__version__,
        "openblas_core": openblas_core(),
        "load_average": " ".join(f"{value:.2f}" for value in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a",
        **{name: os.environ.get(name, "(unset)") for name in OPENBLAS_TUNING},
    }


def run(repeats: int, panda_tasks) -> dict:
    """Time every (case, resolver) ``repeats`` times, interleaved.

    Each round times every pair once, so a minute when the host is busy
    slows every resolver alike instead of whichever case ran then.
    """
    info = machine()
    jobs = []
    for label, robot, trajectory, q0 in cases(panda_tasks):
        for resolver in torqueopt.resolver_names():
            result = torqueopt.simulate(robot, resolver, trajectory, q0)  # warm-up, and the step count
            if not result.completed:
                raise RuntimeError(f"{robot.name} / {resolver} stopped early: {result.stop_reason}")
            jobs.append(
                {
                    "case": label,
                    "resolver": resolver,
                    "steps": result.t.size - 1,
                    "arguments": (robot, resolver, trajectory, q0),
                    "wall": [],
                    "cpu": [],
                }
            )
    yardstick = []
    ticks_before = cpu_ticks()
    for _ in range(repeats):
        yardstick.append(numpy_call_cost())
        for job in jobs:
            wall, cpu = timed_run(*job["arguments"])
            job["wall"].append(wall)
            job["cpu"].append(cpu)
    rows = []
    for job in jobs:
        median = statistics.median(job["wall"])
        rows.append(
            {
                "case": job["case"],
                "resolver": job["resolver"],
                "steps": job["steps"],
                "median_s": median,
                "steps_per_s": job["steps"] / median,
                "cpu_steps_per_s": job["steps"] / statistics.median(job["cpu"]),
                "best_steps_per_s": job["steps"] / min(job["wall"]),
            }
        )
    ticks_after = cpu_ticks()
    if ticks_before and ticks_after and ticks_after[1] > ticks_before[1]:
        info["steal_percent"] = f"{100 * (ticks_after[0] - ticks_before[0]) / (ticks_after[1] - ticks_before[1]):.1f} %"
    else:
        info["steal_percent"] = "n/a"
    info["numpy_add_us_median"] = 1e6 * statistics.median(yardstick)
    info["numpy_add_us_best"] = 1e6 * min(yardstick)
    return {"machine": info, "repeats": repeats, "rows": rows}


def markdown(report: dict, title: str) -> str:
    info = report["machine"]
    lines = [
        f"### {title}",
        "",
        f"- machine: {info['cpu']}, {info['logical_cpus']} logical CPUs, {info['os']}",
        f"- python {info['python']}, numpy {info['numpy']}, pin {info['pin']}, torqueopt {info['torqueopt']}",
        (
            f"- OpenBLAS kernel {info['openblas_core']}; OPENBLAS_CORETYPE={info['OPENBLAS_CORETYPE']}, "
            f"OPENBLAS_L2_SIZE={info['OPENBLAS_L2_SIZE']}; one thread"
        ),
        (
            f"- median of {report['repeats']} timed runs after one warm-up run, in {report['repeats']} interleaved "
            f"rounds; load average before the runs {info['load_average']}; one 3-vector numpy addition took "
            f"{info['numpy_add_us_median']:.2f} µs (median over the rounds; best {info['numpy_add_us_best']:.2f} µs); "
            f"CPU time stolen by the hypervisor during the rounds {info['steal_percent']}"
        ),
        "",
        (
            "| case | resolver | RK4 steps | median wall time [ms] | steps/s (median wall) | steps/s (median CPU) "
            "| steps/s (best wall) |"
        ),
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for row in report["rows"]:
        lines.append(
            f"| {row['case']} | {row['resolver']} | {row['steps']} | {1e3 * row['median_s']:.1f} | "
            f"{row['steps_per_s']:,.0f} | {row['cpu_steps_per_s']:,.0f} | {row['best_steps_per_s']:,.0f} |"
        )
    return "\n".join(lines) + "\n"


def write_block(path: Path, text: str) -> None:
    """Replace the text between the markers in ``path`` (appending the markers if missing)."""
    block = f"{BEGIN}\n{text}{END}"
    old = path.read_text() if path.exists() else "# Benchmarks\n"
    if BEGIN in old and END in old:
        head, rest = old.split(BEGIN, 1)
        new = head + block + rest.split(END, 1)[1]
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    path.write_text(new)


def pin_to_cpu(cpu: int) -> None:
    if not hasattr(os, "sched_setaffinity"):
        raise SystemExit("--cpu needs os.sched_setaffinity (Linux)")
    os.sched_setaffinity(0, {cpu})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument(
        "--repeats", type=int, default=7, help="timed runs per case (default 7); the median is reported"
    )
    parser.add_argument(
        "--panda-task",
        action="append",
        choices=("position", "pose"),
        help="panda task(s) to time (default: position and pose)",
    )
    parser.add_argument(
        "--openblas-env",
        choices=("as-is", "unset", "both"),
        default="as-is",
        help="time with OPENBLAS_CORETYPE/OPENBLAS_L2_SIZE as they are, unset (in a child process only), or both",
    )
    parser.add_argument("--cpu", type=int, help="pin the process to this CPU (default: let the OS place it)")
    parser.add_argument("--write", type=Path, help="write the tables into this Markdown file between the markers")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    panda_tasks = args.panda_task or ["position", "pose"]
    if args.cpu is not None:
        pin_to_cpu(args.cpu)

    reports = []
    if args.openblas_env in ("as-is", "both"):
        reports.append(("OpenBLAS environment as set", run(args.repeats, panda_tasks)))
    if args.openblas_env in ("unset", "both"):
        if any(name in os.environ for name in OPENBLAS_TUNING) or args.openblas_env == "unset":
            env = {k: v for k, v in os.environ.items() if k not in OPENBLAS_TUNING}
            command = [sys.executable, __file__, "--json", "--repeats", str(args.repeats)]
            if args.cpu is not None:
                command += ["--cpu", str(args.cpu)]
            for task in panda_tasks:
                command += ["--panda-task", task]
            output = subprocess.run(command, env=env, check=True, capture_output=True, text=True).stdout
            reports.append(("OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset", json.loads(output)))
        else:
            print("OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE are not set: the 'unset' run would repeat the first.\n")
    if args.json:
        print(json.dumps(reports[0][1]))
        return 0

    text = "\n".join(markdown(report, title) for title, report in reports)
    print(text)
    if args.write:
        write_block(args.write, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
