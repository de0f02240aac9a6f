"""Sweep energy-bounded-torque over E_max and α on a seeded atlas population of the paper's arm.

This is how the defaults of energy-bounded-torque were chosen (the numbers
are in docs/guide/energy-bounded-torque.md). For each setting it runs the
atlas (pinv first, as the baseline) on the same seeded population of random
straight lines, durations 0.5-2 s, and prints, per setting: the whiplash
share with its 95 % Wilson interval, the median peak torque ratio against
pinv on the same path, the share of paths within the torque limits where
pinv is, the share of paths that had an infeasible step (task acceleration
given up), the median and largest tip error, the largest self-motion
energy over E_max, the verdict counts and the share of paths pinv keeps
within its torque limits.

Run: python examples/energy_bounded_sweep.py [--paths 25] [--limits 0.1,0.3,1] [--rates 5,20,100] [--workers 2]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

from torqueopt.atlas import run_atlas
from torqueopt.atlas.stats import wilson_interval
from torqueopt.resolvers import EnergyBoundedTorque

DURATIONS = (0.5, 1.0, 1.5, 2.0)


def numbers(text: str) -> list[float]:
    return [float(part) for part in text.split(",")]


def measure(table, energy_limit: float) -> dict:
    """The figures of one setting's atlas table (each row of the resolver carries pinv's figures on its path)."""
    mine = table[table.resolver != "pinv"]
    whips = int((mine.verdict == "whiplash").sum())
    low, high = wilson_interval(whips, len(mine))
    pinv_within = mine.pinv_peak_torque_ratio <= 1.0
    return {
        "paths": len(mine),
        "whiplash": whips / len(mine),
        "whiplash_95": (low, high),
        "median_peak_vs_pinv": float(np.median(mine.torque_vs_pinv)),
        "within_where_pinv": float((mine.peak_torque_ratio[pinv_within] <= 1.0).mean()),
        "infeasible_paths": float((mine.infeasible_steps > 0).mean()),
        "median_tip_error": float(np.median(mine.max_tip_error)),
        "max_tip_error": float(mine.max_tip_error.max()),
        "peak_energy_over_limit": float(mine.peak_self_motion_energy.max() / energy_limit),
        "verdicts": mine.verdict.value_counts().to_dict(),
        "pinv_within": float(pinv_within.mean()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--paths", type=int, default=25, help="movements per duration (default 25)")
    parser.add_argument("--limits", default="0.1,0.3,1", help="E_max values [J]")
    parser.add_argument("--rates", default="5,20,100", help="α values [1/s]")
    parser.add_argument("--torque-weights", default="unit,range", help="torque_weight values (unit, range)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=0, help="Dask workers (0: in this process)")
    args = parser.parse_args()
    print(
        "torque_weight, E_max [J], α [1/s]: whiplash (95 % Wilson), median peak |τ|/limit vs pinv, within limits where pinv is,"
    )
    print("  paths with an infeasible step, median / largest tip error [m], largest E_N / E_max")
    with tempfile.TemporaryDirectory() as scratch:
        settings = [
            (weight, limit, rate)
            for weight in args.torque_weights.split(",")
            for limit in numbers(args.limits)
            for rate in numbers(args.rates)
        ]
        for weight, limit, rate in settings:
            resolver = EnergyBoundedTorque(energy_limit=limit, energy_rate=rate, torque_weight=weight)
            atlas = run_atlas(
                "planar3",
                paths=args.paths,
                durations=DURATIONS,
                resolvers=[resolver],
                out=Path(scratch) / f"{weight}-{limit}-{rate}",
                seed=args.seed,
                workers=args.workers,
                progress=False,
                figures=False,
            )
            found = measure(atlas.table, limit)
            low, high = found["whiplash_95"]
            print(
                f"{weight}, {limit:g}, {rate:g}: {found['whiplash']:.3f} ({low:.3f}-{high:.3f}) of {found['paths']}, "
                f"{found['median_peak_vs_pinv']:.3f}, {found['within_where_pinv']:.3f}, "
                f"{found['infeasible_paths']:.3f}, {found['median_tip_error']:.2e} / {found['max_tip_error']:.2e}, "
                f"{found['peak_energy_over_limit']:.4f}; verdicts {found['verdicts']}; "
                f"pinv within limits on {found['pinv_within']:.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
