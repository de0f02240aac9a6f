"""Do the remedies hold up away from the paper's one line? Random straight lines on the paper's arm.

The paper's arm (no gravity, limits 54/24/6 N·m) from random start
configurations (σ_min/σ_max of J at least 0.1) along random directions,
√2 m/s² for a movement of --duration seconds, open loop. For each resolver:
how many runs stop early (the Jacobian goes singular: the line leaves the
workspace, or the motion diverges), how many of those that complete the
whiplash detector calls unstable, and the median peak |τ|/limit. Seeded, so the lines are the same
for every resolver and every run of the script.

Run: python examples/remedies_random_lines.py [--lines 30] [--duration 1.5] [--seed 7]
"""

import argparse
import math

import numpy as np

import torqueopt
from torqueopt.whiplash import detect_whiplash

#: (label, resolver, options): the paper's two extremes and the remedies at their defaults and beside them.
CASES = [
    ("pinv", "pinv", {}),
    ("null-space", "null-space", {}),
    ("damped-null-space", "damped-null-space", {}),
    ("damped-null-space μ=0.3 K_D=20", "damped-null-space", {"kinematic_weight": 0.3, "damping": 20.0}),
    ("damped-null-space μ=1", "damped-null-space", {"kinematic_weight": 1.0}),
    ("self-motion-damping", "self-motion-damping", {}),
    ("inverse-inertia-torque", "inverse-inertia-torque", {}),
    ("inverse-inertia-squared-torque", "inverse-inertia-squared-torque", {}),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--lines", type=int, default=30, help="number of random lines (default 30)")
    parser.add_argument("--duration", type=float, default=1.5, help="movement duration [s] (default 1.5)")
    parser.add_argument("--seed", type=int, default=7, help="random seed (default 7)")
    args = parser.parse_args()

    robot = torqueopt.load_robot("planar3", torque_limit=np.array([54.0, 24.0, 6.0]), gravity=False)
    rng = np.random.default_rng(args.seed)
    lines = []
    while len(lines) < args.lines:
        q0, angle = rng.uniform(-math.pi, math.pi, 3), rng.uniform(0.0, 2 * math.pi)
        singular_values = np.linalg.svd(robot.terms(robot.configuration(q0), np.zeros(3)).jacobian, compute_uv=False)
        if singular_values[-1] >= 0.1 * singular_values[0]:
            lines.append((q0, (math.cos(angle), math.sin(angle))))
    print(f"{args.lines} random lines on planar3, {args.duration:g} s at √2 m/s², open loop, seed {args.seed}\n")
    width = max(len(label) for label, _, _ in CASES) + 2
    header = f"{'resolver':<{width}}{'stopped early':>15}{'unstable (of the rest)':>24}{'median peak |τ|/limit':>24}"
    print(header)
    print("-" * len(header))
    for label, name, options in CASES:
        unstable = stopped = 0
        peaks = []
        for q0, direction in lines:
            line = torqueopt.StraightLine(direction, accel=math.sqrt(2.0), duration=args.duration)
            result = torqueopt.simulate(robot, name, line, q0, resolver_options=options)
            stopped += not result.completed
            unstable += result.completed and detect_whiplash(result).unstable
            peaks.append(result.peak_torque_ratio.max())
        print(f"{label:<{width}}{stopped:>15}{unstable:>24}{np.median(peaks):>24.2f}")


if __name__ == "__main__":
    main()
