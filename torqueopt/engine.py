r"""The stepping engine: one loop body that advances B movements of one robot and one resolver.

:func:`run_movements` is the only stepping loop of the package. Every run goes
through it: :func:`torqueopt.simulate` (B = 1), ``torqueopt.batch.simulate_batch``
(B movements side by side) and the velocity-level methods
(``torqueopt.kinematic.simulate_kinematic``). It fixes, once, what a step
is and in which order its parts come:

1. the task terms of the state (``torqueopt.terms``) and the task position x;
2. at the final sample, t = T, the state is recorded and, for a torque
   resolver, no torque is applied from it (a velocity-level method records
   the torque of its motion there too);
3. the command: the reference task acceleration of the sample (with task
   feedback when asked), or the commanded task velocity for a velocity-level
   method;
4. the resolver's step at the state (torque, q̈, σmin/σmax, what was given up);
5. the row is recorded and the stops that read it are applied: a resolver
   that could not resolve the state, a torque beyond its ceiling (and joint
   rates beyond theirs, at the velocity level);
6. the integrator advances the state over the step, and the stops that read
   the new state are applied (joint speeds beyond their ceiling, a
   velocity-level method undefined at a stage).

A movement that stops leaves the batch at once (its row of every stack is
dropped), so the others go on at the cost of those still running; the
reference is sampled a block of steps at a time, so memory follows the steps
taken.

What changes with the level lives in a lanes object (:class:`Lanes`):
:class:`MovementStack` at the torque level, for B movements in (B, ...) stacks
(B = 1 for :func:`torqueopt.simulate`, a stack of one), and
``torqueopt.batch.KinematicStack`` at the velocity level. The caller hands a
stack its pieces: the terms provider (Pinocchio on one data, row by row, or
the forest), the resolver's step on stacks (the single-state step row by row,
or a vectorised one), and the plant's step. The stop tests and messages are
those of ``torqueopt.stop_rules.StopRules``, and every run's
:class:`~torqueopt.SimResult` is made by ``torqueopt.run_records.build_result``.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .linalg import inverse_condition_number
from .result import SimResult, joint_limits_record
from .run_records import build_result
from .run_robot import robot_record
from .self_motion import self_motion_energy
from .trajectory.orientation import rotation_error

__all__ = ["Lanes", "MovementStack", "StepLog", "run_movements", "stack_of_one"]


class Lanes(Protocol):
    """The movements a run advances, in the layout of its batch size, and the pieces that step them.

    ``q`` and ``v`` are the start state (one configuration and velocity for
    B = 1, (B, nq) and (B, n) stacks for B > 1); ``running`` is False once
    every movement stopped. ``j`` is a sample's index in the current block,
    ``t`` its time [s].
    """

    q: np.ndarray
    v: np.ndarray
    #: True when the resolver's step also runs at the final sample (velocity level), False when no torque is applied there.
    resolves_final: bool
    running: bool

    def block(self, start: int) -> list[float]:
        """Sample the reference from step ``start`` on; the times [s] of the block's steps."""

    def terms(self, q, v):
        """``(terms, x)``: the task terms of the state(s) and the task position(s)."""

    def command(self, j: int, terms, x):
        """The command of sample ``j``: the task acceleration (task velocity at the velocity level)."""

    def resolve(self, terms, command, j: int):
        """The resolver's step at the state(s); a failure is reported, never raised."""

    def record(self, j: int, t: float, q, v, x, terms, resolution) -> bool:
        """Record the row(s); True when a movement stopped at it (a failure or a ceiling)."""

    def record_final(self, j: int, q, v, x, terms) -> None:
        """Record the final state(s), where no torque is applied."""

    def compact(self, q, v, resolution):
        """``(q, v, resolution)`` without the movements that stopped."""

    def step(self, q, v, resolution, j: int, t: float):
        """``(q, v, stopped)``: the state(s) after the step, True when a movement stopped during it."""


def run_movements(lanes: Lanes, steps: int) -> None:
    """Advance every movement of ``lanes`` over ``steps`` steps, or until it stops: the one loop body.

    The lanes keep what the run recorded; the loop only orders the step's
    parts (see the module docstring) and drops the movements that stop.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # A diverging run overflows: the stop rules end it on the first non-finite torque or state and say so,
        # so numpy's floating-point warnings would only repeat it (and leak into a command's output).
        _run_movements(lanes, steps)


def _run_movements(lanes: Lanes, steps: int) -> None:
    q, v = lanes.q, lanes.v
    terms_at, command_at, resolve, record, advance = lanes.terms, lanes.command, lanes.resolve, lanes.record, lanes.step
    resolves_final = lanes.resolves_final
    start = 0
    while lanes.running and start <= steps:
        times = lanes.block(start)
        final = steps - start  # the block's index of the final state (past the block until the last one)
        for j, t in enumerate(times):
            terms, x = terms_at(q, v)
            if j == final and not resolves_final:
                # The final state: the movement is over, so no torque is applied from it.
                lanes.record_final(j, q, v, x, terms)
                break
            resolution = resolve(terms, command_at(j, terms, x), j)
            if record(j, t, q, v, x, terms, resolution):
                q, v, resolution = lanes.compact(q, v, resolution)
                if not lanes.running:
                    break
            if j == final:
                break
            q, v, stopped = advance(q, v, resolution, j, t)
            if stopped:
                q, v, _ = lanes.compact(q, v, None)
                if not lanes.running:
                    break
        start += len(times)


class StepLog:
    """What a run records, one entry per step as the step made it, joined into per-movement columns at the end.

    A step appends ``(movements, q, v, q̈, τ, x, σmin/σmax)``: the (B, ...) rows of the movements still running
    (``movements``, their indices, one array per stretch between two stops). Nothing is written into preallocated
    blocks, so a step costs the same few operations for a stack of one as for 256. Beside them: the rows whose
    task was not realised exactly (``shortfalls``: step, movements, task error, infeasible), the energies of the
    batch's extras, and the movements whose last entry is not a row of theirs (``unrecorded``: a velocity-level
    method undefined there).
    """

    FIELDS = ("q", "v", "acceleration", "tau", "x", "jacobian_inverse_condition")

    def __init__(self, robot, count: int, extras: bool):
        self.count = count
        n = robot.nv
        #: Each field's shape per movement (a stack of one held as its row logs these; a stack, (B, ...) of them).
        self.shapes = dict(zip(self.FIELDS, ((robot.nq,), (n,), (n,), (n,), (robot.m,), ())))
        self.shapes.update(kinetic_energy=(), self_motion_energy=())
        self.steps: list[tuple] = []
        self.energies: list[tuple] | None = [] if extras else None
        self.shortfalls: list[tuple] = []
        self.unrecorded: list[int] = []

    def columns(self) -> tuple[dict, np.ndarray]:
        """``(columns, recorded)``: per field a (steps, count, ...) array (NaN where a movement had stopped), the
        task error and infeasible flags as (steps, count), and how many rows each movement recorded."""
        steps, count = self.steps, self.count
        recorded = np.zeros(count, dtype=int)
        stretches, first = [], 0
        for index in range(1, len(steps) + 1):
            if index == len(steps) or steps[index][0] is not steps[first][0]:
                stretches.append((first, index, steps[first][0]))
                first = index
        for _, end, movements in stretches:
            recorded[movements] = end
        recorded[self.unrecorded] -= 1
        names = list(self.FIELDS)
        fields = list(zip(*steps))[1:] if steps else [()] * len(names)
        if self.energies is not None:
            names += ["kinetic_energy", "self_motion_energy"]
            fields += list(zip(*self.energies)) if self.energies else [(), ()]
        columns = {}
        for name, field in zip(names, fields):
            if not stretches:
                columns[name] = np.empty((0, count))
                continue
            shape = self.shapes[name]
            column = np.full((len(steps), count, *shape), np.nan)
            for first, end, movements in stretches:
                rows = field[first:end]
                # joined by one concatenate where the rows are arrays (cheaper per row than np.array)
                joined = np.concatenate(rows) if shape else np.array(rows)
                column[first:end, movements] = joined.reshape(end - first, np.size(movements), *shape)
            columns[name] = column
        task_error, infeasible = np.zeros((len(steps), count)), np.zeros((len(steps), count), dtype=bool)
        for step, movements, error, flag in self.shortfalls:
            task_error[step, movements], infeasible[step, movements] = error, flag
        columns["task_error"], columns["infeasible"] = task_error, infeasible
        return columns, recorded


def stack_of_one(plant, dt: float):
    """The step of a stack of one held as its row, ``(q, v, τ, q̈, movements) -> (q, v)``: the plant's one-state
    :meth:`~torqueopt.plants.Plant.step` (RK4 in its data for Pinocchio, its own MuJoCo data), as a run of its own."""
    step = plant.step

    def advance(q, v, tau, acceleration, movements):
        return step(q, v, tau, dt, acceleration)

    return advance


#: The rows of a stack while none of its movements has stopped.
EVERY_ROW = slice(None)


class MovementStack:
    """The engine's lanes at the torque level: B movements of one robot and one resolver in (B, ...) stacks.

    :func:`torqueopt.simulate` runs a stack of one, ``simulate_batch`` many. The
    caller hands over the pieces: ``terms`` ``(q, v) -> (terms, x)`` (Pinocchio's
    ``TermRows`` for a resolver's single-state step, the
    forest's ``StackTerms`` for a vectorised
    one), ``solve`` the resolver's step on stacks, ``advance`` the plant's step
    on stacks ``(q, v, τ, q̈, movements) -> (q, v)`` (its
    :meth:`~torqueopt.plants.Plant.step_stack`, or :func:`stack_of_one`) and
    ``rules`` the stops. Row r of
    every stack is movement ``active[r]``; a movement that stops leaves the
    stacks at once. A stack of one may be held as its row (``q`` of shape (nq,),
    what ``simulate`` does): every stack is then its one row, (n,) for (1, n),
    so that no step makes a view of it, and its pieces are the one-state
    functions (:class:`~torqueopt.robot.TaskTerms`, the resolver's single-state
    step, the plant's one-state step); it takes no ``extras``. With ``feedback``
    (terms of single-state steps), the command is
    :math:`\\ddot x_{ref} + K_D(\\dot x_{ref} - J\\dot q) + K_P(x_{ref} - x)`, with
    the rotation rows of a turning ``pose`` path :math:`\\log(R_{ref}R^\top)`
    about each movement's ``reference_rotations``.
    """

    resolves_final = False

    def __init__(
        self, robot, resolver, q: np.ndarray, v: np.ndarray, dt: float, steps: int, references: list, *,
        solve, terms, advance, rules, extras: bool = False, feedback=None, reference_rotations=None,
    ):  # fmt: skip
        self.row = q.ndim == 1  # a stack of one held as its row
        count = 1 if self.row else q.shape[0]
        self.robot, self.resolver, self.dt, self.steps, self.references = robot, resolver, dt, steps, references
        self.count, self.with_extras = count, extras
        self.q, self.v = q, v
        self.solve, self.terms, self.advance, self.rules = solve, terms, advance, rules
        self.log = StepLog(robot, count, extras)
        self.stop_reason: list[str | None] = [None] * count
        self.stop_time: list[float | None] = [None] * count
        self.limiting: list[dict] = [{} for _ in range(count)]
        self.active = np.arange(count)  # movement index of each stack row
        self.running = count > 0
        self.where = EVERY_ROW  # the rows of the running movements: every row while none has stopped
        self._keep = None
        self.feedback, self.reference_rotations = feedback, reference_rotations
        if feedback is not None:
            self.command = self._feedback_command
            self.turning = robot.task == "pose" and [getattr(r.trajectory, "oriented", False) for r in references]

    def block(self, start: int) -> list[float]:
        blocks = [reference.block(start) for reference in self.references]
        samples = [sample for _, sample in blocks]
        self.start = start

        def stacked(name):  # time-major: [step, movement, coordinate]
            if self.row:
                return getattr(samples[0], name)
            return np.ascontiguousarray(np.swapaxes(np.array([getattr(sample, name) for sample in samples]), 0, 1))

        self.reference_acceleration = stacked("acceleration")
        # A list of each step's rows: indexing a list costs far less than indexing an array.
        self.command_rows = list(self.reference_acceleration)
        if self.feedback is not None:
            self.reference_position, self.reference_velocity = stacked("position"), stacked("velocity")
        return blocks[0][0].tolist()

    def command(self, j: int, terms, x):
        rows = self.command_rows[j]
        return rows if self.where is EVERY_ROW else rows[self.where]

    def _feedback_command(self, j: int, terms, x):
        where, feedback = self.where, self.feedback
        reference = self.reference_position[j, where]
        position_error = reference - x
        if self.turning:
            size = self.active.size
            errors, references = position_error.reshape(size, -1), reference.reshape(size, -1)
            for row, movement in enumerate(self.active.tolist()):
                if self.turning[movement]:
                    # log(R_ref Rᵀ), the world rotation vector that turns R onto R_ref (both about R0), not the
                    # difference of their rotation vectors about R0, which is it only to first order
                    errors[row, 3:] = rotation_error(
                        references[row, 3:],
                        (terms if self.row else terms.row(row)).placement.rotation,
                        self.reference_rotations[movement],
                    )
        # For pose, x holds log(R R0ᵀ) and the reference orientation is R0, so reference − x = log(R0 Rᵀ).
        return (
            MovementStack.command(self, j, terms, x)
            + feedback.kd * (self.reference_velocity[j, where] - terms.task_velocity)
            + feedback.kp * position_error
        )

    def resolve(self, terms, command, j: int):
        return self.solve(terms, command, self.active)

    def record(self, j: int, t: float, q, v, x, terms, resolution) -> bool:
        active, rules, log = self.active, self.rules, self.log
        torque, acceleration = resolution.torque, resolution.joint_acceleration
        failures, task_error, infeasible = resolution.failures, resolution.task_error, resolution.infeasible
        if failures:  # no torque is applied at a row the resolver could not resolve
            failed = np.zeros(active.size, dtype=bool)
            failed[list(failures)] = True
            torque = np.where(failed[:, None], np.nan, torque.reshape(active.size, -1)).reshape(torque.shape)
            acceleration = np.where(failed[:, None], np.nan, acceleration.reshape(active.size, -1)).reshape(
                acceleration.shape
            )
            if task_error is not None:
                task_error, infeasible = np.where(failed, 0.0, task_error), infeasible & ~failed
        log.steps.append((active, q, v, acceleration, torque, x, resolution.jacobian_inverse_condition))
        k = self.start + j
        if task_error is not None:
            log.shortfalls.append((k, active, task_error, infeasible))
        if self.with_extras:
            log.energies.append(_step_energies(terms, resolution, v))
        if resolution.limiting:
            for row, bounds in resolution.limiting.items():
                self.limiting[int(active[row])][k] = bounds
        if not failures and not rules.any_torque_over(torque):
            return False
        torque = torque.reshape(active.size, -1)  # a row held as itself, as its stack
        stopping = rules.torques_over(torque)
        if failures:
            stopping |= failed
        for row in np.flatnonzero(stopping).tolist():
            movement = int(active[row])
            if failures and row in failures:
                self.stop_reason[movement] = rules.unresolved(failures[row], t)
            else:
                # The torque that ends the run stays in the result: peaks and verdicts count it.
                self.stop_reason[movement] = rules.torque(torque[row], t)
            self.stop_time[movement] = t
        self._keep = ~stopping
        return True

    def record_final(self, j: int, q, v, x, terms) -> None:
        # No torque is applied from the final state (NaN rows).
        not_applied = np.full(v.shape, np.nan)
        jacobian = terms.jacobian
        self.log.steps.append((self.active, q, v, not_applied, not_applied, x, inverse_condition_number(jacobian)))
        if self.with_extras:
            self.log.energies.append(self_motion_energy(terms.inertia, v, jacobian=jacobian))

    def compact(self, q, v, resolution):
        keep = self._keep
        self.active = self.where = self.active[keep]
        self.running = self.active.size > 0

        def kept(stack):  # a row held as itself, as its stack
            return stack.reshape(keep.size, -1)[keep]

        if resolution is not None:
            resolution = resolution._replace(
                torque=kept(resolution.torque), joint_acceleration=kept(resolution.joint_acceleration)
            )
        return kept(q), kept(v), resolution

    def step(self, q, v, resolution, j: int, t: float):
        # For the Pinocchio plant, RK4 with the torque held; k1 is the resolver's q̈ (= ABA(q, v, τ)).
        q, v = self.advance(q, v, resolution.torque, resolution.joint_acceleration, self.active)
        rules = self.rules
        if not rules.any_speed_over(v):
            return q, v, False
        rows = v.reshape(self.active.size, -1)  # a row held as itself, as its stack
        fast = rules.speeds_over(rows)
        for row in np.flatnonzero(fast).tolist():
            movement = int(self.active[row])
            self.stop_reason[movement] = rules.speed(rows[row], t, self.dt)
            self.stop_time[movement] = t + self.dt
        self._keep = ~fast
        return q, v, True

    def results(
        self, duration: float, descriptions: list[dict], plants: list, dexterity: bool = False
    ) -> list[SimResult]:
        """One :class:`~torqueopt.SimResult` per movement from the log; ``plants`` the plant's record of each."""
        robot, dt = self.robot, self.dt
        columns, recorded = self.log.columns()
        self.recorded = recorded
        self._columns = columns
        joint_limits = joint_limits_record(*robot.joint_limits)
        options = self.resolver.settings_for_file()
        source = robot_record(robot)
        times = dt * np.arange(int(recorded.max()) if self.count else 0)
        results = []
        for i in range(self.count):
            own = {name: np.ascontiguousarray(values[: int(recorded[i]), i]) for name, values in columns.items()}
            results.append(
                build_result(
                    robot,
                    self.resolver,
                    **{name: own[name] for name in StepLog.FIELDS},
                    times=times,
                    reference_position=self.references[i].positions(),
                    dt=dt,
                    duration=duration,
                    stop_reason=self.stop_reason[i],
                    stop_time=self.stop_time[i],
                    trajectory=descriptions[i],
                    task_error=own["task_error"],
                    infeasible=own["infeasible"],
                    limiting=self.limiting[i],
                    dexterity=dexterity,
                    joint_limits=joint_limits,
                    resolver_options=options,
                    plant=plants[i],
                    robot_source=source,
                )
            )
        return results

    def energies(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(kinetic energy, self-motion energy) [J] of each movement's recorded rows (after :meth:`results`)."""
        columns, recorded = self._columns, self.recorded
        return [
            tuple(
                np.ascontiguousarray(columns[name][: int(recorded[i]), i])
                for name in ("kinetic_energy", "self_motion_energy")
            )
            for i in range(self.count)
        ]


def _step_energies(terms, resolution, v: np.ndarray):
    """The energies of a resolved step: from the step's null-space basis when it has one, else from J."""
    failures = resolution.failures or {}
    basis = resolution.basis
    if basis is None and terms.jacobian.shape[1] < terms.jacobian.shape[2]:
        return self_motion_energy(terms.inertia, v, jacobian=terms.jacobian)
    kinetic, self_motion = self_motion_energy(terms.inertia, v, null_space_basis=basis)
    if failures:  # the QR basis of a singular J is not its null space
        singular = np.zeros(v.shape[0], dtype=bool)
        singular[list(failures)] = True
        kinetic[singular], self_motion[singular] = self_motion_energy(
            terms.inertia[singular], v[singular], jacobian=terms.jacobian[singular]
        )
    return kinetic, self_motion
