"""Re-run a seeded sample of a committed atlas with pinv and the bounded resolvers at their defaults, and compare two
such samples (the joint limits' deceleration, before and after).

    python benchmarks/bounded_atlas_sample.py run docs/atlas/tiago 1000 /tmp/after-tiago.parquet
    python benchmarks/bounded_atlas_sample.py compare /tmp/before-tiago.parquet /tmp/after-tiago.parquet
    python benchmarks/bounded_atlas_sample.py planar3 300

``run`` draws the atlas's population from its recorded settings (atlas.json), picks PATHS of its movements (seed 0;
all of them when PATHS is the population's size) and runs pinv, bounded-torque, minmax-torque and
energy-bounded-torque on them as the atlas's sweep does (``run_chunk``, batched), with the torqueopt on PYTHONPATH:
run it once on the code before a change (a ``git archive`` of it) and once after. ``compare`` prints, per resolver,
the verdicts, the runs outside a position or velocity limit and those newly so, the runs with an infeasible step
(the task given up), and the median and largest peak torque ratio, on the paths both samples hold. ``planar3``
counts, per bounded resolver, the random planar3 states (seed 0: q uniform in [−π, π]³ rad, q̇ in [−1.5, 1.5]³ rad/s,
ẍ = √2 m/s² in a random direction) at which the step with joint_limits=on gives up task acceleration and the step
with joint_limits=off does not: states far from planar3's ±2π limits, where the joint limits should cost nothing.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

RESOLVERS = ["pinv", "bounded-torque", "minmax-torque", "energy-bounded-torque"]


def run(folder: Path, paths: int, out: Path) -> None:
    from house_numbers import population_of

    import torqueopt
    from torqueopt.atlas.jobs import ResolverChunk
    from torqueopt.atlas.sweep import run_chunk
    from torqueopt.atlas.verdicts import Thresholds
    from torqueopt.resolvers import get_resolver

    config = json.loads((folder / "atlas.json").read_text())["config"]
    spec, movements = population_of(config)
    chosen = np.sort(np.random.default_rng(0).choice(len(movements), min(paths, len(movements)), replace=False))
    start = time.process_time()
    rows = []
    for duration in sorted({movements[i].duration for i in chosen}):
        members = tuple(movements[i] for i in chosen if movements[i].duration == duration)
        job = ResolverChunk(
            spec, tuple(get_resolver(name) for name in RESOLVERS), members, float(config["dt"]),
            Thresholds(**config["thresholds"]), bool(config.get("batch", True)), "",
        )  # fmt: skip
        rows += run_chunk(job)
    pd.DataFrame(rows).to_parquet(out, index=False)
    print(f"{torqueopt.__file__}: {folder.name}, {len(rows)} rows, {time.process_time() - start:.0f} s CPU")


def outside(table: pd.DataFrame) -> pd.Series:
    return table.first_position_limit_violation.notna() | table.first_velocity_limit_violation.notna()


def compare(before_file: Path, after_file: Path) -> None:
    before, after = pd.read_parquet(before_file), pd.read_parquet(after_file)
    before = before[before.path.isin(after.path.unique())]
    after = after[after.path.isin(before.path.unique())]
    pinv = before[before.resolver == "pinv"]
    handled = set(pinv[(pinv.verdict == "stable") & (pinv.peak_torque_ratio <= 1.0)].path)
    print(
        "| resolver | paths | stable | lost path | outside a limit | newly outside (pinv handles it?) "
        "| with an infeasible step | median peak τ ratio | rows unchanged |"
    )
    print("|---|---:|---|---|---|---|---|---|---:|")
    for resolver in RESOLVERS[1:]:
        old = before[before.resolver == resolver].set_index("path").sort_index()
        new = after[after.resolver == resolver].set_index("path").sort_index()
        was, now = outside(old), outside(new)
        newly = sorted(set(now[now].index) - set(was[was].index))
        same = int(((old.max_tip_error == new.max_tip_error) & (old.peak_torque_ratio == new.peak_torque_ratio)).sum())
        marks = ", ".join(f"{path} ({'yes' if path in handled else 'no'})" for path in newly) or "none"
        print(
            f"| {resolver} | {len(new)} | {(old.verdict == 'stable').sum()} → {(new.verdict == 'stable').sum()} "
            f"| {(old.verdict == 'lost path').sum()} → {(new.verdict == 'lost path').sum()} "
            f"| {int(was.sum())} → {int(now.sum())} | {marks} "
            f"| {int((old.infeasible_steps > 0).sum())} → {int((new.infeasible_steps > 0).sum())} "
            f"| {old.peak_torque_ratio.median():.3f} → {new.peak_torque_ratio.median():.3f} | {same} |"
        )


def planar3(count: int) -> None:
    import torqueopt
    from torqueopt.resolvers import get_resolver

    robot = torqueopt.load_robot("planar3")
    rng = np.random.default_rng(0)
    states = [(rng.uniform(-np.pi, np.pi, 3), rng.uniform(-1.5, 1.5, 3), rng.normal(size=2)) for _ in range(count)]
    for name in RESOLVERS[1:]:
        on = get_resolver(name).solver(robot, 1e-3)
        off = get_resolver(name, joint_limits="off").solver(robot, 1e-3)
        given_up = []
        for index, (q, v, direction) in enumerate(states):
            terms = robot.terms(robot.configuration(q), v)
            command = np.sqrt(2.0) * direction / np.linalg.norm(direction)
            if on(terms, command).task_error > 1e-9 and off(terms, command).task_error <= 1e-9:
                given_up.append(index)
        print(f"{name}: {len(given_up)} of {count} states give up the task for the joint limits {given_up}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    commands = parser.add_subparsers(dest="command", required=True)
    run_parser = commands.add_parser("run", help="re-run a sample of a committed atlas")
    run_parser.add_argument("atlas", type=Path)
    run_parser.add_argument("paths", type=int)
    run_parser.add_argument("out", type=Path)
    compare_parser = commands.add_parser("compare", help="compare two samples")
    compare_parser.add_argument("before", type=Path)
    compare_parser.add_argument("after", type=Path)
    states_parser = commands.add_parser("planar3", help="count random planar3 states the joint limits give up")
    states_parser.add_argument("count", type=int)
    arguments = parser.parse_args(argv)
    if arguments.command == "run":
        run(arguments.atlas, arguments.paths, arguments.out)
    elif arguments.command == "compare":
        compare(arguments.before, arguments.after)
    else:
        planar3(arguments.count)


if __name__ == "__main__":
    main()
