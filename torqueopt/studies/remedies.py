r"""The Discussion's remedies for the whiplash, run on the paper's scenario and judged by numbers.

The paper ends with two questions a local method could answer: can the
criterion be weighted "with a kinematic term to avoid high velocity
buildup", and would "linear programming rather than least squares be more
satisfactory" for staying within torque bounds? This study runs every
registered remedy (:data:`REMEDIES`; those not registered in this build are
skipped and said so) on the short, medium and long movements beside ``pinv``
and ``null-space``, sweeps the blend ``damped-null-space`` over its kinematic
weight μ and damping :math:`K_D`, and writes the answers as sentences
generated from the numbers.

Measures (all on the paper's arm, open loop, as the paper):

* the **torque cost** :math:`C = \int \|\tau - \tau_{mid}\|^2 dt` [N²·m²·s]
  over the applied (held) torques; the short movement's **cut kept** is
  :math:`(C_{pinv} - C)/(C_{pinv} - C_{null\text{-}space})`, the share of
  null-space's reduction against pinv that a remedy keeps;
* **stability**: the whiplash detector's verdict
  (:func:`torqueopt.whiplash.detect_whiplash`, the paper's thresholds) and
  the peak :math:`|\tau_i|/\tau^+_i`; within limits means a peak ≤ 1.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..errors import InvalidInput
from ..paper import MOVEMENTS, PaperResults, run_movement
from ..resolvers import RESOLVERS, get_resolver
from ..result import SimResult
from ..simulate import simulate
from ..whiplash import WhiplashReport, detect_whiplash

__all__ = [
    "REMEDIES",
    "BASELINES",
    "SWEPT_RESOLVER",
    "DEFAULT_KINEMATIC_WEIGHTS",
    "DEFAULT_DAMPINGS",
    "SweepPoint",
    "RemediesStudy",
    "registered_remedies",
    "run_remedies",
    "torque_cost",
]

#: The remedies this study runs, when registered (``bounded-torque`` and ``minmax-torque`` come from
#: the bounded resolvers; a build without them answers the LP question with "not run").
REMEDIES = (
    "damped-null-space",
    "self-motion-damping",
    "inverse-inertia-torque",
    "inverse-inertia-squared-torque",
    "bounded-torque",
    "minmax-torque",
)
#: The paper's runs drawn beside the remedies.
BASELINES = ("pinv", "null-space")
#: The least-squares method the LP is compared with (weighted by torque range, Eq. (33)).
LEAST_SQUARES_REFERENCE = "weighted-null-space"
LINEAR_PROGRAM = "minmax-torque"
BOUNDED_QP = "bounded-torque"
SELF_MOTION_DAMPING = "self-motion-damping"
#: The blend whose μ and K_D are swept.
SWEPT_RESOLVER = "damped-null-space"
#: μ values of the sweep (dimensionless, relative to ‖SHZ‖_F; 0 is null-space).
DEFAULT_KINEMATIC_WEIGHTS = (0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2.0, 5.0)
#: K_D values of the sweep [1/s].
DEFAULT_DAMPINGS = (2.0, 5.0, 10.0, 20.0, 50.0)
#: The torque weights the sweep can use, each with the paper's method it equals at μ = 0.
SWEEP_REFERENCES = {"unit": "null-space", "range": "weighted-null-space"}
_WITHIN = 1.0 + 1e-6  # peak |τ|/limit at or below this is within the limits (round-off of a bounded solver)


def registered_remedies() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(the remedies registered in this build, those that are not), each in :data:`REMEDIES` order."""
    present = tuple(name for name in REMEDIES if name in RESOLVERS)
    return present, tuple(name for name in REMEDIES if name not in RESOLVERS)


def torque_cost(result: SimResult, torque_weight: str = "unit") -> float:
    r""":math:`\int \|S(\tau - \tau_{mid})\|^2 dt` over the torques held over each step.

    ``torque_weight``: ``unit`` (S = I, [N²·m²·s]) or ``range`` (S = diag(1/(τ⁺ − τ⁻)) of
    Eq. (33), [s]; 0 for an unbounded joint). The last row of a completed run (t = T)
    starts no step, so it is left out.
    """
    bounded = np.isfinite(result.torque_upper) & np.isfinite(result.torque_lower)
    midpoint = np.where(bounded, 0.5 * (result.torque_upper + result.torque_lower), 0.0)
    if torque_weight == "unit":
        root = np.ones(result.n)
    elif torque_weight == "range":
        root = np.where(bounded, 1.0 / (result.torque_upper - result.torque_lower), 0.0)
    else:
        raise InvalidInput(f"torque weight '{torque_weight}' of a torque cost must be one of unit, range")
    applied = result.tau[:-1] if result.completed else result.tau
    return float(np.sum(np.square(root * (applied - midpoint))) * result.dt)


def _stable(result: SimResult, report: WhiplashReport) -> bool:
    return result.completed and not report.unstable


def _peak_ratio(result: SimResult) -> float:
    return float(result.peak_torque_ratio.max()) if len(result.t) else math.nan


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

    def _sweep_cost_text(self) -> str:
        if self.sweep_torque_weight == "unit":
            return "∫‖τ‖²dt"
        return "∫‖Sτ‖²dt (S = 1/(τ⁺ − τ⁻), Eq. (33))"

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
                        "torque_cost": cost,
                        "torque_cost_vs_pinv": cost / pinv_cost if pinv_cost > 0 else None,
                        "null_space_cut_kept": _json_float(self.cut_kept(movement, name)),
                        "max_tip_error": result.max_tip_error,
                        "max_task_error": result.max_task_error,
                        "infeasible_steps": result.infeasible_steps,
                    }
                )
        return rows

    def kinematic_term_answer(self) -> dict:
        """The Discussion's first question, answered in sentences generated from the runs and the sweep."""
        sentences = []
        reference = self.sweep_reference
        null_long = self.report("long", reference)
        sentences.append(
            f"Without a kinematic term (μ = 0, {reference}) the long movement is "
            + (f"unstable from t = {null_long.time:.3f} s" if null_long.unstable else "stable")
            + f" (peak |τ|/limit {_peak_ratio(self.run('long', reference)):.3g})."
        )
        result = {"sentences": sentences}
        points = [p for p in self.sweep if p.kinematic_weight > 0]
        if points:
            stable = [p for p in points if p.long_stable]
            within = [p for p in points if p.within_limits]
            if within:
                best = max(within, key=lambda p: p.short_kept)
                sentences.append(
                    f"Yes on this arm: with μ = {best.kinematic_weight:g} and K_D = {best.damping:g} 1/s the long "
                    f"movement stays stable and within its torque limits (peak |τ|/limit {best.long_peak_ratio:.3g}), "
                    f"while the short movement keeps {_percent(best.short_kept)} of the cut in "
                    f"{self._sweep_cost_text()} that {reference} makes against pinv."
                )
            elif stable:
                best = max(stable, key=lambda p: p.short_kept)
                sentences.append(
                    f"Only in part: μ = {best.kinematic_weight:g}, K_D = {best.damping:g} 1/s keeps the long movement "
                    f"stable but not within its limits (peak |τ|/limit {best.long_peak_ratio:.3g}); it keeps "
                    f"{_percent(best.short_kept)} of the short movement's cut."
                )
            else:
                best = None
                sentences.append(
                    f"No: none of the {len(points)} settings swept (μ in {_listing(self.kinematic_weights)}, K_D in "
                    f"{_listing(self.dampings)} 1/s) keeps the long movement stable."
                )
            sentences.append(
                f"Of the {len(points)} settings with μ > 0, {len(stable)} keep the long movement stable and "
                f"{len(within)} also within its limits."
            )
            always_unstable = [
                mu for mu in sorted({p.kinematic_weight for p in points})
                if not any(p.long_stable for p in points if p.kinematic_weight == mu)
            ]  # fmt: skip
            if always_unstable:
                sentences.append(
                    f"With μ = {_listing(always_unstable)} every K_D swept leaves it unstable: the term must weigh "
                    "enough against the torque criterion to hold the self-motion down."
                )
            if stable:
                kept = [p.short_kept for p in stable]
                falling = all(
                    later.short_kept <= earlier.short_kept + 1e-9
                    for damping in self.dampings
                    for earlier, later in pairwise(sorted((p for p in points if p.damping == damping),
                                                        key=lambda p: p.kinematic_weight))
                )  # fmt: skip
                sentences.append(
                    f"The stable settings keep between {_percent(min(kept))} and {_percent(max(kept))} of the short "
                    "movement's cut"
                    + (
                        "; at every K_D the share kept falls as μ grows: the more the term weighs, the less torque "
                        "the short movement saves."
                        if falling
                        else "."
                    )
                )
            result.update(
                torque_weight=self.sweep_torque_weight,
                settings=len(points),
                stable_settings=len(stable),
                within_limit_settings=len(within),
                best=None if best is None else asdict(best),
            )
        else:
            sentences.append("The (μ, K_D) sweep was not run.")
        if SWEPT_RESOLVER in self.remedies:
            defaults = get_resolver(SWEPT_RESOLVER)
            long = self.run("long", SWEPT_RESOLVER)
            sentences.append(
                f"The defaults of {SWEPT_RESOLVER} (μ = {defaults.kinematic_weight:g}, K_D = {defaults.damping:g} 1/s) "
                f"keep {_percent(self.cut_kept('short', SWEPT_RESOLVER))} of the short movement's cut"
                + (
                    ""
                    if self.sweep_torque_weight == "unit"
                    else " (null-space's, in ∫‖τ‖²dt: the defaults use the unit weight)"
                )
                + " and leave the long "
                f"movement {self._verdict('long', SWEPT_RESOLVER)} (peak |τ|/limit {_peak_ratio(long):.3g}); the "
                f"medium movement is {self._verdict('medium', SWEPT_RESOLVER)}."
            )
        if SELF_MOTION_DAMPING in self.remedies:
            sentences.append(
                f"Self-motion damping alone (the μ → ∞ limit) leaves the long movement "
                f"{self._verdict('long', SELF_MOTION_DAMPING)} (peak |τ|/limit "
                f"{_peak_ratio(self.run('long', SELF_MOTION_DAMPING)):.3g}) but keeps "
                f"{_percent(self.cut_kept('short', SELF_MOTION_DAMPING))} of the short movement's cut: a kinematic method, "
                "like pinv."
            )
        return result

    def linear_programming_answer(self) -> dict:
        """The Discussion's second question: does the LP (minmax-torque) stay within bounds better than least squares?

        A movement counts as done within the bounds when the run completes, is stable, keeps every
        |τ|/limit ≤ 1 and realises the task at every step (no infeasible step): a resolver that
        stays within the limits by giving up the path has not done the movement.
        """
        if LINEAR_PROGRAM not in self.remedies:
            return {
                "answered": False,
                "sentences": [f"Not answered in this build: the LP resolver {LINEAR_PROGRAM} is not registered."],
            }

        def record(name: str) -> dict:
            peaks = {m: _peak_ratio(self.run(m, name)) for m in MOVEMENTS}
            infeasible = {m: self.run(m, name).infeasible_steps for m in MOVEMENTS}
            within = [m for m in MOVEMENTS if peaks[m] <= _WITHIN and self.stable(m, name)]
            return {
                "peak_torque_ratio": peaks,
                "within_limits": within,
                "infeasible_steps": infeasible,
                "done_within_bounds": [m for m in within if infeasible[m] == 0],
                "max_tip_error": {m: self.run(m, name).max_tip_error for m in MOVEMENTS},
            }

        def peaks_text(entry: dict) -> str:
            return ", ".join(f"{m} {entry['peak_torque_ratio'][m]:.3g}" for m in MOVEMENTS)

        records = {name: record(name) for name in (LINEAR_PROGRAM, BOUNDED_QP, LEAST_SQUARES_REFERENCE)
                   if name == LEAST_SQUARES_REFERENCE or name in self.remedies}  # fmt: skip
        lp, least_squares = records[LINEAR_PROGRAM], records[LEAST_SQUARES_REFERENCE]
        total = len(MOVEMENTS)
        sentences = [
            f"{LINEAR_PROGRAM} (minimum largest normalised torque, an LP) keeps every torque within its limits on "
            f"{len(lp['within_limits'])} of {total} movements (peak |τ|/limit {peaks_text(lp)})."
        ]
        gave_up = {m: n for m, n in lp["infeasible_steps"].items() if n}
        if gave_up:
            pinv_error = max(self.run(m, "pinv").max_tip_error for m in gave_up)
            sentences.append(
                "But at "
                + ", ".join(f"{n} steps of the {m} movement" for m, n in gave_up.items())
                + " no torque within the limits realises the task, so it gives up task acceleration there: the tip "
                f"leaves the path by up to {max(lp['max_tip_error'][m] for m in gave_up) * 1e3:.3g} mm "
                f"(pinv: {pinv_error * 1e3:.3g} mm)."
            )
        compared = [
            f"{LEAST_SQUARES_REFERENCE} (least squares weighted by torque range, no bounds) on "
            f"{len(least_squares['done_within_bounds'])} ({peaks_text(least_squares)})"
        ]
        if BOUNDED_QP in records:
            qp = records[BOUNDED_QP]
            options = self.run("short", BOUNDED_QP).resolver_options or {}
            term = options.get("kinematic_weight") or 0.0
            with_term = (
                f", with its kinematic term μ = {term:g}, K_D = {options.get('damping', 0):g} 1/s" if term else ""
            )
            compared.append(
                f"{BOUNDED_QP} (least squares with hard bounds, a QP{with_term}) on {len(qp['done_within_bounds'])} "
                f"({peaks_text(qp)})"
            )
        sentences.append(
            f"Realising the path with every torque within its limits, the LP does {len(lp['done_within_bounds'])} of "
            f"{total} movements; " + "; ".join(compared) + "."
        )
        lead = len(lp["done_within_bounds"]) - len(least_squares["done_within_bounds"])
        if lead > 0:
            verdict = "more satisfactory than least squares for staying within the bounds on this arm"
        elif lead == 0:
            verdict = "no more satisfactory than least squares for staying within the bounds on this arm"
        else:
            verdict = "less satisfactory than least squares for staying within the bounds on this arm"
        if BOUNDED_QP in records:
            against_qp = len(lp["done_within_bounds"]) - len(records[BOUNDED_QP]["done_within_bounds"])
            verdict += (
                ", and "
                + ("more" if against_qp > 0 else "no more" if against_qp == 0 else "less")
                + " satisfactory than least squares with the bounds as constraints"
            )
        sentences.append(f"By this measure linear programming is {verdict}.")
        return {"answered": True, "sentences": sentences, **records}

    def _verdict(self, movement: str, name: str) -> str:
        result, report = self.run(movement, name), self.report(movement, name)
        if not result.completed:
            return f"stopped early ({result.stop_reason})"
        return f"unstable from t = {report.time:.3f} s" if report.unstable else "stable"

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
                "kinematic_term": self.kinematic_term_answer(),
                "linear_programming": self.linear_programming_answer(),
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
        lines = [
            "## Remedies for the whiplash (the Discussion's questions)",
            "",
            (
                "Every registered remedy on the three movements, beside pinv and null-space. Torque cost "
                "C = ∫‖τ − τ_mid‖² dt over the applied torques; *cut kept*: (C_pinv − C)/(C_pinv − C_null-space), "
                "the share of null-space's reduction against pinv a remedy keeps; unstable: the whiplash detector "
                "above."
            ),
        ]
        if self.skipped:
            lines += ["", f"Not registered in this build, so not run: {', '.join(self.skipped)}."]
        lines += [
            "",
            (
                "| movement | resolver | peak \\|τ\\|/limit | C [N²·m²·s] | cut kept | unstable from [s] "
                "| max tip error [mm] | infeasible steps |"
            ),
            "|---|---|---|---|---|---|---|---|",
        ]
        for row in self.entries():
            when = "-" if row["instability_time"] is None else f"**{row['instability_time']:.3f}**"
            if not row["completed"]:
                when += " (stopped early)"
            kept = "-" if row["null_space_cut_kept"] is None else _percent(row["null_space_cut_kept"])
            lines.append(
                f"| {row['movement']} | {row['resolver']} | {row['peak_torque_ratio']:.3g} | {row['torque_cost']:.4g} "
                f"| {kept} | {when} | {row['max_tip_error'] * 1e3:.3g} | {row['infeasible_steps']} |"
            )
        lines += [
            "",
            "### Can the local criterion be weighted with a kinematic term to avoid high velocity buildup?",
            "",
        ]
        lines += self.kinematic_term_answer()["sentences"]
        lines += ["", "### Would linear programming rather than least squares be more satisfactory?", ""]
        lines += self.linear_programming_answer()["sentences"]
        if self.sweep:
            lines += [
                "",
                f"### The sweep of {SWEPT_RESOLVER} (torque_weight={self.sweep_torque_weight})",
                "",
                (
                    f"Each cell: share of {self.sweep_reference}'s cut in {self._sweep_cost_text()} on the short "
                    "movement kept / peak |τ|/limit on the long movement (**U**: unstable)."
                ),
                "",
                "| μ \\ K_D [1/s] | " + " | ".join(f"{d:g}" for d in self.dampings) + " |",
                "|---|" + "---|" * len(self.dampings),
            ]
            by_setting = {(p.kinematic_weight, p.damping): p for p in self.sweep}
            for mu in self.kinematic_weights:
                cells = []
                for damping in self.dampings:
                    point = by_setting[mu, damping]
                    mark = "" if point.long_stable else " **U**"
                    cells.append(f"{_percent(point.short_kept)} / {point.long_peak_ratio:.3g}{mark}")
                lines.append(f"| {mu:g} | " + " | ".join(cells) + " |")
        descriptions = {
            "remedies_long": "torques of every remedy on the long movement beside pinv and null-space, as |τ|/limit",
            "remedies_tradeoff": "the trade-off: short-movement cut kept against long-movement peak torque, over μ and K_D",
        }
        shown = [f"- `{name}`: {descriptions[Path(name).stem]}" for name in figures if Path(name).stem in descriptions]
        if shown:
            lines += ["", "Figures:", "", *shown]
        return "\n".join(lines) + "\n"


def run_remedies(
    paper: PaperResults,
    *,
    sweep: bool = True,
    kinematic_weights: Sequence[float] = DEFAULT_KINEMATIC_WEIGHTS,
    dampings: Sequence[float] = DEFAULT_DAMPINGS,
    torque_weight: str = "unit",
) -> RemediesStudy:
    """Run every registered remedy on the paper's movements and, with ``sweep``, the (μ, K_D) grid.

    Uses the paper's scenario, robot and whiplash thresholds; the sweep runs
    ``damped-null-space`` with ``torque_weight`` (``unit`` or ``range``) on the
    short and long movements for each μ in ``kinematic_weights`` and K_D in
    ``dampings`` (μ = 0 is run once: K_D has no effect there), and measures
    the short movement's cut in that weight.

    Raises:
        InvalidInput: a μ or K_D that is negative or not finite, or another torque weight.
    """
    if torque_weight not in SWEEP_REFERENCES:
        raise InvalidInput(f"sweep torque weight '{torque_weight}' must be one of {', '.join(SWEEP_REFERENCES)}")
    scenario, robot = paper.scenario, paper.robot
    limit_factor, growth_factor = paper.limit_factor, paper.growth_factor
    kinematic_weights = _grid(kinematic_weights, "kinematic weight")
    dampings = _grid(dampings, "damping")
    remedies, skipped = registered_remedies()
    runs, whiplash = {}, {}
    for movement in MOVEMENTS:
        for name in remedies:
            result = run_movement(scenario, movement, name, robot)
            runs[movement, name] = result
            whiplash[movement, name] = detect_whiplash(result, limit_factor, growth_factor)
    study = RemediesStudy(
        paper=paper, remedies=remedies, skipped=skipped, runs=runs, whiplash=whiplash, sweep_torque_weight=torque_weight
    )
    if not sweep or SWEPT_RESOLVER not in RESOLVERS:
        return study
    pinv_cost, null_cost = (
        torque_cost(paper.runs["short", name], torque_weight) for name in ("pinv", SWEEP_REFERENCES[torque_weight])
    )
    cut = pinv_cost - null_cost
    points = []
    for mu in kinematic_weights:
        at_zero = None
        for damping in dampings:
            if mu == 0.0 and at_zero is not None:
                points.append(SweepPoint(**{**asdict(at_zero), "damping": damping}))
                continue
            options = {"kinematic_weight": mu, "damping": damping, "torque_weight": torque_weight}
            short = simulate(robot, SWEPT_RESOLVER, scenario.line("short"), scenario.q0, dt=scenario.dt,
                             resolver_options=options)  # fmt: skip
            long = simulate(robot, SWEPT_RESOLVER, scenario.line("long"), scenario.q0, dt=scenario.dt,
                            resolver_options=options)  # fmt: skip
            report = detect_whiplash(long, limit_factor, growth_factor)
            cost = torque_cost(short, torque_weight)
            point = SweepPoint(
                kinematic_weight=mu,
                damping=damping,
                short_cost=cost,
                short_kept=(pinv_cost - cost) / cut if cut > 0 else math.nan,
                short_peak_ratio=_peak_ratio(short),
                long_peak_ratio=_peak_ratio(long),
                long_stable=_stable(long, report),
                long_instability_time=report.time,
            )
            points.append(point)
            if mu == 0.0:
                at_zero = point
    study.sweep, study.kinematic_weights, study.dampings = points, kinematic_weights, dampings
    return study


def _grid(values: Sequence[float], what: str) -> tuple[float, ...]:
    grid = tuple(float(v) for v in values)
    if not grid or any(not (math.isfinite(v) and v >= 0) for v in grid):
        raise InvalidInput(f"sweep {what}s {list(values)} must be finite numbers >= 0")
    return grid


def _listing(values: Sequence[float]) -> str:
    values = [f"{v:g}" for v in values]
    return values[0] if len(values) == 1 else ", ".join(values[:-1]) + " and " + values[-1]


def _percent(share: float) -> str:
    """A share as a whole percentage, with no "-0 %" for a tiny negative one."""
    return "-" if not math.isfinite(share) else f"{round(100 * share) + 0:.0f}%"


def _json_float(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


# -- figures ------------------------------------------------------------------
def plot_long_torques(study: RemediesStudy, path: Path) -> Path:
    """One panel per resolver (pinv, null-space, each remedy): every joint's τ/τ⁺ on the long movement."""
    from ..plots.canvas import new_figure, save_figure, symlog_scale

    names = (*BASELINES, *study.remedies)
    fig = new_figure(9.0, 1.0 + 1.9 * len(names))
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        result, report = study.run("long", name), study.report("long", name)
        limit = np.where(np.isfinite(result.torque_upper), result.torque_upper, np.nan)
        ratio = result.tau / limit
        for joint, joint_name in enumerate(result.joint_names):
            ax.plot(result.t, ratio[:, joint], lw=1.3, label=joint_name)
        for level in (1.0, -1.0):
            ax.axhline(level, color="k", ls="--", lw=0.9)
        peak = _peak_ratio(result)
        if peak > 1.5:
            symlog_scale(ax, 1.0, peak)
        else:
            ax.set_ylim(-1.6, 1.6)
        if report.unstable:
            ax.axvline(report.time, color="k", ls=":", lw=1.2)
        state = study._verdict("long", name)
        extra = (
            f", {result.infeasible_steps} infeasible steps (tip off the path by up to {result.max_tip_error * 1e3:.3g} mm)"
            if result.infeasible_steps
            else ""
        )
        ax.set_title(f"{name}: {state}, peak |τ|/limit {peak:.3g}{extra}", fontsize=10, loc="left")
        ax.set_ylabel("τ / τ⁺")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8, ncol=len(study.run("long", "pinv").joint_names))
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(
        f"Long movement ({study.paper.scenario.durations[-1]:g} s): each joint's torque over its limit\n"
        "dashed: ±limit; dotted: instability; logarithmic beyond ±1 where a run exceeds 1.5",
        fontsize=11,
    )
    return save_figure(fig, path)


def plot_tradeoff(study: RemediesStudy, path: Path) -> Path:
    """The sweep in two panels, one line per K_D, filled circles stable, crosses unstable.

    Left: the trade-off itself, the share of the short movement's cut given up
    (x, log; μ = 0 gives up nothing and sits at the left edge) against the long
    movement's peak |τ|/limit (y, log). Right: that peak against μ.
    """
    from ..plots.canvas import new_figure, save_figure

    fig = new_figure(12.0, 5.4)
    trade, by_weight = fig.subplots(1, 2, width_ratios=[3, 2])
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")
    given_up = [100 * (1 - p.short_kept) for p in study.sweep]
    floor = 0.5 * min([g for g in given_up if g > 0] or [1e-3])

    def shown(kept: float) -> float:
        return max(100 * (1 - kept), floor)

    positive = sorted({p.kinematic_weight for p in study.sweep if p.kinematic_weight > 0})
    for index, damping in enumerate(study.dampings):
        points = sorted((p for p in study.sweep if p.damping == damping), key=lambda p: p.kinematic_weight)
        color = colors[index % len(colors)]
        x = [shown(p.short_kept) for p in points]
        y = [p.long_peak_ratio for p in points]
        trade.plot(x, y, color=color, lw=1.2, label=f"K_D = {damping:g} 1/s")
        swept = [p for p in points if p.kinematic_weight > 0]
        by_weight.plot([p.kinematic_weight for p in swept], [p.long_peak_ratio for p in swept], color=color, lw=1.2,
                       label=f"K_D = {damping:g} 1/s")  # fmt: skip
        for p, xi, yi in zip(points, x, y):
            style = {"marker": "o" if p.long_stable else "x", "color": color, "ms": 6,
                     "mfc": color if p.long_stable else "none"}  # fmt: skip
            trade.plot(xi, yi, **style)
            if p.kinematic_weight > 0:
                by_weight.plot(p.kinematic_weight, yi, **style)
    for mu in positive:
        points = [p for p in study.sweep if p.kinematic_weight == mu]
        top = max(points, key=lambda p: p.long_peak_ratio)
        if top.long_peak_ratio < 1.5:
            continue  # those near the limit line crowd each other; the right panel shows every μ
        trade.annotate(f"μ={mu:g}", (shown(top.short_kept), top.long_peak_ratio), textcoords="offset points",
                       xytext=(3, 5), fontsize=8, color="0.3")  # fmt: skip
    references = [("pinv", "s"), (study.sweep_reference, "D")]
    if SELF_MOTION_DAMPING in study.remedies:
        references.append((SELF_MOTION_DAMPING, "^"))
    if SWEPT_RESOLVER in study.remedies:
        references.append((SWEPT_RESOLVER, "*"))
    for name, marker in references:
        label = f"{name} (defaults)" if name == SWEPT_RESOLVER else name
        trade.plot(shown(study.cut_kept("short", name, study.sweep_torque_weight)), _peak_ratio(study.run("long", name)), marker=marker, ms=12,
                   color="k", mfc="gold" if marker == "*" else "none", ls="none", label=label)  # fmt: skip
    for ax in (trade, by_weight):
        ax.axhline(1.0, color="k", ls="--", lw=0.9, label="torque limit")
        ax.axhline(study.paper.limit_factor, color="tab:red", ls=":", lw=1.0,
                   label=f"unstable above {study.paper.limit_factor:g} × limit")  # fmt: skip
        ax.set_yscale("log")
        ax.set_ylabel("long movement (2 s): peak |τ|/limit")
        ax.grid(alpha=0.3, which="both")
    trade.set_xscale("log")
    trade.set_xlabel(
        f"short movement: share of {study.sweep_reference}'s torque cut given up [%] (μ = 0 drawn at {floor:.2g} %)"
    )
    trade.set_title("Torque saving against stability (o stable, x unstable)", fontsize=10, loc="left")
    trade.legend(fontsize=8, loc="upper right")
    by_weight.set_xscale("log")
    by_weight.set_xlabel("kinematic weight μ (relative to ‖SHZ‖_F)")
    by_weight.set_title("Long-movement peak against μ", fontsize=10, loc="left")
    fig.suptitle(
        f"{SWEPT_RESOLVER} (torque_weight={study.sweep_torque_weight}) on the paper's arm as μ and K_D vary",
        fontsize=11,
    )
    return save_figure(fig, path)
