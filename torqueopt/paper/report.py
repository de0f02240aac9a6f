"""The paper's results as files: ``summary.json`` and ``summary.md`` beside the figures."""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import InvalidInput
from ..io import atomic_write, written_together
from ..plots import FIGURE_FORMATS
from .alignment import alignment_times
from .figures import write_figures
from .runner import PaperResults
from .scenario import PAPER_RESOLVERS

__all__ = ["format_summary_markdown", "paper_files", "summary_entries", "write_paper"]


def summary_entries(results: PaperResults) -> list[dict]:
    """One JSON-ready entry per (movement, resolver) run, the rows of ``summary.json``."""
    entries = []
    for (movement, name), result in results.runs.items():
        report = results.whiplash[movement, name]
        entries.append(
            {
                "movement": movement,
                "resolver": name,
                "duration": result.duration,
                "peak_torque": result.peak_torque.tolist(),
                "torque_limit": [float(x) if np.isfinite(x) else None for x in result.torque_upper],
                "first_limit_violation": result.first_limit_violation,
                "unstable": report.unstable,
                "instability_time": report.time,
                "max_tip_error": result.max_tip_error,
            }
        )
    return entries


def paper_files(
    out_dir: str | os.PathLike, figure_format: str = "png", remedies: bool = True, sweep: bool = True
) -> list[Path]:
    """The files :func:`write_paper` writes into ``out_dir``, known before the work so that a command can check them.

    ``remedies``: with the remedies study (``remedies_long``); ``sweep``: with
    its sweep (``remedies_tradeoff``). The order is :func:`write_paper`'s.
    """
    figure_format = _figure_format(figure_format)
    out = Path(out_dir)
    stems = [
        *(f"fig{i}" for i in range(2, 8)),
        *(f"arm_long_{name}" for name in PAPER_RESOLVERS),
        "tip_long",
        *(["remedies_long"] if remedies else []),
        *(["remedies_tradeoff"] if remedies and sweep else []),
    ]
    return [*(out / f"{stem}.{figure_format}" for stem in stems), out / "summary.json", out / "summary.md"]


def write_paper(
    results: PaperResults, out_dir: str | os.PathLike, studies: Sequence = (), figure_format: str = "png"
) -> list[Path]:
    """Write Figures 2-7, the long-movement stick-figure strips, summary.json and summary.md into ``out_dir``.

    ``studies`` (see :class:`torqueopt.studies.Study`) add their figures, a
    key of ``summary.json`` each and a section of ``summary.md`` each.
    ``figure_format`` (``png``, ``pdf`` or ``svg``) is every figure's format.
    The files (:func:`paper_files` names them) land together or not at all.
    """
    figure_format = _figure_format(figure_format)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"output '{out}' exists and is not a directory")
    with written_together():
        return _write_paper(results, out, studies, figure_format)


def _write_paper(results: PaperResults, out: Path, studies: Sequence, figure_format: str) -> list[Path]:
    written = write_figures(results, out, figure_format)
    study_figures = [study.write_figures(out, figure_format) for study in studies]
    scenario, swing = results.scenario, results.free_swing

    summary = {
        "scenario": scenario.as_dict(),
        "whiplash": {
            "definition": (
                "unstable from the first sample at which some joint needs more than limit_factor times its "
                "torque limit (joints without a limit: more than growth_factor times the largest starting "
                "torque of such joints); see torqueopt.whiplash"
            ),
            "limit_factor": results.limit_factor,
            "growth_factor": results.growth_factor,
        },
        "runs": summary_entries(results),
        "free_swing": {
            "gravity": results.free_swing_gravity.tolist(),
            "duration": swing.duration,
            "peak_joint_speed": np.abs(swing.v).max(axis=0).tolist(),
            "peak_joint_speed_time": [float(swing.t[i]) for i in np.abs(swing.v).argmax(axis=0)],
            "links_2_3_aligned": alignment_times(swing),
        },
        "claims": [dataclasses.asdict(claim) for claim in results.claims],
        **{study.key: study.summary() for study in studies},
        "figures": [path.name for path in (*written, *(path for paths in study_figures for path in paths))],
    }
    summary_json = (json.dumps(summary, indent=2) + "\n").encode()
    atomic_write(out / "summary.json", lambda handle: handle.write(summary_json))
    markdown = format_summary_markdown(results, [path.name for path in written])
    for study, paths in zip(studies, study_figures):
        markdown += "\n" + study.markdown([path.name for path in paths])
    encoded = markdown.encode()
    atomic_write(out / "summary.md", lambda handle: handle.write(encoded))
    study_paths = [path for paths in study_figures for path in paths]
    return [*written, *study_paths, out / "summary.json", out / "summary.md"]


def format_summary_markdown(results: PaperResults, figures: list[str]) -> str:
    """``summary.md``: the numbers of ``summary.json`` as tables, for a reader of the output folder.

    What the numbers mean and what they answer is said by the documentation's pages (docs/paper.md).
    """
    lines = [
        "# Hollerbach & Suh 1987, reproduced by torqueopt",
        "",
        "| movement | resolver | duration [s] | peak torque [N·m] | limit [N·m] | first limit violation [s] "
        "| unstable | instability time [s] | max tip error [mm] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for entry in summary_entries(results):
        limits = ["none" if x is None else f"{x:g}" for x in entry["torque_limit"]]
        lines.append(
            f"| {entry['movement']} | {entry['resolver']} | {entry['duration']:g} | {_listed(entry['peak_torque'])} "
            f"| {', '.join(limits)} | {_number(entry['first_limit_violation'], '.3f')} "
            f"| {'**yes**' if entry['unstable'] else 'no'} | {_number(entry['instability_time'], '.3f')} "
            f"| {entry['max_tip_error'] * 1e3:.3g} |"
        )
    stopped = [f"- {m} {n}: {results.runs[m, n].stop_reason}" for m, n in results.stopped_early]
    if stopped:
        lines += ["", "Stopped early:", "", *stopped]
    swing = results.free_swing
    lines += [
        "",
        "## Free swing (Fig. 7)",
        "",
        "| joint | peak speed [rad/s] | at t [s] |",
        "|---|---|---|",
        *(
            f"| {name} | {np.abs(swing.v[:, j]).max():.3g} | {swing.t[np.abs(swing.v[:, j]).argmax()]:.3f} |"
            for j, name in enumerate(swing.joint_names)
        ),
        "",
        f"Links 2 and 3 in line at t [s]: {_listed(alignment_times(swing), '.3f') or 'never'}.",
        "",
        "## The paper's claims",
        "",
        "| claim | verdict |",
        "|---|---|",
        *(f"| {claim.number} | **{'holds' if claim.holds else 'DOES NOT HOLD'}** |" for claim in results.claims),
        "",
        "## Figures",
        "",
        *(f"- `{name}`" for name in figures),
    ]
    return "\n".join(lines) + "\n"


def _listed(values, spec: str = ".3g") -> str:
    return ", ".join(format(x, spec) for x in values)


def _number(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def _figure_format(name: str) -> str:
    """``name`` as one of :data:`torqueopt.plots.FIGURE_FORMATS`, or InvalidInput listing them."""
    if name not in FIGURE_FORMATS:
        raise InvalidInput(f"figure format '{name}' is not one of {', '.join(FIGURE_FORMATS)}")
    return name
