r"""Many movements advanced together: the engine on a batch axis, and :func:`torqueopt.simulate`'s batched twin.

:func:`simulate_batch` runs B movements of one robot and one resolver side
by side, one time step for the whole batch at a time, through the engine's
one loop body (:func:`torqueopt.engine.run_movements`, the loop of
``simulate`` too) and its lanes (:class:`torqueopt.engine.MovementStack`), with the stacked forms of its pieces:

* a terms provider (:mod:`torqueopt.terms`): :math:`H`,
  :math:`b = \dot q\cdot C\cdot\dot q + g`, :math:`J`, :math:`\dot J\dot q`
  and the task position of every running movement, from the forest of
  :mod:`torqueopt.robot_copies` (a few Pinocchio calls per pass of many states);
* the resolver's step on stacks (:meth:`Resolver.batch_solver
  <torqueopt.resolvers.base.Resolver.batch_solver>`): vectorised for the
  paper's resolvers and the remedies, the single-state step row by row for
  every other registered resolver (the bounded QP and LP ones included);
* the plant's step on stacks (:meth:`Plant.step_stack
  <torqueopt.plants.Plant.step_stack>`): for the Pinocchio plant, RK4 with
  the torque held (:class:`torqueopt.integrators.RK4` of
  :class:`~torqueopt.integrators.HeldTorque`), the resolver's :math:`\ddot q`
  as its first stage, the other three stages of the whole stack by one
  ``pin.abaInParallel`` call each; for MuJoCo, each movement in a MuJoCo
  data of its own;

with the stop rules and messages of :class:`torqueopt.stop_rules.StopRules` and
the results of :func:`torqueopt.run_records.build_result`, as ``simulate``. The
tests hold each of its runs to the matching ``simulate`` run to 1e-9, for
every registered resolver.

A movement that stops early (singular Jacobian, an infeasible program,
runaway torque or speed, non-finite values) leaves the batch at once: the
stacks are compacted, so the rest go on at the cost of the movements still
running. The reference is sampled and the logs grow a block of steps at a
time, so memory follows the steps taken.

Velocity-level resolvers run on the same loop body with the velocity level's
lanes: on stacks (:class:`KinematicStack`: the forest's kinematics and
inverse dynamics, the resolver's stacked rates and closed-form q̈) when the
resolver has a stacked form (:meth:`VelocityResolver.stack_rate_function
<torqueopt.resolvers.velocity.base.VelocityResolver.stack_rate_function>`: every velocity-level method on the
``xy`` and ``position`` tasks of a robot whose joints add, with the options each one's docstring names), else
through the kinematic loop (:func:`torqueopt.kinematic.simulate_kinematic`), one movement after another.

Supported: every registered resolver, for the ``xy`` and ``position`` tasks,
open loop. :func:`batch_supports` says whether a case is;
:func:`simulate_many` runs any list of movements, batching what is
supported and calling ``simulate`` for the rest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .checks import configuration_vector, positive_number, trajectory_dimension, whole_number
from .engine import MovementStack, StepLog, run_movements
from .errors import InvalidInput
from .integrators import RK4, VelocityRates
from .plants import PinocchioPlant, Plant, make_plant
from .resolvers import Resolver, get_resolver
from .resolvers.stacks import LoopedStackStep
from .result import SimResult
from .robot import Robot
from .robot_copies import RobotForest
from .run_records import REFERENCE_BLOCK, ReferenceBlocks
from .self_motion import self_motion_energy
from .simulate import (
    DEFAULT_MAX_JOINT_SPEED,
    DEFAULT_MAX_STEPS,
    DEFAULT_MAX_TORQUE_RATIO,
    refuse_plant_at_velocity_level,
    step_budget,
)
from .simulate import simulate as simulate_one
from .stop_rules import StopRules
from .terms import PinocchioTerms, terms_provider
from .trajectory import Trajectory, check_trajectory, describe

__all__ = ["BatchExtras", "batch_supports", "simulate_batch", "simulate_many"]


def batch_supports(robot: Robot, resolver: str | Resolver, feedback=None) -> bool:
    """True when :func:`simulate_batch` can run ``resolver`` on ``robot`` (else use :func:`torqueopt.simulate`).

    Every registered resolver is supported on the position tasks (``xy``,
    ``position``), open loop.
    """
    get_resolver(resolver)
    return robot.task in ("xy", "position") and feedback is None


class BatchExtras:
    r"""Per-step quantities the batch computes beside the :class:`SimResult` rows, per movement.

    Attributes:
        kinetic_energy: :math:`T = \tfrac12\dot q^\top H\dot q` [J] at each recorded sample.
        self_motion_energy: :math:`T - \tfrac12\dot x^\top\Lambda\dot x` [J], with
            :math:`\dot x = J\dot q` and :math:`\Lambda = (J H^{-1} J^\top)^{-1}`:
            the kinetic energy beyond the least any joint motion with the
            same tip velocity has, i.e. the energy of the self-motion
            (zero exactly when :math:`\dot q` is the inertia-weighted
            pseudoinverse velocity :math:`J_H^\dagger\dot x`). See
            :func:`torqueopt.self_motion.self_motion_energy`, which computes it
            here and from a finished run.
    """

    __slots__ = ("kinetic_energy", "self_motion_energy")

    def __init__(self, kinetic_energy: np.ndarray, self_motion_energy: np.ndarray):
        self.kinetic_energy = kinetic_energy
        self.self_motion_energy = self_motion_energy


def simulate_many(
    robot: Robot,
    resolver: str | Resolver,
    trajectories: Sequence[Trajectory],
    q0s,
    dt: float = 1e-3,
    *,
    batch: bool = True,
    max_joint_speed: float = DEFAULT_MAX_JOINT_SPEED,
    max_torque_ratio: float = DEFAULT_MAX_TORQUE_RATIO,
) -> list[SimResult]:
    """One :class:`SimResult` per (trajectory, q0): batched where supported, else :func:`torqueopt.simulate` each.

    Movements of different durations are batched by duration.
    """
    resolver = get_resolver(resolver)
    trajectories = list(trajectories)
    _check_pairs(trajectories, q0s)
    if not (batch and batch_supports(robot, resolver)):
        return [
            simulate_one(
                robot, resolver, line, q0, dt=dt, max_joint_speed=max_joint_speed, max_torque_ratio=max_torque_ratio
            )
            for line, q0 in zip(trajectories, q0s)
        ]
    results: list[SimResult | None] = [None] * len(trajectories)
    for duration in sorted({line.duration for line in trajectories}):
        members = [i for i, line in enumerate(trajectories) if line.duration == duration]
        runs = simulate_batch(
            robot,
            resolver,
            [trajectories[i] for i in members],
            [q0s[i] for i in members],
            dt,
            max_joint_speed=max_joint_speed,
            max_torque_ratio=max_torque_ratio,
        )
        for i, run in zip(members, runs):
            results[i] = run
    return results


def simulate_batch(
    robot: Robot,
    resolver: str | Resolver,
    trajectories: Sequence[Trajectory],
    q0s,
    dt: float = 1e-3,
    *,
    max_joint_speed: float = DEFAULT_MAX_JOINT_SPEED,
    max_torque_ratio: float = DEFAULT_MAX_TORQUE_RATIO,
    threads: int = 1,
    extras: bool = False,
    max_steps: int = DEFAULT_MAX_STEPS,
    plant: str | Plant = "pinocchio",
    plant_options: dict | None = None,
):
    """Simulate every (trajectory, q0) pair with ``resolver``, all movements of one duration together.

    Args:
        robot: from :func:`torqueopt.load_robot`; its data is not touched
            (the batch makes its own Pinocchio Data).
        resolver: any registered resolver (name or object).
        trajectories: any :class:`~torqueopt.trajectory.Trajectory` objects of one duration, anchored at the tip
            at their q0 when they have no start, as in ``simulate``.
        q0s: one start configuration per trajectory (nq values or n angles).
        dt: step [s]; the torque is held over each.
        max_joint_speed, max_torque_ratio: the divergence stops of ``simulate``.
        threads: OpenMP threads for ``abaInParallel`` (1 inside a sweep
            worker, where the sweep's processes use the cores).
        extras: also return one :class:`BatchExtras` per movement.
        max_steps: the most steps a movement may take, as in ``simulate``.
        plant, plant_options: what the torques act on, as in ``simulate``
            (a name and its options, or a :class:`~torqueopt.plants.Plant`);
            each movement's result records the plant as its own run would.

    Returns:
        One :class:`SimResult` per movement, equal to what ``simulate``
        returns for it (to round-off); with ``extras``, (results, extras).

    Raises:
        InvalidInput: an unsupported case, mixed durations or bad values.
    """
    resolver = get_resolver(resolver)
    resolver.check(robot)
    if not batch_supports(robot, resolver):
        raise InvalidInput(
            f"the batched path does not support task '{robot.task}' (robot '{robot.name}'); it supports the xy "
            "and position tasks: use torqueopt.simulate or simulate_many"
        )
    trajectories = list(trajectories)
    count = len(trajectories)
    if count == 0:
        return ([], []) if extras else []
    _check_pairs(trajectories, q0s)
    dt = positive_number(dt, "dt", "s")
    durations = {line.duration for line in trajectories}
    if len(durations) != 1:
        raise InvalidInput(f"a batch needs movements of one duration, got {sorted(durations)} s: use simulate_many")
    duration = durations.pop()
    steps = step_budget(duration, dt, max_steps)
    threads = whole_number(threads, "threads", 1)
    if getattr(resolver, "level", None) == "velocity":
        refuse_plant_at_velocity_level(resolver, plant, plant_options)
        stacked = resolver.stack_rate_function(robot) if robot.euclidean and count > 1 else None
        if stacked is None:
            return _kinematic_runs(robot, resolver, trajectories, q0s, dt, max_joint_speed, max_torque_ratio, extras)
        return _kinematic_stack(
            robot, resolver, stacked, trajectories, q0s, dt, steps, max_joint_speed, max_torque_ratio, extras
        )

    q = np.array([configuration_vector(robot, q0) for q0 in q0s], dtype=float).reshape(count, robot.nq)
    references, descriptions = [], []
    for i, line in enumerate(trajectories):
        check_trajectory(line)
        linear_dimension = trajectory_dimension(robot, line)
        if line.start is None:
            line = line.anchored(robot.frame_placement(q[i]).translation[:linear_dimension].copy())
        descriptions.append(describe(line))
        references.append(ReferenceBlocks(robot, line, dt, steps))

    if plant == "pinocchio" and not plant_options:
        plant = PinocchioPlant(robot, threads=threads)
    plant = make_plant(robot, plant, plant_options)
    plant.reset(dt)
    solve = resolver.batch_solver(robot, dt)
    # A resolver whose step is its single-state one looped row by row gains nothing from stacked terms: it gets
    # simulate's own terms, row by row, and its runs equal simulate's bit for bit.
    looped = isinstance(solve, LoopedStackStep)
    if looped:
        solve.along(reference.trajectory for reference in references)
    lanes = MovementStack(
        robot, resolver, q, np.zeros((count, robot.nv)), dt, steps, references, solve=solve,
        terms=PinocchioTerms(robot).rows if looped else terms_provider(robot, count).terms,
        advance=lambda q, v, tau, acceleration, movements: plant.step_stack(q, v, tau, dt, acceleration, movements),
        rules=StopRules(robot, max_torque_ratio, max_joint_speed), extras=extras,
    )  # fmt: skip
    run_movements(lanes, steps)
    results = lanes.results(duration, descriptions, [plant.record(i) for i in range(count)])
    return (results, [BatchExtras(*pair) for pair in lanes.energies()]) if extras else results


def _kinematic_stack(robot, resolver, stacked, trajectories, q0s, dt, steps, max_joint_speed, max_torque_ratio, extras):
    """A velocity-level resolver's movements advanced together on stacks (:class:`KinematicStack`)."""
    q = np.array([configuration_vector(robot, q0) for q0 in q0s], dtype=float).reshape(len(q0s), robot.nq)
    references, descriptions = [], []
    for i, line in enumerate(trajectories):
        check_trajectory(line)
        if line.start is None:
            line = line.anchored(robot.frame_placement(q[i]).translation[: trajectory_dimension(robot, line)].copy())
        descriptions.append(describe(line))
        # Every step start and mid-step (RK4 reads f at t, t + h/2 and t + h), a block at a time.
        references.append(ReferenceBlocks(robot, line, 0.5 * dt, 2 * steps, size=2 * REFERENCE_BLOCK))
    lanes = KinematicStack(
        robot, resolver, stacked, q, dt, steps, references, max_torque_ratio, max_joint_speed, extras=extras
    )
    run_movements(lanes, steps)
    results = lanes.results(trajectories[0].duration, descriptions, [None] * len(q0s))
    return (results, [BatchExtras(*pair) for pair in lanes.energies()]) if extras else results


class _EvenRows:
    """A half-step reference's rows at the step starts (samples 0, 2, 4, ...), for the results."""

    def __init__(self, reference: ReferenceBlocks):
        self.reference = reference

    def positions(self) -> np.ndarray:
        return self.reference.positions()[::2]


class KinematicStack(MovementStack):
    """The engine's lanes for B movements of a velocity-level resolver on stacks (see :mod:`torqueopt.engine`).

    The stacked form of :class:`torqueopt.kinematic.KinematicMovement`: the
    state is q (B, n); the kinematics of every row (J, J̇, the tip) and the
    inverse-dynamics torques come from the forest
    (:meth:`RobotForest.kinematics <torqueopt.robot_copies.RobotForest.kinematics>`,
    :meth:`~torqueopt.robot_copies.RobotForest.inverse_dynamics`); the rates
    and q̈ from the resolver's stacked form (:meth:`VelocityResolver.stack_rate_function
    <torqueopt.resolvers.velocity.base.VelocityResolver.stack_rate_function>`);
    RK4 of q̇ = f(q, t) on the whole stack. A movement stops as in the
    kinematic loop: where the method is undefined (no row recorded), where
    its rates or torques pass a ceiling (the row kept), or where a stage of
    its step is undefined.
    """

    resolves_final = True

    def __init__(
        self, robot: Robot, resolver, stacked, q: np.ndarray, dt: float, steps: int, references: list,
        max_torque_ratio: float, max_joint_speed: float, extras: bool = False,
    ):  # fmt: skip
        count = q.shape[0]
        self.robot, self.resolver, self.stacked, self.dt, self.steps = robot, resolver, stacked, dt, steps
        self.half_references = references
        self.references = [_EvenRows(reference) for reference in references]
        self.count, self.with_extras = count, extras
        self.q, self.v = q, None
        # a stack may ask for smaller forest passes (its ``forest_dofs``): the quadratic part of a pass falls
        dofs = getattr(stacked, "forest_dofs", None)
        self.forest = RobotForest(robot, None if dofs is None else max(1, dofs // robot.nv))
        self.rows = robot.task_rows
        self.gain = resolver.position_gain
        self.integrator = RK4(VelocityRates(robot, self._stage_rates), dt)
        self.rules = StopRules(robot, max_torque_ratio, max_joint_speed)
        self.log = StepLog(robot, count, extras)
        self.stop_reason: list[str | None] = [None] * count
        self.stop_time: list[float | None] = [None] * count
        self.limiting: list[dict] = [{} for _ in range(count)]
        self.active = np.arange(count)
        self.running = count > 0
        self.where = slice(None)
        self._keep = None

    def block(self, start: int) -> list[float]:
        samples = [reference.block(2 * start)[1] for reference in self.half_references]
        self.start = start

        # Time-major: [half-step sample, movement, coordinate].
        def stacked(name):
            return np.ascontiguousarray(np.swapaxes(np.array([getattr(sample, name) for sample in samples]), 0, 1))

        self.position, self.velocity, self.acceleration = (
            stacked("position"),
            stacked("velocity"),
            stacked("acceleration"),
        )
        length = self.position.shape[0]
        # The block's steps: those whose end sample it holds, and the final sample once it holds it.
        stop = start + (length - 1) // 2 + (2 * start + length - 1 == 2 * self.steps)
        return (self.dt * np.arange(start, stop)).tolist()

    def _task(self, q, v=None, tip=None):
        """The forest's kinematics at q (and v), the task's rows of J and J̇ (the frame's whole ones kept beside them,
        ``frame_jacobian``, ``frame_rate``); H⁻¹ or H at q, or Ḣq̇ at (q, v), from the same pass when the stacked form
        reads them (its ``reads_inverse_inertia``, ``reads_inertia``, ``reads_inertia_rate``), and every joint's
        kinematics when it reads those (``reads_joints``)."""
        stacked = self.stacked
        found = self.forest.kinematics(
            q, v, tip,
            inverse_inertia=v is None and stacked.reads_inverse_inertia,
            inertia_rate=v is not None and stacked.reads_inertia_rate,
            joints=stacked.reads_joints,
            inertia=v is None and stacked.reads_inertia,
        )  # fmt: skip
        rows = self.rows
        return found._replace(
            jacobian=found.jacobian[:, rows], rate=None if v is None else found.rate[:, rows],
            frame_jacobian=found.jacobian, frame_rate=found.rate,
        )  # fmt: skip

    def terms(self, q, v):
        # the configurations (and their task points) the step's q̈ and torques are taken at
        self._kinematics = found = self._task(q)
        self._q, self._tip = q, found.tip
        return found.jacobian, found.tip[:, self.rows]

    def _command(self, index: int, x):
        if self.gain == 0.0:
            return self.velocity[index, self.where]
        return self.velocity[index, self.where] + self.gain * (self.position[index, self.where] - x)

    def command(self, j: int, jacobian, x):
        return self._command(2 * j, x)

    def resolve(self, jacobian, command, j: int):
        index, where = 2 * j, self.where
        velocity, conditions, failures, state = self.stacked.rates(jacobian, command, self._q, self._kinematics)
        self._state = state  # what the rates computed at the step's start, for the energy extras
        # ċ = ẍ_ref + K(ẋ_ref − J q̇)
        command_rate = self.acceleration[index, where] + self.gain * self.velocity[index, where]
        if self.gain != 0.0:
            command_rate = command_rate - self.gain * np.einsum("bij,bj->bi", jacobian, velocity)
        moving = self._task(self._q, velocity, self._tip)
        acceleration = self.stacked.acceleration(jacobian, moving.rate, velocity, command_rate, state, moving)
        torque = self.forest.inverse_dynamics(self._q, velocity, acceleration)  # Eq. (20) on the motion
        return torque, acceleration, velocity, conditions, failures

    def record(self, j: int, t: float, q, v, x, jacobian, resolution) -> bool:
        torque, acceleration, velocity, conditions, failures = resolution
        log, active, rules = self.log, self.active, self.rules
        log.steps.append((active, q, velocity, acceleration, torque, x, conditions))
        if self.with_extras:
            # T and E_N at the recorded state: the stack's own (its ``energies``) when it gives them, else H the
            # step's own pass computed (the stacks that read it) or by CRBA alone, J the step's own
            own = self.stacked.energies(jacobian, velocity, self._state, self._kinematics) if q is self._q else None
            if own is None:
                inertia = self._kinematics.inertia if q is self._q else None
                own = self_motion_energy(
                    self.forest.inertia(q) if inertia is None else inertia, velocity, jacobian=jacobian
                )
            log.energies.append(own)
        # A row where the method is undefined is not recorded (as in the kinematic loop).
        failed = np.zeros(active.size, dtype=bool)
        if failures:
            failed[list(failures)] = True
            log.unrecorded.extend(active[failed].tolist())
        fast = ~failed & rules.speeds_over(velocity)
        over = ~failed & ~fast & rules.torques_over(torque)
        stopping = failed | fast | over
        if not stopping.any():
            return False
        for row in np.flatnonzero(stopping).tolist():
            movement = int(active[row])
            if failed[row]:
                self.stop_reason[movement] = rules.unresolved(failures[row], t)
            elif fast[row]:
                self.stop_reason[movement] = self._diagnosed(rules.rates(velocity[row], t), q[row])
            else:
                self.stop_reason[movement] = self._diagnosed(rules.torque(torque[row], t), q[row])
            self.stop_time[movement] = t
        self._keep = ~stopping
        return True

    def _diagnosed(self, reason: str, q) -> str:
        from .kinematic import with_diagnosis
        from .tasks import FrameTask, Kinematics

        task = FrameTask.of_robot(self.robot, reference_rotation=self.robot.frame_placement(q).rotation)
        return with_diagnosis(reason, self.resolver, Kinematics(self.robot).update(q), task)

    def compact(self, q, v, resolution):
        keep = self._keep
        self.active = self.where = self.active[keep]
        self.running = self.active.size > 0
        if resolution is not None:
            resolution = (*(part[keep] for part in resolution[:4]), {})
        return q[keep], v, resolution

    def _rates(self, q, index: int):
        found = self._task(q)
        velocity, _, failures, _ = self.stacked.rates(
            found.jacobian, self._command(index, found.tip[:, self.rows]), q, found
        )
        return velocity, failures

    def _stage_rates(self, q, index: int):
        """The rates of an RK4 stage; a row undefined there is kept with its first stage's message."""
        velocity, failures = self._rates(q, index)
        for row, message in failures.items():
            self._stage_failures.setdefault(row, message)
        return velocity

    def step(self, q, v, resolution, j: int, t: float):
        self._stage_failures = failures = {}
        next_q, _ = self.integrator.step(q, None, 2 * j, resolution[2])
        if not failures:
            return next_q, v, False
        for row, message in failures.items():
            movement = int(self.active[row])
            self.stop_reason[movement], self.stop_time[movement] = self.rules.unresolved_during_step(message, t), t
        keep = np.ones(self.active.size, dtype=bool)
        keep[list(failures)] = False
        self._keep = keep
        return next_q, v, True


def _kinematic_runs(robot, resolver, trajectories, q0s, dt, max_joint_speed, max_torque_ratio, extras):
    """A velocity-level resolver's movements, each through the kinematic loop; extras from the recorded states."""
    results = [
        simulate_one(
            robot, resolver, line, q0, dt=dt, max_joint_speed=max_joint_speed, max_torque_ratio=max_torque_ratio
        )
        for line, q0 in zip(trajectories, q0s)
    ]
    if not extras:
        return results
    provider = PinocchioTerms(robot)
    more = []
    for result in results:
        terms, _ = provider.terms(result.q, result.v)
        more.append(BatchExtras(*self_motion_energy(terms.inertia, result.v, jacobian=terms.jacobian)))
    return results, more


def _check_pairs(trajectories: Sequence[Trajectory], q0s) -> None:
    """InvalidInput unless there is one start configuration per trajectory."""
    if len(trajectories) != len(q0s):
        raise InvalidInput(f"{len(trajectories)} trajectories but {len(q0s)} start configurations")
