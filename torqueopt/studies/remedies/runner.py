"""Running the remedies study: every registered remedy on the paper's movements, then the (μ, K_D) sweep."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict

from ...checks import finite_values
from ...errors import InvalidInput
from ...paper import MOVEMENTS, PaperResults, run_movement
from ...resolvers import RESOLVERS
from ...simulate import simulate
from ...whiplash import detect_whiplash
from .measures import (
    DEFAULT_DAMPINGS,
    DEFAULT_KINEMATIC_WEIGHTS,
    SWEEP_REFERENCES,
    SWEPT_RESOLVER,
    _peak_ratio,
    _stable,
    registered_remedies,
    torque_cost,
)
from .study import RemediesStudy, SweepPoint

__all__ = ["run_remedies"]


def run_remedies(
    paper: PaperResults,
    *,
    sweep: bool = True,
    kinematic_weights: Sequence[float] = DEFAULT_KINEMATIC_WEIGHTS,
    dampings: Sequence[float] = DEFAULT_DAMPINGS,
    torque_weight: str = "unit",
    on_run=None,
) -> RemediesStudy:
    """Run every registered remedy on the paper's movements and, with ``sweep``, the (μ, K_D) grid.

    ``on_run``, when given, is called after each of the :func:`planned_runs` simulations.

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
    done = on_run or (lambda: None)
    runs, whiplash = {}, {}
    for movement in MOVEMENTS:
        for name in remedies:
            result = run_movement(scenario, movement, name, robot)
            done()
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
            done()
            done()
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


def planned_runs(
    sweep: bool = True,
    kinematic_weights: Sequence[float] = DEFAULT_KINEMATIC_WEIGHTS,
    dampings: Sequence[float] = DEFAULT_DAMPINGS,
) -> int:
    """The simulations :func:`run_remedies` makes with these settings (for a progress bar's total)."""
    remedies, _ = registered_remedies()
    count = len(remedies) * len(MOVEMENTS)
    if sweep and SWEPT_RESOLVER in RESOLVERS:
        dampings = _grid(dampings, "damping")
        count += 2 * sum(1 if mu == 0.0 else len(dampings) for mu in _grid(kinematic_weights, "kinematic weight"))
    return count


def _grid(values: Sequence[float], what: str) -> tuple[float, ...]:
    return finite_values(values, f"sweep {what}s", minimum=0.0)
