"""The explorer's kept traces: what a chunk keeps of its runs for ``explorer.html``, and which paths may be kept.

The page shows the runs of at most ``keep`` paths (:func:`choose_paths`: those where a resolver whips first, then
the others, in path order). The workers simulate every path already; each chunk keeps, of the paths that may
still be chosen (:class:`KeptPaths`, told the rows known so far), what the page draws of each run
(:func:`run_trace`: at most :data:`MAX_SAMPLES` samples of the torque, the arm at the whip and at the start), and
the client writes them beside the chunk's rows (:class:`Traces`, ``chunk-NNNNNN.traces.npz``), so a resumed atlas
finds them too and no path is simulated again after the sweep.
"""

from __future__ import annotations

import bisect
import json
import math
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .verdicts import applied_rows

__all__ = ["MAX_SAMPLES", "KeptPaths", "Traces", "choose_paths", "run_trace"]

#: Samples kept per run and joint (evenly spaced, plus each joint's peak).
MAX_SAMPLES = 300
#: The version of the trace file's layout, recorded in its proof.
_FORMAT = 1


def choose_paths(table, keep: int) -> list[int]:
    """The paths whose traces are kept: those where any resolver whips first, then the others; at most ``keep``."""
    paths = sorted(int(p) for p in table["path"].unique())
    whipped = {int(p) for p in table.loc[table["verdict"] == "whiplash", "path"]}
    ordered = [p for p in paths if p in whipped] + [p for p in paths if p not in whipped]
    return ordered[: max(int(keep), 0)]


class KeptPaths:
    """Which paths :func:`choose_paths` may still keep, told the table's rows a part at a time.

    A whipped path is kept while fewer than ``keep`` whipped paths lie below it; a calm one while the whipped
    paths and the calm ones below it are fewer than ``keep``. Rows told later only add to those counts, so a path
    ruled out by part of the table is out of the whole table's choice too, and told every row the answer is
    :func:`choose_paths`'s. A path comes in ``parts`` (2 with the global optimum: its resolver chunk and its
    global chunk): until every part is told, it may still whip. Memory: the ``keep`` lowest whipped and calm
    paths, the whipped paths and those with a part still to come.
    """

    def __init__(self, keep: int, parts: int = 1):
        self.keep, self.parts = max(int(keep), 0), int(parts)
        self._whipped: set[int] = set()
        self._lowest_whipped: list[int] = []  # sorted, at most keep
        self._lowest_calm: list[int] = []  # sorted, at most keep: paths told whole and calm
        self._parts_told: Counter = Counter()  # paths not whipped so far with a part still to come

    def tell(self, paths, whipped) -> None:
        """One part of each of ``paths`` (a chunk's), of which those in ``whipped`` have a whiplash row."""
        for path in map(int, paths):
            if path in self._whipped:
                continue
            if path in whipped:
                self._parts_told.pop(path, None)
                self._whipped.add(path)
                self._insert(self._lowest_whipped, path)
            elif self._parts_told[path] + 1 >= self.parts:
                self._parts_told.pop(path, None)
                self._insert(self._lowest_calm, path)
            else:
                self._parts_told[path] += 1

    def tell_rows(self, rows) -> None:
        """Tell a chunk's rows: plain dicts or a DataFrame with ``path`` and ``verdict``."""
        if hasattr(rows, "columns"):
            paths, verdicts = rows["path"].tolist(), rows["verdict"].tolist()
        else:
            paths, verdicts = [row["path"] for row in rows], [row["verdict"] for row in rows]
        whipped = {int(path) for path, verdict in zip(paths, verdicts) if verdict == "whiplash"}
        self.tell(dict.fromkeys(int(path) for path in paths), whipped)

    def may_keep(self, path: int) -> bool:
        """Whether ``path`` (told at least one part) may be among the kept paths, on what was told so far."""
        path = int(path)
        whipped = path in self._whipped
        may_whip = whipped or path in self._parts_told
        if may_whip and bisect.bisect_left(self._lowest_whipped, path) < self.keep:
            return True
        return not whipped and len(self._whipped) + bisect.bisect_left(self._lowest_calm, path) < self.keep

    def _insert(self, lowest: list[int], path: int) -> None:
        bisect.insort(lowest, path)
        if len(lowest) > self.keep:
            lowest.pop()


def run_trace(robot, result, whip_time: float) -> dict:
    """What the page draws of one run: ``t`` [s] and ``tau`` (samples × joints) [N·m] at ``kept_rows``, the
    arm's points (x, y) [m] at the sample nearest ``whip_time`` (the last applied one when it is NaN) and at the
    start, and ``arm_time`` [s]. The torques are those applied (``torqueopt.atlas.verdicts.applied_rows``),
    as the table's figures read them."""
    from ..plots.stick import arm_points

    result = applied_rows(result)[0]
    rows = kept_rows(result)
    whip_row = int(np.argmin(np.abs(result.t - whip_time))) if math.isfinite(whip_time) else len(result.t) - 1
    return {
        "t": result.t[rows],
        "tau": result.tau[rows],
        "arm": arm_points(robot, result.joint_angles[whip_row])[:, :2],
        "start_arm": arm_points(robot, result.joint_angles[0])[:, :2],
        "arm_time": float(result.t[whip_row]),
    }


def kept_rows(result) -> np.ndarray:
    """At most MAX_SAMPLES evenly spaced rows, with each joint's row of peak |τ|/τ⁺ (a whip's spike is kept)."""
    count = len(result.t)
    rows = set(np.linspace(0, count - 1, min(count, MAX_SAMPLES)).round().astype(int).tolist())
    ratio = np.nan_to_num(np.abs(result.torque_ratio), nan=-1.0)
    rows.update(int(r) for r in np.argmax(ratio, axis=0))
    return np.array(sorted(rows))


@dataclass(frozen=True)
class Traces:
    """The :func:`run_trace` of several runs, packed: run ``i`` is path ``path[i]`` by resolver
    ``resolvers[resolver[i]]``, its samples ``t[start[i]:start[i + 1]]`` (and the rows of ``tau``)."""

    resolvers: tuple[str, ...]
    path: np.ndarray
    resolver: np.ndarray
    start: np.ndarray
    t: np.ndarray
    tau: np.ndarray
    arm: np.ndarray
    start_arm: np.ndarray
    arm_time: np.ndarray

    @classmethod
    def pack(cls, resolvers, runs: list[tuple[int, str, dict]], joints: int, points: int) -> Traces:
        """``runs``: (path, resolver label, :func:`run_trace`) in the order the page lists them."""
        resolvers = tuple(resolvers)
        counts = [len(trace["t"]) for _, _, trace in runs]
        return cls(
            resolvers=resolvers,
            path=np.array([path for path, _, _ in runs], dtype=np.int64),
            resolver=np.array([resolvers.index(label) for _, label, _ in runs], dtype=np.int64),
            start=np.concatenate([[0], np.cumsum(counts, dtype=np.int64)]).astype(np.int64),
            t=np.concatenate([trace["t"] for _, _, trace in runs]) if runs else np.zeros(0),
            tau=np.concatenate([trace["tau"] for _, _, trace in runs]) if runs else np.zeros((0, joints)),
            arm=np.array([trace["arm"] for _, _, trace in runs]).reshape(len(runs), points, 2),
            start_arm=np.array([trace["start_arm"] for _, _, trace in runs]).reshape(len(runs), points, 2),
            arm_time=np.array([trace["arm_time"] for _, _, trace in runs], dtype=float),
        )

    def only(self, paths) -> Traces:
        """The runs of ``paths`` alone."""
        paths = {int(p) for p in paths}
        runs = [(int(p), self.resolvers[r], trace) for p, r, trace in self._runs() if int(p) in paths]
        return Traces.pack(self.resolvers, runs, self.tau.shape[1], self.arm.shape[1])

    def by_path(self) -> dict:
        """``{path: {resolver label: run_trace}}``, the runs of a path in the order they were packed."""
        kept: dict = {}
        for path, resolver, trace in self._runs():
            kept.setdefault(int(path), {})[self.resolvers[resolver]] = trace
        return kept

    def _runs(self):
        for i, (path, resolver) in enumerate(zip(self.path, self.resolver)):
            rows = slice(self.start[i], self.start[i + 1])
            trace = {
                "t": self.t[rows],
                "tau": self.tau[rows],
                "arm": self.arm[i],
                "start_arm": self.start_arm[i],
                "arm_time": float(self.arm_time[i]),
            }
            yield int(path), int(resolver), trace

    def write(self, handle, digest: str, index: int) -> None:
        """Write the traces as ``.npz`` (uncompressed: float64 as computed) to a binary ``handle``, with the atlas's
        fingerprint and the chunk's index: the proof :meth:`read` checks."""
        proof = json.dumps({"atlas": digest, "chunk": int(index), "format": _FORMAT})
        np.savez(
            handle, proof=np.array(proof), resolvers=np.array(self.resolvers, dtype=str), path=self.path,
            resolver=self.resolver, start=self.start, t=self.t, tau=self.tau, arm=self.arm,
            start_arm=self.start_arm, arm_time=self.arm_time,
        )  # fmt: skip

    @classmethod
    def read(cls, path: Path, digest: str, index: int) -> tuple[Traces | None, str | None]:
        """(the traces in ``path``, None) when they prove to be chunk ``index``'s of the atlas ``digest``, else
        (None, why not: missing, unreadable, another atlas's or chunk's). The zip's CRC32s are checked on reading."""
        import zipfile

        if not path.is_file():
            return None, "missing"
        try:
            with np.load(path, allow_pickle=False) as stored:
                arrays = {name: stored[name] for name in stored.files}
            proof = json.loads(str(arrays.pop("proof")))
            traces = cls(resolvers=tuple(str(r) for r in arrays.pop("resolvers")), **arrays)
        except (OSError, EOFError, ValueError, KeyError, TypeError, zipfile.BadZipFile):
            return None, "unreadable (truncated or corrupt)"
        if proof.get("format") != _FORMAT or proof.get("atlas") != digest or proof.get("chunk") != index:
            return None, "another atlas's or chunk's"
        return traces, None
