"""The local-against-global study's record: what it compares, one row per method and movement, and the study."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ...optimal import OptimalResult
from ...paper import PaperScenario
from ...result import SimResult
from ...robot import Robot
from ...whiplash import DEFAULT_PATH_TOLERANCE
from .figures import write_figures
from .report import joint_3_range, markdown_text

__all__ = ["GLOBAL_VARIANTS", "LOCAL", "REMEDIES", "STUDY_GRID_STEP", "LocalGlobalStudy", "Row"]

#: The paper's local resolvers compared.
LOCAL = ("pinv", "null-space", "weighted-null-space")
#: Remedies of the remedies and bounded work, run when registered.
REMEDIES = ("damped-null-space", "self-motion-damping", "bounded-torque", "minmax-torque")
#: (label, weight, torque bounds) of the global optima.
GLOBAL_VARIANTS = (
    ("global", "identity", False),
    ("global, bounded", "identity", True),
    ("global weighted", "range", False),
    ("global weighted, bounded", "range", True),
)
#: Transcription interval of the study [s]: the short movement's cost is within 0.3 % of its 1 ms-grid value.
STUDY_GRID_STEP = 0.005
_WITHIN = (
    1.0 + 1e-3
)  # peak |τ|/limit at or below this counts as within the limits (bounds hold at the grid's midpoints)


@dataclass
class Row:
    """One method on one movement.

    Attributes:
        movement, method: names. kind: ``local`` or ``global``.
        cost: ∫‖τ‖² dt [N²·m²·s] (None for a run that stopped early).
        weighted_cost: ∫Σ(τ_i/τ_i⁺)² dt [s] (None likewise).
        peak_ratio: largest |τ_i|/τ_i⁺ over the run.
        unstable: the whiplash detector's verdict; unstable_time [s] when it trips.
        completed: the run reached T (local); status: IPOPT's outcome (global).
        replay_tip_error: the open-loop replay's largest tip deviation [m] (global),
            max_tip_error: the run's own (local) [m].
    """

    movement: str
    method: str
    kind: str
    cost: float | None
    weighted_cost: float | None
    peak_ratio: float
    unstable: bool
    unstable_time: float | None
    completed: bool
    status: str
    max_tip_error: float
    replay_tip_error: float | None = None
    solve_seconds: float | None = None

    @property
    def problem_free(self) -> bool:
        """Completed, stable, within the limits, on the path (and, for a global one, converged)."""
        return (
            self.completed
            and not self.unstable
            and self.max_tip_error <= DEFAULT_PATH_TOLERANCE
            and self.peak_ratio <= _WITHIN
            and self.status in ("completed", "converged")
        )

    @property
    def verdict(self) -> str:
        if self.kind == "global" and self.status != "converged":
            return f"NOT CONVERGED ({self.status})"
        if not self.completed:
            return "diverged" + (f", unstable from {self.unstable_time:.3f} s" if self.unstable else "")
        if self.unstable:
            return f"unstable from {self.unstable_time:.3f} s"
        if self.max_tip_error > DEFAULT_PATH_TOLERANCE:
            return f"lost path ({self.max_tip_error * 1e3:.4g} mm off)"
        if self.peak_ratio > _WITHIN:
            return "over a limit"
        return "problem-free"

    def as_dict(self) -> dict:
        return {
            "movement": self.movement,
            "method": self.method,
            "kind": self.kind,
            "cost": self.cost,
            "weighted_cost": self.weighted_cost,
            "peak_ratio": self.peak_ratio,
            "unstable": self.unstable,
            "unstable_time": self.unstable_time,
            "completed": self.completed,
            "status": self.status,
            "verdict": self.verdict,
            "problem_free": self.problem_free,
            "max_tip_error": self.max_tip_error,
            "replay_tip_error": self.replay_tip_error,
            "solve_seconds": self.solve_seconds,
        }


@dataclass
class LocalGlobalStudy:
    """Everything :func:`run_local_global` computed (it also meets :class:`torqueopt.studies.Study`)."""

    scenario: PaperScenario
    robot: Robot
    rows: list[Row]
    local_runs: dict[tuple[str, str], SimResult]
    global_runs: dict[tuple[str, str], OptimalResult]
    missing_remedies: tuple[str, ...]
    grid_step: float
    key: str = field(default="local_global", init=False)

    @property
    def all_optimal(self) -> bool:
        """True when every global solve converged."""
        return all(result.optimal for result in self.global_runs.values())

    def row(self, movement: str, method: str) -> Row:
        return next(row for row in self.rows if row.movement == movement and row.method == method)

    def summary(self) -> dict:
        return {
            "scenario": self.scenario.as_dict(),
            "grid_step": self.grid_step,
            "end": "free",
            "missing_remedies": list(self.missing_remedies),
            "rows": [row.as_dict() for row in self.rows],
            "all_optimal": self.all_optimal,
            "long_optimum_joint_3_deg": joint_3_range(self),
        }

    def markdown(self, figures: list[str]) -> str:
        return markdown_text(self, figures)

    def write_figures(self, out_dir: Path, figure_format: str = "png") -> list[Path]:
        return write_figures(self, out_dir, figure_format)
