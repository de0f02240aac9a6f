"""``torqueopt run``: simulate one resolver on one tip path (the paper's line by default)."""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np

from ..dexterity import summarise_along
from ..errors import InvalidInput
from ..io import json_file_with, refuse_foreign, writable_paths, written_together
from ..progress import progress_bar
from ..resolvers import Resolver
from ..result import SimResult
from ..result_files import run_files
from ..robot import Robot
from ..settings import Settings, group, numbers, positive, positive_in, setting, time_step, whole, whole_at_least
from ..simulate import DEFAULT_MAX_STEPS, Feedback, simulate, step_budget
from ..whiplash import DEFAULT_LIMIT_FACTOR, detect_whiplash
from . import EXIT_OK, EXIT_STOPPED
from .common import RobotSettings, StartSettings, torque_table
from .paths import PathSettings
from .plant import RunPlantSettings, plant_summary
from .play import PlaybackSettings, check_frames, play_live, prepare_playback
from .resolvers import ResolverSettings

__all__ = ["RunSettings", "add_parser", "format_summary"]

#: Steps from which ``torqueopt run`` shows its progress (100 s at the default 1 ms).
LONG_RUN_STEPS = 100_000

#: Keys every run sidecar has: a .csv.json with them is one torqueopt wrote, and may be replaced.
SIDECAR_KEYS = ("robot", "frame", "task", "resolver", "joint_names", "dt")


@dataclass(frozen=True)
class RunSettings(Settings):
    """Every setting of ``torqueopt run``: its options, and the record of them its sidecar keeps (``settings``)."""

    TITLE = "movement"

    model: RobotSettings = group(RobotSettings)
    resolving: ResolverSettings = group(ResolverSettings)
    start: StartSettings = group(StartSettings)
    tip_path: PathSettings = group(PathSettings)
    dt: float = time_step("integration step [s]; torque held over each; must divide the duration (default 0.001)")
    max_steps: int = setting(
        DEFAULT_MAX_STEPS,
        f"refuse a run of more than N steps (duration / dt), checked before it starts (default {DEFAULT_MAX_STEPS})",
        check=whole_at_least(1),
        parse=whole(1),
        metavar="N",
    )
    feedback: tuple[float, float] | None = setting(
        None,
        "task-space PD feedback: xdd = xdd_ref + KD(xd_ref − xd) + KP(x_ref − x); default open loop, as the paper",
        parse=numbers(2),
        metavar="KP,KD",
    )
    limit_factor: float = setting(
        DEFAULT_LIMIT_FACTOR,
        "whiplash detector: unstable once a joint needs more than K times its torque limit (default 2)",
        check=positive_in(),
        parse=positive,
        metavar="K",
    )
    dexterity: bool = setting(
        True,
        "record the dexterity measures of every step (manipulability, Eq. (25), ...) in the summary and "
        "the run file (default: on)",
        switch="both",
    )
    margin: bool = setting(
        False,
        "record the stability margin of every step (growth rate of the linearised closed-loop self-motion "
        "[1/s], computed after the run) in the summary and the run file, column stability_margin",
        switch="on",
    )
    out: str | None = setting(None, "write the run: .csv (with a .csv.json sidecar) or .npz", metavar="FILE")
    simulation: RunPlantSettings = group(RunPlantSettings)
    playback: PlaybackSettings = group(PlaybackSettings)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "run",
        help="simulate a resolver tracking a tip path (the paper's straight line by default)",
        description=(
            "Simulate a resolver tracking a tip path: by default the paper's rest-to-rest straight line (constant "
            "tangential acceleration over the first half, deceleration over the second); --path picks a "
            "minimum-jerk line, a circle or waypoints from a CSV file. RK4 with the torque held over each step. Prints peak torques against limits, the first limit violation, the tip error and "
            "whether the run stopped early. Angles in radians; give negative vectors as --q0=-0.78,..."
        ),
    )
    RunSettings.add_arguments(parser)
    parser.set_defaults(handler=run_command)


def run_command(args: argparse.Namespace) -> int:
    settings = RunSettings.from_arguments(args)
    trajectory = settings.tip_path.trajectory(settings.start.degrees)
    steps = step_budget(trajectory.duration, settings.dt, settings.max_steps, option="--max-steps")
    feedback = None if settings.feedback is None else Feedback(*settings.feedback)
    playback = settings.playback
    check_frames(playback, trajectory.duration)
    resolver = settings.resolving.build(settings.model.robot)
    robot = settings.model.load("run")
    resolver.check(robot)
    check_torque_limits(robot, resolver)
    plant = settings.simulation.build(robot)
    q0 = settings.start.configuration(robot)
    v0 = settings.start.velocity(robot)
    out = settings.out
    # Every file the run will write, checked before it starts, and no two of them one file.
    writable_paths([*(run_files(out) if out else []), *([playback.html] if playback.html else [])])
    if out and len(run_files(out)) == 2:
        sidecar = run_files(out)[1]
        refuse_foreign([sidecar], json_file_with(sidecar, SIDECAR_KEYS), "a run's sidecar", "give --out another name")
    reach_note = path_beyond_reach(robot, trajectory, q0)
    if reach_note:
        print(f"note: {reach_note}", file=sys.stderr)
    # A long run (100 s at 1 ms and more: a minute or more of work) says how far it is; a short one says nothing.
    bar = progress_bar(f"torqueopt run: {steps:,} steps", total=steps, unit="step", enabled=steps >= LONG_RUN_STEPS)
    try:
        result = simulate(
            robot,
            resolver,
            trajectory,
            q0,
            v0,
            dt=settings.dt,
            feedback=feedback,
            max_steps=settings.max_steps,
            dexterity=settings.dexterity,
            plant=plant,
            margin=settings.margin,
            progress=lambda done: bar.update(done - bar.n),
        )
    finally:
        bar.close()
    result.settings = settings.record()
    # Every file is written before anything is printed, so a closed stdout
    # (``torqueopt run ... | head -1``) cannot cost a result.
    lines = []
    with written_together():
        if out:
            result.to_csv(out)
            lines.append(f"wrote {' and '.join(map(str, run_files(out)))}")
        if playback.wanted:
            viewer, playback_lines = prepare_playback(playback, robot, result)
    if playback.wanted:
        lines += [line() for line in playback_lines]
    print(format_summary(robot, result, settings.limit_factor))
    for line in lines:
        print(line)
    if playback.play:
        play_live(viewer)
    return EXIT_OK if result.completed else EXIT_STOPPED


def path_beyond_reach(robot: Robot, trajectory, q0, samples: int = 201) -> str:
    """A sentence when the tip path leaves the arm's sampled reach (no motion can follow it there), else ``""``.

    The reach is :func:`torqueopt.atlas.population.arm_reach`'s: the farthest the task frame got from the first
    moving joint over 4,096 random configurations (a lower bound of the true reach, exact for planar3). The
    path is sampled at ``samples`` times, anchored at the tip's position at ``q0`` as :func:`simulate` anchors it.
    """
    from ..atlas.population import arm_reach, default_accel
    from ..checks import trajectory_dimension

    linear = trajectory_dimension(robot, trajectory)  # a path the task cannot follow is refused here, as simulate does
    if trajectory.start is None:
        trajectory = trajectory.anchored(robot.frame_placement(q0).translation[:linear])
    times = np.linspace(0.0, trajectory.duration, samples)
    base, reach = arm_reach(robot)
    with np.errstate(over="ignore", invalid="ignore"):  # --accel 1e308: the path runs to inf, beyond any reach
        distance = np.linalg.norm(trajectory.sample(times).position[:, :linear] - base[:linear], axis=1)
    farthest = int(np.argmax(np.nan_to_num(distance, nan=np.inf)))
    if distance[farthest] <= reach:
        return ""
    return (
        f"the path passes {distance[farthest]:.3g} m from the arm's base at t = {times[farthest]:.3g} s, beyond the "
        f"{reach:.3g} m its task frame reached in 4,096 random configurations, so no motion can follow it there; "
        f"the atlas sizes a line to the arm with --accel {default_accel(reach):.3g} (m/s²)"
    )


def check_torque_limits(robot: Robot, resolver: Resolver) -> None:
    """Say which joints have no usable limit; refuse where the resolver, with its options, divides by the range."""
    missing = robot.joints_without_torque_limit
    if not missing:
        return
    joints = ", ".join(missing)
    if resolver.needs_torque_limits:
        raise InvalidInput(
            f"joints {joints} of robot '{robot.name}' have no torque limit (URDF effort zero, infinite or missing) "
            f"and {resolver.name} weights torques by their range: give --torque-limit (or a weight option)"
        )
    print(
        f"note: joints {joints} of robot '{robot.name}' have no torque limit (URDF effort zero, infinite or "
        "missing); they are treated as unbounded: give --torque-limit to check them",
        file=sys.stderr,
    )


def _steps_taken(result: SimResult) -> int:
    """Steps integrated: up to the last row, or up to the stop (which may follow the last row's step)."""
    end = result.stop_time if result.stop_time is not None else (result.t[-1] if len(result.t) else 0.0)
    return round(end / result.dt)


def margin_summary(result: SimResult) -> str:
    """One line: the largest stability margin and when it first turned positive."""
    margin = result.stability_margin
    known = np.isfinite(margin)
    if not known.any():
        return "stability margin: no step with an applied torque"
    peak = int(np.nanargmax(margin))
    positive = np.flatnonzero(known & (margin > 0))
    first = f"first positive at t = {result.t[positive[0]]:.3f} s" if positive.size else "never positive"
    return f"stability margin: largest {margin[peak]:.4g} 1/s at t = {result.t[peak]:.3f} s, {first}"


#: The gravity vectors a run's summary need not state: off, and the usual −9.81 m/s² along z [m/s²].
_USUAL_GRAVITY = ((0.0, 0.0, 0.0), (0.0, 0.0, -9.81))


def _model_lines(result: SimResult) -> list[str]:
    """What the run's model carries beyond its URDF: a payload, gravity along another vector."""
    lines = []
    if result.payload is not None:
        payload = result.payload
        inertia = (
            "a point mass"
            if not any(payload["inertia"])
            else "moments " + ", ".join(f"{moment:g}" for moment in payload["inertia"]) + " kg·m²"
        )
        position = ", ".join(f"{coordinate:g}" for coordinate in payload["position"])
        lines.append(f"payload: {payload['mass']:g} kg at ({position}) m in frame '{result.frame}', {inertia}")
    if result.gravity is not None and tuple(result.gravity) not in _USUAL_GRAVITY:
        lines.append(f"gravity: ({', '.join(f'{g:g}' for g in result.gravity)}) m/s²")
    return lines


def format_summary(robot: Robot, result: SimResult, limit_factor: float = DEFAULT_LIMIT_FACTOR) -> str:
    """A short human-readable report of a run."""
    lines = [
        f"{result.robot}: resolver {result.resolver}, task {result.task} at frame '{result.frame}' "
        f"(n={robot.nv}, m={robot.m}), {_steps_taken(result)} steps of {result.dt * 1e3:g} ms",
        *_model_lines(result),
        *torque_table(result),
    ]
    if robot.joints_without_torque_limit:
        lines.append(
            "no torque limit for joints "
            + ", ".join(robot.joints_without_torque_limit)
            + " (URDF effort zero, infinite or missing): give --torque-limit to check them"
        )
    violation = result.first_limit_violation
    lines.append(
        "first limit violation: none"
        if violation is None
        else f"first limit violation: t = {violation:.3f} s at joint {result.first_limit_violation_joint}"
    )
    for kind, violation in (
        ("position", result.first_position_violation),
        ("velocity", result.first_velocity_violation),
    ):
        if violation is None:
            lines.append(f"first joint {kind} limit exceeded: none")
        else:
            time, joint, value, limit = violation
            unit = result.joint_unit(list(result.joint_names).index(joint), kind)
            lines.append(
                f"first joint {kind} limit exceeded: t = {time:.3f} s at joint {joint} "
                f"({value:.4g} {unit}, limit {limit:.4g} {unit})"
            )
    lines.append(f"max tip error: {result.max_tip_error * 1e3:.3f} mm")
    if result.max_task_error == 0 and result.infeasible_steps:
        # A bounded resolver with infeasible=exceed: the task held, the bounds gave way.
        steps = result.infeasible_steps
        lines.append(
            f"task realised, but {steps} step{'s' if steps != 1 else ''} found no torque within the limits "
            "that realises it: the torques exceed the limits there"
        )
    elif result.max_task_error > 0 or result.infeasible_steps:
        lines.append(
            f"task not realised: largest task-acceleration shortfall {result.max_task_error:.4g} m/s², "
            f"{result.infeasible_steps} infeasible step{'s' if result.infeasible_steps != 1 else ''}"
        )
    first_infeasible = result.first_infeasible_step
    if first_infeasible is not None and first_infeasible[1]:
        lines.append(f"first infeasible step: t = {first_infeasible[0]:.3f} s, on {first_infeasible[1]}")
    if result.max_orientation_error is not None:
        lines.append(f"max orientation error: {math.degrees(result.max_orientation_error):.4f} deg")
    if result.dexterity:
        lines.extend(summarise_along(result.t, result.dexterity))
    if result.stability_margin is not None:
        lines.append(margin_summary(result))
    lines.append(f"whiplash: {detect_whiplash(result, limit_factor=limit_factor).reason}")
    lines.extend(joint_dynamics_summary(result))
    lines.extend(plant_summary(result))
    lines.append("status: completed" if result.completed else f"status: STOPPED EARLY: {result.stop_reason}")
    return "\n".join(lines)


def joint_dynamics_summary(result) -> list[str]:
    """One line when the URDF has joint damping or friction: whether the run modelled them, and their peaks."""
    record = result.joint_dynamics
    if record is None:
        return []

    def shown(values) -> str:
        values = [float(value) for value in values]
        return f"{values[0]:g}" if len(set(values)) == 1 else ", ".join(f"{value:g}" for value in values)

    given = f"damping {shown(record['damping'])} N·m·s/rad, friction {shown(record['friction'])} N·m"
    if not result.models_joint_dynamics:
        return [f"joint dynamics: the URDF's joint {given} NOT modelled (--joint-dynamics off); urdf models them"]
    damping = np.nanmax(np.abs(result.damping_torque), axis=0, initial=0.0)
    friction = np.nanmax(np.abs(result.friction_torque), axis=0, initial=0.0)
    joint = int(np.argmax(damping + friction))
    unit = result.joint_unit(joint, "torque")
    # Each a peak of its own over the run: they may exceed the motor's peak, where they oppose gravity or inertia.
    return [
        f"joint dynamics: the URDF's joint {given} modelled (--joint-dynamics urdf); largest at joint "
        f"{result.joint_names[joint]}: damping up to {damping[joint]:.4g} {unit} and friction up to "
        f"{friction[joint]:.4g} {unit}, beside a peak motor torque of {result.peak_torque[joint]:.4g} {unit}"
    ]
