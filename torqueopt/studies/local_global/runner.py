"""Running the local-against-global study: every local method and global variant on the paper's three movements."""

from __future__ import annotations

import numpy as np

from ...optimal import OptimalResult, optimize, run_cost
from ...paper import MOVEMENTS, PAPER, PaperScenario
from ...resolvers import RESOLVERS, get_resolver
from ...result import SimResult
from ...robot import Robot
from ...simulate import simulate
from ...whiplash import detect_whiplash
from .study import GLOBAL_VARIANTS, LOCAL, REMEDIES, STUDY_GRID_STEP, LocalGlobalStudy, Row

__all__ = ["run_local_global"]


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
            run = simulate(
                robot, get_resolver(name, **scenario.resolver_options(name)), line, scenario.q0, dt=scenario.dt
            )
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
                # Exact derivatives from two starts: the direct transcription's Gauss-Newton and L-BFGS stop at
                # IPOPT's acceptable level on the long weighted, bounded movement on some machines.
                transcription="shooting",
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
