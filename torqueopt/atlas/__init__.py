r"""The stability atlas: how often, where and why local resolvers go unstable.

:func:`run_atlas` draws a seeded population of movements (the paper's
straight lines, minimum-jerk lines or circles, :mod:`torqueopt.atlas.population`),
runs every resolver on each
(batched, on a Dask cluster, :mod:`torqueopt.atlas.sweep`), gives each run
a verdict (:mod:`torqueopt.atlas.verdicts`: the 2x-limit rule and a runaway
criterion that tells a whip from a path that is simply too demanding), and
turns the table into the paper's claims with Wilson 95 % intervals
(:mod:`torqueopt.atlas.stats`), a summary and figures
(:mod:`torqueopt.atlas.report`).

Files in the output folder:

``results.parquet``
    one row per (movement, resolver): ``path``, ``duration``, ``resolver``
    (the resolver's label: its name, with the options that differ from their
    defaults in brackets, ``bounded-torque[joint_limits=off]``),
    ``resolver_options`` (those options as a JSON object, ``{}`` for the defaults),
    ``q0_1..q0_n``, ``direction_1..direction_d``, ``path_kind``, ``path_length``
    [m] (and ``path_accel`` for a line; ``radius``, ``centre_1..d``,
    ``normal_1..3`` for a circle), ``unstable``, ``verdict``,
    ``instability_time``, ``peak_torque_ratio``, ``first_limit_violation``,
    ``max_tip_error`` and more (see :func:`torqueopt.atlas.verdicts.run_row`).
``atlas.md``, ``atlas.json``
    the settings, the unstable fractions and the claims.
``unstable_fraction.png``, ``workspace_map.png``, ``instability_time.png``, ``tradeoff.png``
    the figures.
``explorer.html``
    one self-contained page (Plotly, inlined): the workspace map by verdict,
    and for a bounded sample of paths (``keep_traces``, whips first) the
    torque of every resolver and the arm at the instability
    (``torqueopt.atlas.explorer``). Written with the figures: not with
    ``figures=False``.
``atlas-config.json``, ``chunks/``
    the settings the sweep was started with, and each finished chunk (with
    the atlas's fingerprint and its own checksum, :mod:`torqueopt.atlas.sweep`):
    what lets a killed sweep resume.

Nothing is written before every check has passed (the settings, the size
of the sweep, the folder, the files, the scheduler), and only into a folder
that is new, empty or this atlas's: a folder that holds anything else is
refused, so no file of the user's is ever replaced. The table, the summaries
and the figures land together at the end, or none of them does.

The runs use :func:`torqueopt.simulate`'s acceleration profile, step and
integrator: held-torque RK4 for the torque resolvers (the batched path is
held to it at 1e-9), RK4 on the joint velocities with inverse-dynamics
torques for the velocity-level methods.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..checks import positive_number, step_count, whole_number
from ..errors import InvalidInput, OutputError, TorqueoptWarning
from ..io import atomic_write, json_text, resumable_folder, writable_path, writable_paths, written_together
from ..progress import said_if_slow
from ..resolvers import Resolver
from ..whiplash import DEFAULT_LIMIT_FACTOR
from . import explorer
from .explorer import DEFAULT_KEEP_TRACES
from .global_optimum import (
    DEFAULT_GLOBAL_CHUNK_SIZE,
    DEFAULT_GLOBAL_MAX_ITERATIONS,
    DEFAULT_GLOBAL_MAX_TIME,
    GLOBAL_RESOLVER,
    add_global_ratios,
    check_transcription,
)
from .global_optimum import settings as global_settings
from .margins import DEFAULT_MARGIN_EVERY, MARGIN_STEP_EQUIVALENT
from .population import Movement, PopulationSpec, arm_reach, draw_population, grid_start_points
from .stats import claims, import_scipy_stats_meanwhile, proportion, unstable_fractions, wilson_interval
from .sweep import (
    RobotSpec,
    config_digest,
    executor,
    read_chunks,
    remove_partial_chunks,
    require,
    resolvers_from,
    run_chunks,
    scheduler_address,
    start_fork_server,
)
from .verdicts import DEFAULT_ENERGY_FACTOR, DEFAULT_PINV_FACTOR, VERDICTS, Thresholds

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_KEEP_TRACES",
    "DEFAULT_MAX_STEPS",
    "VERDICTS",
    "AtlasResult",
    "PopulationSpec",
    "Thresholds",
    "claims",
    "draw_population",
    "proportion",
    "run_atlas",
    "unstable_fractions",
    "wilson_interval",
]

#: Largest sweep (movements × resolvers × steps) run_atlas starts without being told otherwise.
DEFAULT_MAX_STEPS = 10_000_000_000
#: Movements per chunk of work.
DEFAULT_CHUNK_SIZE = 256
_FORMAT = 1
_CONFIG = "atlas-config.json"
#: The files written at the end, together: the table, the summaries, the figures.
_RESULT_FILES = (
    "results.parquet", "atlas.json", "atlas.md",
    "unstable_fraction.png", "workspace_map.png", "instability_time.png", "tradeoff.png", "explorer.html",
    "margin_roc.png",
)  # fmt: skip


@dataclass
class AtlasResult:
    """What :func:`run_atlas` made: the table (a pandas DataFrame), the summary dict and the output folder."""

    table: object
    summary: dict
    out: Path

    def claims(self, criterion: str = "unstable") -> list[dict]:
        return claims(self.table, criterion)


def run_atlas(
    robot: str | RobotSpec = "planar3",
    paths: int = 100,
    durations=(0.5, 1.0, 1.5, 2.0),
    resolvers=("pinv", "inertia-pinv", "null-space", "weighted-null-space"),
    out: str | os.PathLike = "atlas",
    *,
    seed: int = 0,
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
    mode: str = "random",
    reach_fraction: float = 0.9,
    min_condition: float = 0.05,
    grid_spacing: float = 0.25,
    grid_directions: int = 8,
    accel: float | None = None,
    path: str = "line",
    length_range=(0.25, 1.0),
    dt: float = 1e-3,
    limit_factor: float = DEFAULT_LIMIT_FACTOR,
    pinv_factor: float = DEFAULT_PINV_FACTOR,
    energy_factor: float = DEFAULT_ENERGY_FACTOR,
    batch: bool = True,
    progress: bool = True,
    figures: bool = True,
    max_steps: int = DEFAULT_MAX_STEPS,
    keep_traces: int = DEFAULT_KEEP_TRACES,
    global_optimum: bool = False,
    global_max_iterations: int = DEFAULT_GLOBAL_MAX_ITERATIONS,
    global_max_time: float = DEFAULT_GLOBAL_MAX_TIME,
    margin: bool = False,
    margin_every: float = DEFAULT_MARGIN_EVERY,
) -> AtlasResult:
    """Run the stability atlas and write its files into ``out``.

    Args:
        robot: a robot name or URDF (as :func:`torqueopt.load_robot`), or a
            :class:`~torqueopt.atlas.sweep.RobotSpec` with frame, task, limits.
        paths: movements per duration (random mode).
        durations: movement durations T [s].
        resolvers: names, labels with options (``"bounded-torque[joint_limits=off]"``,
            read by ``torqueopt.resolvers.resolver_from_label``) or Resolver objects
            (``get_resolver("bounded-torque", joint_limits="off")``); one resolver
            may come with several settings, each its own resolver under its
            :attr:`~torqueopt.Resolver.label` (the ``resolver`` column;
            ``resolver_options`` holds the options as JSON). ``pinv`` (its
            defaults) is always run, first, as the baseline of the runaway criterion.
        out: output folder; an existing atlas there with the same settings is
            resumed, one with other settings is refused.
        seed: seed of the population.
        scheduler: address of an existing Dask scheduler (``tcp://host:port``);
            None starts a LocalCluster with one worker process per core.
        workers: LocalCluster worker processes (default: the machine's cores);
            0 runs everything in this process, without Dask.
        chunk_size: movements per chunk of work.
        mode, reach_fraction, min_condition, grid_spacing, grid_directions:
            the population, :class:`~torqueopt.atlas.population.PopulationSpec`.
        accel: the lines' tangential acceleration a [m/s²]; None (the default)
            sizes it to the arm, √2 m/s² × reach / 3 m
            (:func:`~torqueopt.atlas.population.default_accel`: √2 on planar3).
        path: ``line`` (the paper's), ``min-jerk`` (minimum-jerk lines of random
            length) or ``circle`` (circles in random planes about random centres);
            length_range: the min-jerk line's length, or the circle's
            circumference, as a fraction of a·T²/4, drawn uniformly in this range
            (:mod:`torqueopt.atlas.population`).
        dt: step [s].
        limit_factor, pinv_factor, energy_factor: the verdict thresholds,
            :mod:`torqueopt.atlas.verdicts`.
        batch: use the batched simulation path where it applies.
        progress: show a progress bar (paths done, rate, time left) on stderr.
        figures: draw the figures (needs matplotlib) and write explorer.html
            (needs plotly); False writes neither and keeps no traces.
        keep_traces: paths whose runs explorer.html keeps (every resolver's
            torque, the arm at the instability): those where a resolver
            whips first, then the others; simulated again after the sweep.
        max_steps: refuse a sweep of more trajectory-steps than this (a global
            optimum counts as ``GLOBAL_STEP_EQUIVALENT`` (25) runs of its path, a
            margin evaluation as ``MARGIN_STEP_EQUIVALENT`` steps).
        global_optimum: also run :func:`torqueopt.optimize` on every movement:
            rows with resolver ``global-optimum``, judged from the open-loop
            replay of the optimal torques, and the columns ``cost_vs_global``
            and ``peak_vs_global`` on every row (:mod:`torqueopt.atlas.global_optimum`).
        global_max_iterations, global_max_time: the optimiser's budget per path
            (IPOPT iterations per Hessian tried; wall time of the solve [s]).
        margin: record ``peak_stability_margin`` and ``margin_warning_time`` per
            torque-resolver row (:mod:`torqueopt.atlas.margins`), the margin
            evaluated every ``margin_every`` seconds of each run.

    A chunk already in ``out/chunks`` that does not prove to be this
    atlas's (another atlas's, truncated, corrupt) is recomputed, with a
    :class:`~torqueopt.errors.TorqueoptWarning` naming it.

    Raises:
        InvalidInput: bad settings, a sweep larger than ``max_steps``, a
            scheduler that cannot be reached, or an ``out`` folder that holds
            an atlas with other settings or anything that is not an atlas's.
        OutputError: a file of the atlas cannot be written.
        MissingDependency: pandas, pyarrow, dask[distributed] or tqdm missing.
    """
    scheduler = scheduler_address(scheduler)
    workers = None if workers is None else whole_number(workers, "workers", 0, 1024)
    spec = robot if isinstance(robot, RobotSpec) else RobotSpec(str(robot))
    population = PopulationSpec(
        mode=mode, paths=paths, durations=tuple(np.atleast_1d(np.asarray(durations, dtype=float)).tolist()), seed=seed,
        accel=accel, path=path, length_range=tuple(length_range), reach_fraction=reach_fraction,
        min_condition=min_condition, grid_spacing=grid_spacing, grid_directions=grid_directions,
    )  # fmt: skip
    thresholds = Thresholds(limit_factor, pinv_factor, energy_factor)
    keep_traces = whole_number(keep_traces, "keep_traces", minimum=0)
    if figures:
        require("plotly", "atlas")
    resolver_objects = resolvers_from(resolvers)
    chunk_size = whole_number(chunk_size, "chunk_size", minimum=1)
    global_optimum, margin = bool(global_optimum), bool(margin)
    global_max_iterations = whole_number(global_max_iterations, "global_max_iterations", 1, 100_000)
    global_max_time = positive_number(global_max_time, "global_max_time", "s")
    margin_every = positive_number(margin_every, "margin_every", "s")
    if margin and margin_every < dt:
        raise InvalidInput(f"margin_every={margin_every:g} s is shorter than the step dt={dt:g} s; give at least dt")
    dt = positive_number(dt, "dt", "s")
    for duration in population.durations:
        step_count(duration, dt)  # a dt that does not divide a duration would simulate another movement
    out = writable_path(out, directory=True)
    if out.exists() and not out.is_dir():
        raise OutputError(f"cannot write the atlas to '{out}': it is a file; give a folder")
    writable_paths(out / name for name in (_CONFIG, *_RESULT_FILES))
    if scheduler is None and workers != 0:
        # The local cluster's fork server imports torqueopt and distributed while this process imports pandas and
        # distributed and draws the population: started with the cluster, its imports came after all of those.
        # Started once the settings are known good, so that a refused call leaves no server behind.
        start_fork_server()
    pandas = require("pandas")
    require("pyarrow")

    # Bound the work before drawing anything: the population's size is known up front in random mode.
    steps_per_run = {duration: round(duration / dt) + 1 for duration in population.durations}
    work = _Work(len(resolver_objects), global_optimum, margin, margin_every / dt)
    if population.mode == "random":
        _check_size(population.paths * sum(steps_per_run.values()) * work.per_step, max_steps, population, work)

    with said_if_slow(f"torqueopt atlas: loading robot '{spec.source}'", enabled=progress):
        loaded = spec.load()
    for resolver in resolver_objects:
        resolver.check(loaded)
    if global_optimum:
        check_transcription(loaded, population.durations)
    if population.mode == "grid":
        # Counted, not built: the grid's start points bound its movements before any inverse kinematics.
        _check_grid_size(grid_start_points(loaded, population), steps_per_run, max_steps, population, work, dt)
    reach = arm_reach(loaded)[1]
    accel_from_reach = population.accel is None
    population = population.sized(reach)  # the acceleration, when not given, from the arm's reach
    movements = draw_population(loaded, population, progress=progress)
    total_steps = sum(steps_per_run[m.duration] for m in movements) * work.per_step
    _check_size(total_steps, max_steps, population, work)

    config = {
        "format": _FORMAT,
        "robot": spec.as_dict(),
        "robot_name": loaded.name,
        "task": loaded.task,
        "joint_names": list(loaded.joint_names),
        "torque_limit": [x if math.isfinite(x) else None for x in loaded.torque_upper.tolist()],
        "population": population.as_dict(),
        "reach": float(reach),
        "accel_from_reach": accel_from_reach,
        "resolvers": [_resolver_description(r) for r in resolver_objects],
        "thresholds": thresholds.as_dict(),
        "dt": float(dt),
        "chunk_size": int(chunk_size),
        "batch": bool(batch),
        "movements": len(movements),
    }
    # Only when asked, so that an atlas without them keeps its fingerprint (and resumes).
    if global_optimum:
        config["global"] = global_settings(global_max_iterations, global_max_time)
    if margin:
        config["margin"] = {"every": float(margin_every)}
    config = json.loads(json.dumps(config, default=_json_default))  # as atlas-config.json will read back
    digest = config_digest(config)
    resume = _check_folder(out, config)

    chunks = _chunks(movements, chunk_size)
    local_chunks = len(chunks)
    if global_optimum:  # the global rows in chunks of their own, after the resolvers' (smaller: a path takes ~1 s)
        chunks += _chunks(movements, min(chunk_size, DEFAULT_GLOBAL_CHUNK_SIZE))
    frames, rejected = read_chunks(out, len(chunks), digest) if resume else ({}, [])
    done = set(frames)
    jobs = {}
    for index, chunk in enumerate(chunks):
        if index in done:
            continue
        jobs[index] = {
            "robot": spec,
            "resolvers": resolver_objects,
            "dt": float(dt),
            "thresholds": thresholds.as_dict(),
            "batch": bool(batch),
            "digest": digest,
            "movements": chunk,
        }
        if index >= local_chunks:
            jobs[index]["global"] = config["global"]
        elif margin:
            jobs[index]["margin"] = float(margin_every)
    # Sent in the order of their first path, each resolver chunk before the global chunks of its paths: the paths
    # finish in order, both halves of a path together, so a sweep stopped early leaves a whole prefix of paths.
    jobs = dict(sorted(jobs.items(), key=lambda item: (item[1]["movements"][0].path, "global" in item[1])))
    done_paths = sum(len(chunks[index]) for index in done)
    if rejected:
        warnings.warn(
            f"recomputing {len(rejected)} of {len(chunks)} chunks, which do not match this atlas: {', '.join(rejected)}",
            TorqueoptWarning,
            stacklevel=2,
        )
    # The scheduler is reached (or the cluster started) before the first file is written.
    with executor(scheduler, workers, progress) if jobs else contextlib.nullcontext() as client:
        if not resume:
            _claim_folder(out, config)
        remove_partial_chunks(out)
        if jobs:
            frames.update(
                run_chunks(
                    jobs,
                    out,
                    client,
                    progress=progress,
                    total_paths=len(movements) * (2 if global_optimum else 1),
                    done_paths=done_paths,
                    description=f"torqueopt atlas: {len(movements):,} paths x {len(resolver_objects)} resolvers"
                    + (" and the global optimum of each (a path counted twice)" if global_optimum else ""),
                    # This process loads what the report needs on the core the sweep's last chunks leave idle.
                    once_a_worker_idles=import_scipy_stats_meanwhile,
                )
            )

    order = [r.label for r in resolver_objects] + ([GLOBAL_RESOLVER] if global_optimum else [])
    table = _collect(pandas, [frames[index] for index in range(len(chunks))], order)
    if global_optimum:
        table = add_global_ratios(table)
    from .report import summarise, write_figures, write_markdown

    summary = summarise(table, config)
    summary["resumed_chunks"] = len(done)
    traces = (
        explorer.keep_traces(
            loaded, table, movements, resolver_objects, dt=float(dt), batch=bool(batch), keep=keep_traces,
        )
        if figures
        else {}
    )  # fmt: skip
    with written_together():
        atomic_write(out / "results.parquet", lambda handle: table.to_parquet(handle, index=False))
        text = json_text(summary).encode()
        atomic_write(out / "atlas.json", lambda handle: handle.write(text))
        if figures:
            summary["figures"] = write_figures(table, summary, out, loaded)
            summary["figures"]["explorer: the map, and the runs of each kept path"] = explorer.write_explorer(
                out / "explorer.html", table, summary, traces, keep_traces
            )
        markdown = write_markdown(summary).encode()
        atomic_write(out / "atlas.md", lambda handle: handle.write(markdown))
    return AtlasResult(table=table, summary=summary, out=out)


def _json_default(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    raise TypeError(type(value).__name__)


def _resolver_description(resolver: Resolver) -> dict:
    # The declared options as JSON values (a resolver's other attributes may be objects: task stacks, criteria).
    return {
        "name": resolver.name,
        "label": resolver.label,
        "class": type(resolver).__name__,
        "options": resolver.settings_for_file(),
    }


#: What one global optimum counts as in the bound on the work: this many runs of its path (measured: a solve of a
#: 2 s planar3 path, ~1.4 s, is about 23 pinv runs of 2,001 steps at 33k steps/s).
GLOBAL_STEP_EQUIVALENT = 25


@dataclass(frozen=True)
class _Work:
    """What each trajectory-step of the population costs, in trajectory-steps: the resolvers' runs, the global
    optimum's and the margin's equivalents."""

    resolvers: int
    global_optimum: bool
    margin: bool
    steps_between_margins: float

    @property
    def per_step(self) -> float:
        margins = self.resolvers * MARGIN_STEP_EQUIVALENT / self.steps_between_margins if self.margin else 0.0
        return self.resolvers + (GLOBAL_STEP_EQUIVALENT if self.global_optimum else 0) + margins

    def describe(self) -> str:
        text = f"{self.resolvers} resolvers, pinv included"
        if self.global_optimum:
            text += f", a global optimum counted as {GLOBAL_STEP_EQUIVALENT} runs"
        if self.margin:
            text += f", a margin every {self.steps_between_margins:.3g} steps counted as {MARGIN_STEP_EQUIVALENT} steps"
        return text


def _check_size(total_steps: float, max_steps: int, population: PopulationSpec, work: _Work) -> None:
    if total_steps > max_steps:
        raise InvalidInput(
            f"the atlas would simulate {total_steps:.3g} trajectory-steps ({population.paths} paths x "
            f"{len(population.durations)} durations x {work.describe()}), more than "
            f"max_steps={max_steps:.3g}: fewer paths, durations or resolvers, a larger dt, or raise max_steps (--max-steps)"
        )


def _check_grid_size(points: int, steps_per_run: dict, max_steps: int, population: PopulationSpec, work, dt) -> None:
    directions = population.grid_directions
    total_steps = points * directions * sum(steps_per_run.values()) * work.per_step
    if total_steps > max_steps:
        durations = ", ".join(f"{duration:g}" for duration in population.durations)
        raise InvalidInput(
            f"the grid atlas would simulate up to {total_steps:.3g} trajectory-steps ({points:,} start points x "
            f"{directions} direction{'s' if directions != 1 else ''}, durations {durations} s at dt {dt:g} s, "
            f"{work.describe()}), more than max_steps={max_steps:.3g}: a coarser "
            "--grid-spacing, fewer --grid-directions, durations or resolvers, a larger dt, or raise max_steps "
            "(--max-steps)"
        )


def _chunks(movements: list[Movement], size: int) -> list[list[Movement]]:
    """Consecutive movements of one duration, at most ``size`` per chunk (independent of the workers)."""
    chunks: list[list[Movement]] = []
    for movement in movements:
        if chunks and len(chunks[-1]) < size and chunks[-1][0].duration == movement.duration:
            chunks[-1].append(movement)
        else:
            chunks.append([movement])
    return chunks


def _check_folder(out: Path, config: dict) -> bool:
    """True when ``out`` holds this atlas (resume), False when it is new or empty; writes nothing."""
    return resumable_folder(out, _CONFIG, config, "atlas")


def _claim_folder(out: Path, config: dict) -> None:
    """Write atlas-config.json into a new or empty folder (checked by :func:`_check_folder`), making it this atlas's."""
    text = json.dumps(config, indent=2, sort_keys=True).encode()
    atomic_write(out / _CONFIG, lambda handle: handle.write(text))


def _collect(pandas, frames: list, resolver_order: list[str]):
    """Every chunk's rows, sorted by path and resolver (the order of the settings)."""
    table = pandas.concat(frames, ignore_index=True)
    rank = {name: i for i, name in enumerate(resolver_order)}
    table = table.assign(_rank=table["resolver"].map(rank)).sort_values(["path", "_rank"], kind="stable")
    return table.drop(columns="_rank").reset_index(drop=True)
