r"""What the bounded resolvers share: their checks, the ``infeasible`` option and the step on stacks.

``_BoundedResolver``'s step on one state is
:class:`~torqueopt.resolvers.bounded.infeasible.BoundedStep`: the resolver's
own optimum within bounds (``_optimum``, one per resolver), and, when there
is none, the policy the ``infeasible`` option names (scale the task, least
task error, exceed the bounds least, stop), in the coordinates of Eq. (26).

Its step on stacks (``batch_solver``, ``BoundedStackStep``) builds every
row's program with stacked numpy (null-space basis, criterion, torque-bound
rows, joint-limit rows, the resolver's own rows: ``_stack_optimum`` and
``_stack_acceleration_constraints``, one per resolver) and solves each row
with DAQP in a loop, one warm-started program per movement; a row whose
optimum is infeasible goes through the single-state step, whose policies,
``limiting`` texts and stops are then those of ``simulate`` by construction.
"""

from __future__ import annotations

import numpy as np

from ...checks import Refused
from ...errors import NoRedundancy, SolverFailure
from ...robot import Robot
from ..base import Resolver, Step, _defining_class
from ..null_space import torque_midpoint
from ..options import Option
from ..stacks import LoopedStackStep, StackResolution, StackStep, StackTerms, singular_rows, task_factorisation
from .infeasible import BoundedStep
from .infeasible import bounded_joints as _bounded_joints
from .infeasible import solver_bounds as _solver_bounds
from .joint_limits import JointLimits

__all__ = ["INFEASIBLE_OPTION", "INFEASIBLE_POLICIES", "torque_utilisation"]

#: What a bounded resolver does when no torque within bounds realises the task.
INFEASIBLE_POLICIES = ("scale", "least-error", "exceed", "stop")


def torque_utilisation(torque, torque_lower, torque_upper) -> np.ndarray:
    r"""The largest normalised torque :math:`\max_i |\tau_i - \tau_{mid,i}| / (\tau^+_i - \tau^-_i)`.

    Joints without a finite limit are left out (0 when no joint has one).
    Within bounds iff the value is at most 1/2. ``torque`` is one torque
    vector (n) or a run's rows (N × n); the result is a float or (N,).
    """
    torque = np.asarray(torque, dtype=float)
    lower, upper = np.asarray(torque_lower, float), np.asarray(torque_upper, float)
    bounded = np.isfinite(lower) & np.isfinite(upper)
    if not bounded.any():
        return np.zeros(torque.shape[:-1]) if torque.ndim > 1 else np.float64(0.0)
    middle = 0.5 * (upper[bounded] + lower[bounded])
    spread = upper[bounded] - lower[bounded]
    return (np.abs(torque[..., bounded] - middle) / spread).max(axis=-1)


def _policy(value) -> str:
    """Converter of the ``infeasible`` option."""
    text = str(value).strip() if isinstance(value, str) else value
    if text not in INFEASIBLE_POLICIES:
        raise Refused(f"must be one of {', '.join(INFEASIBLE_POLICIES)}")
    return text


INFEASIBLE_OPTION = Option(
    name="infeasible",
    kind=" | ".join(f"'{policy}'" for policy in INFEASIBLE_POLICIES),
    unit="",
    default="scale",
    meaning=(
        "when no torque within bounds realises the task: scale the task acceleration down (largest s in [0, 1]), "
        "take the least task error, exceed the bounds least (min-max torque), or stop"
    ),
    convert=_policy,
)


class _BoundedResolver(Resolver):
    """Shared checks, options and the infeasible-task policies of the two bounded resolvers."""

    needs_redundancy = True

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if not (np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)).any():
            raise NoRedundancy(
                f"resolver '{self.name}' bounds torques, but robot '{robot.name}' has no finite torque limit; "
                "give torque limits (--torque-limit)"
            )

    @property
    def needs_torque_limits(self) -> bool:
        return True

    def joint_limits_of(self, robot: Robot, dt: float | None = None) -> JointLimits | None:
        """The joint-limit bounds on q̈ this resolver adds to its programs on ``robot`` (None: none)."""
        if self.joint_limits != "on":
            return None
        limits = JointLimits(robot, dt, self.joint_acceleration_limit)
        return limits if limits.count else None

    def solver_for_run(self, robot: Robot, dt: float) -> Step:
        return self.solver(robot, dt)

    def batch_solver(self, robot: Robot, dt: float | None = None) -> StackStep:
        """The vectorised step on stacks, ``BoundedStackStep``; the looped default for a subclass that changes
        its criterion (``_optimum``) or its own rows (``_acceleration_constraints``) without their stacked forms."""
        cls = type(self)
        for single, stacked in (
            ("_optimum", "_stack_optimum"),
            ("_acceleration_constraints", "_stack_acceleration_constraints"),
        ):
            if _defining_class(cls, stacked) is not _defining_class(cls, single):
                return super().batch_solver(robot, dt)
        return BoundedStackStep(self, robot, dt)

    def solver(self, robot: Robot, dt: float | None = None) -> Step:
        """The step ``(terms, ẍ) -> Resolution`` on ``robot``, with its DAQP programs set up once (:class:`BoundedStep`).

        ``dt`` [s] is the step over which the run holds the torque: the
        joint-limit bounds keep the state after it within the limits
        (:data:`~torqueopt.resolvers.bounded.joint_limits.DEFAULT_STEP` when None).
        """
        return BoundedStep(self, robot, dt)

    def program_solver(self, robot: Robot) -> Step:
        """:meth:`solver`'s step whose resolutions carry the program each solved (``BoundedStep`` with ``record``)."""
        return BoundedStep(self, robot, None, record=True)

    def _acceleration_constraints(self, robot: Robot):
        """``(k, function, names)``: this resolver's own k constraints G q̈ <= h on the joint acceleration, beside
        the torque bounds and the joint limits, as a function ``(terms, Z) -> (G (k × n), h (k))`` with unit rows,
        and a name for each; ``(0, None, ())`` when it has none."""
        return 0, None, ()

    def _optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int, record: bool = False):
        """``(terms, Z, HZ, τ̃, p, joint_rows) -> (y, τ, program)`` of this resolver's criterion with τ within bounds
        and q̈ = p + Z y within the rows on q̈ (``joint_rows(offset, rows)``, None: none), or None when none is;
        ``program`` the :class:`~torqueopt.resolvers.Program` it solved when ``record``, else None."""
        raise NotImplementedError

    def _stack_acceleration_constraints(self, robot: Robot):
        """:meth:`_acceleration_constraints` on stacks: ``(k, function, names)`` with ``(StackTerms, Z (B, n, r))
        -> (G (B, k, n), h (B, k))``; ``(0, None, ())`` when the resolver has none."""
        return 0, None, ()

    def _stack_optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int) -> StackOptimum:
        """:meth:`_optimum` on stacks: the :class:`StackOptimum` of this resolver's criterion."""
        raise NotImplementedError


class StackOptimum:
    """A bounded resolver's own program on stacks: built for every row at once, solved row by row.

    ``program()`` makes one movement's workspace (warm-started from its
    previous step, as in ``simulate``); ``build(terms, Z, HZ, τ̃, p, joint_rows)``
    the numbers of every row (``joint_rows(offset, rows)``: the stacked rows on
    q̈ = offset + rows · x, None: none); ``solve(program, problem, row)`` one row's
    solution, None when infeasible; ``coordinates(problem, rows, solutions)`` the
    null-space coordinates y (len(rows), r) of the solved rows. ``free(problem)``,
    for a strictly convex QP, gives every row's unconstrained minimiser and
    whether it meets every row's bounds: there it is the program's optimum, and
    the row needs no solver call (None: every row is solved).
    """

    def __init__(self, program, build, solve, coordinates=None, free=None):
        self.program, self.build, self.solve, self.free = program, build, solve, free
        self.coordinates = coordinates if coordinates is not None else (lambda problem, rows, solutions: solutions)


def _rows_of(terms: StackTerms, rows) -> StackTerms:
    """The stack of the given rows only."""
    return StackTerms(*(field[rows] for field in terms))


class BoundedStackStep:
    r"""A bounded resolver's step on stacks: every row's program built at once, each solved by DAQP in a loop.

    Per call: Eq. (26)'s particular solution and null-space basis of every
    row (the stacked factorisation of the paper's resolvers), :math:`HZ` and
    :math:`\tilde\tau` (Eq. (28)), the joint-limit bounds on q̈ (Del Prete's, on
    the stacks) and the resolver's own rows, then its program's numbers
    (:class:`StackOptimum`). Each row is solved in its movement's own DAQP
    workspace; a row with no optimum within the bounds is handed, with its
    movement, to the single-state step (:class:`~torqueopt.resolvers.stacks.LoopedStackStep`),
    which applies the ``infeasible`` policy, says which bounds its answer lay
    on (``limiting``) or stops, as in ``simulate``. A row with a singular
    Jacobian fails with the paper's resolvers' message.
    """

    def __init__(self, resolver: _BoundedResolver, robot: Robot, dt: float | None = None):
        resolver.check(robot)
        self.robot = robot
        self.factor = task_factorisation(robot)
        self.tolerance = resolver.singular_tolerance
        self.limits = resolver.joint_limits_of(robot, dt)
        self.own_count, self.constraints_at, _ = resolver._stack_acceleration_constraints(robot)
        rows_count = (0 if self.limits is None else self.limits.count) + self.own_count
        bounded = _bounded_joints(robot)
        _, _, spread = _solver_bounds(robot, bounded)
        self.optimum = resolver._stack_optimum(robot, bounded, spread, torque_midpoint(robot), rows_count)
        self.rows_count = rows_count
        self.single = LoopedStackStep(resolver, robot, dt)
        self.programs: dict = {}

    def joint_rows(self, terms: StackTerms, basis: np.ndarray):
        """The stacked ``joint_rows(offset, rows)`` of the joint limits and the resolver's own rows at these states,
        or None when the resolver has neither (the single-state step's ``joint_rows``, row for row)."""
        if not self.rows_count:
            return None
        limits, parts_at = self.limits, []
        if limits is not None:
            bounds = limits(terms)
            scale = limits.scale(bounds)
            joints = limits.joints

            def joint_part(offset, rows):
                return (
                    rows[:, joints] / scale[..., None],
                    (bounds.upper - offset[:, joints]) / scale,
                    (bounds.lower - offset[:, joints]) / scale,
                )

            parts_at.append(joint_part)
        if self.constraints_at is not None:
            own_rows, own_upper = self.constraints_at(terms, basis)  # G q̈ <= h, unit rows
            no_lower = np.full(own_upper.shape, -np.inf)

            def own_part(offset, rows):
                return own_rows @ rows, own_upper - np.einsum("bkn,bn->bk", own_rows, offset), no_lower

            parts_at.append(own_part)

        def joint_rows(offset, rows):
            parts = [part(offset, rows) for part in parts_at]
            if len(parts) == 1:
                return parts[0]
            return tuple(np.concatenate(part, axis=1) for part in zip(*parts))

        return joint_rows

    def __call__(self, terms: StackTerms, task_accelerations: np.ndarray, movements: np.ndarray) -> StackResolution:
        count, n = task_accelerations.shape[0], self.robot.nv
        particular, basis, conditions = self.factor(terms.jacobian, task_accelerations - terms.drift, True)
        failures = singular_rows(conditions, self.tolerance)
        torque, acceleration = np.full((count, n), np.nan), np.full((count, n), np.nan)
        task_error, infeasible, limiting = np.zeros(count), np.zeros(count, dtype=bool), {}
        if failures:
            failed = np.zeros(count, dtype=bool)
            failed[list(failures)] = True
            kept = np.flatnonzero(~failed)
            states, kept_particular, kept_basis = _rows_of(terms, kept), particular[kept], basis[kept]
        else:
            kept, states, kept_particular, kept_basis = np.arange(count), terms, particular, basis
        if kept.size:
            inertia = states.inertia
            inertia_basis = inertia @ kept_basis  # HZ
            tilde_torque = np.einsum("bij,bj->bi", inertia, kept_particular) + states.bias_torque  # Eq. (28)
            optimum = self.optimum
            problem = optimum.build(
                states, kept_basis, inertia_basis, tilde_torque, kept_particular, self.joint_rows(states, kept_basis)
            )
            programs, solve, make = self.programs, optimum.solve, optimum.program
            solved, solutions, hard = [], [], []
            if optimum.free is not None:
                # Rows whose unconstrained minimiser meets every bound: that is their optimum, no solver call.
                free_solutions, inside = optimum.free(problem)
                solved = np.flatnonzero(inside).tolist()
                solutions = list(free_solutions[inside])
                pending = np.flatnonzero(~inside).tolist()
            else:
                pending = range(kept.size)
            kept_movements = movements[kept]
            for index in pending:
                movement = int(kept_movements[index])
                program = programs.get(movement)
                if program is None:
                    program = programs[movement] = make()
                try:
                    solution = solve(program, problem, index)
                except SolverFailure:
                    # DAQP failed on the stacked program (cycling on minmax-torque's LP, measured on tiago):
                    # the single-state step solves the row, or says why it cannot.
                    hard.append(index)
                    continue
                if solution is None:
                    hard.append(index)
                else:
                    solved.append(index)
                    solutions.append(solution)
            if solved:
                solved = np.asarray(solved)
                y = optimum.coordinates(problem, solved, np.array(solutions))
                rows = kept[solved]
                torque[rows] = tilde_torque[solved] + np.einsum("bij,bj->bi", inertia_basis[solved], y)  # Eq. (27)
                # Eq. (26)
                acceleration[rows] = kept_particular[solved] + np.einsum("bij,bj->bi", kept_basis[solved], y)
            if hard:
                # No optimum within the bounds: the single-state step's policy, row for row, as in simulate.
                rows = kept[hard]
                resolution = self.single(_rows_of(terms, rows), task_accelerations[rows], movements[rows])
                torque[rows], acceleration[rows] = resolution.torque, resolution.joint_acceleration
                if resolution.task_error is not None:  # None: every row realised its task
                    task_error[rows], infeasible[rows] = resolution.task_error, resolution.infeasible
                conditions[rows] = resolution.jacobian_inverse_condition
                for index, text in resolution.failures.items():
                    failures[int(rows[index])] = text
                for index, text in resolution.limiting.items():
                    limiting[int(rows[index])] = text
        return StackResolution(torque, acceleration, conditions, task_error, infeasible, failures, limiting, basis)
