"""Do the paper's resolvers go unstable on 7-DOF arms too?

The paper conjectured about 7-DOF arms but only simulated a planar 3-link
arm. This script runs every registered resolver on panda and xarm7 (3-D position
task, n − m = 4, gravity on, open loop as in the paper) over a long
straight-line movement from each arm's default configuration, and reports
which runs stay within the torque limits, which exceed them, which the
whiplash detector calls unstable (a joint needing more than twice its torque
limit), which lose their path (the tip more than 1 mm from it) and which diverge outright, each
with when. Only a run that completed, stayed under the detector's thresholds and within the limits,
and kept its tip on the path is "ok".

Run: python examples/seven_dof_instability.py [--duration 2.0]
"""

import argparse

import torqueopt
from torqueopt.whiplash import detect_whiplash

#: Resolvers that solve a program over a window at every step: minutes per run on these arms
#: (``benchmarks/horizon_curve.py`` measures them), not the local methods this table compares.
PLANS_AHEAD = {"receding-horizon"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--duration", type=float, default=2.0, help="movement duration [s] (default 2.0)")
    parser.add_argument("--robots", default="panda,xarm7", help="comma-separated arms (default panda,xarm7)")
    args = parser.parse_args()

    line = torqueopt.StraightLine(direction=[0.0, 1.0, 0.0], accel=0.2, duration=args.duration)
    print(f"straight line along +y, {line.length:.3f} m in {args.duration} s (0.2 m/s²), open loop, gravity on\n")
    width = max(len(name) for name in torqueopt.resolver_names()) + 2
    header = (
        f"{'robot':<8}{'resolver':<{width}}{'verdict':<12}{'from [s]':>9}{'diverged [s]':>14}"
        f"{'peak |τ|/limit':>16}{'tip error [mm]':>16}"
    )
    print(header)
    print("-" * len(header))
    for robot_name in args.robots.split(","):
        robot = torqueopt.load_robot(robot_name, task="position")
        for name in torqueopt.resolver_names("torque"):
            if name in PLANS_AHEAD:
                continue
            result = torqueopt.simulate(robot, name, line, robot.default_configuration)
            whiplash = detect_whiplash(result)
            # "ok" only for a run that is stable by torque, completed and kept its tip on the path.
            if whiplash.unstable:
                verdict, when = "UNSTABLE", whiplash.time
            elif whiplash.lost_path:
                verdict, when = "OFF-PATH", None
            elif not result.completed:
                verdict, when = "STOPPED", None
            elif result.first_limit_violation is not None:
                verdict, when = "over-limit", result.first_limit_violation
            else:
                verdict, when = "ok", None
            when_text = f"{when:9.3f}" if when is not None else f"{'-':>9}"
            diverged = f"{result.stop_time:14.3f}" if not result.completed else f"{'-':>14}"
            print(
                f"{robot_name:<8}{name:<{width}}{verdict:<12}{when_text}{diverged}{result.peak_torque_ratio.max():16.2f}"
                f"{result.max_tip_error * 1e3:16.2f}"
            )
            if not whiplash.stable:
                print(f"{'':<8}  {whiplash.reason}")


if __name__ == "__main__":
    main()
