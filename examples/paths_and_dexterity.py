"""The paper's arm on three tip paths: how each resolver's torques and the arm's dexterity fare.

The paper's long movement (a straight line with constant acceleration, then
deceleration, 2 s), the minimum-jerk line over the same distance and time, and
a rest-to-rest circle that closes at the start. For each path and resolver:
the peak torque as a multiple of its limit, the whiplash verdict, the lowest
manipulability w (Eq. (6)) and dynamic manipulability (Eq. (25)) along the run,
and how far the joints end from where they started (the circle returns the tip
to its start; the joints need not return).

Run: python examples/paths_and_dexterity.py [--out FOLDER]
(with --out, also stick figures of each null-space run with the velocity ellipse)
"""

import argparse
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt import plots
from torqueopt.whiplash import detect_whiplash

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
parser.add_argument("--out", type=Path, help="folder for stick figures with dexterity ellipses")
args = parser.parse_args()

robot = torqueopt.load_robot("planar3")  # the paper's arm: no gravity, limits 54, 24, 6 N·m
q0 = np.radians([-45.0, 135.0, -135.0])
paper_line = torqueopt.StraightLine([1.0, 1.0], accel=np.sqrt(2.0), duration=2.0)
paths = {
    "paper line": paper_line,
    "min-jerk line": torqueopt.MinimumJerkLine([1.0, 1.0], length=paper_line.length, duration=2.0),
    "circle r=0.1": torqueopt.Circle(0.1, 2.0),
}

start = torqueopt.dexterity(robot, q0)
print(
    f"at q0: w = {start.manipulability:.4f}, dynamic w = {start.dynamic_manipulability:.4f} (m/s²)², "
    f"acceleration ellipse radii {np.round(start.acceleration_ellipsoid.radii, 3)} m/s²"
)
print(
    f"{'path':<15}{'resolver':<21}{'peak/limit':>11}  {'whiplash':<10}{'lowest w':>9}{'lowest dyn w':>13}"
    f"{'|q(T)-q0|':>11}"
)
for path_name, path in paths.items():
    for resolver in ("pinv", "inertia-pinv", "null-space", "weighted-null-space"):  # the paper's four
        result = torqueopt.simulate(robot, resolver, path, q0, dexterity=True)
        verdict = detect_whiplash(result)
        drift = np.linalg.norm(result.joint_angles[-1] - result.joint_angles[0])
        status = "unstable" if verdict.unstable else "stable"
        print(
            f"{path_name:<15}{resolver:<21}{result.peak_torque_ratio.max():11.2f}  {status:<10}"
            f"{np.nanmin(result.dexterity['manipulability']):9.3f}"
            f"{np.nanmin(result.dexterity['dynamic_manipulability']):13.3f}{drift:11.3f}"
        )
        if args.out and resolver == "null-space":
            name = path_name.replace(" ", "-").replace("=", "")
            figure = plots.plot_stick_strip(
                robot,
                result,
                args.out / f"{name}-null-space.png",
                title=f"null-space, {path_name}",
                snapshots=8,
                ellipse="velocity",
            )
            print(f"{'':<15}wrote {figure}")
