"""The report of an atlas stopped before its end: the whole prefix of paths its landed chunks cover.

The sweep sends its chunks path by path (each resolver chunk before the
global-optimum chunks of the same paths), so a sweep stopped early has
finished every run of paths 0 .. P-1 for some P and a few runs beyond.
:func:`prefix_report` reads the chunks that prove to be the atlas's
(``torqueopt.atlas.sweep.read_chunk``), keeps the paths below the first
path that lacks a run, and writes ``atlas.md``, ``atlas.json``,
``results.parquet`` and the figures of those paths into another folder, with
the same functions as a finished atlas (:mod:`torqueopt.atlas.report`).
``atlas.json``'s ``partial`` says how many paths of how many it covers; the
sweep itself is left as it was, to be resumed with its own command. On a
finished atlas it writes the whole atlas's report again, with the summary
this version of the package computes (and no ``partial``).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from ..errors import InvalidInput
from ..io import atomic_write, json_text, written_together
from ..loading import load_robot
from .frontier import readme_answer, write_atlas_page
from .global_optimum import GLOBAL_RESOLVER, add_global_ratios
from .report import summarise, write_figures, write_markdown
from .sweep import CHUNK_FOLDER, collect, config_digest, read_chunk, require

__all__ = ["main", "prefix_report", "prefix_rows"]


def prefix_rows(out, config: dict) -> tuple:
    """(the rows of the paths 0 .. P-1 whose runs have all landed in the atlas folder ``out``, sorted by path and
    resolver, with the global ratios where the atlas has a global optimum; P), ``config`` its ``atlas-config.json``.

    Raises:
        InvalidInput: no chunk of this atlas has landed yet.
    """
    pandas = require("pandas")
    digest = config_digest(config)
    frames = []
    for path in sorted((Path(out) / CHUNK_FOLDER).glob("chunk-*.parquet")):
        frame, _ = read_chunk(path, digest, int(path.stem.split("-")[1]))
        if frame is not None:
            frames.append(frame)
    if not frames:
        raise InvalidInput(f"'{out}' has no finished chunk of this atlas yet")
    table = pandas.concat(frames, ignore_index=True)
    resolvers = [item.get("label", item["name"]) for item in config["resolvers"]]
    order = resolvers + ([GLOBAL_RESOLVER] if "global" in config else [])
    runs = table.groupby("path")["resolver"].nunique()
    whole = set(runs.index[runs == len(order)])
    paths = 0
    while paths in whole:
        paths += 1
    table = collect(pandas, [table[table["path"] < paths]], order)
    return (add_global_ratios(table) if "global" in config else table), paths


def prefix_report(out, dest, *, note: str = "") -> dict:
    """Write the report of the paths 0 .. P-1 whose runs have all landed in the atlas folder ``out`` into ``dest``.

    Args:
        out: the folder of a sweep (``atlas-config.json``, ``chunks/``).
        dest: a new or empty folder for the report.
        note: a paragraph put under the report's title (``{paths}`` is replaced by P).

    Returns:
        The summary, as ``dest/atlas.json`` holds it.
    """
    out, dest = Path(out), Path(dest)
    config = json.loads((out / "atlas-config.json").read_text())
    if dest.exists() and any(dest.iterdir()):
        raise InvalidInput(f"'{dest}' is not empty: give a new or empty folder for the report")
    table, paths = prefix_rows(out, config)
    if not paths:
        raise InvalidInput(f"'{out}' has not finished every run of its first path yet")
    summary = summarise(table, config)
    if paths < int(config["movements"]):  # the report of a finished atlas is no part of one
        summary["partial"] = {"paths": paths, "of": int(config["movements"])}
    dest.mkdir(parents=True, exist_ok=True)
    robot = load_robot(config["robot"]["source"], frame=config["robot"]["frame"], task=config["robot"]["task"])
    with written_together():
        atomic_write(dest / "results.parquet", lambda handle: table.to_parquet(handle, index=False))
        text = json_text(summary).encode()
        atomic_write(dest / "atlas.json", lambda handle: handle.write(text))
        summary["figures"] = write_figures(table, summary, dest, robot)
        markdown = write_markdown(summary)
        if note:
            title, rest = markdown.split("\n", 1)
            markdown = f"{title}\n\n{note.replace('{paths}', str(paths))}\n{rest}"
        atomic_write(dest / "atlas.md", lambda handle: handle.write(markdown.encode()))
    return summary


def main(argv=None) -> int:
    """``python -m torqueopt.atlas.frontier page FOLDER DOCS NAME [NOTE]``
    (:func:`~torqueopt.atlas.frontier.write_atlas_page`; a sweep's folder gets its :func:`prefix_report` first) and
    ``python -m torqueopt.atlas.frontier readme README.md SUMMARY.json``
    (:func:`~torqueopt.atlas.frontier.readme_answer`)."""
    command, *args = list(sys.argv[1:] if argv is None else argv)
    if command == "page" and len(args) in (3, 4):
        folder, note = Path(args[0]), args[3] if len(args) == 4 else ""
        if (folder / "atlas-config.json").is_file() and (folder / "chunks").is_dir():
            # A sweep's folder, finished or not: its report again, of its whole prefix of finished paths, with the
            # summary this version computes.
            with tempfile.TemporaryDirectory() as report:
                prefix_report(folder, report)
                print(write_atlas_page(report, args[1], args[2], note))
        else:
            print(write_atlas_page(folder, args[1], args[2], note))
        return 0
    if command == "readme" and len(args) == 2:
        readme = Path(args[0])
        readme.write_text(readme_answer(readme.read_text(), json.loads(Path(args[1]).read_text())))
        return 0
    print(
        "usage: python -m torqueopt.atlas.frontier page FOLDER DOCS NAME [NOTE] | readme README.md SUMMARY.json",
        file=sys.stderr,
    )
    return 2


if __name__ == "__main__":
    raise SystemExit(main())
