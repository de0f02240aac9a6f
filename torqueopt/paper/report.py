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
from .scenario import MOVEMENTS, PAPER_RESOLVERS

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
    """The readable summary: scenario, instability definition, one row per run, the claims."""
    scenario = results.scenario
    q0 = ", ".join(f"{a:g}°" for a in np.degrees(scenario.q0).round(6))
    direction = np.asarray(scenario.direction) / np.linalg.norm(scenario.direction)
    lines = [
        "# Hollerbach & Suh 1987, reproduced by torqueopt",
        "",
        f"Scenario `paper`: arm `{scenario.robot}` (three 1 m, 10 kg thin rods, no gravity), q0 = ({q0}), "
        f"line direction ({direction[0]:.4g}, {direction[1]:.4g}), tangential acceleration {scenario.accel:.4g} m/s², "
        f"torque limits {', '.join(f'{x:g}' for x in scenario.torque_limit)} N·m, "
        f"W = diag(1/limit²), RK4 with dt = {scenario.dt * 1e3:g} ms and the torque held over each step, open loop. "
        "Movements: " + ", ".join(f"{m} {d:g} s" for m, d in zip(MOVEMENTS, scenario.durations)) + ".",
        "",
        (
            f"**Unstable** (whiplash): from the first sample at which some joint needs more than "
            f"{results.limit_factor:g} times its torque limit (a joint without a limit: more than "
            f"{results.growth_factor:g} times the torque the movement started with). Tip error is the distance "
            "from the reference path; the simulation tracks open loop, as the paper did."
        ),
        "",
        (
            "| movement | resolver | duration [s] | peak torque [N·m] | limit [N·m] | first limit violation [s] "
            "| unstable | instability time [s] | max tip error [mm] |"
        ),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for entry in summary_entries(results):
        peaks = ", ".join(f"{x:.3g}" for x in entry["peak_torque"])
        limits = ", ".join("none" if x is None else f"{x:g}" for x in entry["torque_limit"])
        violation = "-" if entry["first_limit_violation"] is None else f"{entry['first_limit_violation']:.3f}"
        when = "-" if entry["instability_time"] is None else f"{entry['instability_time']:.3f}"
        lines.append(
            f"| {entry['movement']} | {entry['resolver']} | {entry['duration']:g} | {peaks} | {limits} | {violation} "
            f"| {'**yes**' if entry['unstable'] else 'no'} | {when} | {entry['max_tip_error'] * 1e3:.3g} |"
        )
    stopped = [f"- {m} {n}: {results.runs[m, n].stop_reason}" for m, n in results.stopped_early]
    if stopped:
        lines += ["", "Runs that stopped early (their rows up to then are summarised):", "", *stopped]
    lines += ["", "## Why each unstable run tripped", ""]
    tripped = [(key, report) for key, report in results.whiplash.items() if report.unstable]
    lines += [f"- {m} {n}: {report.reason}" for (m, n), report in tripped] or ["- none"]
    swing = results.free_swing
    gravity = results.free_swing_gravity
    lines += [
        "",
        "## Free swing (Fig. 7)",
        "",
        f"Zero torque from q0 at rest, gravity ({gravity[0]:.4g}, {gravity[1]:.4g}, {gravity[2]:.4g}) m/s² "
        f"({np.linalg.norm(gravity):.4g} m/s² along the line direction, so that the tip starts with "
        f"{scenario.accel:.4g} m/s²), {swing.duration:g} s. Peak joint speeds "
        + ", ".join(f"{name} {s:.3g} rad/s" for name, s in zip(swing.joint_names, np.abs(swing.v).max(axis=0)))
        + "; links 2 and 3 in line at t = "
        + (", ".join(f"{t:.3f}" for t in alignment_times(swing)) or "never")
        + " s.",
        "",
        "## The paper's claims",
        "",
    ]
    for claim in results.claims:
        lines.append(f"{claim.number}. **{'holds' if claim.holds else 'DOES NOT HOLD'}**: {claim.statement}.  ")
        lines.append(f"   {claim.evidence}.")
    lines += ["", "## Figures", ""]
    descriptions = {
        "fig2": "short movement, torques of pinv and null-space with the ± limits",
        "fig3": "medium movement, the same",
        "fig4": "long movement, the same: null-space goes unstable",
        "fig5": "joint velocities and accelerations of the long null-space movement",
        "fig6": "short movement, weighted-null-space and inertia-pinv",
        "fig7": "the free-swinging arm as stick figures, with its joint speeds",
        "tip_long": "tip paths of the long movement against the straight line",
    }
    for name in figures:
        stem = Path(name).stem
        text = descriptions.get(stem)
        if text is None and stem.startswith("arm_long_"):
            text = f"stick figures of the arm during the long movement, {stem[len('arm_long_') :]}"
        lines.append(f"- `{name}`: {text}")
    return "\n".join(lines) + "\n"


def _figure_format(name: str) -> str:
    """``name`` as one of :data:`torqueopt.plots.FIGURE_FORMATS`, or InvalidInput listing them."""
    if name not in FIGURE_FORMATS:
        raise InvalidInput(f"figure format '{name}' is not one of {', '.join(FIGURE_FORMATS)}")
    return name
