"""The paper's experiment from Python: rerun it, judge the runs, check the claims, write the figures.

Hollerbach & Suh's scenario is ``torqueopt.paper.PAPER`` (the 3-link planar
arm from q0 = (-45°, 135°, -135°) along (1, 1) at √2 m/s², limits 54/24/6
N·m, movements of 0.5, 1.25 and 2 s). The same in one command:
``torqueopt paper --out paper-out``.

Run: python examples/paper_experiment.py [OUT_DIR]
"""

import sys

import numpy as np

from torqueopt.paper import PAPER, run_movement, run_paper, write_paper
from torqueopt.whiplash import detect_whiplash

# One run: the long null-space movement, and when its whip sets in.
result = run_movement(PAPER, "long", "null-space")
report = detect_whiplash(result)
print(f"long null-space: peak |tau| = {np.round(result.peak_torque, 1)} N·m; {report.reason}\n")

# The same start, another direction and shorter movements: does pinv stay within its limits?
other = PAPER.replace(direction=(1.0, 0.3), durations=(0.4, 1.0, 1.6))
for name in ("pinv", "null-space"):
    run = run_movement(other, "long", name)
    print(
        f"direction (1, 0.3), 1.6 s, {name:>10}: peak |tau|/limit {run.peak_torque_ratio.max():.2f}, "
        f"{'unstable' if detect_whiplash(run).unstable else 'stable'}"
    )

# Everything: every resolver on every movement, the free swing, the six claims, the figures.
results = run_paper()
for claim in results.claims:
    print(f"claim {claim.number} {'holds' if claim.holds else 'DOES NOT HOLD'}: {claim.evidence}")
if len(sys.argv) > 1:
    written = write_paper(results, sys.argv[1])
    print(f"wrote {len(written)} files to {sys.argv[1]}")
