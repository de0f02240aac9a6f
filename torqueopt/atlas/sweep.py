"""Running the atlas: chunks of movements on a Dask cluster, each chunk's rows written as it lands.

Work goes out in chunks of movements of one duration (``chunk_size``
paths, default 64). A chunk runs every resolver on its movements (``pinv``
first: it is the baseline of the runaway criterion), batched by
``torqueopt.batch.simulate_batch`` (every registered resolver on the
position tasks: a vectorised step or its single-state step on stacks), by
:func:`torqueopt.simulate` otherwise (``batch=False``, other tasks). Each worker thread loads the robot once
and keeps it; every run makes its own Pinocchio ``Data``.

The client writes each finished chunk to ``chunks/chunk-NNNNNN.parquet``
atomically (a temporary file renamed into place) as soon as Dask's
``as_completed`` hands it over. Started again with the same settings, the
sweep finds the chunks already written and sends only the others, so a
sweep killed at any moment loses at most the chunks in flight, counts none
twice, and ends with the same table as an uninterrupted run: the table is
the chunks' rows sorted by path and resolver, and every chunk's rows are a
deterministic function of the settings (Dask may run a chunk twice: the
second gives the same file).

With the explorer on (``keep_traces``), a chunk also hands back what the page draws of the runs of the
paths it may keep (:mod:`torqueopt.atlas.traces`), and the client writes those that the chunks landed so far
still allow beside the rows, first: ``chunk-NNNNNN.traces.npz``.

A chunk is trusted only when it proves it is this atlas's: its Parquet
schema metadata (key ``torqueopt.atlas``) records the atlas fingerprint
(:func:`config_digest` of the settings), its index, its row count and a
SHA-256 of its rows (pandas' ``hash_pandas_object``), and its data pages
carry Parquet's own CRC32 page checksums, verified on reading. A chunk that
fails any of these (copied from another atlas, truncated, corrupt, written
before chunks carried a fingerprint) is recomputed, and :func:`read_chunks`
says which and why.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import NamedTuple

from ..batch import batch_supports, simulate_batch
from ..errors import InvalidInput, MissingDependency
from ..io import atomic_write
from ..optimal import run_cost
from ..progress import command_name, interrupt_deferred, progress_bar, said_if_slow
from ..resolvers import Resolver, get_resolver, resolver_from_label
from ..simulate import simulate
from .global_optimum import run_global_chunk
from .jobs import GlobalChunk, ResolverChunk, RobotSpec, worker_robot
from .margins import margin_columns
from .population import movement_trajectory
from .rows import movement_columns, path_columns, peak_applied_ratio, start_columns
from .traces import KeptPaths, Traces, run_trace
from .verdicts import run_row, self_motion_energy

__all__ = [
    "CHUNK_FOLDER",
    "ChunkOutput",
    "RobotSpec",
    "chunk_output",
    "chunk_path",
    "collect",
    "executor",
    "read_chunks",
    "run_chunk",
    "run_chunks",
    "simulate_all",
    "start_fork_server",
    "traces_path",
]

CHUNK_FOLDER = "chunks"
BASELINE = "pinv"
#: How long to try to reach a ``--scheduler`` before refusing it.
SCHEDULER_TIMEOUT = "20s"
#: The key of a chunk's Parquet schema metadata that proves it is this atlas's.
CHUNK_KEY = b"torqueopt.atlas"


def require(module: str, extra: str = "atlas"):
    """Import an optional dependency of the atlas, or MissingDependency naming the package to install."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        package = {"distributed": "dask[distributed]", "pyarrow": "pyarrow"}.get(module, module)
        raise MissingDependency(
            f"the atlas needs '{package}', which is not installed: pip install 'torqueopt[{extra}]'"
        ) from None


def chunk_path(out: Path, index: int) -> Path:
    return out / CHUNK_FOLDER / f"chunk-{index:06d}.parquet"


def traces_path(out: Path, index: int) -> Path:
    """Where chunk ``index``'s kept traces lie, beside its rows."""
    return out / CHUNK_FOLDER / f"chunk-{index:06d}.traces.npz"


class ChunkOutput(NamedTuple):
    """What a worker hands back for a chunk: its rows, and the traces of the paths the explorer may keep
    (None when the job keeps none, and for the global optimum's chunks)."""

    rows: list[dict]
    traces: Traces | None


def run_chunk(job: ResolverChunk | GlobalChunk) -> list[dict]:
    """The rows of one chunk (plain dicts): every resolver on every movement, pinv's first, or the global
    optimum of each movement (a :class:`~torqueopt.atlas.jobs.GlobalChunk`). The same job gives the same rows."""
    return chunk_output(job).rows


def chunk_output(job: ResolverChunk | GlobalChunk) -> ChunkOutput:
    """The rows of one chunk (:func:`run_chunk`) and, when the job keeps traces (``keep_traces``), each run's
    :func:`~torqueopt.atlas.traces.run_trace` on the paths the chunk's own rows leave among those the explorer may
    keep. Memory: the traces of the chunk's runs, each at most MAX_SAMPLES samples plus a peak per joint."""
    if isinstance(job, GlobalChunk):
        return ChunkOutput(run_global_chunk(job), None)
    robot = worker_robot(job.robot)
    movements = list(job.movements)
    lines = [movement_trajectory(m) for m in movements]
    q0s = [m.q0 for m in movements]
    rows: list[dict] = []
    runs: list[tuple[int, str, dict]] = []
    pinv_peaks = None
    for resolver in job.resolvers:
        results, energies = simulate_all(
            robot, resolver, lines, q0s, job.dt, job.batch, plant=job.plant, plant_options=dict(job.plant_options)
        )
        options_text = json.dumps(resolver.changed_settings(), sort_keys=True)
        if pinv_peaks is None:  # the first resolver is pinv, the baseline
            pinv_peaks = [peak_applied_ratio(result) for result in results]
        for movement, line, result, (kinetic, self_energy), pinv_peak in zip(
            movements, lines, results, energies, pinv_peaks
        ):
            row = movement_columns(movement, resolver.label)  # its name and changed options: a setting is a resolver
            row["resolver_options"] = options_text
            row.update(run_row(result, kinetic, self_energy, pinv_peak, job.thresholds))
            row["cost"] = run_cost(result, robot)  # ∫‖τ − τ_mid‖² dt, optimize's criterion, on the run's grid
            if job.margin_every is not None:
                row.update(margin_columns(robot, resolver, result, line, row, job.margin_every))
            row.update(start_columns(movement))
            row.update(path_columns(movement))
            row["pinv_peak_torque_ratio"] = pinv_peak
            row["batched"] = bool(job.batch and batch_supports(robot, resolver))
            rows.append(row)
            if job.keep_traces:
                runs.append((movement.path, row["resolver"], run_trace(robot, result, row["whip_time"])))
    if not job.keep_traces:
        return ChunkOutput(rows, None)
    kept = KeptPaths(job.keep_traces, job.parts_per_path)
    kept.tell_rows(rows)
    runs = [run for run in runs if kept.may_keep(run[0])]
    labels = [resolver.label for resolver in job.resolvers]
    return ChunkOutput(rows, Traces.pack(labels, runs, robot.nv, robot.model.njoints))  # arm_points' count


def simulate_all(robot, resolver, lines, q0s, dt, batch, *, plant="pinocchio", plant_options=None):
    """(results, [(kinetic energy, self-motion energy) per run]) for one resolver on a chunk's movements, the
    torques acting on ``plant`` (a name, with ``plant_options``, as :func:`torqueopt.plants.make_plant` takes)."""
    on_plant = {"plant": plant, "plant_options": plant_options or None}
    if batch and batch_supports(robot, resolver):
        results, energies = [None] * len(lines), [None] * len(lines)
        for duration in sorted({line.duration for line in lines}):
            members = [i for i, line in enumerate(lines) if line.duration == duration]
            runs, extras = simulate_batch(
                robot, resolver, [lines[i] for i in members], [q0s[i] for i in members], dt, extras=True, **on_plant
            )
            for i, run, extra in zip(members, runs, extras):
                results[i], energies[i] = run, (extra.kinetic_energy, extra.self_motion_energy)
        return results, energies
    results = [simulate(robot, resolver, line, q0, dt=dt, **on_plant) for line, q0 in zip(lines, q0s)]
    return results, [self_motion_energy(robot, result) for result in results]


def collect(pandas, frames: list, resolver_order: list[str]):
    """Every chunk's rows, sorted by path and resolver (the order of the settings)."""
    table = pandas.concat(frames, ignore_index=True)
    rank = {name: i for i, name in enumerate(resolver_order)}
    table = table.assign(_rank=table["resolver"].map(rank)).sort_values(["path", "_rank"], kind="stable")
    return table.drop(columns="_rank").reset_index(drop=True)


def config_digest(config: dict) -> str:
    return hashlib.sha256(json.dumps(config, sort_keys=True).encode()).hexdigest()[:16]


def rows_checksum(frame) -> str:
    """SHA-256 of a chunk's rows as pandas hashes them (every column's values, in order), and of its column names."""
    pandas = require("pandas")
    digest = hashlib.sha256(json.dumps(list(frame.columns)).encode())
    digest.update(pandas.util.hash_pandas_object(frame, index=False).to_numpy().tobytes())
    return digest.hexdigest()


def write_chunk(out: Path, index: int, rows: list[dict], digest: str):
    """Write one chunk's rows atomically as Parquet, with its proof of origin; returns the rows as read back.

    The schema metadata records the atlas fingerprint ``digest``, the
    chunk's index, its row count and :func:`rows_checksum`; the data pages
    carry Parquet's CRC32 page checksums. The same rows give the same file.
    """
    pandas = require("pandas")
    arrow = require("pyarrow")
    parquet = require("pyarrow.parquet")
    table = arrow.Table.from_pandas(pandas.DataFrame(rows), preserve_index=False)
    frame = table.to_pandas()  # what a reader gets back, which the checksum is of
    proof = {"atlas": digest, "chunk": int(index), "rows": len(frame), "checksum": rows_checksum(frame)}
    table = table.replace_schema_metadata({**table.schema.metadata, CHUNK_KEY: json.dumps(proof).encode()})
    atomic_write(chunk_path(out, index), lambda handle: parquet.write_table(table, handle, write_page_checksum=True))
    return frame


def read_chunk(path: Path, digest: str, index: int):
    """The rows of the chunk at ``path`` when it proves to be chunk ``index`` of the atlas ``digest``.

    Returns:
        (frame, None), or (None, why it does not match, in a few words).
    """
    parquet = require("pyarrow.parquet")
    arrow = require("pyarrow")
    try:
        table = parquet.read_table(path, page_checksum_verification=True)
        frame = table.to_pandas()
    except (OSError, ValueError, arrow.ArrowException):
        return None, "unreadable (truncated or corrupt)"
    metadata = table.schema.metadata or {}
    if CHUNK_KEY not in metadata:
        return None, "written without the atlas fingerprint"
    try:
        proof = json.loads(metadata[CHUNK_KEY])
        atlas, chunk, rows, checksum = proof["atlas"], proof["chunk"], proof["rows"], proof["checksum"]
    except (ValueError, TypeError, KeyError):
        return None, "its fingerprint is unreadable (corrupt)"
    if atlas != digest:
        return None, "written by another atlas (other settings)"
    if chunk != index:
        return None, f"it is chunk {chunk}, not chunk {index}"
    if rows != len(frame) or checksum != rows_checksum(frame):
        return None, "its rows do not match their checksum (corrupt)"
    return frame, None


def read_chunks(out: Path, count: int, digest: str) -> tuple[dict, list[str]]:
    """The chunks already written that prove to be this atlas's, and a note on each that does not.

    Returns:
        The pair ``({index: rows as a DataFrame}, ["chunk-NNNNNN.parquet (why)", ...])``;
        only whole files are looked at (a partial one never gets its final name).
    """
    done, rejected = {}, []
    folder = out / CHUNK_FOLDER
    if not folder.is_dir():
        return done, rejected
    for index in range(count):
        path = chunk_path(out, index)
        if not path.is_file():
            continue
        frame, why = read_chunk(path, digest, index)
        if frame is None:
            rejected.append(f"{path.name} ({why})")
        else:
            done[index] = frame
    return done, rejected


def remove_partial_chunks(out: Path) -> None:
    """Delete temporary chunk files left by a killed run (ours: ``.chunk-*.part``)."""
    folder = out / CHUNK_FOLDER
    if folder.is_dir():
        for path in folder.glob(".chunk-*.part"):
            path.unlink(missing_ok=True)


@contextlib.contextmanager
def executor(scheduler: str | None, workers: int | None, progress: bool = False) -> Iterator:
    """Where the chunks run: a Dask client (to ``scheduler``, or a new LocalCluster), or None for this process.

    Entered before anything is written, so that an unreachable scheduler
    leaves no file behind; the cluster is closed on leaving. With ``progress``,
    a start that takes more than a second says so on stderr
    (``torqueopt.progress.said_if_slow``).

    Raises:
        InvalidInput: the scheduler cannot be reached within :data:`SCHEDULER_TIMEOUT`.
    """
    if workers == 0 and scheduler is None:
        yield None
        return
    distributed = require("distributed")
    count = workers if workers else (os.cpu_count() or 1)
    what = f"reaching the Dask scheduler at {scheduler}" if scheduler else f"starting {count} Dask workers"
    with said_if_slow(
        f"{command_name('torqueopt atlas')}: {what}", enabled=progress
    ):  # seconds, more on a loaded machine
        client, cluster = _client(distributed, scheduler, workers)
    try:
        yield client
    finally:
        with interrupt_deferred():  # a Ctrl-C while the cluster closes waits for it, then ends the run
            client.close()
            if cluster is not None:
                cluster.close()


def run_chunks(
    jobs: dict[int, ResolverChunk | GlobalChunk],
    out: Path,
    client,
    *,
    progress,
    total_paths,
    done_paths,
    description,
    once_a_worker_idles: Callable[[], None] | None = None,
    kept_paths: KeptPaths | None = None,
) -> dict:
    """Run the pending chunks on ``client`` (an :func:`executor`), writing each as it finishes; returns their rows.

    With ``progress``, a bar of paths done on stderr (``torqueopt.progress.progress_bar``: on a terminal;
    one line ``description ...`` otherwise). ``once_a_worker_idles`` is called once, as soon as fewer chunks are
    left than the cluster has worker threads: what it starts (the report's imports) then takes a core that the
    sweep leaves idle, not one a worker computes on. ``kept_paths``, told the rows of the chunks done before,
    is told each chunk's rows as it lands, and a chunk's traces are written (:func:`traces_path`, before its
    rows) for the paths it may still keep.
    """
    bar = progress_bar(description, total=total_paths, unit="path", enabled=progress, initial=done_paths)
    frames = {}

    def land(index: int, output: ChunkOutput) -> None:
        rows, traces = output
        digest = jobs[index].digest
        if kept_paths is not None:
            kept_paths.tell_rows(rows)
        if kept_paths is not None and traces is not None:
            traces = traces.only(path for path in set(traces.path.tolist()) if kept_paths.may_keep(path))
            atomic_write(traces_path(out, index), lambda handle: traces.write(handle, digest, index))
        frames[index] = write_chunk(out, index, rows, digest)
        bar.update(len(jobs[index].movements))

    try:
        if client is None:
            for index, job in jobs.items():
                land(index, chunk_output(job))
            return frames
        distributed = require("distributed")
        futures = {}
        for index, job in jobs.items():
            futures[client.submit(chunk_output, job, pure=False, key=f"atlas-chunk-{job.digest}-{index}")] = index
        threads, left = sum(client.nthreads().values()), len(futures)

        def when_a_worker_idles():
            nonlocal once_a_worker_idles
            if once_a_worker_idles is not None and left < threads:
                once_a_worker_idles()
                once_a_worker_idles = None

        when_a_worker_idles()
        pending = distributed.as_completed(list(futures))
        # A Ctrl-C is held and read between polls, never raised inside Dask's waiting (a KeyboardInterrupt there
        # could leave the client's machinery half-way, and closing the cluster then hung): the chunks still
        # pending are cancelled and the block's end raises it.
        with interrupt_deferred() as interrupted:
            while not interrupted and not pending.is_empty():
                batch = pending.next_batch(block=False)
                if not batch:
                    time.sleep(_POLL_SECONDS)
                for future in batch:
                    left -= 1
                    when_a_worker_idles()
                    land(futures[future], future.result())
                    future.release()
            if interrupted:
                client.cancel(list(futures))
        return frames
    finally:
        bar.close()


#: How often the sweep looks for finished chunks and for a Ctrl-C [s].
_POLL_SECONDS = 0.05

_SCHEDULER_ADDRESS = re.compile(r"^(?:(?:tcp|tls)://)?(?:\[[0-9a-fA-F:.]+\]|[A-Za-z0-9_.-]+):[0-9]{1,5}$")


def scheduler_address(value) -> str | None:
    """``value`` when it reads as a Dask scheduler address (``tcp://HOST:PORT``, ``tls://``, or ``HOST:PORT``), else
    InvalidInput; None stays None (a local cluster)."""
    if value is None:
        return None
    text = str(value).strip()
    if not _SCHEDULER_ADDRESS.match(text) or not 0 < int(text.rsplit(":", 1)[1]) < 65536:
        raise InvalidInput(
            f"scheduler '{value}' is not a Dask scheduler address; give tcp://HOST:PORT (or tls://HOST:PORT), "
            "e.g. tcp://10.0.0.5:8786"
        )
    return text


def _client(distributed, scheduler, workers):
    """A Dask client: to ``scheduler`` when given, else to a new LocalCluster (one process per core)."""
    if scheduler is not None:
        try:
            return distributed.Client(scheduler, timeout=SCHEDULER_TIMEOUT), None
        except (OSError, ValueError) as error:
            raise InvalidInput(f"cannot reach the Dask scheduler at '{scheduler}': {error}") from None
    import logging

    count = workers if workers else (os.cpu_count() or 1)
    # Ctrl-C goes to the whole process group. The workers must not hear it (each printed a KeyboardInterrupt
    # traceback, or failed the cluster's start with one): multiprocessing's fork server forks them with SIGINT
    # ignored (torqueopt.atlas._fork_server). This process holds a Ctrl-C while the cluster starts (a start cut
    # short would leave processes behind), then closes the cluster and ends.
    dask = require("dask")
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        from distributed.utils import get_mp_context

        get_mp_context()  # Dask's forkserver context, with Dask's preload, which start_fork_server replaces
        start_fork_server()
        with interrupt_deferred() as interrupted:
            # Everything on the loopback interface: the embedded cluster serves no one else.
            cluster = distributed.LocalCluster(
                n_workers=count,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address="127.0.0.1:0",  # its HTTP server (health, metrics) on a free loopback port
                silence_logs=logging.ERROR,
            )
            try:
                client = distributed.Client(cluster)
            except BaseException:
                cluster.close()
                raise
            if interrupted:
                client.close()
                cluster.close()
    return client, cluster


def start_fork_server() -> None:
    """Start multiprocessing's fork server, which forks a LocalCluster's workers, unless it runs already.

    It preloads torqueopt.atlas._fork_server (torqueopt) and distributed, as Dask does: a second or two of
    imports, in its own process. Started before this process imports pandas and distributed (:func:`run_atlas`),
    the two import side by side, and the cluster forks its workers at once instead of waiting for them.

    SIGINT is blocked while the server is spawned, as Python's resource tracker is: the server is born deaf to
    a Ctrl-C (which would print the traceback of the import it cut short) and unblocks SIGINT once it ignores it
    (torqueopt.atlas._fork_server). This process's own Ctrl-C waits in the mask until the spawn is done.
    """
    import multiprocessing
    from multiprocessing import forkserver, resource_tracker

    multiprocessing.get_context("forkserver").set_forkserver_preload(["distributed", "torqueopt.atlas._fork_server"])
    resource_tracker.ensure_running()  # first: starting it unblocks SIGINT, which the server's start would do inside
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def resolvers_from(names) -> list[Resolver]:
    """Resolver objects from names, labels (``bounded-torque[joint_limits=off]``) or objects, pinv first (added
    when missing: it is the baseline, with its defaults), no label twice.

    One resolver may come several times with different options: each setting is its own resolver of the
    atlas, under its :attr:`~torqueopt.Resolver.label`.
    """
    if isinstance(names, (str, Resolver)):
        names = [names]
    resolvers = [resolver_from_label(name) for name in names]
    labels = [resolver.label for resolver in resolvers]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise InvalidInput(
            f"resolvers {', '.join(repeated)} given twice (the same options: a label names the options that differ "
            "from the defaults); give each setting once"
        )
    if not resolvers:
        raise InvalidInput("give at least one resolver")
    baseline = [resolver for resolver in resolvers if resolver.label == BASELINE]
    others = [resolver for resolver in resolvers if resolver.label != BASELINE]
    return (baseline or [get_resolver(BASELINE)]) + others
