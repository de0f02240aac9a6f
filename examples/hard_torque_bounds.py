"""Do hard torque bounds help against the whiplash? The paper's three movements with the bounded resolvers.

Runs the paper's scenario (planar 3-link arm, limits 54, 24, 6 N·m, √2 m/s²
straight lines of 0.5, 1.25 and 2 s from q0 = (-45°, 135°, -135°)) with
``null-space`` and ``weighted-null-space`` (the paper's least squares), the
QP ``bounded-torque`` (the paper's criterion, ``kinematic_weight=0``, with
unit and range weights, and at its defaults, the criterion of
``damped-null-space``, shown beside it) and the LP ``minmax-torque``
(the paper's "linear programming", with the bounds enforced by task scaling,
and with ``infeasible=exceed``: the LP alone, torques allowed past the
limits). For each run it prints the peak torque over the limit, the largest
normalised torque maxᵢ |τᵢ − τ_mid,ᵢ|/(τ⁺ᵢ − τ⁻ᵢ) (within bounds iff <= 0.5),
the whiplash verdict, how many steps could not realise the task within the
bounds and from when, the largest task-acceleration shortfall, the largest
tip error and the fastest joint.

Run from the repository root::

    python examples/hard_torque_bounds.py
"""

import numpy as np

import torqueopt
from torqueopt.paper.scenario import MOVEMENTS, PAPER
from torqueopt.resolvers.bounded import torque_utilisation
from torqueopt.whiplash import detect_whiplash

CASES = [
    ("pinv", {}),
    ("null-space", {}),
    ("weighted-null-space", {}),
    ("bounded-torque", {"kinematic_weight": 0.0}),
    ("bounded-torque", {"kinematic_weight": 0.0, "torque_weight": "range"}),
    ("damped-null-space", {}),
    ("bounded-torque", {}),
    ("minmax-torque", {}),
    ("minmax-torque", {"infeasible": "exceed"}),
]
#: The paper's arm turns freely: its URDF's ±2π limits are placeholders (docs/decisions/0005), so the bounded
#: resolvers run without their joint-limit rows here, as the paper's runs do.
PAPER_ARM = {"joint_limits": "off"}


def main() -> None:
    robot = PAPER.load_robot()
    print(
        "| movement | resolver | options | peak τ/limit | max utilisation | whiplash | infeasible steps (from) "
        "| max task error [m/s²] | max tip error [m] | max joint speed [rad/s] |"
    )
    print("|---|---|---|---:|---:|---|---:|---:|---:|---:|")
    for movement in MOVEMENTS:
        for name, options in CASES:
            bounded = name in ("bounded-torque", "minmax-torque")
            resolver = torqueopt.get_resolver(name, **options, **(PAPER_ARM if bounded else {}))
            run = torqueopt.simulate(robot, resolver, PAPER.line(movement), PAPER.q0, dt=PAPER.dt)
            verdict = detect_whiplash(run)
            # The last row (t = T) applies no torque: NaN, skipped.
            utilisation = np.nanmax(torque_utilisation(run.tau, run.torque_lower, run.torque_upper))
            infeasible = int(run.infeasible.sum())
            since = f" ({run.t[run.infeasible][0]:.3f} s)" if infeasible else ""
            whip = f"from {verdict.time:.3f} s" if verdict.unstable else "no"
            shown = ", ".join(f"{key}={value}" for key, value in options.items()) or "-"
            print(
                f"| {movement} | {name} | {shown} | {run.peak_torque_ratio.max():.2f} | {utilisation:.3f} | {whip} "
                f"| {infeasible}{since} | {run.max_task_error:.3g} | {run.max_tip_error:.3g} "
                f"| {np.abs(run.v).max():.1f} |"
            )


if __name__ == "__main__":
    main()
