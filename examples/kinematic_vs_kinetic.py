"""Kinematic against kinetic redundancy resolution on the paper's long movement (Section 1.1 against 1.2).

The paper's torque methods (acceleration level, torques from the resolver) beside the kinematic
methods of its Section 1.1 (velocity level: joint rates integrated by RK4, torques by inverse
dynamics on the resulting motion), on the same arm, start and 2 s straight line. Then one loop
of a circle, to show which methods are repeatable (Klein & Huang).

Run: python examples/kinematic_vs_kinetic.py [--out DIR]   (DIR: torque and joint-speed figures)
"""

import argparse

import numpy as np

import torqueopt
from torqueopt.resolvers.velocity import JointLimits
from torqueopt.tasks import FrameTask, Kinematics, ObstacleTask
from torqueopt.whiplash import detect_whiplash

Q0 = np.radians([-45.0, 135.0, -135.0])  # the paper's start, tip at (√2, 1 − √2)
LONG = torqueopt.StraightLine(direction=[1.0, 1.0], accel=np.sqrt(2.0), duration=2.0)
#: A point obstacle of radius 0.1 m that the plain pseudoinverse runs link 2 through.
OBSTACLE = ObstacleTask([1.2, 0.3], radius=0.1)

#: label -> (resolver name, options); the torque methods first, then Section 1.1's.
METHODS = {
    "pinv": ("pinv", {}),
    "inertia-pinv": ("inertia-pinv", {}),
    "null-space": ("null-space", {}),
    "weighted-null-space": ("weighted-null-space", {}),
    "velocity-pinv": ("velocity-pinv", {}),
    "gradient-projection(5)": ("gradient-projection", {"criterion": "joint-limits", "k": 30.0}),
    "gradient-projection(6)": ("gradient-projection", {"criterion": "manipulability", "k": 1.0}),
    "task-priority": ("task-priority", {"secondary": FrameTask("link3", "xy", target=[1.0, 0.0])}),
    "obstacle-avoidance": ("obstacle-avoidance", {"obstacle": OBSTACLE}),
    "extended-jacobian": ("extended-jacobian", {}),
    "kinetic-energy-pinv": ("kinetic-energy-pinv", {}),
}


def joint_limit_measures(robot, result):
    """Mean of Eq. (5) over the run and the largest |q − q_mid| / half range reached."""
    criterion, kinematics = JointLimits(), Kinematics(robot)
    values = [criterion.value(kinematics.update(q)) for q in result.q]
    distance = max(np.abs(criterion.normalised_distance(robot, q)).max() for q in result.q)
    return float(np.mean(values)), float(distance)


def clearance(robot, result):
    kinematics = Kinematics(robot)
    return min(OBSTACLE.clearance(kinematics.update(q)) for q in result.q)


def long_movement(robot):
    print(f"Long movement: {LONG.length:.3f} m along (1, 1)/√2 in {LONG.duration:g} s from q0 = (-45°, 135°, -135°)")
    header = (
        f"{'method':<24}{'level':<10}{'verdict':<24}{'peak |tau|/limit (j1, j2, j3)':<32}"
        f"{'peak speed':>11}{'w min':>8}{'w end':>8}{'Eq. (5) mean':>13}{'max |dq|/half':>14}{'clearance':>10}"
    )
    print(header)
    print("-" * len(header))
    results = {}
    for label, (name, options) in METHODS.items():
        result = torqueopt.simulate(robot, name, LONG, Q0, resolver_options=options, dexterity=True)
        results[label] = result
        verdict = detect_whiplash(result)
        state = f"WHIPS at {verdict.time:.3f} s" if verdict.unstable else "no whiplash"
        if not result.completed:
            state += " (stopped)"
        ratios = ", ".join(f"{ratio:5.2f}" for ratio in result.peak_torque_ratio)
        w = result.dexterity["manipulability"]
        mean_p, distance = joint_limit_measures(robot, result)
        level = getattr(torqueopt.get_resolver(name, **options), "level", "torque")
        print(
            f"{label:<24}{level:<10}{state:<24}{'(' + ratios + ')':<32}{np.abs(result.v).max():>11.2f}"
            f"{np.nanmin(w):>8.3f}{w[-1]:>8.3f}{mean_p:>13.4f}{distance:>14.3f}{clearance(robot, result):>10.3f}"
        )
    print("peak speed in rad/s; w = sqrt(det JJᵀ) [m²], Eq. (6); Eq. (5) with the URDF's ±2π limits;")
    print("clearance from the obstacle at (1.2, 0.3), radius 0.1 m [m], negative: through it")
    return results


def repeatability(robot):
    loop = torqueopt.Circle(0.5, 4.0, centre_direction=[1.0, 0.0])
    print()
    print("One loop of a 0.5 m circle in 4 s (rest to rest) from the same q0: joint drift |q(T) − q(0)| [rad]")
    for name in ("pinv", "velocity-pinv", "kinetic-energy-pinv", "gradient-projection", "extended-jacobian"):
        result = torqueopt.simulate(robot, name, loop, Q0, dt=0.005 if name != "pinv" else 0.001)
        drift = np.abs(result.joint_angles[-1] - result.joint_angles[0])
        closure = np.linalg.norm(result.x[-1] - result.x[0])
        print(f"{name:<24}drift per joint ({', '.join(f'{d:.2e}' for d in drift)}), tip closes to {closure:.1e} m")


def figures(results, out):
    from torqueopt import plots

    shown = [
        "pinv",
        "null-space",
        "velocity-pinv",
        "gradient-projection(5)",
        "extended-jacobian",
        "kinetic-energy-pinv",
    ]
    runs = [results[label] for label in shown]
    path = plots.plot_torques(
        runs,
        f"{out}/kinematic_vs_kinetic_torques.png",
        title="Long movement: torque against kinetic and kinematic methods",
    )
    print(f"wrote {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--out", help="directory for the torque figure")
    args = parser.parse_args()
    robot = torqueopt.load_robot("planar3")
    results = long_movement(robot)
    repeatability(robot)
    if args.out:
        figures(results, args.out)


if __name__ == "__main__":
    main()
