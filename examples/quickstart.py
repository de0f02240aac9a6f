"""Quick start: the paper's arm, one straight line, two resolvers.

Run: python examples/quickstart.py
"""

import numpy as np

import torqueopt

robot = torqueopt.load_robot("planar3")  # the paper's 3-link planar arm, no gravity
q0 = np.radians([-45.0, 135.0, -135.0])  # tip at (√2, 1 − √2)
line = torqueopt.StraightLine(direction=[1.0, 1.0], accel=np.sqrt(2.0), duration=0.5)

for name in ("pinv", "null-space"):
    result = torqueopt.simulate(robot, name, line, q0)
    peaks = ", ".join(f"{peak:6.2f}" for peak in result.peak_torque)
    print(
        f"{name:>12}: peak |tau| = [{peaks}] N·m (limits 54, 24, 6), max tip error {result.max_tip_error * 1e3:.2f} mm"
    )

# The torque at one state, without simulating:
tau = torqueopt.resolve(robot, "null-space", q0, np.zeros(3), task_acceleration=[1.0, 1.0]).torque
print("null-space torque at rest for a tip acceleration of (1, 1) m/s²:", np.round(tau, 3), "N·m")
