"""Figures 2-7 of the paper, the long movement's stick-figure strips and its tip paths, from the runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..result import SimResult
from ..whiplash import WhiplashReport
from .alignment import alignment_times
from .runner import PaperResults
from .scenario import PAPER_RESOLVERS

__all__ = ["write_figures"]


def write_figures(results: PaperResults, out: Path, figure_format: str = "png") -> list[Path]:
    """Write Figures 2-7, the long movement's stick-figure strips and its tip paths into the folder ``out``; returns their paths.

    ``figure_format`` is the files' format and suffix: ``png``, ``pdf`` or ``svg``.
    """
    from .. import plots

    scenario, runs, judged = results.scenario, results.runs, results.whiplash

    def movement_text(movement):
        line = scenario.line(movement)
        return f"{movement} movement ({line.duration:g} s, {line.length:.3g} m straight line, peak tip speed {line.peak_speed:.3g} m/s)"

    written = []
    for stem, movement, names, label in _COMPARISONS:
        written.append(
            plots.plot_torques(
                [runs[movement, n] for n in names], out / f"{stem}.{figure_format}",
                title=f"{label}: joint torques, {' vs '.join(names)}, {movement_text(movement)}",
                instability_times={name: judged[movement, name].time for name in names},
            )
        )  # fmt: skip
    long_null = runs["long", "null-space"]
    written.append(
        plots.plot_motion(
            long_null, out / f"fig5.{figure_format}",
            title=f"Fig. 5: joint velocities and accelerations of the null-space method, {movement_text('long')}",
            events=_events(long_null, judged["long", "null-space"]),
        )
    )  # fmt: skip
    swing = results.free_swing
    gravity = np.linalg.norm(results.free_swing_gravity)
    written.append(
        plots.plot_stick_strip(
            results.robot, swing, out / f"fig7.{figure_format}",
            title=(
                f"Fig. 7: free-swinging arm: zero torque, gravity {gravity:.3g} m/s² along the line direction "
                f"(initial tip acceleration {scenario.accel:.3g} m/s²), {swing.duration:g} s; dashed: the long "
                "movement's straight line, which the swing replaces"
            ),
            snapshots=10, events=dict(zip(["links 2 and 3 in line"], alignment_times(swing))),
        )
    )  # fmt: skip
    for name in PAPER_RESOLVERS:
        result, verdict = runs["long", name], judged["long", name]
        written.append(
            plots.plot_stick_strip(
                results.robot, result, out / f"arm_long_{name}.{figure_format}",
                title=f"{name}: the arm during the {movement_text('long')}: {verdict.summary}",
                snapshots=10, events=_events(result, verdict), ellipse="velocity",
            )
        )  # fmt: skip
    written.append(
        plots.plot_tip_path(
            [runs["long", name] for name in PAPER_RESOLVERS], out / f"tip_long.{figure_format}",
            title=f"Tip paths of the four resolvers, {movement_text('long')} (open loop)",
        )
    )  # fmt: skip
    return written


#: Figures 2, 3, 4 and 6: (file stem, movement, the two resolvers compared, the paper's label).
_COMPARISONS = (
    ("fig2", "short", ("pinv", "null-space"), "Fig. 2"),
    ("fig3", "medium", ("pinv", "null-space"), "Fig. 3"),
    ("fig4", "long", ("pinv", "null-space"), "Fig. 4"),
    ("fig6", "short", ("weighted-null-space", "inertia-pinv"), "Fig. 6"),
)


def _events(result: SimResult, report: WhiplashReport) -> dict[str, float]:
    events = {}
    if report.unstable:
        events[f"{result.resolver} unstable"] = report.time
    aligned = alignment_times(result)
    if aligned:
        events["links 2 and 3 first in line"] = aligned[0]
    return events
