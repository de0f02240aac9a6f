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
    (``torqueopt.atlas.explorer``), as the sweep's chunks kept them. Written
    with the figures: not with ``figures=False``.
``atlas-config.json``, ``chunks/``
    the settings the sweep was started with, and each finished chunk (with
    the atlas's fingerprint and its own checksum, :mod:`torqueopt.atlas.sweep`;
    beside it, with the figures, the traces it kept for the explorer,
    :mod:`torqueopt.atlas.traces`): what lets a killed sweep resume.

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
import functools
import json
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import InvalidInput, OutputError, TorqueoptWarning
from ..io import (
    atomic_write,
    held_exclusively,
    json_text,
    resumable_folder,
    writable_path,
    writable_paths,
    written_together,
)
from ..progress import command_name, said_if_slow
from . import explorer
from .explorer import DEFAULT_KEEP_TRACES
from .global_optimum import DEFAULT_GLOBAL_CHUNK_SIZE, GLOBAL_RESOLVER, add_global_ratios, check_transcription
from .jobs import GlobalChunk, ResolverChunk
from .margins import MARGIN_STEP_EQUIVALENT
from .population import Movement, PopulationSpec, arm_reach, draw_population, grid_start_points
from .settings import (
    DEFAULT_CHUNK_SIZE,
    DEFAULT_MAX_STEPS,
    AtlasSettings,
    ExecutionSettings,
    FrontierSettings,
    PopulationSettings,
    atlas_config,
)
from .stats import claims, import_scipy_stats_meanwhile, proportion, unstable_fractions, wilson_interval
from .sweep import (
    collect,
    config_digest,
    executor,
    read_chunks,
    remove_partial_chunks,
    require,
    run_chunks,
    start_fork_server,
    traces_path,
)
from .traces import KeptPaths, Traces
from .verdicts import VERDICTS, Thresholds

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_KEEP_TRACES",
    "DEFAULT_MAX_STEPS",
    "VERDICTS",
    "AtlasResult",
    "AtlasSettings",
    "ExecutionSettings",
    "FrontierSettings",
    "PopulationSettings",
    "PopulationSpec",
    "Thresholds",
    "claims",
    "draw_population",
    "proportion",
    "run_atlas",
    "unstable_fractions",
    "wilson_interval",
]

_CONFIG = "atlas-config.json"
#: The files written at the end, together: the table, the summaries, the figures.
_RESULT_FILES = (
    "results.parquet", "atlas.json", "atlas.md",
    "unstable_fraction.png", "workspace_map.png", "instability_time.png", "tradeoff.png", "explorer.html",
    "margin_roc.png",
)  # fmt: skip
#: run_atlas's positional arguments, in order (every setting may be given by keyword).
_POSITIONAL = ("robot", "paths", "durations", "resolvers", "out")


@dataclass
class AtlasResult:
    """What :func:`run_atlas` made: the table (a pandas DataFrame), the summary dict and the output folder."""

    table: object
    summary: dict
    out: Path

    def claims(self, criterion: str = "unstable") -> list[dict]:
        return claims(self.table, criterion)


def run_atlas(settings: AtlasSettings | object = None, *args, **keywords) -> AtlasResult:
    """Run the stability atlas and write its files into ``out``.

    Call it with an :class:`~torqueopt.atlas.settings.AtlasSettings`, or with the settings themselves:
    ``robot, paths, durations, resolvers, out`` in this order or by keyword, every other one by keyword
    (``run_atlas("panda", paths=50, out="atlas", path="circle", workers=2)``). An existing atlas in ``out``
    with the same settings is resumed; one with other settings is refused.

    Args:
        {arguments}

    A chunk already in ``out/chunks`` that does not prove to be this
    atlas's (another atlas's, truncated, corrupt) is recomputed, with a
    :class:`~torqueopt.errors.TorqueoptWarning` naming it.

    Raises:
        InvalidInput: bad settings, a sweep larger than ``max_steps``, a
            scheduler that cannot be reached, or an ``out`` folder that holds
            an atlas with other settings or anything that is not an atlas's.
        OutputError: a file of the atlas cannot be written.
        MissingDependency: pandas, pyarrow, dask[distributed] or tqdm missing.
        TypeError: a keyword that is no setting, or settings given twice.
    """
    settings = _settings_of(settings, args, keywords)
    execution, frontier = settings.execution, settings.frontier
    if execution.figures:
        require("plotly", "atlas")
    resolver_objects = list(settings.resolvers)
    out = writable_path(settings.out, directory=True)
    if out.exists() and not out.is_dir():
        raise OutputError(f"cannot write the atlas to '{out}': it is a file; give a folder")
    writable_paths(out / name for name in (_CONFIG, *_RESULT_FILES))
    if execution.scheduler is None and execution.workers != 0:
        # The local cluster's fork server imports torqueopt and distributed while this process imports pandas and
        # distributed and draws the population: started with the cluster, its imports came after all of those.
        # Started once the settings are known good, so that a refused call leaves no server behind.
        start_fork_server()
    pandas = require("pandas")
    require("pyarrow")

    loaded, reach, movements = _load_and_draw(settings)

    config = atlas_config(settings, loaded, reach, len(movements))
    digest = config_digest(config)
    resume = _check_folder(out, config)

    chunks, local_chunks, frames, done = _sweep(settings, out, movements, config, digest, resume)

    order = [r.label for r in resolver_objects] + ([GLOBAL_RESOLVER] if frontier.global_optimum else [])
    table = collect(pandas, [frames[index] for index in range(len(chunks))], order)
    if frontier.global_optimum:
        table = add_global_ratios(table)
    stored_traces = functools.partial(_stored_traces, out, chunks[:local_chunks], digest)
    summary = _write_report(settings, out, table, config, loaded, movements, len(done), stored_traces)
    return AtlasResult(table=table, summary=summary, out=out)


run_atlas.__doc__ = run_atlas.__doc__.replace("        {arguments}", AtlasSettings.arguments_doc("        "))


def _sweep(settings: AtlasSettings, out: Path, movements, config: dict, digest: str, resume: bool) -> tuple:
    """Run the chunks not done yet (read the others), holding the folder: (the chunks, how many are the resolvers'
    before the global ones, ``{index: frame}`` of every chunk, the indices that were done before)."""
    execution, frontier = settings.execution, settings.frontier
    chunks = _chunks(movements, execution.chunk_size)
    local_chunks = len(chunks)
    if frontier.global_optimum:  # the global rows in chunks of their own, after the resolvers' (smaller: ~1 s a path)
        chunks += _chunks(movements, min(execution.chunk_size, DEFAULT_GLOBAL_CHUNK_SIZE))
    frames, rejected = read_chunks(out, len(chunks), digest) if resume else ({}, [])
    done = set(frames)
    jobs = _pending_jobs(settings, chunks, local_chunks, done, digest, config)
    kept_paths = _kept_paths(settings, frames) if jobs else None
    if rejected:
        warnings.warn(
            f"recomputing {len(rejected)} of {len(chunks)} chunks, which do not match this atlas: {', '.join(rejected)}",
            TorqueoptWarning,
            stacklevel=3,
        )
    description = f"{command_name('torqueopt atlas')}: {len(movements):,} paths x {len(settings.resolvers)} resolvers"
    if frontier.global_optimum:
        description += " and the global optimum of each (a path counted twice)"
    # The scheduler is reached (or the cluster started) before the first file is written.
    with (
        contextlib.ExitStack() as lock,  # the folder, held while its chunks run (a second atlas would redo them)
        (
            executor(execution.scheduler, execution.workers, execution.progress) if jobs else contextlib.nullcontext()
        ) as client,
    ):
        if not resume:
            _claim_folder(out, config)
        lock.enter_context(held_exclusively(out / _CONFIG, "torqueopt atlas"))
        remove_partial_chunks(out)
        if jobs:
            frames.update(
                run_chunks(
                    jobs, out, client, progress=execution.progress,
                    total_paths=len(movements) * (2 if frontier.global_optimum else 1),
                    done_paths=sum(len(chunks[index]) for index in done), description=description,
                    # This process loads what the report needs on the core the sweep's last chunks leave idle.
                    once_a_worker_idles=import_scipy_stats_meanwhile, kept_paths=kept_paths,
                )
            )  # fmt: skip
    return chunks, local_chunks, frames, done


def _check_plant(settings: AtlasSettings, robot) -> None:
    """Build the plant once before any work (its options checked, MuJoCo's model compiled), and refuse what a
    plant other than the robot's own model cannot give: velocity-level resolvers, the global optimum's rows."""
    from ..plants import make_plant
    from ..simulate import refuse_plant_at_velocity_level

    plant, options = settings.simulation.plant, dict(settings.simulation.plant_options)
    make_plant(robot, plant, options)
    for resolver in settings.resolvers:
        if getattr(resolver, "level", None) == "velocity":
            refuse_plant_at_velocity_level(resolver, plant, options)
    if settings.frontier.global_optimum:
        raise InvalidInput(
            f"--global judges each optimum by replaying its torques on the robot's own model, not on --plant {plant}: "
            "run the global optimum in an atlas without --plant"
        )


def _load_and_draw(settings: AtlasSettings) -> tuple:
    """(the robot, its reach [m], the population's movements), the sweep's size checked against ``max_steps``
    before anything is drawn and again once it is."""
    execution, frontier, dt = settings.execution, settings.frontier, settings.population.dt
    population = settings.population_spec()
    if frontier.global_bounded and not frontier.global_optimum:
        raise InvalidInput(
            "--global-bounded (global_bounded=True) says how the global optimum is solved: give --global "
            "(global_optimum=True) too"
        )
    # Bound the work before drawing anything: the population's size is known up front in random mode.
    max_steps = execution.max_steps
    steps_per_run = {duration: round(duration / dt) + 1 for duration in population.durations}
    work = _Work(len(settings.resolvers), frontier.global_optimum, frontier.margin, frontier.margin_every / dt)
    if population.mode == "random":
        _check_size(population.paths * sum(steps_per_run.values()) * work.per_step, max_steps, population, work)

    with said_if_slow(
        f"{command_name('torqueopt atlas')}: loading robot '{settings.robot.source}'", enabled=execution.progress
    ):
        loaded = settings.robot.load()
    for resolver in settings.resolvers:
        resolver.check(loaded)
    if frontier.global_optimum:
        check_transcription(loaded, population.durations, torque_bounds=frontier.global_bounded)
    if not settings.simulation.is_default():
        _check_plant(settings, loaded)
    if population.mode == "grid":
        # Counted, not built: the grid's start points bound its movements before any inverse kinematics.
        _check_grid_size(grid_start_points(loaded, population), steps_per_run, max_steps, population, work, dt)
    reach = arm_reach(loaded)[1]
    population = population.sized(reach)  # the acceleration, when not given, from the arm's reach
    movements = draw_population(loaded, population, progress=execution.progress)
    total_steps = sum(steps_per_run[m.duration] for m in movements) * work.per_step
    _check_size(total_steps, max_steps, population, work)
    return loaded, reach, movements


def _stored_traces(out: Path, chunks, digest: str, paths):
    """The kept traces of the resolver ``chunks`` that hold ``paths`` (None for a chunk without them), read one
    chunk at a time."""
    wanted = set(paths)
    for index, chunk in enumerate(chunks):
        if any(movement.path in wanted for movement in chunk):
            yield Traces.read(traces_path(out, index), digest, index)[0]


def _kept_traces(settings: AtlasSettings) -> int:
    """How many paths' traces the explorer keeps: none without the figures."""
    return settings.execution.keep_traces if settings.execution.figures else 0


def _kept_paths(settings: AtlasSettings, frames: dict) -> KeptPaths | None:
    """The paths whose traces the chunks still to run may need to write, told the rows of those done."""
    if not _kept_traces(settings):
        return None
    kept = KeptPaths(_kept_traces(settings), 2 if settings.frontier.global_optimum else 1)
    for frame in frames.values():
        kept.tell_rows(frame)
    return kept


def _pending_jobs(settings: AtlasSettings, chunks, local_chunks: int, done, digest: str, config: dict) -> dict:
    """``{chunk index: job}`` of the chunks not done yet, sent in the order of their first path, each resolver
    chunk before the global chunks of its paths: the paths finish in order, both halves of a path together, so a
    sweep stopped early leaves a whole prefix of paths."""
    frontier, dt = settings.frontier, settings.population.dt
    margin_every = frontier.margin_every if frontier.margin else None
    jobs = {}
    for index, chunk in enumerate(chunks):
        if index in done:
            continue
        if index >= local_chunks:
            jobs[index] = GlobalChunk(settings.robot, tuple(chunk), dt, settings.verdicts, digest, config["global"])
        else:
            jobs[index] = ResolverChunk(
                settings.robot, settings.resolvers, tuple(chunk), dt, settings.verdicts, settings.execution.batch,
                digest, margin_every, settings.simulation.plant, settings.simulation.plant_options,
                _kept_traces(settings), 2 if frontier.global_optimum else 1,
            )  # fmt: skip
    return dict(sorted(jobs.items(), key=lambda item: (item[1].movements[0].path, isinstance(item[1], GlobalChunk))))


def _write_report(
    settings: AtlasSettings, out: Path, table, config: dict, robot, movements, resumed_chunks: int, stored_traces
):
    """Write the table, the summaries and (unless ``figures`` is off) the figures and the explorer, together;
    returns the summary. ``stored_traces`` is :func:`~torqueopt.atlas.explorer.page_traces`'s ``stored``."""
    # Imported here, not with the package: `python -m torqueopt.atlas.frontier` runs a module the report imports.
    from .report import summarise, write_figures, write_markdown

    execution = settings.execution
    summary = summarise(table, config)
    summary["resumed_chunks"] = resumed_chunks
    traces = (
        explorer.page_traces(
            robot, table, movements, list(settings.resolvers), stored_traces, dt=settings.population.dt,
            batch=execution.batch, keep=execution.keep_traces, plant=settings.simulation.plant,
            plant_options=dict(settings.simulation.plant_options), progress=execution.progress,
        )
        if execution.figures
        else {}
    )  # fmt: skip
    with written_together():
        atomic_write(out / "results.parquet", lambda handle: table.to_parquet(handle, index=False))
        text = json_text(summary).encode()
        atomic_write(out / "atlas.json", lambda handle: handle.write(text))
        if execution.figures:
            summary["figures"] = write_figures(table, summary, out, robot)
            summary["figures"]["explorer: the map, and the runs of each kept path"] = explorer.write_explorer(
                out / "explorer.html", table, summary, traces, execution.keep_traces
            )
        markdown = write_markdown(summary).encode()
        atomic_write(out / "atlas.md", lambda handle: handle.write(markdown))
    return summary


def _settings_of(settings, args: tuple, keywords: dict) -> AtlasSettings:
    """The AtlasSettings of run_atlas's arguments: given whole, or made from the settings themselves."""
    if isinstance(settings, AtlasSettings):
        if args or keywords:
            raise TypeError("run_atlas() takes AtlasSettings alone, or the settings themselves, not both")
        return settings
    if len(args) >= len(_POSITIONAL):
        raise TypeError(f"run_atlas() takes at most {len(_POSITIONAL)} settings by position ({', '.join(_POSITIONAL)})")
    positional = dict(zip(_POSITIONAL, (settings, *args)))
    if settings is None:  # no robot given by position: the default, or the keyword's
        del positional["robot"]
    twice = sorted(set(positional) & set(keywords))
    if twice:
        raise TypeError(f"run_atlas() got {', '.join(twice)} by position and by keyword")
    return AtlasSettings.from_keywords(**positional, **keywords)


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
