"""The horizon curve at a small scale: how much look-ahead torque optimisation needs, on random planar3 lines.

On PATHS random 2 s lines of the atlas's population (torqueopt.atlas.population, planar3, seed 0) it runs

* the local methods at the left edge: ``pinv``, ``null-space`` (the paper's torque optimum, unbounded) and
  ``bounded-torque[kinematic_weight=0]`` (the same criterion under the torque bounds and joint limits);
* ``receding-horizon`` with windows of one control step, 0.05, 0.1, 0.2, 0.5, 1 and 2 s (knots 5 ms, or the
  step for the one-step window), replanned every ``--replan-every`` steps (every step for the one-step window);
* the whole-movement optimum at the right edge (``optimize(transcription="shooting")`` from ``pinv``'s run,
  torque bounds and joint limits on, end free, grid ``--grid-step``);

judges every run as the atlas does (torqueopt.atlas.verdicts.run_row: whiplash, too demanding, ..., stable;
problem-free = stable within the torque limits, torqueopt.atlas.frontier.problem_free) and writes, per method,
the problem-free and whiplash shares, the median cost ∫‖τ − τ_mid‖² dt and its median ratio to the optimum's,
the median peak |τ|/τ⁺, the compute per control step and ``fallback_rows`` (rows with a ``limiting`` note:
receding-horizon's fallback rows; bounded-torque's rows on its bounds without the task) to ``--out`` (JSON; the
rows per path beside it, ``.rows.jsonl``). Rows are appended as they come (a run killed and started again with
the same arguments resumes).

    nice python benchmarks/horizon_curve.py --paths 20 --out horizon_curve.json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt.atlas.frontier import problem_free
from torqueopt.atlas.population import PopulationSpec, arm_reach, draw_population, movement_trajectory
from torqueopt.atlas.verdicts import Thresholds, run_row, self_motion_energy
from torqueopt.optimal import optimize, run_cost

HORIZONS = ("step", 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
LOCAL = ("pinv", "null-space", "bounded-torque[kinematic_weight=0]")
OPTIMUM = "whole-movement optimum"


def methods(replan_every: int) -> list[str]:
    """The resolver labels of the curve, left to right (the optimum is added apart)."""
    windows = [
        "receding-horizon[horizon=0.001]"
        if horizon == "step"
        else f"receding-horizon[horizon={horizon:g},replan_every={replan_every}]"
        for horizon in HORIZONS
    ]
    return [*LOCAL, *windows]


def judged(robot, run, pinv_peak: float) -> dict:
    kinetic, self_energy = self_motion_energy(robot, run)
    row = run_row(run, kinetic, self_energy, pinv_peak, Thresholds())
    return {
        "verdict": row["verdict"],
        "peak_torque_ratio": row["peak_torque_ratio"],
        "cost": run_cost(run, robot) if run.completed else math.nan,
        "completed": bool(run.completed),
        "fallback_rows": len(run.limiting or {}),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--paths", type=int, default=20)
    parser.add_argument("--replan-every", type=int, default=10)
    parser.add_argument("--grid-step", type=float, default=0.01)
    parser.add_argument("--out", type=Path, default=Path("horizon_curve.json"))
    arguments = parser.parse_args(argv)
    robot = torqueopt.load_robot("planar3")
    spec = PopulationSpec(paths=arguments.paths, durations=(2.0,), seed=0)
    movements = draw_population(robot, spec.sized(arm_reach(robot)[1]))
    rows_path = arguments.out.with_suffix(".rows.jsonl")
    done = set()
    if rows_path.exists():
        done = {(row["path"], row["method"]) for row in map(json.loads, rows_path.read_text().splitlines())}
    labels = methods(arguments.replan_every)
    with rows_path.open("a") as rows_file:
        for movement in movements:
            trajectory, q0 = movement_trajectory(movement), movement.q0
            pinv = torqueopt.simulate(robot, "pinv", trajectory, q0)
            pinv_peak = float(np.nanmax(pinv.torque_ratio[:-1]))
            for label in [*labels, OPTIMUM]:
                if (movement.path, label) in done:
                    continue
                began = time.process_time()
                if label == OPTIMUM:
                    result = optimize(
                        robot, trajectory, q0, transcription="shooting", starts=("pinv",), torque_bounds=True,
                        joint_limits=True, end="free", grid_step=arguments.grid_step,
                    )  # fmt: skip
                    seconds = time.process_time() - began
                    row = {
                        "verdict": result.status,
                        "peak_torque_ratio": float(np.nanmax(np.abs(result.tau[:-1]) / robot.torque_upper)),
                        "cost": result.cost if result.optimal else math.nan,
                        "completed": bool(result.optimal),
                        "fallback_rows": 0,
                    }
                else:
                    run = torqueopt.simulate(robot, label, trajectory, q0)
                    seconds = time.process_time() - began
                    row = judged(robot, run, pinv_peak)
                row.update(
                    path=movement.path, method=label, cpu_seconds=seconds, steps=round(trajectory.duration / 1e-3)
                )
                rows_file.write(json.dumps(row) + "\n")
                rows_file.flush()
                print(f"path {movement.path:3d} {label:55s} {row['verdict']:15s} cost {row['cost']:10.4g} "
                      f"peak {row['peak_torque_ratio']:.3f} cpu {seconds:7.1f} s", flush=True)  # fmt: skip
    write_summary(rows_path, arguments.out, labels)


def write_summary(rows_path: Path, out: Path, labels: list[str]) -> None:
    """Per method: shares, median cost and its ratio to the optimum's, median peak, CPU per control step."""
    import pandas

    rows = pandas.DataFrame(map(json.loads, rows_path.read_text().splitlines()))
    optimum = rows[rows["method"] == OPTIMUM].set_index("path")["cost"]
    summary = []
    for label in [*labels, OPTIMUM]:
        part = rows[rows["method"] == label]
        if not len(part):
            continue
        ratio = part["cost"].to_numpy(float) / optimum.reindex(part["path"]).to_numpy(float)
        free = problem_free(part) if label != OPTIMUM else (
            part["completed"].to_numpy() & (part["peak_torque_ratio"].to_numpy(float) <= 1.0 + 1e-3)
        )  # fmt: skip
        summary.append(
            {
                "method": label,
                "paths": len(part),
                "problem_free_share": float(np.mean(free)),
                "whiplash_share": float(np.mean(part["verdict"].to_numpy() == "whiplash")),
                "median_cost": float(np.nanmedian(part["cost"])),
                "median_cost_vs_optimum": float(np.nanmedian(ratio)) if np.isfinite(ratio).any() else math.nan,
                "median_peak_torque_ratio": float(np.nanmedian(part["peak_torque_ratio"])),
                "cpu_ms_per_control_step": float(1e3 * part["cpu_seconds"].sum() / part["steps"].sum()),
                "verdicts": part["verdict"].value_counts().to_dict(),
                "fallback_rows": int(part["fallback_rows"].sum()),
            }
        )
    out.write_text(json.dumps({"robot": "planar3", "duration": 2.0, "methods": summary}, indent=1))
    for entry in summary:
        print(
            f"{entry['method']:55s} free {entry['problem_free_share']:5.0%} whip {entry['whiplash_share']:5.0%} "
            f"cost {entry['median_cost']:9.4g} (x{entry['median_cost_vs_optimum']:.3f}) "
            f"peak {entry['median_peak_torque_ratio']:.3f} cpu {entry['cpu_ms_per_control_step']:.2f} ms/step"
        )


if __name__ == "__main__":
    main()
