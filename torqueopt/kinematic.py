r"""The simulation loop of the velocity-level (kinematic) resolvers of Section 1.1.

A velocity-level resolver gives the joint rates :math:`\dot q = f(q, t)`
from the commanded task velocity :math:`c(t, q) = \dot x_{ref}(t) + K(x_{ref}(t) - x(q))`
(K = 0, open loop, by default; on a ``pose`` path with rotations the orientation rows of
:math:`x_{ref} - x` are :math:`\log(R_{ref}R^\top)`). The loop integrates this first-order system
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

A resolver whose ``acceleration_function`` gives q̈ in closed form
(velocity-pinv, gradient projection with the joint-limit or manipulability
criterion, the kinetic-energy pseudoinverse, task priority without damping,
the extended Jacobian, obstacle avoidance) supplies it instead, at the cost of about one more
rate evaluation rather than four; the central difference stays the
reference the tests hold each closed form to.

The recorded torque is the inverse-dynamics torque at the step start; the
motion is the kinematic one. A run stops, keeping what it computed, where
the method is undefined (a singular task Jacobian, an algorithmic
singularity of the extended Jacobian), or where joint speeds or torques
pass the same ceilings as :func:`torqueopt.simulate`.

The loop is the engine's (:func:`torqueopt.engine.run_movements`), with the
velocity level's pieces (:class:`KinematicMovement`).
"""

from __future__ import annotations

import operator
from functools import partial

import numpy as np
import pinocchio as pin

from .checks import (
    DEFAULT_MAX_STEPS,
    configuration_vector,
    finite_vector,
    positive_number,
    step_budget,
    trajectory_dimension,
    velocity_vector,
)
from .engine import run_movements
from .errors import InvalidInput, SingularJacobian
from .integrators import RK4, VelocityRates
from .result import SimResult
from .robot import Robot
from .run_records import REFERENCE_BLOCK, ReferenceBlocks, logged_row_bytes, run_result
from .stop_rules import StopRules
from .tasks import FrameTask, Kinematics
from .trajectory import check_trajectory
from .trajectory.orientation import rotation_error

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
    progress=None,
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
    # Rows at half steps: the progress is told steps.
    told = None if progress is None else (lambda row: progress(row // 2))
    reference = ReferenceBlocks(
        robot,
        trajectory,
        0.5 * dt,
        2 * steps,
        size=2 * REFERENCE_BLOCK,
        progress=told,
        start_rotation=reference_rotation,
    )

    lanes = KinematicMovement(
        robot, resolver, trajectory, q, dt, steps, reference, reference_rotation,
        StopRules(robot, max_torque_ratio, max_joint_speed),
    )  # fmt: skip
    run_movements(lanes, steps)
    return lanes.result(duration, dexterity)


class KinematicMovement:
    """The engine's lanes for one movement of a velocity-level resolver (see :mod:`torqueopt.engine`).

    The state is q alone (the joint rates are f(q, t)); the "terms" are the
    kinematics at q; the resolver's step gives q̇ = f(q, t), q̈ and the
    inverse-dynamics torque (see the module docstring), also at the final
    sample; the integrator is :class:`~torqueopt.integrators.RK4` of
    :class:`~torqueopt.integrators.VelocityRates`. The
    reference is sampled on the half-step grid RK4 reads (sample 2k at t_k,
    2k + 1 mid-step), a block of steps at a time with each step's own mid and
    end samples.
    """

    resolves_final = True

    def __init__(
        self, robot: Robot, resolver, trajectory, q, dt: float, steps: int, reference: ReferenceBlocks,
        reference_rotation, rules: StopRules,
    ):  # fmt: skip
        self.robot, self.resolver, self.trajectory, self.dt, self.steps = robot, resolver, trajectory, dt, steps
        self.reference, self.rules = reference, rules
        self.q, self.v = q, None
        self.running = True
        self.stop_reason: str | None = None
        self.stop_time: float | None = None
        self.log: list[tuple] = []
        self.torque_ceiling = rules.torque_ceiling.tolist()
        self.speed_ceiling = [rules.speed_ceiling] * robot.nv
        self.ceilings = self.speed_ceiling + self.torque_ceiling
        self.within = partial(map, operator.le)
        self.x_ref: list[np.ndarray] = []
        self.task = task = FrameTask.of_robot(robot, reference_rotation=reference_rotation)
        self.kinematics = kinematics = Kinematics(robot)
        # x of a position task read from a view of the frame's position in Pinocchio's data, made once (a copy per
        # read: the log keeps it); a pose's rotation vector by FrameTask.value
        self.task_position = (
            None if task.kind == "pose" else kinematics.frame_position_view(task.frame_id(kinematics))[task.rows]
        )
        # the joint rates and, when the resolver has it, q̈ in closed form (else a central difference of f)
        rates, self.closed_form = resolver.step_functions(robot, task)
        self.rates = rates
        self.gain = gain = resolver.position_gain
        self.zero = np.zeros(robot.m)
        self.offset = 0
        # A pose path that turns: the feedback's rotation rows are log(R_ref Rᵀ), not a difference of rotation vectors
        self.turning = gain != 0.0 and task.kind == "pose" and getattr(trajectory, "oriented", False)
        self.reference_rotation = reference_rotation

        def f(configuration: np.ndarray, index: int):
            """f(q, t) at the reference sample ``index`` of the block (half steps)."""
            kinematics.update(configuration)
            velocity = self.velocity[index]
            if gain != 0.0:
                error = self.position[index] - task.value(kinematics)
                if self.turning:
                    self.turn_rows(error, index, kinematics)
                velocity = velocity + gain * error
            return rates(kinematics, velocity)

        self.f = f
        self.system = VelocityRates(robot, lambda configuration, index: f(configuration, index)[0])
        self.integrator = RK4(self.system, dt)

    def block(self, start: int) -> list[float]:
        # The block's steps: those whose end sample it holds, and the final sample once it holds it.
        _, sample = self.reference.block(2 * start)
        self.position, self.velocity, self.acceleration = sample.position, sample.velocity, sample.acceleration
        samples = len(sample.position)
        stop = start + (samples - 1) // 2 + (2 * start + samples - 1 == 2 * self.steps)
        self.x_ref.extend(sample.position[0 : 2 * (stop - start) : 2])
        return (self.dt * np.arange(start, stop)).tolist()

    def terms(self, q, v):
        kinematics, position = self.kinematics.update(q), self.task_position
        return kinematics, self.task.value(kinematics) if position is None else position.copy()

    def command(self, j: int, kinematics, x):
        """c(t, q) at the step's sample, with the kinematics at q."""
        if self.gain == 0.0:
            return self.velocity[2 * j]
        error = self.position[2 * j] - x
        if self.turning:
            self.turn_rows(error, 2 * j, kinematics)
        return self.velocity[2 * j] + self.gain * error

    def turn_rows(self, error: np.ndarray, index: int, kinematics: Kinematics) -> None:
        """Write log(R_ref Rᵀ), the rotation from the frame to the reference sample ``index``, into the rotation
        rows of the feedback error x_ref − x (a turning pose path)."""
        rotation = kinematics.data.oMf[self.task.frame_id(kinematics)].rotation
        error[3:] = rotation_error(self.position[index][3:], rotation, self.reference_rotation)

    def turning_time_rate(self, index: int, kinematics: Kinematics) -> np.ndarray:
        r""":math:`\partial/\partial t` of the feedback error at fixed q on a turning pose path: :math:`\dot x_{ref}`
        with the rotation rows :math:`J_{\log}(E) E^\top \omega_{ref}` of :math:`E = R_{ref}R^\top` (Pinocchio's
        ``Jlog3``), since E turns on the left at the reference's world angular velocity."""
        velocity = self.velocity[index]
        rotation = kinematics.data.oMf[self.task.frame_id(kinematics)].rotation
        turn = pin.exp3(self.position[index][3:]).dot(self.reference_rotation).dot(rotation.T)
        rate = velocity.copy()
        rate[3:] = pin.Jlog3(turn).dot(turn.T.dot(velocity[3:]))
        return rate

    def resolve(self, kinematics, command, j: int):
        rates, f, index = self.rates, self.f, 2 * j
        q = kinematics.q  # the differences below move the kinematics off q
        try:
            velocity, inverse_condition = rates(kinematics, command)
            # ∂c/∂t: ẍ_ref + K ẋ_ref (open loop, K = 0: ẍ_ref itself)
            time_rate = self.acceleration[index]
            if self.gain != 0.0:
                reference_rate = self.turning_time_rate(index, kinematics) if self.turning else self.velocity[index]
                time_rate = time_rate + self.gain * reference_rate
            if self.closed_form is not None:
                # ċ = ∂c/∂t − K J q̇ (the position feedback moves with q)
                command_rate = (
                    time_rate
                    if self.gain == 0.0
                    else time_rate - self.gain * self.task.jacobian(kinematics).dot(velocity)
                )
                acceleration = self.closed_form(kinematics, velocity, command, command_rate)
                return self.system.torque(q, velocity, acceleration), acceleration, velocity, inverse_condition
            # ∂f/∂c ∂c/∂t, exact for a map affine in c
            homogeneous = rates(kinematics, self.zero)[0]
            acceleration = rates(kinematics, time_rate)[0] - homogeneous
            speed = float(np.linalg.norm(velocity))
            if speed > 0.0:
                # ∂f/∂q q̇ by a central difference along q̇/|q̇|, at the same reference sample
                integrate = self.robot.integrate
                direction = velocity / speed
                forward = f(integrate(q, DIFFERENCE_STEP * direction), index)[0]
                backward = f(integrate(q, -DIFFERENCE_STEP * direction), index)[0]
                acceleration = acceleration + speed * (forward - backward) / (2.0 * DIFFERENCE_STEP)
        except SingularJacobian as error:
            return error
        torque = self.system.torque(q, velocity, acceleration)  # Eq. (20) on the motion
        return torque, acceleration, velocity, inverse_condition

    def record(self, j: int, t: float, q, v, x, kinematics, resolution) -> bool:
        rules = self.rules
        if isinstance(resolution, Exception):
            self.stop_reason, self.stop_time = rules.unresolved(resolution, t), t
            return True
        torque, acceleration, velocity, inverse_condition = resolution
        # The row that passes a ceiling stays in the result: peaks and verdicts count it.
        self.log.append((q, velocity, acceleration, torque, x, inverse_condition))
        # One test for both vectors, all(|value| <= ceiling) on a plain list, which also fails inf and NaN; the
        # speeds, tested first, name a failure.
        if all(self.within(map(abs, velocity.tolist() + torque.tolist()), self.ceilings)):
            return False
        if not all(self.within(map(abs, velocity.tolist()), self.speed_ceiling)):
            self.stop_reason, self.stop_time = self._diagnosed(rules.rates(velocity, t), q), t
        else:
            self.stop_reason, self.stop_time = self._diagnosed(rules.torque(torque, t), q), t
        return True

    def _diagnosed(self, reason: str, q) -> str:
        return with_diagnosis(reason, self.resolver, self.kinematics.update(q), self.task)

    def record_final(self, j: int, q, v, x, terms) -> None:
        raise AssertionError("the velocity level resolves its final sample")

    def compact(self, q, v, resolution):
        self.running = False
        return q, v, resolution

    def step(self, q, v, resolution, j: int, t: float):
        try:
            return self.integrator.step(q, v, 2 * j, resolution[2])[0], v, False
        except SingularJacobian as error:
            self.stop_reason, self.stop_time = self.rules.unresolved_during_step(error, t), t
            return q, v, True

    def result(self, duration: float, dexterity: bool) -> SimResult:
        """The run's :class:`SimResult`; the kinematic motion realises the task velocity itself: nothing is given up."""
        log = self.log
        return run_result(
            self.robot,
            self.resolver,
            log,
            self.dt * np.arange(len(log)),
            np.array(self.x_ref).reshape(-1, self.robot.m),
            dt=self.dt,
            duration=duration,
            stop_reason=self.stop_reason,
            stop_time=self.stop_time,
            trajectory=self.trajectory,
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


def with_diagnosis(reason: str, resolver, kinematics: Kinematics, task: FrameTask) -> str:
    """The stop reason, followed by what the method says of its own state there (if anything)."""
    diagnosis = resolver.stop_diagnosis(kinematics, task)
    return reason if diagnosis is None else f"{reason}; {diagnosis}"
