"""Sweep damped-null-space over μ and K_D on the paper's arm, with either torque weight.

This is how the defaults of damped-null-space (μ = 0.5, K_D = 10 1/s) were
chosen: the setting that keeps the long (2 s) movement stable and within its
torque limits with both torque weights while keeping most of the short
(0.5 s) movement's torque cut. For each (μ, K_D) it prints the share of the
short movement's cut kept (against pinv, in the chosen weight: null-space's
cut for ``unit``, weighted-null-space's for ``range``) and the long
movement's peak |τ|/limit (U: unstable), then the numbers of the answer
(docs/discussion/remedies.md says what they answer).

Run: python examples/remedies_sweep.py [--torque-weight range] [--kinematic-weights 0,0.1,...] [--dampings 2,5,...]
"""

import argparse

from torqueopt.paper import run_paper
from torqueopt.studies.remedies import run_remedies
from torqueopt.studies.remedies.discussion_answers import kinematic_term_answer
from torqueopt.studies.remedies.report import answer_lines

#: The grid used to choose the defaults.
KINEMATIC_WEIGHTS = "0,0.1,0.15,0.2,0.3,0.5,0.7"
DAMPINGS = "2,5,10,15,20,30,50"


def numbers(text: str) -> list[float]:
    return [float(part) for part in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--torque-weight", choices=("unit", "range"), default="unit")
    parser.add_argument(
        "--kinematic-weights", default=KINEMATIC_WEIGHTS, help=f"μ values (default {KINEMATIC_WEIGHTS})"
    )
    parser.add_argument("--dampings", default=DAMPINGS, help=f"K_D values [1/s] (default {DAMPINGS})")
    args = parser.parse_args()

    study = run_remedies(
        run_paper(),
        kinematic_weights=numbers(args.kinematic_weights),
        dampings=numbers(args.dampings),
        torque_weight=args.torque_weight,
    )
    width = 13
    print(f"damped-null-space, torque_weight={args.torque_weight}: cut kept / long peak |τ|/limit (U: unstable)\n")
    corner = "μ / K_D"
    print(f"{corner:<8}" + "".join(f"{d:>{width}g}" for d in study.dampings))
    by_setting = {(p.kinematic_weight, p.damping): p for p in study.sweep}
    for mu in study.kinematic_weights:
        cells = []
        for damping in study.dampings:
            point = by_setting[mu, damping]
            cells.append(
                f"{round(100 * point.short_kept) + 0:.0f}%/{point.long_peak_ratio:.3g}{'' if point.long_stable else 'U'}"
            )
        print(f"{mu:<8g}" + "".join(f"{cell:>{width}}" for cell in cells))
    print()
    print("\n".join(answer_lines({"kinematic_term": kinematic_term_answer(study)})))


if __name__ == "__main__":
    main()
