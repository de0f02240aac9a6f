"""Check that a speed-up of the velocity-level resolvers leaves their runs unchanged beyond round-off.

Runs every velocity-level resolver (with the variants whose code paths differ: criteria, secondary
tasks, position gain, the central-difference fallbacks) on the paper's movement on planar3, and a few
on panda's position task, and saves or compares the :class:`~torqueopt.SimResult` arrays q, v and tau.
Run it once on the code before a change and once after::

    python benchmarks/velocity_runs_unchanged.py --save /tmp/before.npz      # at the old commit
    python benchmarks/velocity_runs_unchanged.py --compare /tmp/before.npz   # at the new one

``--compare`` prints the largest difference of each array relative to the array's largest magnitude
and exits with status 1 if any passes ``--tolerance`` (1e-12 by default) or a run's length or stop
reason changed. The torque of a run whose q̈ holds a central difference (step δ = 1e-5 or 1e-6 rad: the
loop's own, the manipulability's curvature, the extended Jacobian's) is held to
:data:`DIFFERENCED_TOLERANCE` instead: a last-bit change of q̇ moves the rounding of q ± δq̇/|q̇|, which
the difference divides by δ. On the code of 747c523, moving q0 by one unit in the last place changed
tau by 2.3e-9 (obstacle-avoidance), 7.8e-11 (extended-jacobian) and 7.0e-11 (gradient projection with
the manipulability) of its largest value, and q and v by 8.3e-15 at most.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import torqueopt

#: Largest relative change of tau in a run whose q̈ holds a central difference: round-off divided by the
#: difference's step. Measured on the code of 6d7c40a, two units in the last place of one joint of q0 move
#: obstacle avoidance's torques by 1.4e-8 (relative), so a change of the order in which a step sums its stages
#: may move them as much; 5e-8 leaves that margin.
DIFFERENCED_TOLERANCE = 5e-8

#: Runs whose q̈ holds a central difference (the loop's or the method's own), or did in a baseline saved before
#: its closed form: obstacle avoidance's q̈ is in closed form since the commit that says so, and its torques move
#: by the former difference's own error (8.6e-9 against a baseline of 6d7c40a, 8.0e-9 against one of 8fba51c;
#: the tests hold the closed form to the loop's difference at 1e-8 run for run). The extended Jacobian's
#: curvature q̇ᵀ∇²Gq̇ is in closed form (its stack's) since the commit that says so: its torques move by the
#: former difference's own error, 4.0e-11 (extended-jacobian) and 4.5e-11 (K=5) against a baseline of 6d7c40a
#: (the difference itself was at 5.9e-11 and 5.4e-11 from it), 3.7e-11 and 4.2e-11 against one of 8625dbf
#: (q and v equal: q̈ does not enter the motion). Gradient projection with the manipulability likewise takes its
#: curvature k∇²p q̇ in closed form since the commit that says so: against a baseline of 6d7c40a its torques move
#: by 5.1e-11 on planar3 and 8.1e-15 on panda, q and v by 1.5e-14 at most (the tests hold the closed form to the
#: former central difference at 2e-9 of the term, to a five-point one at 5e-11).
DIFFERENCED = {
    "velocity-pinv self_motion",
    "gradient-projection manipulability",
    "task-priority damping",
    "extended-jacobian",
    "extended-jacobian K=5",
    "obstacle-avoidance",
    "panda gradient-projection manipulability",
}

#: (label, robot, resolver, options, duration [s]); planar3 runs the paper's 2 s movement.
RUNS = (
    ("velocity-pinv", "planar3", "velocity-pinv", {}, 2.0),
    ("velocity-pinv self_motion", "planar3", "velocity-pinv", {"self_motion": "0.1,-0.2,0.3"}, 2.0),
    ("gradient-projection", "planar3", "gradient-projection", {}, 2.0),
    ("gradient-projection K=5", "planar3", "gradient-projection", {"position_gain": 5.0}, 2.0),
    ("gradient-projection manipulability", "planar3", "gradient-projection", {"criterion": "manipulability"}, 2.0),
    ("kinetic-energy-pinv", "planar3", "kinetic-energy-pinv", {}, 2.0),
    ("kinetic-energy-pinv K=5", "planar3", "kinetic-energy-pinv", {"position_gain": 5.0}, 2.0),
    ("task-priority", "planar3", "task-priority", {}, 2.0),
    ("task-priority elbow", "planar3", "task-priority", {"secondary": "link3:0.5,-0.5"}, 2.0),
    ("task-priority damping", "planar3", "task-priority", {"damping": 0.01}, 0.5),
    ("extended-jacobian", "planar3", "extended-jacobian", {}, 2.0),
    ("extended-jacobian K=5", "planar3", "extended-jacobian", {"position_gain": 5.0}, 2.0),
    ("obstacle-avoidance", "planar3", "obstacle-avoidance", {"obstacle": "1.2,0.3,0,0.1"}, 2.0),
    ("panda velocity-pinv", "panda", "velocity-pinv", {}, 0.3),
    ("panda gradient-projection", "panda", "gradient-projection", {}, 0.3),
    ("panda gradient-projection manipulability", "panda", "gradient-projection", {"criterion": "manipulability"}, 0.3),
    ("panda kinetic-energy-pinv", "panda", "kinetic-energy-pinv", {}, 0.3),
    ("panda task-priority", "panda", "task-priority", {}, 0.3),
)


def run(robot_name: str, resolver: str, options: dict, duration: float) -> torqueopt.SimResult:
    """One run of the paper's movement (planar3) or a 0.2 m line along x (panda's position task)."""
    if robot_name == "planar3":
        robot = torqueopt.load_robot("planar3")
        q0, trajectory = np.radians([-45.0, 135.0, -135.0]), torqueopt.StraightLine([1.0, 1.0], duration=2.0)
    else:
        robot = torqueopt.load_robot(robot_name, task="position")
        q0 = robot.default_configuration
        trajectory = torqueopt.StraightLine([1.0, 0.0, 0.0], accel=0.2, duration=2.0)
    return torqueopt.simulate(robot, resolver, trajectory, q0, duration=duration, resolver_options=options)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--save", metavar="FILE", help="write the runs' q, v, tau to this .npz file")
    mode.add_argument("--compare", metavar="FILE", help="compare the runs with those saved in this .npz file")
    parser.add_argument("--tolerance", type=float, default=1e-12, help="largest relative difference (default 1e-12)")
    arguments = parser.parse_args()
    arrays = {}
    for label, robot, resolver, options, duration in RUNS:
        result = run(robot, resolver, options, duration)
        arrays[f"{label}|q"], arrays[f"{label}|v"], arrays[f"{label}|tau"] = result.q, result.v, result.tau
        arrays[f"{label}|stop"] = np.array(str(result.stop_reason))
    if arguments.save:
        np.savez(arguments.save, **arrays)
        print(f"saved {len(RUNS)} runs to {arguments.save}")
        return
    saved = np.load(arguments.compare)
    failed = False
    for label, *_ in RUNS:
        if str(saved[f"{label}|stop"]) != str(arrays[f"{label}|stop"]):
            print(f"{label}: stop reason {saved[f'{label}|stop']} -> {arrays[f'{label}|stop']}")
            failed = True
            continue
        line = []
        for name in ("q", "v", "tau"):
            before, after = saved[f"{label}|{name}"], arrays[f"{label}|{name}"]
            if before.shape != after.shape:
                line.append(f"{name} shape {before.shape} -> {after.shape}")
                failed = True
                continue
            scale = float(np.max(np.abs(before))) or 1.0
            relative = float(np.max(np.abs(after - before))) / scale
            tolerance = DIFFERENCED_TOLERANCE if name == "tau" and label in DIFFERENCED else arguments.tolerance
            failed |= not relative <= tolerance
            line.append(f"{name} {relative:.1e}")
        print(f"{label} ({len(saved[f'{label}|q'])} rows): " + ", ".join(line))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
