"""What does model error do to the paper's resolvers and the remedies on a 7-DOF arm?

The resolver computes its torque with the robot's exact (URDF) model; the plant
is MuJoCo with every moving link's mass and inertia scaled by factors drawn
from U(1 − p, 1 + p) (p = 5, 10, 20 %, a few seeds each). Everything else is
matched (the URDF compiled by MuJoCo, its RK4 at dt, no contacts, no joint
limits, no damping or armature), so that with p = 0 the MuJoCo run is the
Pinocchio run and any difference is the model error alone.

For every resolver, on each arm, along the same straight line in open loop
(as in the paper), it reports the exact model's tip error and whiplash
verdict, then at each level the worst tip deviation from the exact model's
run over the seeds (how far the tip ends up from where the exact plant took
it) and how many perturbed runs whip (a joint needing more than twice its
torque limit, :func:`torqueopt.whiplash.detect_whiplash`) or stop early.
A resolver degrades gracefully when its exact run is stable, no perturbed run
whips or stops, and the deviation grows no faster than the perturbation
(deviation per percent within a factor 2 from 5 % to 20 %).

With ``--joint-dynamics`` it runs instead the table of the URDF's joint damping and friction: the plant is
the unperturbed MuJoCo model with the URDF's damping and friction (as ``frictionloss``), and the controller
either ignores them (``joint_dynamics="off"``) or models them (``"urdf"``, the Pinocchio model's
D q̇ + F tanh(q̇/v_s) in its bias torque), open loop and with the task-space feedback.

Run: python examples/model_error.py [--robots xarm7,panda] [--seeds 3] [--duration 1.0] [--joint-dynamics]
(about three minutes for the whole table on one core; needs pip install '.[mujoco]')
"""

import argparse
import time
import warnings

import torqueopt
from torqueopt.paper import PAPER_RESOLVERS
from torqueopt.plants.mujoco import MujocoPlant
from torqueopt.studies.remedies import REMEDIES
from torqueopt.whiplash import detect_whiplash

#: The plant settings that make the unperturbed MuJoCo run equal the Pinocchio run.
MATCHED = {"integrator": "rk4", "contacts": False, "joint_limits": False, "damping": "zero"}


def verdict(result) -> str:
    if not result.completed:
        return "stopped"
    return "whips" if detect_whiplash(result).unstable else "stable"


def first_failing_level(verdicts: dict[float, list[str]]) -> float | None:
    """The smallest perturbation at which some run whips or stops, or None."""
    return next((level for level, found in sorted(verdicts.items()) if any(v != "stable" for v in found)), None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--robots", default="xarm7,panda", help="comma-separated arms (default xarm7,panda)")
    parser.add_argument("--resolvers", default=",".join((*PAPER_RESOLVERS, *REMEDIES)),
                        help="comma-separated resolvers (default: the paper's four and the remedies)")  # fmt: skip
    parser.add_argument("--levels", default="0.05,0.1,0.2", help="perturbation fractions p (default 0.05,0.1,0.2)")
    parser.add_argument("--seeds", type=int, default=2, help="perturbed plants per level (default 2)")
    parser.add_argument("--duration", type=float, default=1.0, help="movement duration [s] (default 1.0)")
    parser.add_argument(
        "--feedback", default="400,40", help="task-space PD gains KP,KD of the second table (default 400,40)"
    )
    parser.add_argument(
        "--joint-dynamics", action="store_true",
        help="run only the table of the URDF's joint damping and friction: controller ignoring them, or modelling them",
    )  # fmt: skip
    args = parser.parse_args()
    levels = [float(level) for level in args.levels.split(",")]
    resolvers = args.resolvers.split(",")
    robots = args.robots.split(",")
    gains = tuple(float(gain) for gain in args.feedback.split(","))
    line = torqueopt.StraightLine(direction=[0.0, 1.0, 0.0], accel=0.4, duration=args.duration)
    if args.joint_dynamics:
        joint_dynamics_table(robots, resolvers, line, gains)
        return
    print(
        f"straight line along +y, {line.length * 1e3:.0f} mm in {args.duration:g} s, gravity on; plant: MuJoCo with "
        f"every link's mass and inertia scaled by factors from U(1 − p, 1 + p), {args.seeds} seed{'s' if args.seeds != 1 else ''} per level"
    )
    started = time.perf_counter()
    plants = {}
    for robot_name in robots:
        robot = torqueopt.load_robot(robot_name, task="position")
        plants[robot_name] = (robot, {0.0: [MujocoPlant(robot, **MATCHED)]} | {
            level: [MujocoPlant(robot, **MATCHED, perturb=level, seed=seed) for seed in range(args.seeds)]
            for level in levels
        })  # fmt: skip
    failing = {}
    for mode, feedback in (
        ("open loop, as in the paper", None),
        (f"task-space feedback KP,KD = {args.feedback}", gains),
    ):
        print(f"\n{mode}: largest tip error [mm] (worst seed), runs that whip / stop early")
        header = f"{'robot':<8}{'resolver':<32}{'exact model':>20}" + "".join(
            f"{f'p = {level:.0%}':>18}" for level in levels
        )
        print(header)
        print("-" * len(header))
        for robot_name in robots:
            robot, level_plants = plants[robot_name]
            for name in resolvers:
                runs = {}
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", torqueopt.TorqueoptWarning)
                    for level, plant_list in level_plants.items():
                        runs[level] = [
                            torqueopt.simulate(
                                robot, name, line, robot.default_configuration, plant=plant, feedback=feedback
                            )
                            for plant in plant_list
                        ]
                exact = runs[0.0][0]
                cells = [f"{exact.max_tip_error * 1e3:12.2f} {verdict(exact):>7}"]
                for level in levels:
                    worst = max(run.max_tip_error for run in runs[level])
                    whips = sum(verdict(run) == "whips" for run in runs[level])
                    stops = sum(verdict(run) == "stopped" for run in runs[level])
                    cells.append(f"{worst * 1e3:12.2f} {whips:>2}/{stops:<2}")
                print(f"{robot_name:<8}{name:<32}{''.join(f'{cell:>18}' for cell in cells)}")
                verdicts = {level: [verdict(run) for run in found] for level, found in runs.items()}
                failing.setdefault((robot_name, name), []).append(first_failing_level(verdicts))
    print(f"\n{len(robots) * len(resolvers) * (1 + len(levels) * args.seeds) * 2} runs in "
          f"{time.perf_counter() - started:.0f} s")  # fmt: skip
    print("\nstability under model error (whip or early stop in either table):")
    for robot_name in robots:
        graceful, own, broken = [], [], []
        for name in resolvers:
            found = [level for level in failing[(robot_name, name)] if level is not None]
            if not found:
                graceful.append(name)
            elif min(found) == 0.0:
                own.append(name)
            else:
                broken.append(f"{name} (from p = {min(found):.0%})")
        print(f"  {robot_name}: degrade gracefully: {', '.join(graceful) or 'none'}")
        print(f"  {robot_name}: unstable on the exact model already: {', '.join(own) or 'none'}")
        print(f"  {robot_name}: stable on the exact model, not on a perturbed one: {', '.join(broken) or 'none'}")


def joint_dynamics_table(robots, resolvers, line, gains) -> None:
    """Largest tip error [mm] and verdict on the MuJoCo plant with the URDF's joint damping and friction."""
    print(
        f"straight line along +y, {line.length * 1e3:.0f} mm in {line.duration:g} s, gravity on; plant: MuJoCo with "
        "the URDF's joint damping and friction (frictionloss), nothing else perturbed; KP,KD = "
        f"{gains[0]:g},{gains[1]:g} in the closed-loop columns"
    )
    header = (
        f"{'robot':<8}{'resolver':<32}{'ignores: open loop':>26}{'closed loop':>20}"
        f"{'models: open loop':>26}{'closed loop':>20}"
    )
    print(header)
    print("-" * len(header))
    started = time.perf_counter()
    for robot_name in robots:
        modelled = torqueopt.load_robot(robot_name, task="position", joint_dynamics="urdf")
        ignoring = modelled.with_joint_dynamics("off")
        plant_options = {**MATCHED, "damping": "urdf"}
        cells = {}
        for name in resolvers:
            row = []
            for robot in (ignoring, modelled):
                for feedback in (None, gains):
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", torqueopt.TorqueoptWarning)
                        run = torqueopt.simulate(robot, name, line, robot.default_configuration, plant="mujoco",
                                                 plant_options=plant_options, feedback=feedback)  # fmt: skip
                    row.append(f"{run.max_tip_error * 1e3:12.2f} {verdict(run):>7}")
            cells[name] = row
            print(f"{robot_name:<8}{name:<32}" + "".join(
                f"{cell:>26}" if index % 2 == 0 else f"{cell:>20}" for index, cell in enumerate(row)
            ))  # fmt: skip
    print(f"\n{len(robots) * len(resolvers) * 4} runs in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
