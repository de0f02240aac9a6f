r"""The simulation loop of the velocity-level (kinematic) resolvers of Section 1.1.

A velocity-level resolver gives the joint rates :math:`\dot q = f(q, t)`
from the commanded task velocity :math:`c(t, q) = \dot x_{ref}(t) + K(x_{ref}(t) - x(q))`
(K = 0, open loop, by default). The loop integrates this first-order system
by classical RK4 with the reference sampled at the stage times,

.. math::

    k_1 = f(q, t),\ k_2 = f(q \oplus \tfrac h2 k_1, t + \tfrac h2),\
    k_3 = f(q \oplus \tfrac h2 k_2, t + \tfrac h2),\ k_4 = f(q \oplus h k_3, t + h),\qquad
    q^+ = q \oplus \tfrac h6(k_1 + 2k_2 + 2k_3 + k_4),

and records at each step start the state :math:`(q, \dot q = k_1)`, the
joint acceleration of the motion and the torques that produce it, by
inverse dynamics (Pinocchio's RNEA), Eq. (20):
:math:`\tau = H\ddot q + \dot q\cdot C\cdot\dot q + g`.

The joint acceleration is the derivative of f along the motion,

.. math::

    \ddot q = \frac{d}{dt} f(q(t), t) = \frac{\partial f}{\partial q}\dot q + \frac{\partial f}{\partial c}\frac{\partial c}{\partial t},

taken at the state itself, not from neighbouring steps: the first term by a
central difference of f along :math:`\dot q` (step δ = 1e-6 rad along the
unit direction, error O(δ²) plus round-off ≈ 1e-10 relative), the second
exactly, since every Section 1.1 method is affine in the task velocity:
:math:`\frac{\partial f}{\partial c} u = f(q, u) - f(q, 0)`, with
:math:`\partial c/\partial t = \ddot x_{ref} + K\dot x_{ref}` taken from the
reference sample of the step (the step that starts at T/2 decelerates). So
q̈ is consistent with the integrated motion to integration accuracy, and
the torque jumps where the reference acceleration jumps (t = 0 and T/2 on
the paper's line) exactly as the torque resolvers' do.

The recorded torque is the inverse-dynamics torque at the step start; the
motion is the kinematic one. A run stops, keeping what it computed, where
the method is undefined (a singular task Jacobian, an algorithmic
singularity of the extended Jacobian), or where joint speeds or torques
pass the same ceilings as :func:`torqueopt.simulate`.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .checks import configuration_vector, finite_vector, positive_number, trajectory_dimension, velocity_vector
from .errors import InvalidInput, SingularJacobian
from .integrators import VelocityRK4
from .result import SimResult
from .robot import Robot
from .run_log import REFERENCE_BLOCK, ReferenceBlocks, StopRules, logged_row_bytes, run_result
from .tasks import FrameTask, Kinematics
from .trajectory import check_trajectory

__all__ = ["simulate_kinematic", "joint_rates", "DIFFERENCE_STEP"]

#: Step [rad] of the central difference of f along q̇.
DIFFERENCE_STEP = 1.0e-6


def joint_rates(robot: Robot, resolver, q, task_velocity) -> np.ndarray:
    """Joint rates q̇ [rad/s] that a velocity-level resolver gives for ``task_velocity`` (m values) at q."""
    from .resolvers import get_resolver

    resolver = get_resolver(resolver)
    _require_velocity_level(resolver)
    resolver.check(robot)
    q = configuration_vector(robot, q)
    task_velocity = finite_vector(task_velocity, robot.m, f"task velocity for task '{robot.task}'")
    task = FrameTask.of_robot(robot, reference_rotation=robot.frame_placement(q).rotation)
    kinematics = Kinematics(robot).update(q)
    return resolver.rate_function(robot, task)(kinematics, task_velocity)[0]


def _require_velocity_level(resolver) -> None:
    if getattr(resolver, "level", None) != "velocity":
        raise InvalidInput(f"resolver '{resolver.name}' is not a velocity-level resolver")


def simulate_kinematic(
    robot: Robot,
    resolver,
    trajectory,
    q0,
    v0=None,
    dt: float = 1e-3,
    *,
    duration: float | None = None,
    feedback=None,
    max_joint_speed: float,
    max_torque_ratio: float,
    dexterity: bool = False,
    max_steps: int | None = None,
) -> SimResult:
    """Run a velocity-level resolver along ``trajectory``; called by :func:`torqueopt.simulate`.

    Same arguments and result as :func:`torqueopt.simulate`, except that
    ``v0`` must be None or zero (the method itself sets q̇ = f(q0, 0)) and
    ``feedback`` is refused (closed loop is the resolver's ``position_gain``).
    Every row, the last included, holds the inverse-dynamics torque of the
    motion at its instant (nothing is held over a step here); a run stopped
    by a ceiling ends with the row that passed it, one stopped where the
    method is undefined with the last row where it was.
    """
    from .simulate import DEFAULT_MAX_STEPS, step_budget

    _require_velocity_level(resolver)
    resolver.check(robot)
    check_trajectory(trajectory)
    if feedback is not None:
        raise InvalidInput(
            f"resolver '{resolver.name}' works at the velocity level; task acceleration feedback does not apply: "
            "give it position_gain= [1/s] instead"
        )
    dt = positive_number(dt, "dt", "s")
    duration = trajectory.duration if duration is None else duration
    duration = positive_number(duration, "duration", "s")
    steps = step_budget(
        duration, dt, DEFAULT_MAX_STEPS if max_steps is None else max_steps, row_bytes=logged_row_bytes(robot)
    )
    q = configuration_vector(robot, q0)
    if v0 is not None and np.any(velocity_vector(robot, v0) != 0.0):
        raise InvalidInput(
            f"resolver '{resolver.name}' sets the joint velocity itself (q̇ = f(q, t)); v0 must be None or zero"
        )

    placement = robot.frame_placement(q)
    reference_rotation = placement.rotation.copy()
    trajectory = _anchored(robot, trajectory, placement)
    # Reference at every step start and mid-step (RK4 evaluates f at t, t + h/2 and t + h), a block at a time.
    reference = ReferenceBlocks(robot, trajectory, 0.5 * dt, 2 * steps, size=2 * REFERENCE_BLOCK)

    task = FrameTask.of_robot(robot, reference_rotation=reference_rotation)
    kinematics = Kinematics(robot)
    rates = resolver.rate_function(robot, task)
    gain = resolver.position_gain
    integrate = robot.integrate
    rules = StopRules(robot, max_torque_ratio, max_joint_speed)
    torque_ceiling, speed_ceiling = rules.torque_ceiling, rules.speed_ceiling
    # The block's rows, refreshed as the run goes; sample ``index`` of the run is row ``index - offset``.
    block = {"offset": 0, "end": 0}

    def load(index: int) -> None:
        """Sample the block that starts at ``index`` (even: a step start), with its step's mid and end samples."""
        _, sample = reference.block(index)
        block.update(
            offset=index,
            end=index + len(sample.position),
            position=sample.position,
            velocity=sample.velocity,
            acceleration=sample.acceleration,
        )

    def command(index: int) -> np.ndarray:
        """c(t, q) at the reference sample ``index`` (half steps), with kinematics at q."""
        row = index - block["offset"]
        if gain == 0.0:
            return block["velocity"][row]
        return block["velocity"][row] + gain * (block["position"][row] - task.value(kinematics))

    def f(configuration: np.ndarray, index: int):
        kinematics.update(configuration)
        return rates(kinematics, command(index))

    integrator = VelocityRK4(robot, f, dt)
    log = []
    x_ref = []
    stop_reason = stop_time = None
    for k in range(steps + 1):
        t = dt * k
        index = 2 * k
        if index + 2 >= block["end"] and block["end"] <= 2 * steps:
            # A new block from this step start: it holds the step's own mid and end samples too.
            load(index)
        row = index - block["offset"]
        x_ref.append(block["position"][row])
        try:
            velocity, inverse_condition = f(q, index)
            x = task.value(kinematics)
            # ∂f/∂c ∂c/∂t, exact for a map affine in c
            time_rate = block["acceleration"][row] + gain * block["velocity"][row]
            homogeneous = rates(kinematics, np.zeros(robot.m))[0]
            acceleration = rates(kinematics, time_rate)[0] - homogeneous
            speed = float(np.linalg.norm(velocity))
            if speed > 0.0:
                # ∂f/∂q q̇ by a central difference along q̇/|q̇|, at the same reference sample
                direction = velocity / speed
                forward = f(integrate(q, DIFFERENCE_STEP * direction), index)[0]
                backward = f(integrate(q, -DIFFERENCE_STEP * direction), index)[0]
                acceleration = acceleration + speed * (forward - backward) / (2.0 * DIFFERENCE_STEP)
        except SingularJacobian as error:
            stop_reason, stop_time = rules.unresolved(error, t), t
            break
        torque = integrator.torque(q, velocity, acceleration)  # Eq. (20) on the motion
        # The row that passes a ceiling stays in the result: peaks and verdicts count it.
        log.append((q, velocity, acceleration, torque, x, inverse_condition))
        if not (np.isfinite(velocity).all() and np.abs(velocity).max() <= speed_ceiling):
            stop_reason, stop_time = rules.rates(velocity, t), t
            stop_reason = _with_diagnosis(stop_reason, resolver, kinematics.update(q), task)
            break
        if not (np.isfinite(torque).all() and (np.abs(torque) <= torque_ceiling).all()):
            stop_reason, stop_time = rules.torque(torque, t), t
            stop_reason = _with_diagnosis(stop_reason, resolver, kinematics.update(q), task)
            break
        if k == steps:
            break
        try:
            q = integrator.step(q, velocity, index)
        except SingularJacobian as error:
            stop_reason, stop_time = rules.unresolved_during_step(error, t), t
            break

    # the kinematic motion realises the task velocity itself: nothing is given up
    return run_result(
        robot,
        resolver,
        log,
        dt * np.arange(len(log)),
        np.array(x_ref).reshape(-1, robot.m),
        dt=dt,
        duration=duration,
        stop_reason=stop_reason,
        stop_time=stop_time,
        trajectory=trajectory,
        task_error=np.zeros(len(log)),
        infeasible=np.zeros(len(log), dtype=bool),
        dexterity=dexterity,
    )


def _anchored(robot: Robot, trajectory, placement: pin.SE3):
    """The trajectory anchored at the tip's position at q0 when it has no start, as :func:`torqueopt.simulate` does."""
    linear_dimension = trajectory_dimension(robot, trajectory)
    if trajectory.start is None:
        trajectory = trajectory.anchored(placement.translation[:linear_dimension])
    return trajectory


def _with_diagnosis(reason: str, resolver, kinematics: Kinematics, task: FrameTask) -> str:
    """The stop reason, followed by what the method says of its own state there (if anything)."""
    diagnosis = resolver.stop_diagnosis(kinematics, task)
    return reason if diagnosis is None else f"{reason}; {diagnosis}"
