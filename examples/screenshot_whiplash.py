"""Screenshot of the paper's whiplash, as the meshcat playback shows it in a browser.

Simulates the long (2.0 s) movement of the paper's three-link arm with the
null-space resolver, writes the playback as a self-contained HTML file, and
has headless Chromium render that file paused at ``--at`` seconds: by 1.5 s
the arm has whipped round and all three joints are over their torque limits
(red spheres). This is how docs/whiplash.png, shown in the README, is made.

The same HTML file comes from the command line:

    torqueopt run --robot planar3 --resolver null-space --q0=-0.7853981634,2.3561944902,-2.3561944902 \\
        --direction 1,1 --duration 2.0 --html whiplash.html

Run: python examples/screenshot_whiplash.py [--at 1.5] [--out docs/whiplash.png] [--html FILE]
Needs meshcat and Chromium (Debian: apt-get install chromium).
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt import viewer

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
parser.add_argument("--at", type=float, default=1.5, help="simulated time of the screenshot [s] (default 1.5)")
parser.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "docs" / "whiplash.png"))
parser.add_argument("--html", help="also keep the HTML file here")
args = parser.parse_args()

robot = torqueopt.load_robot("planar3")
q0 = np.radians([-45.0, 135.0, -135.0])
line = torqueopt.StraightLine(direction=[1.0, 1.0], accel=np.sqrt(2.0), duration=2.0)
result = torqueopt.simulate(robot, "null-space", line, q0)

playback = viewer.Playback(robot, result)
frame = int(np.searchsorted(playback.frames.time, args.at / playback.speed, side="right")) - 1
over = ", ".join(playback.highlighted_joints(frame)) or "none"
with tempfile.TemporaryDirectory() as scratch:
    html = viewer.export_html(playback, args.html or Path(scratch) / "whiplash.html")
    png = viewer.screenshot_html(html, args.out, at=args.at, width=1280, height=720)
print(f"wrote {png}: planar3, null-space resolver, t = {args.at:g} s; joints over their limits: {over}")
