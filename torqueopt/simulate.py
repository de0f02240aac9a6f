r"""Simulation of a resolver tracking a tip trajectory, as in Section 3 of the paper.

At the start of each step :math:`[t_k, t_k + \Delta t]` the resolver maps
the reference task acceleration to joint torques :math:`\tau_k`; the torque
is held over the step while the forward dynamics
:math:`\ddot q = H^{-1}(\tau_k - \dot q\cdot C\cdot\dot q - g)` (Pinocchio's
ABA) is integrated by classical fourth-order Runge-Kutta. The paper used
:math:`\Delta t = 1` ms and open loop (no feedback of the tip error); task
feedback :math:`\ddot x = \ddot x_{ref} + K_D(\dot x_{ref} - \dot x) + K_P(x_{ref} - x)`
is an option.

A run stops early, keeping every row computed so far, when the task Jacobian
becomes singular, when a torque or the state stops being finite, or when the
motion explodes (a joint speed beyond ``max_joint_speed`` or a torque beyond
``max_torque_ratio`` times its limit).

The loop is the engine's (:func:`torqueopt.engine.run_movements`, the same
loop body as the batch's and the velocity-level methods'), over a stack of one
(:class:`~torqueopt.engine.MovementStack`): the resolver's single-state step,
Pinocchio's terms on the run's own data and the plant's one-state step.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from .checks import (
    DEFAULT_MAX_STEPS,
    configuration_vector,
    finite_vector,
    non_negative_number,
    positive_number,
    step_budget,
    trajectory_dimension,
    velocity_vector,
)
from .engine import MovementStack, run_movements, stack_of_one
from .errors import InvalidInput, TorqueoptWarning
from .integrators import rk4_step
from .linalg import inverse_condition_number
from .plants import PinocchioPlant, Plant, make_plant
from .resolvers import Resolution, Resolver, get_resolver
from .resolvers.stacks import LoopedStackStep
from .result import SimResult
from .robot import Robot
from .run_records import ReferenceBlocks, logged_row_bytes, task_reference
from .stop_rules import StopRules
from .terms import PinocchioTerms
from .trajectory import Trajectory, check_trajectory, describe
from .trajectory.orientation import rotation_error

__all__ = ["simulate", "rk4_step", "resolve", "step_budget", "Feedback", "DEFAULT_MAX_STEPS"]

#: Joint speed [rad/s or m/s] beyond which a run is declared diverged.
DEFAULT_MAX_JOINT_SPEED = 1.0e3
#: Torque, as a multiple of its limit, beyond which a run is declared diverged.
DEFAULT_MAX_TORQUE_RATIO = 1.0e3


@dataclass(frozen=True)
class Feedback:
    """Task-space PD gains: ẍ = ẍ_ref + kd (ẋ_ref − ẋ) + kp (x_ref − x); kp in [1/s²], kd in [1/s]."""

    kp: float
    kd: float

    def __post_init__(self):
        for name in ("kp", "kd"):
            object.__setattr__(self, name, non_negative_number(getattr(self, name), f"feedback gain {name}"))


def resolve(robot: Robot, resolver: str | Resolver, q, v, task_acceleration, **options) -> Resolution:
    """What ``resolver`` gives for ``task_acceleration`` at state (q, v): torques, joint accelerations, task error.

    ``q`` is a configuration vector (as from :meth:`Robot.configuration`),
    ``v`` the joint velocities [rad/s], ``task_acceleration`` the m-vector ẍ;
    ``options`` are the resolver's declared options (see
    ``torqueopt resolvers``). The torque is ``resolve(...).torque`` [N·m];
    ``task_error`` and ``infeasible`` say whether the task was realised.
    """
    resolver = get_resolver(resolver, **options)
    resolver.check(robot)
    q = configuration_vector(robot, q)
    v = velocity_vector(robot, v)
    task_acceleration = finite_vector(task_acceleration, robot.m, f"task acceleration for task '{robot.task}'")
    return resolver.resolve(robot, robot.terms(q, v), task_acceleration)


def simulate(
    robot: Robot,
    resolver: str | Resolver,
    trajectory: Trajectory,
    q0,
    v0=None,
    dt: float = 1e-3,
    *,
    duration: float | None = None,
    feedback: Feedback | tuple[float, float] | None = None,
    max_joint_speed: float = DEFAULT_MAX_JOINT_SPEED,
    max_torque_ratio: float = DEFAULT_MAX_TORQUE_RATIO,
    resolver_options: dict | None = None,
    dexterity: bool = False,
    max_steps: int = DEFAULT_MAX_STEPS,
    plant: str | Plant = "pinocchio",
    plant_options: dict | None = None,
    margin: bool = False,
    progress=None,
) -> SimResult:
    """Simulate ``resolver`` tracking ``trajectory`` from (q0, v0).

    Args:
        robot: from :func:`torqueopt.load_robot`.
        resolver: a registered name (see :func:`torqueopt.resolver_names`) or a Resolver.
        trajectory: the tip reference, any :class:`torqueopt.Trajectory`
            (StraightLine, MinimumJerkLine, Circle, WaypointPath, or an object
            with the same members); anchored at the tip's position at q0
            when it has no start.
        q0: initial configuration, either a configuration vector (nq) or one
            angle per joint (n) [rad].
        v0: initial joint velocities [rad/s]; zero by default.
        dt: step [s]; the torque is held over each step.
        duration: simulated time [s]; the trajectory's duration by default.
        feedback: task-space PD gains (kp, kd); open loop when None. On a ``pose`` path with rotations
            (:class:`~torqueopt.WaypointPath` ``rotations``) the orientation rows of x_ref − x are
            log(R_ref Rᵀ), the world rotation vector from the frame to the reference.
        max_joint_speed: a joint speed beyond this [rad/s] ends the run as diverged.
        max_torque_ratio: a torque beyond this multiple of its limit ends the run as diverged.
        resolver_options: the resolver's declared options, when ``resolver`` is a name
            (``simulate(robot, "damped-null-space", ..., resolver_options={"damping": 2.0})``).
        dexterity: also record the dexterity measures of every row
            (:func:`torqueopt.dexterity_along`, computed after the
            run from the stored configurations) as ``SimResult.dexterity``.
        max_steps: the most steps the run may take (checked before it starts,
            with the memory it would need), so that a mistyped duration or dt
            fails at once.
        plant: what the torque acts on (:mod:`torqueopt.plants`): ``"pinocchio"``
            (the robot's own model, RK4 with the torque held), ``"mujoco"``
            (a MuJoCo model of the arm; each step reads its state, computes the
            torque from it with the robot's Pinocchio model, and lets MuJoCo
            advance), or a :class:`~torqueopt.plants.Plant`. The result's
            ``plant`` records it.
        margin: also record the stability margin of every row with an applied torque
            (:func:`torqueopt.stability_margin` at the logged state and task
            acceleration, computed after the run, so the loop's cost is unchanged) as
            ``SimResult.stability_margin`` [1/s] (NaN on the other rows).
        plant_options: the plant's options by name, for a plant name
            (``{"integrator": "euler", "joint-limits": "off", "mjcf": "arm.xml"}``;
            see :mod:`torqueopt.plants.mujoco`).
        progress: called with the number of steps taken as each block of 4,096 steps starts (a long run's
            progress bar; ``torqueopt run`` shows one for runs of 100,000 steps or more).

    Returns:
        SimResult with one row per step start, t = 0, dt, ..., duration.
        Row k holds the state at t_k and the torque held over [t_k, t_k + dt];
        the last row, at t = duration, holds the final state and no torque
        (NaN), since none is applied after the movement. A run that stopped
        early ends with the row at which it stopped: the state there and the
        torque that stopped it (NaN when the Jacobian went singular there).

    Raises:
        InvalidInput: a bad value, more than ``max_steps`` steps, or a dt that
            does not divide the duration (the run would end before or after
            the movement; the message offers the nearest dt that divides it).
    """
    resolver = get_resolver(resolver, **(resolver_options or {}))
    if getattr(resolver, "level", None) == "velocity":
        if margin:
            raise InvalidInput(
                f"resolver {resolver.name} works at the velocity level: the stability margin is of a torque "
                "resolver's closed loop; give a torque resolver or leave margin off"
            )
        refuse_plant_at_velocity_level(resolver, plant, plant_options)
        from .kinematic import simulate_kinematic

        return simulate_kinematic(
            robot, resolver, trajectory, q0, v0, dt, duration=duration, feedback=feedback,
            max_joint_speed=max_joint_speed, max_torque_ratio=max_torque_ratio, dexterity=dexterity, max_steps=max_steps,
            progress=progress,
        )  # fmt: skip
    resolver.check(robot)
    check_trajectory(trajectory)
    dt = positive_number(dt, "dt", "s")
    duration = trajectory.duration if duration is None else duration
    duration = positive_number(duration, "duration", "s")
    steps = step_budget(duration, dt, max_steps, row_bytes=logged_row_bytes(robot))
    if feedback is not None and not isinstance(feedback, Feedback):
        feedback = Feedback(*feedback)

    q = configuration_vector(robot, q0)
    v = np.zeros(robot.nv) if v0 is None else velocity_vector(robot, v0)
    plant = make_plant(robot, plant, plant_options)
    plant.reset(dt)
    for note in start_notes(robot, q, dt if isinstance(plant, PinocchioPlant) else None):
        warnings.warn(note, TorqueoptWarning, stacklevel=2)
    placement = robot.frame_placement(q)
    reference_rotation = placement.rotation.copy()
    linear_dimension = trajectory_dimension(robot, trajectory)
    if trajectory.start is None:
        trajectory = trajectory.anchored(placement.translation[:linear_dimension])

    # The reference a block of steps at a time, so memory follows the steps taken, not the duration asked for.
    reference = ReferenceBlocks(robot, trajectory, dt, steps, progress=progress, start_rotation=reference_rotation)

    # One Pinocchio data per run: runs in threads cannot race, and nothing
    # outside this run writes into the views its terms hold.
    terms = PinocchioTerms(robot, robot.model.createData(), reference_rotation)
    # The resolver's per-robot constants and workspaces are built once per run (solver_for_movement).
    solve = LoopedStackStep(resolver, robot, dt)
    solve.along([trajectory])
    lanes = MovementStack(
        robot, resolver, q, v, dt, steps, [reference], solve=solve.stack_of_one(),
        terms=terms.stack_of_one(),
        advance=stack_of_one(plant, dt), rules=StopRules(robot, max_torque_ratio, max_joint_speed),
        feedback=feedback, reference_rotations=[reference_rotation],
    )  # fmt: skip
    run_movements(lanes, steps)
    (result,) = lanes.results(duration, [describe(trajectory)], [plant.record()], dexterity)
    if margin:
        result = with_margins(
            robot, resolver.solver_for_run(robot, dt), result, trajectory, feedback, reference_rotation
        )
    return result


def refuse_plant_at_velocity_level(resolver: Resolver, plant, plant_options) -> None:
    """InvalidInput for a velocity-level resolver given a plant other than the Pinocchio one."""
    if not (isinstance(plant, PinocchioPlant) or plant == "pinocchio") or plant_options:
        raise InvalidInput(
            f"resolver {resolver.name} works at the velocity level (the kinematic loop integrates its joint "
            "velocities, no torque drives a plant); a plant needs a torque resolver"
        )


def with_margins(
    robot: Robot, step, result: SimResult, trajectory: Trajectory, feedback: Feedback | None, reference_rotation=None
):
    """``result`` with its ``stability_margin`` column: σ at each row's state and task acceleration [1/s]."""
    from .stability import margins_along

    sample = task_reference(robot, trajectory, result.t, reference_rotation)
    commands = sample.acceleration
    if feedback is not None:
        task_velocity = np.array([robot.terms(q, v).task_velocity for q, v in zip(result.q, result.v)])
        position_error = sample.position - result.x
        if robot.task == "pose" and getattr(trajectory, "oriented", False):
            # as the run's command (MovementStack._feedback_command): the rotation from R to R_ref
            position_error[:, 3:] = [
                rotation_error(row, robot.frame_placement(q).rotation, reference_rotation)
                for row, q in zip(sample.position[:, 3:], result.q)
            ]
        commands = commands + feedback.kd * (sample.velocity - task_velocity) + feedback.kp * position_error
    applied = np.isfinite(result.tau).all(axis=1)
    return replace(result, stability_margin=margins_along(robot, step, result.q, result.v, commands, applied))


#: Below this σmin/σmax of the task Jacobian a start is called near-singular.
NEAR_SINGULAR = 0.05


def start_notes(robot: Robot, q: np.ndarray, dt: float | None = None) -> list[str]:
    """What is wrong with starting at configuration ``q`` at rest, one sentence each (empty when nothing).

    A start is questioned when its task Jacobian is near-singular
    (σmin/σmax below :data:`NEAR_SINGULAR`), when holding it against
    gravity alone needs more than a joint's torque limit, or when a joint is
    outside its URDF position limits; given the step ``dt`` [s] of the Pinocchio plant's RK4, when the joint
    damping and friction the robot models are too stiff for it.
    """
    notes = []
    terms = robot.terms(q, np.zeros(robot.nv))
    inverse_condition = inverse_condition_number(terms.jacobian)
    if inverse_condition < NEAR_SINGULAR:
        notes.append(
            f"the start is near-singular: σmin/σmax of the task Jacobian is {inverse_condition:.3g} (below {NEAR_SINGULAR:g}); "
            "give another --q0"
        )
    rest = np.abs(terms.bias_torque) / np.where(terms.bias_torque >= 0, robot.torque_upper, -robot.torque_lower)
    if (rest > 1.0).any():
        joint = int(np.argmax(rest))
        notes.append(
            f"holding the start against gravity needs {terms.bias_torque[joint]:.4g} {robot.joint_unit(joint, 'torque')} at joint "
            f"{robot.joint_names[joint]}, {rest[joint]:.3g} times its torque limit, before any movement"
        )
    lower, upper, _ = robot.joint_limits
    angles = robot.joint_angles(q)
    outside = (angles < lower - 1e-9) | (angles > upper + 1e-9)
    if outside.any():
        joint = int(np.argmax(outside))
        notes.append(
            f"the start has joint {robot.joint_names[joint]} at {angles[joint]:.4g}, outside its URDF limits "
            f"[{lower[joint]:.4g}, {upper[joint]:.4g}]"
        )
    if dt is not None and robot.models_joint_dynamics:
        rate = joint_dynamics_rate(robot, terms.inertia)
        if rate * dt > RK4_REAL_STABILITY:
            notes.append(
                f"the joint damping and friction are stiff for dt={dt:g} s: they damp the arm at up to {rate:.4g} /s "
                f"at the start, and dt times that is {rate * dt:.3g}, beyond the {RK4_REAL_STABILITY} where the RK4 "
                f"step stays stable; the integration error grows (a dt below {RK4_REAL_STABILITY / rate:.2g} s "
                "keeps it stable)"
            )
    return notes


#: The largest h·λ for which classical RK4 damps y' = −λy: the root of |1 − x + x²/2 − x³/6 + x⁴/24| = 1.
RK4_REAL_STABILITY = 2.785


def joint_dynamics_rate(robot: Robot, inertia: np.ndarray) -> float:
    """The fastest decay rate [1/s] the joint damping and friction give the arm of joint-space inertia H: the
    largest eigenvalue of H⁻¹(D + F/v_s), the friction F·tanh(q̇/v_s) taken at its slope at rest."""
    slope = robot.joint_damping + robot.joint_friction / robot.friction_velocity_scale
    return float(np.linalg.eigvals(np.linalg.solve(inertia, np.diag(slope))).real.max())
