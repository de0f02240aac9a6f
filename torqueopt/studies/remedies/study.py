"""The remedies study's record: every run and verdict, the (μ, K_D) sweep, and the numbers they give."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import ClassVar

from ...paper import MOVEMENTS, PaperResults
from ...result import SimResult
from ...whiplash import WhiplashReport
from .discussion_answers import kinematic_term_answer, linear_programming_answer
from .figures import plot_long_torques, plot_tradeoff
from .measures import _WITHIN, BASELINES, SWEEP_REFERENCES, SWEPT_RESOLVER, _peak_ratio, _stable, torque_cost
from .report import markdown_section

__all__ = ["RemediesStudy", "SweepPoint"]


@dataclass(frozen=True)
class SweepPoint:
    """One (μ, K_D) setting of ``damped-null-space`` on the short and the long movement.

    Attributes:
        kinematic_weight: μ (dimensionless).
        damping: K_D [1/s].
        short_cost: torque cost of the short movement in the sweep's torque weight.
        short_kept: share of null-space's short-movement cut against pinv that it keeps (1: all of it).
        short_peak_ratio: largest |τ|/limit on the short movement.
        long_peak_ratio: largest |τ|/limit on the long movement.
        long_stable: the long movement completed and the whiplash detector found no instability.
        long_instability_time: when the long movement went unstable [s], None when stable.
    """

    kinematic_weight: float
    damping: float
    short_cost: float
    short_kept: float
    short_peak_ratio: float
    long_peak_ratio: float
    long_stable: bool
    long_instability_time: float | None

    @property
    def within_limits(self) -> bool:
        return self.long_stable and self.long_peak_ratio <= _WITHIN


@dataclass
class RemediesStudy:
    """Every remedy on the paper's movements, the (μ, K_D) sweep, and the answers they support.

    Attributes:
        paper: the paper's results (its runs of pinv, null-space and weighted-null-space are reused).
        remedies: the remedies run, in :data:`REMEDIES` order.
        skipped: remedies of :data:`REMEDIES` not registered in this build.
        runs: SimResult per (movement, remedy).
        whiplash: WhiplashReport per (movement, remedy).
        sweep: the (μ, K_D) settings of ``damped-null-space``, empty when not swept.
        kinematic_weights, dampings: the grid swept.
        sweep_torque_weight: the blend's ``torque_weight`` in the sweep (``unit`` or ``range``); the
            sweep's cut is then measured in that weight against the method it equals at μ = 0.
    """

    key: ClassVar[str] = "remedies"

    paper: PaperResults
    remedies: tuple[str, ...]
    skipped: tuple[str, ...]
    runs: dict[tuple[str, str], SimResult]
    whiplash: dict[tuple[str, str], WhiplashReport]
    sweep: list[SweepPoint] = field(default_factory=list)
    kinematic_weights: tuple[float, ...] = ()
    dampings: tuple[float, ...] = ()
    sweep_torque_weight: str = "unit"

    # -- lookups ---------------------------------------------------------------
    def run(self, movement: str, name: str) -> SimResult:
        """The run of a remedy, or of one of the paper's resolvers."""
        return self.runs[movement, name] if (movement, name) in self.runs else self.paper.runs[movement, name]

    def report(self, movement: str, name: str) -> WhiplashReport:
        key = (movement, name)
        return self.whiplash[key] if key in self.whiplash else self.paper.whiplash[key]

    def stable(self, movement: str, name: str) -> bool:
        return _stable(self.run(movement, name), self.report(movement, name))

    def cut_kept(self, movement: str, name: str, torque_weight: str = "unit") -> float:
        """Share of the cut in torque cost against pinv on ``movement`` that ``name`` keeps.

        The cut is null-space's in ∫‖τ‖²dt (``unit``), or weighted-null-space's in
        ∫‖Sτ‖²dt with the range weight S of Eq. (33) (``range``).
        """
        reference = SWEEP_REFERENCES[torque_weight]
        pinv = torque_cost(self.run(movement, "pinv"), torque_weight)
        best = torque_cost(self.run(movement, reference), torque_weight)
        if not pinv > best:
            return math.nan
        return (pinv - torque_cost(self.run(movement, name), torque_weight)) / (pinv - best)

    @property
    def sweep_reference(self) -> str:
        """The paper's method the swept blend equals at μ = 0."""
        return SWEEP_REFERENCES[self.sweep_torque_weight]

    # -- numbers ---------------------------------------------------------------
    def entries(self) -> list[dict]:
        """One JSON-ready row per (movement, resolver): the baselines and every remedy."""
        rows = []
        for movement in MOVEMENTS:
            pinv_cost = torque_cost(self.run(movement, "pinv"))
            for name in (*BASELINES, *self.remedies):
                result, report = self.run(movement, name), self.report(movement, name)
                cost = torque_cost(result)
                rows.append(
                    {
                        "movement": movement,
                        "resolver": name,
                        "options": result.resolver_options,
                        "completed": result.completed,
                        "stop_reason": result.stop_reason,
                        "peak_torque": result.peak_torque.tolist(),
                        "peak_torque_ratio": _peak_ratio(result),
                        "unstable": report.unstable,
                        "instability_time": report.time,
                        "verdict": report.verdict,
                        "torque_cost": cost,
                        "torque_cost_vs_pinv": cost / pinv_cost if pinv_cost > 0 else None,
                        "null_space_cut_kept": _json_float(self.cut_kept(movement, name)),
                        "max_tip_error": result.max_tip_error,
                        "max_task_error": result.max_task_error,
                        "infeasible_steps": result.infeasible_steps,
                    }
                )
        return rows

    def verdict(self, movement: str, name: str) -> str:
        """How a run ended, in words: stopped early (and why), unstable from when, lost its path, or stable."""
        result, report = self.run(movement, name), self.report(movement, name)
        if not result.completed:
            return f"stopped early ({result.stop_reason})"
        return report.summary

    def summary(self) -> dict:
        """The study's entry in ``summary.json``."""
        return {
            "remedies": list(self.remedies),
            "not_registered": list(self.skipped),
            "measures": {
                "torque_cost": "∫‖τ − τ_mid‖² dt over the applied torques [N²·m²·s]",
                "null_space_cut_kept": "(C_pinv − C)/(C_pinv − C_null-space) on the same movement",
                "unstable": "the whiplash detector of the paper's runs, same thresholds",
            },
            "runs": self.entries(),
            "sweep": {
                "resolver": SWEPT_RESOLVER,
                "torque_weight": self.sweep_torque_weight,
                "kinematic_weights": list(self.kinematic_weights),
                "dampings": list(self.dampings),
                "points": [{**asdict(p), "within_limits": p.within_limits} for p in self.sweep],
            },
            "answers": {
                "kinematic_term": kinematic_term_answer(self),
                "linear_programming": linear_programming_answer(self),
            },
        }

    # -- files -----------------------------------------------------------------
    def write_figures(self, out_dir: Path, figure_format: str = "png") -> list[Path]:
        """``remedies_long`` (torques on the long movement) and, when swept, ``remedies_tradeoff``, as ``figure_format``."""
        out = Path(out_dir)
        written = [plot_long_torques(self, out / f"remedies_long.{figure_format}")]
        if self.sweep:
            written.append(plot_tradeoff(self, out / f"remedies_tradeoff.{figure_format}"))
        return written

    def markdown(self, figures: Sequence[str]) -> str:
        """The study's section of ``summary.md``."""
        return markdown_section(self, figures)


def _json_float(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
