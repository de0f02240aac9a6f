r"""Local against global: the paper's last question, answered with numbers.

"The broader question is whether any local algorithm can ever be completely
successful, or whether ultimately only a global resolution of redundancy can
be guaranteed problem-free." (Discussion.) This study runs, on the paper's
arm and its short, medium and long movements,

* the local resolvers :data:`LOCAL` (``pinv``, ``null-space``,
  ``weighted-null-space`` with the paper's W = diag(1/limit²)) and every
  registered remedy of :data:`REMEDIES` (those not registered are skipped and
  listed), open loop as in the paper;
* the whole-movement optimum of :func:`torqueopt.optimize` in four variants
  (:data:`GLOBAL_VARIANTS`): unweighted or weighted by torque range
  (S = diag(2/(τ⁺ − τ⁻)), whose :math:`S^\top S` is the paper's W), each
  without and with the hard bounds :math:`\tau^- \le \tau \le \tau^+`.

The global problems start at rest at q0 and keep the tip on the path, as the
local methods do, and leave the final joint velocity free (a local run ends
with whatever self-motion it has), so every feasible local run is a candidate
of the global problem and the comparison is fair.

Every run is judged the same way, on the 1 ms simulation grid: the
unweighted cost :math:`\int\|\tau\|^2 dt` [N²·m²·s], the weighted cost
:math:`\int\sum_i(\tau_i/\tau_i^{+})^2 dt` [s] (both over the applied, held
torques; τ_mid = 0 for these symmetric limits), the peak
:math:`|\tau_i|/\tau_i^+`, and the whiplash detector's verdict
(:func:`torqueopt.whiplash.detect_whiplash`, the paper's thresholds). A
global solution is also replayed open loop through the same RK4 and its
largest tip deviation reported.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io import atomic_write
from ..optimal import OptimalResult, optimize, run_cost
from ..paper import MOVEMENTS, PAPER, PaperScenario
from ..resolvers import RESOLVERS, get_resolver
from ..result import SimResult
from ..robot import Robot
from ..simulate import simulate
from ..whiplash import detect_whiplash

__all__ = [
    "GLOBAL_VARIANTS",
    "LOCAL",
    "REMEDIES",
    "STUDY_GRID_STEP",
    "LocalGlobalStudy",
    "Row",
    "run_local_global",
    "write_local_global",
]

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

    # -- what the numbers say ------------------------------------------------------
    def answer(self) -> str:
        """One paragraph that answers the paper's question with this study's numbers."""
        local_long = [row for row in self.rows if row.movement == "long" and row.kind == "local"]
        failed = [row.method for row in local_long if not row.problem_free]
        free_local = [row for row in local_long if row.problem_free]
        best_local = min(free_local, key=lambda row: row.cost) if free_local else None
        optimum, pinv = self.row("long", "global"), self.row("long", "pinv")
        weighted, weighted_bounded = self.row("long", "global weighted"), self.row("long", "global weighted, bounded")
        gaps = []
        for movement in MOVEMENTS:
            local, best = self.row(movement, "null-space"), self.row(movement, "global")
            excess = local.cost / best.cost - 1 if local.cost is not None else math.nan
            gaps.append(
                f"{movement} {local.cost:.2f} against {best.cost:.2f} "
                + (
                    f"(+{100 * excess:.1f} %)"
                    if excess < 1
                    else f"({local.cost / best.cost:.0f} times, {local.verdict})"
                )
                if local.cost is not None
                else f"{movement}: null-space {local.verdict} against {best.cost:.1f}"
            )
        sentences = [
            (
                f"On the paper's long movement {len(failed)} of the {len(local_long)} local methods run here fail "
                f"({', '.join(failed) if failed else 'none'}: unstable, diverged or over a torque limit)."
            ),
            (
                "Null-space, the local torque optimum, is nearly globally optimal while the movement is short and "
                f"falls behind as it grows (∫‖τ‖² dt in N²·m²·s: {'; '.join(gaps)})."
            ),
        ]
        if best_local is not None:
            sentences.append(
                f"The cheapest local method that stays problem-free on the long movement is {best_local.method} at "
                f"{best_local.cost:.1f} (pinv {pinv.cost:.1f}); the whole-movement optimum costs "
                f"{optimum.cost:.1f}, {100 * (1 - optimum.cost / best_local.cost):.0f} % less, peaks at "
                f"{optimum.peak_ratio:.2f} of a limit, and its torques replayed open loop keep the tip within "
                f"{optimum.replay_tip_error * 1e3:.1g} mm of the path."
            )
        sentences.append(
            f"Weighted by torque range, the optimum of the long movement exceeds a limit "
            f"(peak {weighted.peak_ratio:.2f}) unless the bounds are imposed, and with them it peaks at "
            f"{weighted_bounded.peak_ratio:.4f} and is "
            f"{'stable' if not weighted_bounded.unstable else 'unstable'}: a quadratic criterion, local or "
            "global, does not by itself keep torques within limits."
        )
        global_rows = [row for row in self.rows if row.kind == "global"]
        clean = [row for row in global_rows if row.problem_free]
        sentences.append(
            f"{len(clean)} of the {len(global_rows)} global solutions are problem-free by the same detector "
            + (
                "(all of them). "
                if len(clean) == len(global_rows)
                else f"(not: {', '.join(f'{row.movement} {row.method}' for row in global_rows if not row.problem_free)}). "
            )
            + "So, on this arm and these paths, the global resolution is free of the whiplash that ends the "
            "local torque optimisers"
            + (
                ", and no local method comes within 20 % of its cost on the long movement; it is "
                if best_local is not None and best_local.cost > 1.2 * optimum.cost
                else "; it is "
            )
            + "a local optimum of a nonconvex problem, reached from pinv's motion, and it needs the whole path in "
            "advance and an NLP solve where a local method needs one instant."
        )
        return " ".join(sentences)

    def summary(self) -> dict:
        return {
            "scenario": self.scenario.as_dict(),
            "grid_step": self.grid_step,
            "end": "free",
            "missing_remedies": list(self.missing_remedies),
            "rows": [row.as_dict() for row in self.rows],
            "all_optimal": self.all_optimal,
            "answer": self.answer(),
        }

    def markdown(self, figures: list[str]) -> str:
        lines = [
            "# Local against global torque optimisation",
            "",
            (
                "The paper's arm, its three movements, open loop; every cost on the 1 ms grid over the applied "
                f"torques. Global optima: direct transcription with {self.grid_step * 1e3:g} ms intervals, IPOPT, "
                "start at rest at q0, end free, replayed open loop through the same RK4."
            ),
            "",
            "| movement | method | ∫‖τ‖² dt [N²·m²·s] | ∫Σ(τᵢ/τᵢ⁺)² dt [s] | peak \\|τ\\|/limit | verdict |",
            "| --- | --- | ---: | ---: | ---: | --- |",
        ]
        for row in self.rows:
            cost = "—" if row.cost is None else f"{row.cost:.2f}"
            weighted = "—" if row.weighted_cost is None else f"{row.weighted_cost:.4f}"
            verdict = row.verdict
            if row.kind == "global":
                verdict += f"; replay within {row.replay_tip_error * 1e3:.2g} mm"
            lines.append(f"| {row.movement} | {row.method} | {cost} | {weighted} | {row.peak_ratio:.3f} | {verdict} |")
        if self.missing_remedies:
            lines += ["", f"Not registered in this build, so not run: {', '.join(self.missing_remedies)}."]
        lines += ["", "## The paper's question", "", self.answer(), ""]
        for figure in figures:
            lines.append(f"![{figure}]({figure})")
            lines.append("")
        return "\n".join(lines)

    def write_figures(self, out_dir: Path, figure_format: str = "png") -> list[Path]:
        from .. import plots

        out = Path(out_dir)
        torques = plot_long_torques(self, out / f"global_torques_long.{figure_format}")
        strip = plots.plot_stick_strip(
            self.robot,
            _labelled(self.global_runs["long", "global"].as_sim_result(), "global"),
            out / f"global_arm_long.{figure_format}",
            title="Long movement: the whole-movement torque optimum (unweighted, end free)",
        )
        return [torques, strip]


#: (method, colour, line style) of the long-movement torque figure, drawn when run.
_FIGURE_LINES = (
    ("pinv", "tab:blue", "-"),
    ("null-space", "tab:red", "-"),
    ("damped-null-space", "tab:orange", "-"),
    ("bounded-torque", "tab:brown", ":"),  # dotted: on this path it coincides with damped-null-space
    ("global", "black", "-"),
    ("global weighted, bounded", "tab:green", "--"),
)


def plot_long_torques(study: LocalGlobalStudy, path: Path) -> Path:
    """The long movement's torques, one panel per joint: local resolvers against the global optima.

    The axes span ±1.6 times each limit; a run that leaves them (null-space's
    whiplash) is marked where the detector trips.
    """
    from ..plots.canvas import new_figure, save_figure

    limits = np.asarray(study.scenario.torque_limit, float)
    fig = new_figure(9.0, 7.5)
    axes = fig.subplots(len(limits), 1, sharex=True)
    for joint, ax in enumerate(axes):
        for method, colour, style in _FIGURE_LINES:
            if ("long", method) in study.local_runs:
                run = study.local_runs["long", method]
            elif ("long", method) in study.global_runs:
                run = study.global_runs["long", method]
            else:
                continue
            ax.plot(run.t[:-1], run.tau[:-1, joint], color=colour, linestyle=style, linewidth=1.4, label=method)
            row = study.row("long", method)
            if row.unstable and joint == 0:
                ax.axvline(row.unstable_time, color=colour, linestyle=":", linewidth=1.0)
        for sign in (1.0, -1.0):
            ax.axhline(sign * limits[joint], color="0.3", linestyle="--", linewidth=0.8)
        ax.set_ylim(-1.6 * limits[joint], 1.6 * limits[joint])
        ax.set_ylabel(f"τ{joint + 1} [N·m]")
        ax.set_title(f"joint {joint + 1} (limit ±{limits[joint]:g} N·m)", fontsize=10, loc="left")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    unstable = [row for row in study.rows if row.movement == "long" and row.kind == "local" and row.unstable]
    note = "; ".join(
        f"{row.method} unstable from {row.unstable_time:.2f} s (dotted), leaves the axes"
        for row in unstable
        if any(row.method == line[0] for line in _FIGURE_LINES)
    )
    fig.suptitle(
        "Long movement (2 s): local resolvers against the whole-movement optimum" + (f"\n{note}" if note else "")
    )
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 6), fontsize=9)
    return save_figure(fig, path)


def _labelled(result: SimResult, label: str) -> SimResult:
    result.resolver = label
    return result


def _weighted_cost(result: SimResult | OptimalResult, robot: Robot, limits: np.ndarray) -> float:
    applied = result.tau[:-1]
    return float(result.dt * np.sum((applied / limits) ** 2))


def run_local_global(
    scenario: PaperScenario = PAPER,
    *,
    grid_step: float = STUDY_GRID_STEP,
    progress: bool = False,
) -> LocalGlobalStudy:
    """Run every local method and global variant on the scenario's three movements (about a minute)."""
    robot = scenario.load_robot()
    limits = np.asarray(scenario.torque_limit, float)
    present = tuple(name for name in REMEDIES if name in RESOLVERS)
    missing = tuple(name for name in REMEDIES if name not in RESOLVERS)
    rows, local_runs, global_runs = [], {}, {}
    for movement in MOVEMENTS:
        line = scenario.line(movement)
        for name in (*LOCAL, *present):
            # Each method at its defaults, as the paper's runner does (weighted-null-space's
            # default 1/(τ⁺−τ⁻)² is the paper's W up to a scale, the same minimiser).
            run = simulate(robot, get_resolver(name), line, scenario.q0, dt=scenario.dt)
            report = detect_whiplash(run)
            local_runs[movement, name] = run
            rows.append(
                Row(
                    movement=movement,
                    method=name,
                    kind="local",
                    cost=run_cost(run, robot) if run.completed else None,
                    weighted_cost=_weighted_cost(run, robot, limits) if run.completed else None,
                    peak_ratio=float(np.nanmax(run.peak_torque_ratio)),
                    unstable=report.unstable,
                    unstable_time=report.time,
                    completed=run.completed,
                    status="completed" if run.completed else "stopped",
                    max_tip_error=run.max_tip_error,
                )
            )
            if progress:
                print(f"{movement:>6} {name:<26} {rows[-1].verdict}", flush=True)
        for label, weight, bounded in GLOBAL_VARIANTS:
            result = optimize(
                robot,
                line,
                scenario.q0,
                weight=weight,
                torque_bounds=bounded,
                end="free",
                dt=scenario.dt,
                grid_step=grid_step,
            )
            global_runs[movement, label] = result
            report = detect_whiplash(result.as_sim_result())
            rows.append(
                Row(
                    movement=movement,
                    method=label,
                    kind="global",
                    cost=run_cost(result.as_sim_result(), robot),
                    weighted_cost=_weighted_cost(result, robot, limits),
                    peak_ratio=float(result.peak_torque_ratio.max()),
                    unstable=report.unstable,
                    unstable_time=report.time,
                    completed=result.replay_tip_error < 1e-3,
                    status=result.status,
                    max_tip_error=result.plan_tip_error,
                    replay_tip_error=result.replay_tip_error,
                    solve_seconds=result.solve_seconds,
                )
            )
            if progress:
                print(f"{movement:>6} {label:<26} {rows[-1].verdict} ({result.solve_seconds:.2f} s)", flush=True)
    return LocalGlobalStudy(scenario, robot, rows, local_runs, global_runs, missing, grid_step)


def write_local_global(study: LocalGlobalStudy, out_dir) -> list[Path]:
    """Write global.md, global.json and the two figures into ``out_dir``; every file atomically."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = study.write_figures(out)
    summary = json.dumps(study.summary(), indent=2, default=_json_default).encode()
    markdown = study.markdown([path.name for path in figures]).encode()
    atomic_write(out / "global.json", lambda handle: handle.write(summary))
    atomic_write(out / "global.md", lambda handle: handle.write(markdown))
    return [*figures, out / "global.json", out / "global.md"]


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
