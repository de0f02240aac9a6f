"""The numbers the house redesign (issue 37) must keep: record them once, compare every later commit with them.

Three commands, run with the code to measure importable (``export PYTHONPATH=`` its worktree)::

    python benchmarks/house_numbers.py record DIR            # on the code to keep: writes the baseline into DIR
    python benchmarks/house_numbers.py compare DIR [PART...] # on the changed code: runs the same again, compares
    python benchmarks/house_numbers.py committed [ATLAS...]  # the committed atlases (docs/atlas) against this code

``record DIR`` writes, and ``compare DIR`` runs again and compares:

``paper/summary.json``
    ``torqueopt paper --out``'s summary (the paper's scenario, claims and remedies study): every number within
    1e-12 relative, every string, boolean and key identical.
``atlases/NAME/results.parquet``
    seeded atlases (``torqueopt.atlas.run_atlas``, no figures, no Dask) of every registered resolver that accepts
    the robot, with a few option settings whose code paths differ: planar3 batched and not batched (both loops),
    planar3 circles, and panda. Rows are matched by (path, resolver): every numeric column within 1e-9 relative,
    every other column (verdict, stop reason, path kind, options) identical.
``velocity_runs.npz``
    ``benchmarks/velocity_runs_unchanged.py --save``: q, v and tau of each velocity-level run, compared by that
    script's ``--compare`` (1e-12 of each array's largest value; its own tolerance for differenced torques).

Two numbers apart by at most :data:`ROUND_OFF` (1e-12 in their own unit) count as equal: quantities that are
zero in exact arithmetic (the tip error of a velocity-level run, the self-motion energy of kinetic-energy-pinv)
are round-off, which any reordering of a sum moves by its own size. ``compare --strict`` counts every difference.
``compare DIR paper planar3-batch`` runs only the parts whose name holds one of the words (paper, atlas,
planar3-batch, planar3-no-batch, planar3-circle, panda, velocity).

``DIR/manifest.json`` holds the commit, the settings of every atlas (``compare`` runs those, whatever this file's
defaults have become) and the wall and CPU seconds each part took. ``compare`` prints, per atlas and resolver, the
largest relative difference and its column, and exits with status 1 when anything differs beyond the tolerances.

``committed`` re-runs a seeded sample of ``--paths-per-atlas`` (100) paths of every committed atlas in docs/atlas
(each folder with a results.parquet; its settings from atlas-config.json, or from the ``config`` of its
atlas.json or of the summary beside the folder) and compares them row by row with the committed rows by the same
rule. A population is drawn path by path from a stream that depends only on the seed, the duration and the path
kind (``torqueopt.atlas.population``): path k is the same whatever the population's size. So the whole population
is drawn (cheap), the sample's movements are picked out with their own path numbers and run through the sweep's
own ``run_chunk``, one chunk per duration, in this process; no hook in the atlas is needed. The sample's batches
hold other movements than the atlas's chunks did: a batched torque resolver's row does not depend on them (bit for
bit on planar3 with the margin), but the bounded family's does (minmax-torque on panda: which joint peaks, the whip
descriptors of runs stopped at joint limits), so those rows reproduce only in the atlas's own chunks. The global
optimum's rows and their columns (``optimizer_*``, ``cost_vs_global``, ``peak_vs_global``, ...) are left out unless
``--global`` is given (the optimiser stops on a wall-clock budget).

The numbers a baseline holds are regression pins: what the project computed itself at one commit, not an
independent check. A copy recorded at 300bb77 is committed in ``benchmarks/house_numbers/baseline-300bb77``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

import torqueopt
from torqueopt.atlas import run_atlas
from torqueopt.errors import TorqueoptError
from torqueopt.resolvers import get_resolver, resolver_names

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
SUMMARY_TOLERANCE = 1e-12
ROW_TOLERANCE = 1e-9
#: Absolute differences at or below this (in each number's own unit) count as none: the round-off of quantities
#: that are zero in exact arithmetic. Reordering the sum of one RK4 step (k4 + 2k3 + 2k2 + k1) moved the largest
#: tip error of velocity-level runs from 4.4233e-13 m to 4.4234e-13 m (1.3e-5 relative) and kinetic-energy-pinv's
#: self-motion energy ratio from 5.2e-15 to 7.1e-15; ``compare --strict`` sets it to 0.
ROUND_OFF = 1e-12
#: Columns of the global optimum's rows and made from them: compared only with ``committed --global``.
GLOBAL_COLUMNS = (
    "cost_vs_global", "peak_vs_global", "optimizer_status", "optimizer_iterations", "optimizer_cost", "replay_tip_error",
)  # fmt: skip
GLOBAL_RESOLVER = "global-optimum"

#: Options a resolver needs on each robot (obstacle-avoidance has no default obstacle).
REQUIRED_OPTIONS = {
    ("planar3", "obstacle-avoidance"): {"obstacle": "1.2,0.3,0,0.1"},
    ("panda", "obstacle-avoidance"): {"obstacle": "0.4,0.2,0.5,0.1"},
}
#: Settings beside the defaults whose code paths differ (as the committed atlases run them).
VARIANTS = (
    ("bounded-torque", {"joint_limits": "off"}),
    ("minmax-torque", {"joint_limits": "off"}),
    ("energy-bounded-torque", {"energy_limit": 0.01, "joint_acceleration_limit": 10.0}),
    ("damped-null-space", {"torque_weight": "range"}),
    ("gradient-projection", {"criterion": "manipulability"}),
    ("gradient-projection-acceleration", {"criterion": "manipulability"}),
)


def resolver_settings(robot: str) -> list[list]:
    """[name, options] of every registered resolver (and each variant) that accepts ``robot``, pinv first."""
    loaded = torqueopt.load_robot(robot)
    settings = [[name, REQUIRED_OPTIONS.get((robot, name), {})] for name in resolver_names()]
    settings += [[name, {**REQUIRED_OPTIONS.get((robot, name), {}), **options}] for name, options in VARIANTS]
    kept = []
    for name, options in settings:
        try:
            get_resolver(name, **options).check(loaded)
        except TorqueoptError as error:
            print(f"  {robot}: {name} left out ({error})", file=sys.stderr)
            continue
        kept.append([name, options])
    return kept


def atlas_settings() -> dict:
    """The atlases a baseline records: name -> run_atlas keyword arguments (JSON), resolvers as [name, options]."""
    planar3, panda = resolver_settings("planar3"), resolver_settings("panda")
    lines = {"durations": [0.5, 1.0, 1.5, 2.0], "seed": 2026}
    return {
        "planar3-batch": {"robot": "planar3", "paths": 8, **lines, "resolvers": planar3, "batch": True},
        "planar3-no-batch": {"robot": "planar3", "paths": 4, **lines, "resolvers": planar3, "batch": False},
        "planar3-circle": {
            "robot": "planar3",
            "paths": 6,
            "durations": [1.0],
            "seed": 7,
            "path": "circle",
            "resolvers": planar3,
            "batch": True,
        },
        "panda-batch": {"robot": "panda", "paths": 5, **lines, "resolvers": panda, "batch": True},
    }


def run_one_atlas(settings: dict, out: Path) -> pd.DataFrame:
    """The atlas of ``settings`` run in this process into ``out`` (no figures, no Dask): its rows."""
    arguments = dict(settings)
    arguments["resolvers"] = [get_resolver(name, **options) for name, options in arguments["resolvers"]]
    result = run_atlas(out=out, workers=0, progress=False, figures=False, **arguments)
    return result.table


def run_paper(out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    # Run inside ``out``: ``python -m`` puts the working directory first on sys.path, before PYTHONPATH, and a
    # worktree's directory would import that worktree's torqueopt instead of the one measured.
    subprocess.run(
        [sys.executable, "-m", "torqueopt", "paper", "--out", "."], check=True, stdout=subprocess.DEVNULL, cwd=out
    )
    return json.loads((out / "summary.json").read_text())


def run_velocity(mode: str, path: Path) -> int:
    script = HERE / "velocity_runs_unchanged.py"
    return subprocess.run([sys.executable, str(script), mode, str(path)]).returncode


def commit_of_code() -> str:
    """HEAD of the imported torqueopt's repository and the last commit that changed torqueopt/ ('+changes': and
    the tree differs from it)."""
    root = Path(torqueopt.__file__).resolve().parent.parent

    def git(*arguments: str) -> str:
        return subprocess.run(["git", "-C", str(root), *arguments], capture_output=True, text=True).stdout.strip()

    changed = "+changes" if git("status", "--porcelain", "torqueopt") else ""
    return f"{git('rev-parse', '--short', 'HEAD')} (torqueopt/ of {git('log', '-1', '--format=%h', '--', 'torqueopt')}{changed})"


def cpu_seconds() -> float:
    """CPU time [s] of this process and of the subprocesses it waited for: the measure on a loaded machine."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


class Stopwatch:
    """Wall and CPU seconds of each part, printed as each ends."""

    def __init__(self):
        self.seconds = {}

    @contextlib.contextmanager
    def part(self, name: str):
        wall, cpu = time.perf_counter(), cpu_seconds()
        yield
        self.seconds[name] = {"wall": round(time.perf_counter() - wall, 1), "cpu": round(cpu_seconds() - cpu, 1)}
        print(f"{name}: {self.seconds[name]['wall']} s wall, {self.seconds[name]['cpu']} s CPU", flush=True)


def record(directory: Path) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    manifest = {"commit": commit_of_code(), "atlases": atlas_settings()}
    watch = Stopwatch()
    with watch.part("paper"):
        run_paper(directory / "paper")
    for name, settings in manifest["atlases"].items():
        with watch.part(f"atlas {name}"):
            run_one_atlas(settings, directory / "atlases" / name)
    with watch.part("velocity runs"):
        if run_velocity("--save", directory / "velocity_runs.npz") != 0:
            sys.exit("velocity_runs_unchanged.py --save failed")
    manifest["seconds"] = watch.seconds
    (directory / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    wall, cpu = (sum(part[kind] for part in watch.seconds.values()) for kind in ("wall", "cpu"))
    print(f"recorded into {directory}: {wall:.0f} s wall, {cpu:.0f} s CPU")


# ---------------------------------------------------------------------------------------------------- comparing


def relative_difference(before, after, round_off: float = ROUND_OFF) -> float:
    """|after − before| / max(|before|, |after|) elementwise; 0 where equal (NaN equal to NaN) or apart by at most
    ``round_off``, inf where one is NaN."""
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.maximum(np.abs(before), np.abs(after))
        difference = np.abs(after - before) / scale
        same = (before == after) | (np.isnan(before) & np.isnan(after)) | (np.abs(after - before) <= round_off)
    difference = np.where(same, 0.0, difference)
    return np.where(np.isnan(difference), np.inf, difference)


def compare_json(before, after, where: str = "summary", round_off: float = ROUND_OFF) -> list[str]:
    """Every difference between two JSON values: numbers beyond SUMMARY_TOLERANCE, anything else not identical."""
    if isinstance(before, dict) and isinstance(after, dict):
        problems = [f"{where}.{key}: only in the baseline" for key in before.keys() - after.keys()]
        problems += [f"{where}.{key}: new" for key in after.keys() - before.keys()]
        for key in before.keys() & after.keys():
            problems += compare_json(before[key], after[key], f"{where}.{key}", round_off)
        return problems
    if isinstance(before, list) and isinstance(after, list):
        if len(before) != len(after):
            return [f"{where}: {len(before)} items -> {len(after)}"]
        return [
            problem
            for i, (b, a) in enumerate(zip(before, after))
            for problem in compare_json(b, a, f"{where}[{i}]", round_off)
        ]
    numbers = (int, float)
    if isinstance(before, numbers) and isinstance(after, numbers) and not isinstance(before, bool):
        if isinstance(after, bool):
            return [f"{where}: {before!r} -> {after!r}"]
        difference = float(relative_difference(before, after, round_off))
        return (
            [] if difference <= SUMMARY_TOLERANCE else [f"{where}: {before!r} -> {after!r} (relative {difference:.2e})"]
        )
    return [] if before == after and type(before) is type(after) else [f"{where}: {before!r} -> {after!r}"]


def plain(value):
    """A NumPy scalar as the Python value it holds (for messages)."""
    return value.item() if isinstance(value, np.generic) else value


def compare_rows(
    before: pd.DataFrame, after: pd.DataFrame, skip_columns=(), round_off: float = ROUND_OFF
) -> tuple[list[str], list[dict]]:
    """(problems, per-resolver table) of two atlas tables matched by (path, resolver)."""
    problems = []
    key = ["path", "resolver"]
    missing = sorted(set(before.columns) - set(after.columns) - set(skip_columns))
    if missing:
        problems.append(f"columns missing: {', '.join(missing)}")
    new = sorted(set(after.columns) - set(before.columns))
    if new:
        print(f"    new columns (not compared): {', '.join(new)}")
    merged = before.merge(after, on=key, how="outer", suffixes=("|before", "|after"), indicator=True)
    lost = merged[merged["_merge"] != "both"]
    if len(lost):
        problems.append(f"{len(lost)} rows in one table only, e.g. {lost[key].head(3).to_dict('records')}")
    merged = merged[merged["_merge"] == "both"]
    columns = [c for c in before.columns if c in after.columns and c not in key and c not in skip_columns]
    table = []
    for resolver in pd.unique(before["resolver"]):
        rows = merged[merged["resolver"] == resolver]
        worst, worst_column, unequal = 0.0, "", []
        for column in columns:
            b, a = rows[f"{column}|before"], rows[f"{column}|after"]
            if (
                pd.api.types.is_numeric_dtype(b)
                and pd.api.types.is_numeric_dtype(a)
                and not pd.api.types.is_bool_dtype(b)
            ):
                difference = relative_difference(b.to_numpy(float), a.to_numpy(float), round_off)
                largest = float(difference.max()) if difference.size else 0.0
                if largest > worst:
                    worst, worst_column = largest, column
                if largest > ROW_TOLERANCE:
                    where = int(np.argmax(difference))
                    verdict = f", {rows['verdict|before'].iloc[where]}" if "verdict|before" in rows else ""
                    problems.append(
                        f"{resolver} {column}: relative {largest:.2e} on path {int(rows['path'].iloc[where])}{verdict} "
                        f"({plain(b.iloc[where])!r} -> {plain(a.iloc[where])!r}), {int((difference > ROW_TOLERANCE).sum())} rows"
                    )
            else:
                changed = ~((b == a) | (b.isna() & a.isna()))
                if changed.any():
                    where = int(np.argmax(changed.to_numpy()))
                    unequal.append(column)
                    problems.append(
                        f"{resolver} {column}: {int(changed.sum())} rows differ, e.g. path "
                        f"{int(rows['path'].iloc[where])}: {plain(b.iloc[where])!r} -> {plain(a.iloc[where])!r}"
                    )
        table.append({"resolver": resolver, "rows": len(rows), "largest": worst, "column": worst_column,
                      "unequal": ", ".join(unequal)})  # fmt: skip
    return problems, table


def print_table(table: list[dict]) -> None:
    print(f"    {'resolver':<72} {'rows':>5} {'largest rel.':>12}  column / columns not identical")
    for entry in table:
        flag = "" if entry["largest"] <= ROW_TOLERANCE and not entry["unequal"] else "  <-- FAILS"
        text = entry["column"] + (f"; not identical: {entry['unequal']}" if entry["unequal"] else "")
        print(f"    {entry['resolver']:<72} {entry['rows']:>5} {entry['largest']:>12.2e}  {text}{flag}")


def compare(directory: Path, only: list[str], round_off: float = ROUND_OFF) -> None:
    """Run the parts of the baseline in ``directory`` again (those whose name holds a word of ``only``, or all)."""
    manifest = json.loads((directory / "manifest.json").read_text())
    print(f"baseline {directory} of commit {manifest['commit']}; this code: {commit_of_code()}, {torqueopt.__file__}")

    def wanted(part: str) -> bool:
        return not only or any(word in part for word in only)

    failed, watch = [], Stopwatch()
    with tempfile.TemporaryDirectory(prefix="house-numbers-") as scratch:
        scratch = Path(scratch)
        if wanted("paper"):
            with watch.part("paper"):
                summary = run_paper(scratch / "paper")
            problems = compare_json(
                json.loads((directory / "paper" / "summary.json").read_text()), summary, round_off=round_off
            )
            print("paper summary.json: " + ("equal" if not problems else "DIFFERS"))
            for problem in problems:
                print(f"    {problem}")
            failed += ["paper"] if problems else []
        for name, settings in manifest["atlases"].items():
            if not wanted(f"atlas {name}"):
                continue
            with watch.part(f"atlas {name}"):
                after = run_one_atlas(settings, scratch / "atlases" / name)
            before = pd.read_parquet(directory / "atlases" / name / "results.parquet")
            problems, table = compare_rows(before, after, round_off=round_off)
            print(f"atlas {name} ({len(before)} rows): " + ("equal" if not problems else "DIFFERS"))
            print_table(table)
            for problem in problems:
                print(f"    {problem}")
            failed += [f"atlas {name}"] if problems else []
    if wanted("velocity runs"):
        with watch.part("velocity runs"):
            if run_velocity("--compare", directory / "velocity_runs.npz") != 0:
                failed.append("velocity runs")
    print(f"FAILED: numbers changed in {', '.join(failed)}" if failed else "every number compared is unchanged")
    sys.exit(1 if failed else 0)


# ---------------------------------------------------------------------------------------------- committed atlases


def committed_atlases(root: Path) -> list[tuple[Path, dict, str]]:
    """(folder, config, where the config came from) of every folder under ``root`` with a results.parquet."""
    found = []
    for rows in sorted(root.rglob("results.parquet")):
        folder = rows.parent
        for source in (folder / "atlas-config.json", folder / "atlas.json", folder.parent / f"{folder.name}.json"):
            if source.exists():
                text = json.loads(source.read_text())
                found.append(
                    (
                        folder,
                        text if source.name == "atlas-config.json" else text["config"],
                        str(source.relative_to(root)),
                    )
                )
                break
        else:
            print(f"{folder}: no settings found, skipped")
    return found


def committed_resolvers(config: dict) -> list:
    """The atlas's resolvers from the options it recorded (by its label where those no longer make it)."""
    resolvers = []
    for description in config["resolvers"]:
        try:
            resolvers.append(get_resolver(description["name"], **description["options"]))
        except TorqueoptError:
            resolvers.append(torqueopt.resolvers.resolver_from_label(description["label"]))
    return resolvers


def population_of(config: dict) -> tuple:
    """(the RobotSpec, the movements) of the atlas whose settings are ``config`` (atlas-config.json's)."""
    from torqueopt.atlas.jobs import RobotSpec
    from torqueopt.atlas.population import PopulationSpec, draw_population

    spec = RobotSpec(**config["robot"])
    fields = PopulationSpec.__dataclass_fields__
    population = {key: value for key, value in config["population"].items() if key in fields}
    for key in ("durations", "length_range", "grid_posture"):
        if population.get(key) is not None:
            population[key] = tuple(population[key])
    return spec, draw_population(spec.load(), PopulationSpec(**population))


def rerun_sample(config: dict, sample_size: int, sample_seed: int, with_global: bool) -> tuple[pd.DataFrame, int]:
    """(rows, population size) of ``sample_size`` seeded paths of the atlas of ``config``, run as its sweep does."""
    from torqueopt.atlas.jobs import GlobalChunk, ResolverChunk
    from torqueopt.atlas.sweep import run_chunk
    from torqueopt.atlas.verdicts import Thresholds

    spec, movements = population_of(config)
    chosen = np.sort(
        np.random.default_rng(sample_seed).choice(len(movements), min(sample_size, len(movements)), replace=False)
    )
    sample = [movements[i] for i in chosen]
    resolvers = tuple(committed_resolvers(config))
    thresholds = Thresholds(**config["thresholds"])
    margin = float(config["margin"]["every"]) if "margin" in config else None
    batch = bool(config.get("batch", True))
    rows = []
    for duration in sorted({m.duration for m in sample}):
        members = tuple(m for m in sample if m.duration == duration)
        rows += run_chunk(ResolverChunk(spec, resolvers, members, float(config["dt"]), thresholds, batch, "", margin))
        if with_global and "global" in config:
            rows += run_chunk(GlobalChunk(spec, members, float(config["dt"]), thresholds, "", config["global"]))
    table = pd.DataFrame(rows)
    if with_global and "global" in config:
        from torqueopt.atlas.global_optimum import add_global_ratios

        table = add_global_ratios(table)
    return table, len(movements)


def committed(
    root: Path,
    sample_size: int,
    sample_seed: int,
    with_global: bool,
    only: list[str],
    save: Path | None = None,
    against: Path | None = None,
) -> None:
    """Re-run each committed atlas's sample; compare with its committed rows, or with the sample's rows saved in
    ``against`` (``save`` writes them: the rows the code of one commit gives, where the committed rows were made by
    an older one)."""
    failed = []
    for folder, config, source in committed_atlases(root):
        name = str(folder.relative_to(root))
        if only and not any(part in name for part in only):
            continue
        start = time.perf_counter()
        try:
            after, size = rerun_sample(config, sample_size, sample_seed, with_global)
        except TorqueoptError as error:
            print(f"{name}: cannot be run again today: {error}")
            failed.append(name)
            continue
        saved = name.replace("/", "--") + ".parquet"
        if save is not None:
            save.mkdir(parents=True, exist_ok=True)
            after.to_parquet(save / saved, index=False)
        before = pd.read_parquet(folder / "results.parquet" if against is None else against / saved)
        before = before[before["path"].isin(after["path"].unique())]
        skip = ()
        if not with_global:
            before = before[before["resolver"] != GLOBAL_RESOLVER]
            skip = GLOBAL_COLUMNS
        problems, table = compare_rows(before, after, skip_columns=skip)
        verdict = "reproduces" if not problems else "DIFFERS"
        print(
            f"{name} (settings from {source}; {after['path'].nunique()} of {size} paths, {len(after)} rows, "
            f"{time.perf_counter() - start:.0f} s): {verdict}",
            flush=True,
        )
        print_table(table)
        for problem in problems[:20]:
            print(f"    {problem}")
        if len(problems) > 20:
            print(f"    ... and {len(problems) - 20} more")
        if problems:
            failed.append(name)
    print("every committed atlas reproduces" if not failed else f"differ: {', '.join(failed)}")
    sys.exit(1 if failed else 0)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    commands = parser.add_subparsers(dest="command", required=True)
    command = commands.add_parser(
        "record", allow_abbrev=False, help="run everything on this code and write the baseline into DIR"
    )
    command.add_argument("directory", metavar="DIR", type=Path)
    command = commands.add_parser(
        "compare", allow_abbrev=False, help="run everything again and compare with the baseline in DIR"
    )
    command.add_argument("directory", metavar="DIR", type=Path)
    command.add_argument("--strict", action="store_true", help="no round-off floor: every difference counts")
    command.add_argument(
        "only",
        nargs="*",
        help="only the parts whose name holds one of these words (paper, atlas, planar3-batch, panda, velocity, ...)",
    )
    command = commands.add_parser(
        "committed", allow_abbrev=False, help="re-run a sample of each committed atlas and compare its rows"
    )
    command.add_argument("--paths-per-atlas", type=int, default=100, metavar="N", help="paths per atlas (default 100)")
    command.add_argument("--sample-seed", type=int, default=0, help="seed of the sample of paths (default 0)")
    command.add_argument("--global", dest="with_global", action="store_true", help="also the global optimum's rows")
    command.add_argument("--root", type=Path, default=REPO / "docs" / "atlas", help="where the atlases are")
    command.add_argument("--save", type=Path, metavar="DIR", help="also write each sample's rows into DIR")
    command.add_argument(
        "--against", type=Path, metavar="DIR", help="compare with the rows --save wrote into DIR, not the committed"
    )
    command.add_argument("only", nargs="*", help="only the atlases whose folder contains one of these words")
    arguments = parser.parse_args(argv)
    if arguments.command == "record":
        record(arguments.directory)
    elif arguments.command == "compare":
        compare(arguments.directory, arguments.only, 0.0 if arguments.strict else ROUND_OFF)
    else:
        committed(
            arguments.root,
            arguments.paths_per_atlas,
            arguments.sample_seed,
            arguments.with_global,
            arguments.only,
            arguments.save,
            arguments.against,
        )


if __name__ == "__main__":
    main()
