r"""A bounded resolver's step on one state: its own optimum within bounds, else the ``infeasible`` policy.

:class:`BoundedStep` is the step ``(terms, ẍ) -> Resolution`` of every
bounded resolver. It sets up the policies' DAQP programs once per run and,
at each state, asks the resolver's own optimum (its criterion with the
torque bounds, the joint limits and its own rows on q̈); when there is none,
it applies the policy the ``infeasible`` option names, in the coordinates of
Eq. (26). The programs of the policies are written as functions of their
numbers alone (:func:`largest_task_scaling`, :func:`least_error_task`,
:func:`least_joint_excess`, :func:`acceleration_rows`), so that each can be
checked against another solver.

The policies' programs run on :math:`x = (a, z)` with
:math:`\tau = \tau_{rest} + HJ^+a + Uz` (``TaskRows``): a the task
acceleration realised, U an orthonormal basis of the range of HZ.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import numpy as np

from ...errors import SolverFailure, TorqueBoundsInfeasible
from ...linalg import JacobianSolver
from ...robot import Robot, TaskTerms
from ..base import Resolution
from ..null_space import torque_midpoint
from .programs import _EXIT_INFEASIBLE, BOUND_MARGIN, BoundProgram, _MinMax, _Program, _RangeBasis, solve_program

__all__ = ["BoundedStep", "acceleration_rows", "largest_task_scaling", "least_error_task", "least_joint_excess"]

#: ``raised`` value of :func:`acceleration_rows` that gives up the resolver's own rows.
DROPPED = "dropped"


def bounded_joints(robot: Robot):
    """The joints with finite limits: their indices, or ``slice(None)`` (a view, no copy) when every joint has them."""
    finite = np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)
    return slice(None) if finite.all() else np.flatnonzero(finite)


def solver_bounds(robot: Robot, bounded):
    """(τ⁺, τ⁻) of the bounded joints as given to DAQP, and their ranges τ⁺ − τ⁻ [N·m].

    DAQP accepts a row that exceeds its bound by about ``primal_tol``
    (measured: up to 1.4 times it on the LPs); the bounds it gets are pulled
    in by :data:`BOUND_MARGIN` of each range, so that the torques it returns
    never exceed the true limits.
    """
    upper, lower = robot.torque_upper[bounded], robot.torque_lower[bounded]
    spread = upper - lower
    margin = BOUND_MARGIN * spread
    return upper - margin, lower + margin, spread


def torque_box(robot: Robot):
    """(τ⁺, τ⁻) of every joint as the solver sees them (pulled in by :data:`BOUND_MARGIN`; ±inf when unbounded)."""
    spread = robot.torque_upper - robot.torque_lower
    margin = np.where(np.isfinite(spread), BOUND_MARGIN * spread, 0.0)
    return robot.torque_upper - margin, robot.torque_lower + margin


def least_within_box(rows, inertia, bias_torque, box_upper, box_lower):
    r"""The least value of each row of :math:`G\ddot q = G H^{-1}(\tau - b)` over the torques in the box.

    Per row, with :math:`g = H^{-1}G^\top`: :math:`\sum_i \min(g_i\tau^+_i, g_i\tau^-_i) - g^\top b`,
    the tip left free (−inf when a joint without limits moves the row).
    """
    weights = np.linalg.solve(inertia, rows.T)  # H⁻¹ Gᵀ, n × k
    with np.errstate(invalid="ignore"):
        ends = np.minimum(weights * box_upper[:, None], weights * box_lower[:, None])
    ends = np.where(weights == 0.0, 0.0, ends)
    return ends.sum(axis=0) - bias_torque.dot(weights)


def scaling_program(rows_count: int, redundancy: int) -> _Program:
    """The LP of :func:`largest_task_scaling`: max s over (s, z), 0 <= s <= 1 a simple bound on the first variable."""
    return _Program(
        np.zeros((1 + redundancy, 1 + redundancy)),
        np.r_[-1.0, np.zeros(redundancy)],
        np.zeros((rows_count, 1 + redundancy)),
        np.r_[1.0, np.ones(rows_count)],
        np.r_[0.0, -np.ones(rows_count)],
        bounds=1,
        linear=True,
    )


def least_error_program(rows_count: int, task_dimension: int, redundancy: int) -> _Program:
    """The QP of :func:`least_error_task`: min ½‖a − ẍ‖² over (a, z).

    Its Hessian is singular in z, as an LP's (a zero matrix) is everywhere:
    DAQP then runs proximal-point iterations, whose limit is an exact optimum.
    """
    n = task_dimension + redundancy
    return _Program(
        np.diag(np.r_[np.ones(task_dimension), np.zeros(redundancy)]),
        np.zeros(n),
        np.zeros((rows_count, n)),
        np.ones(rows_count),
        -np.ones(rows_count),
    )


def excess_program(torque_rows_count: int, joint_rows_count: int, n: int) -> _Program:
    """The LP of :func:`least_joint_excess`: min Σ tᵢ over (t, a, z), t >= 0 simple bounds."""
    nb, nj = torque_rows_count, joint_rows_count
    return _Program(
        np.zeros((nj + n, nj + n)),
        np.r_[np.ones(nj), np.zeros(n)],
        np.zeros((nb + 2 * nj, nj + n)),
        np.r_[np.full(nj, np.inf), np.ones(nb + 2 * nj)],
        np.r_[np.zeros(nj), -np.ones(nb + 2 * nj)],
        bounds=nj,
        linear=True,
    )


def largest_task_scaling(program: _Program, rows, upper, lower, command):
    """(s ẍ, z) with the largest s in [0, 1] for which ``lower <= rows · (s ẍ, z) <= upper``, or None when none is.

    Flacco, De Luca & Khatib (ICRA 2012): the direction of the task acceleration ẍ (``command``) is kept.
    ``rows`` act on x = (a, z); ``program`` is :func:`scaling_program`'s.
    """
    m = command.size
    scaled_rows = np.hstack([rows[:, :m].dot(command)[:, None], rows[:, m:]])
    x, flag = solve_program(program, BoundProgram(None, None, scaled_rows, np.r_[1.0, upper], np.r_[0.0, lower]))
    if flag == _EXIT_INFEASIBLE:
        return None
    return float(np.clip(x[0], 0.0, 1.0)) * command, x[1:]


def least_error_task(program: _Program, rows, upper, lower, command):
    """(a, z) of min ½‖a − ẍ‖² with ``lower <= rows · (a, z) <= upper``, or None when no (a, z) meets them.

    ``program`` is :func:`least_error_program`'s with as many rows as ``rows``.
    """
    m = command.size
    redundancy = rows.shape[1] - m
    x, flag = solve_program(program, BoundProgram(None, np.r_[-command, np.zeros(redundancy)], rows, upper, lower))
    if flag == _EXIT_INFEASIBLE:
        return None
    return x[:m], x[m:]


def least_joint_excess(program: _Program, torque_part, joint_part, task_dimension: int):
    """(t, (a, z)): the least widenings t >= 0 (Σ t least) of the joint limits' rows that leave a torque within
    bounds, and a point x = (a, z) there; None when DAQP finds none.

    ``torque_part`` and ``joint_part`` are (rows, upper, lower) on x: the torque bounds, and the joint limits'
    rows divided by ā, row i widened by tᵢ on both sides. A row with no finite side holds whatever x.
    ``program`` is :func:`excess_program`'s.
    """
    torque_rows, torque_upper, torque_lower = torque_part
    rows, upper, lower = joint_part
    nb, nj, m = torque_rows.shape[0], rows.shape[0], task_dimension
    finite_upper, finite_lower = np.isfinite(upper), np.isfinite(lower)
    # Each row twice, one side each (a row with no finite side holds whatever x: zeros within ±1).
    slack = np.eye(nj)
    above = np.hstack([-slack * finite_upper, np.where(finite_upper[:, None], rows, 0.0)])
    below = np.hstack([slack * finite_lower, np.where(finite_lower[:, None], rows, 0.0)])
    program_rows = np.vstack([np.hstack([np.zeros((nb, nj)), torque_rows]), above, below])
    program_upper = np.r_[np.full(nj, np.inf), torque_upper, np.where(finite_upper, upper, 1.0), np.full(nj, np.inf)]
    program_lower = np.r_[np.zeros(nj), torque_lower, np.full(nj, -np.inf), np.where(finite_lower, lower, -1.0)]
    x, flag = solve_program(program, BoundProgram(None, None, program_rows, program_upper, program_lower))
    if flag == _EXIT_INFEASIBLE:  # pragma: no cover - H is invertible: the box holds some torque
        return None
    return np.maximum(x[:nj], 0.0), (x[nj : nj + m], x[nj + m :])


def acceleration_rows(
    joints, joint_bounds, joint_scale, constraints, offset, rows, raised=None, free_joints=False, widen=0.0
):
    """Rows and bounds on x of the joint limits and the resolver's own rows, with q̈ = ``offset`` + ``rows`` · x.

    The joint limits' rows (``joints``: their joints, None: no joint limits) are each divided by its ā
    (``joint_scale``) and widened by ``widen`` on both sides; with ``free_joints`` they hold whatever x (the joint
    limits given up). Then the resolver's own rows G q̈ <= h (``constraints`` = (G, h), None: none), h raised
    to ``raised`` where that is higher; ``raised`` = :data:`DROPPED`: they hold whatever x.
    """
    parts = []
    if joints is not None and free_joints:
        parts.append((np.zeros((joints.size, rows.shape[1])), np.ones(joints.size), -np.ones(joints.size)))
    elif joints is not None:
        parts.append(
            (
                rows[joints] / joint_scale[:, None],
                (joint_bounds.upper - offset[joints]) / joint_scale + widen,
                (joint_bounds.lower - offset[joints]) / joint_scale - widen,
            )
        )
    if constraints is not None:
        own_rows, own_upper = constraints
        own_count = own_rows.shape[0]
        if raised is DROPPED:
            # Rows that hold whatever x (DAQP needs a finite bound on a general row).
            parts.append((np.zeros((own_count, rows.shape[1])), np.ones(own_count), -np.ones(own_count)))
        else:
            if raised is not None:
                own_upper = np.maximum(own_upper, raised)
            parts.append((own_rows.dot(rows), own_upper - own_rows.dot(offset), np.full(own_count, -np.inf)))
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate(part) for part in zip(*parts))


class StepState(NamedTuple):
    """One state's numbers of Eq. (26) to Eq. (28) and its bounds on q̈."""

    terms: TaskTerms
    #: ẍ, the task acceleration asked.
    command: np.ndarray
    #: p and Z of Eq. (26), and σ_min/σ_max of J.
    particular: np.ndarray
    basis: np.ndarray
    inverse_condition: float
    #: HZ and τ̃ of Eq. (27), Eq. (28).
    inertia_basis: np.ndarray
    tilde_torque: np.ndarray
    #: The joint limits' bounds on q̈ and their ā (None: no joint limits).
    joint_bounds: object
    joint_scale: np.ndarray | None
    #: The resolver's own rows (G, h): G q̈ <= h (None: none).
    constraints: tuple | None


class TaskRows(NamedTuple):
    """The policies' coordinates x = (a, z): τ = ``rest_torque`` + ``task_torque`` a + U z, and the rows on x.

    ``torque`` holds the torque bounds as (rows, upper, lower) divided by each range; ``offset`` and
    ``coordinates`` give q̈ = offset + coordinates · x (None without rows on q̈).
    """

    pseudo_inverse: np.ndarray
    task_torque: np.ndarray
    rest_torque: np.ndarray
    range_rows: np.ndarray
    torque: tuple
    offset: np.ndarray | None
    coordinates: np.ndarray | None


class BoundedStep:
    """A bounded resolver's step ``(terms, ẍ) -> Resolution`` on ``robot``, with its DAQP programs set up once.

    ``dt`` [s] is the step over which the run holds the torque: the joint-limit bounds keep the state after it
    within the limits (``joint_limits.DEFAULT_STEP``, 1 ms, when None). With ``record`` each resolution carries
    the program whose solution gives its torque (``Resolution.program``: the resolver's own optimum, at the task
    acceleration achieved on an infeasible step, or the min-max LP of ``exceed``; None where a policy's first
    stage gives the answer), copied at each step, which a run does not need.
    """

    def __init__(self, resolver, robot: Robot, dt: float | None = None, record: bool = False):
        resolver.check(robot)
        self.name, self.policy, self.robot = resolver.name, resolver.infeasible, robot
        n, self.m = robot.nv, robot.m
        r = n - self.m
        self.bounded = bounded = bounded_joints(robot)
        self.upper, self.lower, self.spread = solver_bounds(robot, bounded)
        midpoint = torque_midpoint(robot)
        self.decompose = JacobianSolver(self.m, n, resolver.singular_tolerance)
        self.limits = limits = resolver.joint_limits_of(robot, dt)
        # The resolver's own constraints G q̈ <= h beside the joint limits (energy-bounded-torque's barrier).
        own_count, self.constraints_at, self.constraint_names = resolver._acceleration_constraints(robot)
        nj = 0 if limits is None else limits.count
        self.nl = nl = nj + own_count
        self.optimum = resolver._optimum(robot, bounded, self.spread, midpoint, nl, record)
        self.record = record
        self.nb = nb = self.spread.size
        self.box_upper, self.box_lower = torque_box(robot)
        self.scaling = scaling_program(nb + nl, r)
        self.least_error = least_error_program(nb + nl, self.m, r)
        # With joint limits, torque and joint bounds may leave no q̈ at all: then the torque bounds alone.
        self.torque_least_error = least_error_program(nb, self.m, r) if nl else self.least_error
        # The least excess of the joint limits' rows a torque within bounds allows (in units of each joint's ā).
        self.excess = excess_program(nb, nj, n) if nj else None
        self.minmax = _MinMax(bounded, self.spread, midpoint, r, own_count) if self.policy == "exceed" else None
        self.range_basis = _RangeBasis(n, r)

    def state(self, terms: TaskTerms, command: np.ndarray) -> StepState:
        """Eq. (26) to Eq. (28) and the bounds on q̈ at this state."""
        particular, basis, inverse_condition = self.decompose(terms.jacobian, command - terms.drift)
        inertia = terms.inertia
        inertia_basis = inertia.dot(basis)
        tilde_torque = inertia.dot(particular) + terms.bias_torque  # Eq. (28)
        joint_bounds = joint_scale = constraints = None
        if self.limits is not None:
            joint_bounds = self.limits(terms)
            joint_scale = self.limits.scale(joint_bounds)
        if self.constraints_at is not None:
            constraints = self.constraints_at(terms, basis)  # (G, h): G q̈ <= h, unit rows
        return StepState(
            terms, command, particular, basis, inverse_condition, inertia_basis, tilde_torque, joint_bounds,
            joint_scale, constraints,
        )  # fmt: skip

    def rows_at(self, state: StepState):
        """The state's :func:`acceleration_rows` as ``(offset, rows, **options)``, or None without rows on q̈."""
        if not self.nl:
            return None
        joints = None if self.limits is None else self.limits.joints
        return partial(acceleration_rows, joints, state.joint_bounds, state.joint_scale, state.constraints)

    def __call__(self, terms: TaskTerms, task_acceleration: np.ndarray) -> Resolution:
        state = self.state(terms, task_acceleration)
        joint_rows = self.rows_at(state)
        found = self.optimum(
            terms, state.basis, state.inertia_basis, state.tilde_torque, state.particular, joint_rows
        )  # fmt: skip
        if found is not None:
            y, torque, program = found
            acceleration = state.particular + state.basis.dot(y)  # Eq. (26)
            return Resolution(torque, acceleration, state.inverse_condition, 0.0, False, "", program)
        if self.policy == "stop":
            raise self.stop_error(state)
        range_rows = self.range_basis(state.inertia_basis)  # U, orthonormal, spans the range of HZ
        if self.policy == "exceed":
            return self.exceed(state, range_rows)
        return self.give_up_task(state, range_rows, joint_rows)

    def stop_error(self, state: StepState) -> TorqueBoundsInfeasible:
        """The error of ``infeasible='stop'``: no torque within bounds realises the task."""
        return TorqueBoundsInfeasible(
            f"resolver '{self.name}' (infeasible='stop'): no torque within bounds realises the task "
            f"acceleration {np.round(state.command, 6).tolist()}"
            + (" within the joint limits" if self.limits is not None else "")
            + (f" within its {', '.join(self.constraint_names)}" if state.constraints is not None else "")
        )

    def exceed(self, state: StepState, range_rows) -> Resolution:
        """``infeasible='exceed'``: the task and the resolver's own rows kept (not the joint limits), the torque of
        least largest normalised excess (the min-max LP; the own rows alone are always feasible)."""
        own = None
        if state.constraints is not None:
            own_rows, own_upper = state.constraints
            own = (
                own_rows.dot(np.linalg.solve(state.terms.inertia, range_rows)),  # q̈ = p + H⁻¹U z
                own_upper - own_rows.dot(state.particular),
                np.full(own_rows.shape[0], -np.inf),
            )
        z, utilisation = self.minmax(range_rows, state.tilde_torque, own)
        if utilisation is None:  # pragma: no cover - the barrier alone is always feasible
            z, _ = self.minmax(range_rows, state.tilde_torque)
        y = self.range_basis.coordinates(range_rows.dot(z))
        torque = state.tilde_torque + state.inertia_basis.dot(y)  # Eq. (27)
        acceleration = state.particular + state.basis.dot(y)
        limiting = self.limiting_bounds(state, torque, acceleration)
        program = self.minmax.solved(z, utilisation, state.tilde_torque, range_rows) if self.record else None
        return Resolution(torque, acceleration, state.inverse_condition, 0.0, True, limiting, program)

    def task_rows(self, state: StepState, range_rows, joint_rows) -> TaskRows:
        """The torque bounds on x = (a, z), and q̈ = (p − J⁺ẍ) + J⁺ a + H⁻¹U z when there are rows on q̈."""
        inertia, bounded, spread = state.terms.inertia, self.bounded, self.spread
        pseudo_inverse = np.linalg.pinv(state.terms.jacobian)
        task_torque = inertia.dot(pseudo_inverse)  # H J⁺, n × m
        rest_torque = state.tilde_torque - task_torque.dot(state.command)  # b − H J⁺ J̇q̇
        rows = np.hstack([task_torque, range_rows])[bounded] / spread[:, None]
        row_upper = (self.upper - rest_torque[bounded]) / spread
        row_lower = (self.lower - rest_torque[bounded]) / spread
        offset = coordinates = None
        if joint_rows is not None:
            offset = state.particular - pseudo_inverse.dot(state.command)
            coordinates = np.hstack([pseudo_inverse, np.linalg.solve(inertia, range_rows)])
        return TaskRows(pseudo_inverse, task_torque, rest_torque, range_rows, (rows, row_upper, row_lower), offset,
                        coordinates)  # fmt: skip

    def with_rows(self, task: TaskRows, joint_rows):
        """(rows, upper, lower) on x: the torque bounds, then ``joint_rows`` at the task's q̈ (None: none)."""
        if joint_rows is None:
            return task.torque
        extra = joint_rows(task.offset, task.coordinates)
        return tuple(np.vstack([a, b]) if a.ndim == 2 else np.r_[a, b] for a, b in zip(task.torque, extra))

    def give_up_task(self, state: StepState, range_rows, joint_rows) -> Resolution:
        """``infeasible='scale'`` or ``'least-error'``: the task acceleration given up least, then the resolver's
        own optimum at the task acceleration achieved."""
        task = self.task_rows(state, range_rows, joint_rows)
        rows, upper, lower = self.with_rows(task, joint_rows)
        found_task = None
        if self.policy == "scale":
            found_task = largest_task_scaling(self.scaling, rows, upper, lower, state.command)
        # Not even s = 0 (the tip held on its path) has a torque within bounds, or the policy
        # asks for it: give up the direction too, for the least task error.
        if found_task is None:
            found_task = least_error_task(self.least_error, rows, upper, lower, state.command)
        within_joint_limits, widened = True, 0.0  # widened: by how much (in units of ā) each joint row was
        if found_task is None and state.constraints is not None:
            found_task, joint_rows, within_joint_limits, widened = self.yield_own_rows(state, task, joint_rows)
        elif found_task is None and self.limits is not None:
            found_task, joint_rows, within_joint_limits, widened = self.widen_joint_limits(state, task, joint_rows)
        if found_task is None:
            within_joint_limits = joint_rows is None
            joint_rows, widened = None, 0.0
            # No q̈ within the joint limits has a torque within bounds: the torque bounds win.
            found_task = least_error_task(self.torque_least_error, *task.torque, state.command)
        if found_task is None:  # pragma: no cover - H is invertible: every torque in the box is some (a, z)
            raise SolverFailure(f"resolver '{self.name}': DAQP found no torque in the box for the least task error")
        return self.settle(state, task, found_task, joint_rows, within_joint_limits, widened)

    def least_excess(self, state: StepState, task: TaskRows):
        """(widening, point): the least widening of the joint limits' rows a torque within bounds allows (a hair
        more), and a point (a, z) there; (None, None) when DAQP finds none."""
        joints, joint_scale, joint_bounds = self.limits.joints, state.joint_scale, state.joint_bounds
        joint_part = (
            task.coordinates[joints] / joint_scale[:, None],
            (joint_bounds.upper - task.offset[joints]) / joint_scale,
            (joint_bounds.lower - task.offset[joints]) / joint_scale,
        )
        least = least_joint_excess(self.excess, task.torque, joint_part, self.m)
        if least is None:  # pragma: no cover - H is invertible: the box holds some torque
            return None, None
        widen, point = least
        if widen.max() <= 1e-9:
            # Within the joint limits after all (DAQP's least-error program called them infeasible).
            return np.zeros_like(widen), point
        return widen * (1.0 + 1e-3) + 1e-6, point

    def yield_own_rows(self, state: StepState, task: TaskRows, all_rows):
        """(a, z), the rows kept, whether within the joint limits, the widening: the resolver's own rows yield first,
        each raised to the least value a torque within bounds gives it, the tip left free (the barrier: energy out
        as fast as the bounds allow); then, with joint limits, the own rows given up with the joint limits kept;
        then the joint limits widened least and the own rows back, raised; then the joint limits given up."""
        least = least_within_box(
            state.constraints[0], state.terms.inertia, state.terms.bias_torque, self.box_upper, self.box_lower
        )
        least_raised = least + 1e-9 * (1.0 + np.abs(least))
        stages = [(least_raised, False, 0.0)]
        if self.limits is not None:
            stages += [(DROPPED, False, 0.0), (least_raised, False, None), (least_raised, True, 0.0)]
        joint_rows = all_rows
        for raised, free_joints, widen in stages:
            if widen is None:
                widen, _ = self.least_excess(state, task)
                if widen is None:  # pragma: no cover - H is invertible: the box holds some torque
                    continue
            joint_rows = partial(all_rows, raised=raised, free_joints=free_joints, widen=widen)
            found_task = least_error_task(self.least_error, *self.with_rows(task, joint_rows), state.command)
            if found_task is not None:
                return found_task, joint_rows, not free_joints and not np.any(widen), widen
        return None, joint_rows, True, 0.0

    def widen_joint_limits(self, state: StepState, task: TaskRows, joint_rows):
        """(a, z), the rows kept, whether within the joint limits, the widening: no q̈ within the joint limits has
        a torque within bounds, so the joint limits widened least (each row by a multiple of its joint's ā), and
        the least task error within them."""
        widen, point = self.least_excess(state, task)
        if widen is None:  # pragma: no cover - H is invertible: the box holds some torque
            return None, joint_rows, True, 0.0
        joint_rows = partial(joint_rows, widen=widen)
        found_task = least_error_task(self.least_error, *self.with_rows(task, joint_rows), state.command)
        if found_task is None:
            # DAQP's warm-started least-error program can call a feasible set infeasible (its proximal
            # iterations; measured on baxter, where HiGHS and a cold start solve it): the LP's own point.
            found_task = point
        return found_task, joint_rows, not np.any(widen), widen

    def settle(self, state: StepState, task: TaskRows, found_task, joint_rows, within_joint_limits, widened):
        """The resolution at the task acceleration achieved: the resolver's own optimum there (with ``joint_rows``),
        or, where round-off on the boundary makes that program infeasible, the first stage's z."""
        achieved, z = found_task
        command = state.command
        shifted_particular = state.particular + task.pseudo_inverse.dot(achieved - command)
        shifted_tilde = task.rest_torque + task.task_torque.dot(achieved)
        found = self.optimum(
            state.terms, state.basis, state.inertia_basis, shifted_tilde, shifted_particular, joint_rows
        )  # fmt: skip
        if found is None:
            y = self.range_basis.coordinates(task.range_rows.dot(z))
            found = y, shifted_tilde + state.inertia_basis.dot(y), None
        y, torque, program = found
        error = float(np.linalg.norm(achieved - command))
        acceleration = shifted_particular + state.basis.dot(y)
        limiting = self.limiting_bounds(state, torque, acceleration)
        limits, joint_bounds = self.limits, state.joint_bounds
        if np.any(widened):
            exceeded = "; ".join(limits.exceeded(joint_bounds, acceleration)) or "none beyond 1e-6 of ā"
            limiting = f"joint limits exceeded least for the torque limits ({exceeded}); " + limiting
        elif not within_joint_limits:
            exceeded = "; ".join(limits.exceeded(joint_bounds, acceleration)) if limits is not None else ""
            limiting = (
                "joint limits given up for the torque limits" + (f" ({exceeded})" if exceeded else "") + "; "
            ) + limiting
        return Resolution(torque, acceleration, state.inverse_condition, error, True, limiting, program)

    def torque_bounds_active(self, torque) -> list[str]:
        """The torque bounds ``torque`` lies on (within 1e-6 of the range), as texts."""
        robot, bounded = self.robot, self.bounded
        found = []
        joints = np.arange(robot.nv)[bounded]
        for side, bound in (("upper", robot.torque_upper), ("lower", robot.torque_lower)):
            on = np.abs(torque[bounded] - bound[bounded]) <= 1e-6 * self.spread
            found.extend(
                f"torque limit ({side}) of joint {robot.joint_names[joints[row]]}" for row in np.flatnonzero(on)
            )
        return found

    def limiting_bounds(self, state: StepState, torque, acceleration) -> str:
        """The bounds the answer of an infeasible step lies on, in one line."""
        found = self.torque_bounds_active(torque)
        if state.joint_bounds is not None:
            found += self.limits.active(state.joint_bounds, acceleration)
        if state.constraints is not None:
            own_rows, own_upper = state.constraints
            slack = own_upper - own_rows.dot(acceleration)
            found += [self.constraint_names[row] for row in np.flatnonzero(np.abs(slack) <= 1e-6)]
        return "; ".join(found) if found else "no bound within 1e-6 of its range"
