r"""What the two bounded resolvers share: the bounded joints, the ``infeasible`` option and its policies.

``_BoundedResolver`` writes the step of both: the resolver's own
optimum within bounds (``_optimum``, one per resolver), and, when there is
none, the policy the ``infeasible`` option names (scale the task, least task
error, exceed the bounds least, stop), in the coordinates of Eq. (26).

Its step on stacks (``batch_solver``, ``BoundedStackStep``) builds every
row's program with stacked numpy (null-space basis, criterion, torque-bound
rows, joint-limit rows, the resolver's own rows: ``_stack_optimum`` and
``_stack_acceleration_constraints``, one per resolver) and solves each row
with DAQP in a loop, one warm-started program per movement; a row whose
optimum is infeasible goes through the single-state step, whose policies,
``limiting`` texts and stops are then those of ``simulate`` by construction.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from ...checks import Refused
from ...errors import NoRedundancy, SolverFailure, TorqueBoundsInfeasible
from ...linalg import JacobianSolver
from ...robot import Robot, TaskTerms
from ..base import Resolution, Resolver, Step, _defining_class
from ..null_space import torque_midpoint
from ..options import Option
from ..stacks import LoopedStackStep, StackResolution, StackStep, StackTerms, singular_rows, task_factorisation
from .joint_limits import JointLimits
from .programs import _EXIT_INFEASIBLE, BOUND_MARGIN, _MinMax, _Program, _RangeBasis

__all__ = ["INFEASIBLE_OPTION", "INFEASIBLE_POLICIES", "torque_utilisation"]

#: ``raised`` value of a program's rows on q̈ that gives up the resolver's own rows.
_DROPPED = "dropped"
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


def _bounded_joints(robot: Robot):
    """The joints with finite limits: their indices, or ``slice(None)`` (a view, no copy) when every joint has them."""
    finite = np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)
    return slice(None) if finite.all() else np.flatnonzero(finite)


def _solver_bounds(robot: Robot, bounded):
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


def _box(robot: Robot):
    """(τ⁺, τ⁻) of every joint as the solver sees them (pulled in by :data:`BOUND_MARGIN`; ±inf when unbounded)."""
    spread = robot.torque_upper - robot.torque_lower
    margin = np.where(np.isfinite(spread), BOUND_MARGIN * spread, 0.0)
    return robot.torque_upper - margin, robot.torque_lower + margin


def _least_within_box(rows, inertia, bias_torque, box_upper, box_lower):
    r"""The least value of each row of :math:`G\ddot q = G H^{-1}(\tau - b)` over the torques in the box.

    Per row, with :math:`g = H^{-1}G^\top`: :math:`\sum_i \min(g_i\tau^+_i, g_i\tau^-_i) - g^\top b`,
    the tip left free (−inf when a joint without limits moves the row).
    """
    weights = np.linalg.solve(inertia, rows.T)  # H⁻¹ Gᵀ, n × k
    with np.errstate(invalid="ignore"):
        ends = np.minimum(weights * box_upper[:, None], weights * box_lower[:, None])
    ends = np.where(weights == 0.0, 0.0, ends)
    return ends.sum(axis=0) - bias_torque.dot(weights)


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
        """The step ``(terms, ẍ) -> Resolution`` on ``robot``, with its DAQP programs set up once.

        ``dt`` [s] is the step over which the run holds the torque: the
        joint-limit bounds keep the state after it within the limits
        (:data:`~torqueopt.resolvers.bounded.joint_limits.DEFAULT_STEP` when None).
        """
        self.check(robot)
        n, m = robot.nv, robot.m
        r = n - m
        bounded = _bounded_joints(robot)
        upper, lower, spread = _solver_bounds(robot, bounded)
        midpoint = torque_midpoint(robot)
        decompose = JacobianSolver(m, n, self.singular_tolerance)
        limits = self.joint_limits_of(robot, dt)
        # The resolver's own constraints G q̈ <= h beside the joint limits (energy-bounded-torque's barrier).
        own_count, constraints_at, constraint_names = self._acceleration_constraints(robot)
        nl = (0 if limits is None else limits.count) + own_count
        optimum = self._optimum(robot, bounded, spread, midpoint, nl)
        nb = spread.size
        box_upper, box_lower = _box(robot)
        # Largest scaling: max s over (s, y), 0 <= s <= 1 a simple bound on the first variable.
        rows_count = nb + nl
        scaling = _Program(
            np.zeros((1 + r, 1 + r)),
            np.r_[-1.0, np.zeros(r)],
            np.zeros((rows_count, 1 + r)),
            np.r_[1.0, np.ones(rows_count)],
            np.r_[0.0, -np.ones(rows_count)],
            bounds=1,
            linear=True,
        )

        # Least task error: min ½‖a − ẍ‖² over (a, y). Its Hessian is singular in y, as an
        # LP's (a zero matrix) is everywhere: DAQP then runs proximal-point iterations, whose
        # limit is an exact optimum.
        def least_error_program(count):
            return _Program(
                np.diag(np.r_[np.ones(m), np.zeros(r)]),
                np.zeros(n),
                np.zeros((count, n)),
                np.ones(count),
                -np.ones(count),
            )

        least_error = least_error_program(rows_count)
        # With joint limits, torque and joint bounds may leave no q̈ at all: then the torque bounds alone.
        torque_least_error = least_error_program(nb) if nl else least_error
        # The least excess of the joint limits' rows a torque within bounds allows: min Σ tᵢ over (t, a, z),
        # t >= 0 simple bounds, row i within its bounds widened by tᵢ (in units of its joint's ā).
        nj = 0 if limits is None else limits.count
        excess_program = (
            _Program(
                np.zeros((nj + n, nj + n)),
                np.r_[np.ones(nj), np.zeros(n)],
                np.zeros((nb + 2 * nj, nj + n)),
                np.r_[np.full(nj, np.inf), np.ones(nb + 2 * nj)],
                np.r_[np.zeros(nj), -np.ones(nb + 2 * nj)],
                bounds=nj,
                linear=True,
            )
            if nj
            else None
        )
        minmax = _MinMax(bounded, spread, midpoint, r, own_count) if self.infeasible == "exceed" else None
        range_basis = _RangeBasis(n, r)
        policy = self.infeasible
        name = self.name
        joint_names = robot.joint_names

        def least_joint_excess(torque_rows, torque_upper, torque_lower, joint_part):
            """(t, (a, z)): the least widenings t >= 0 (Σ t least, one per row) of the joint limits' rows
            (``joint_part``: rows, upper, lower on x = (a, z), divided by ā) that leave a torque within bounds, and
            a point x there; None when DAQP finds none."""
            rows, upper, lower = joint_part
            finite_upper, finite_lower = np.isfinite(upper), np.isfinite(lower)
            # Each row twice, one side each (a row with no finite side holds whatever x: zeros within ±1).
            slack = np.eye(nj)
            above = np.hstack([-slack * finite_upper, np.where(finite_upper[:, None], rows, 0.0)])
            below = np.hstack([slack * finite_lower, np.where(finite_lower[:, None], rows, 0.0)])
            program_rows = np.vstack([np.hstack([np.zeros((nb, nj)), torque_rows]), above, below])
            program_upper = np.r_[
                np.full(nj, np.inf), torque_upper, np.where(finite_upper, upper, 1.0), np.full(nj, np.inf)
            ]
            program_lower = np.r_[np.zeros(nj), torque_lower, np.full(nj, -np.inf), np.where(finite_lower, lower, -1.0)]
            x, flag, _ = excess_program.solve(A=program_rows, bupper=program_upper, blower=program_lower)
            if flag == _EXIT_INFEASIBLE:  # pragma: no cover - H is invertible: the box holds some torque
                return None
            return np.maximum(x[:nj], 0.0), (x[nj : nj + m], x[nj + m :])

        def least_error_task(rows, row_upper, row_lower, command, program=least_error):
            """(a, z) of min ½‖a − ẍ‖² with τ = (rest) + H J⁺ a + U z within bounds, or None when there is none."""
            x, flag, _ = program.solve(f=np.r_[-command, np.zeros(r)], A=rows, bupper=row_upper, blower=row_lower)
            if flag == _EXIT_INFEASIBLE:
                return None
            return x[:m], x[m:]

        def torque_bounds_active(torque):
            """The torque bounds ``torque`` lies on, as texts."""
            found = []
            joints = np.arange(n)[bounded]
            for side, bound in (("upper", robot.torque_upper), ("lower", robot.torque_lower)):
                on = np.abs(torque[bounded] - bound[bounded]) <= 1e-6 * spread
                found.extend(f"torque limit ({side}) of joint {joint_names[joints[row]]}" for row in np.flatnonzero(on))
            return found

        def step(terms: TaskTerms, task_acceleration: np.ndarray) -> Resolution:
            command = task_acceleration
            particular, basis, inverse_condition = decompose(terms.jacobian, command - terms.drift)
            inertia = terms.inertia
            inertia_basis = inertia.dot(basis)
            tilde_torque = inertia.dot(particular) + terms.bias_torque  # Eq. (28)
            joint_rows = joint_bounds = constraints = None
            if limits is not None:
                joint_bounds = limits(terms)
                joint_scale = limits.scale(joint_bounds)
                joints = limits.joints
            if constraints_at is not None:
                constraints = constraints_at(terms, basis)  # (G, h): G q̈ <= h, unit rows
            if nl:

                def joint_rows(offset, rows, raised=None, free_joints=False, widen=0.0):
                    """Rows and bounds of the joint limits on q̈ = offset + rows · x, each divided by its ā (and
                    widened by ``widen`` on both sides), then the resolver's own rows G q̈ <= h (h raised to
                    ``raised`` where that is higher); with ``free_joints`` the joint limits' rows hold whatever x
                    (the joint limits given up)."""
                    parts = []
                    if limits is not None and free_joints:
                        parts.append(
                            (np.zeros((joints.size, rows.shape[1])), np.ones(joints.size), -np.ones(joints.size))
                        )
                    elif limits is not None:
                        parts.append(
                            (
                                rows[joints] / joint_scale[:, None],
                                (joint_bounds.upper - offset[joints]) / joint_scale + widen,
                                (joint_bounds.lower - offset[joints]) / joint_scale - widen,
                            )
                        )
                    if constraints is not None and raised is _DROPPED:
                        # Rows that hold whatever x (DAQP needs a finite bound on a general row).
                        parts.append((np.zeros((own_count, rows.shape[1])), np.ones(own_count), -np.ones(own_count)))
                    elif constraints is not None:
                        own_rows, own_upper = constraints
                        if raised is not None:
                            own_upper = np.maximum(own_upper, raised)
                        parts.append(
                            (own_rows.dot(rows), own_upper - own_rows.dot(offset), np.full(own_count, -np.inf))
                        )
                    if len(parts) == 1:
                        return parts[0]
                    return tuple(np.concatenate(part) for part in zip(*parts))

            found = optimum(terms, basis, inertia_basis, tilde_torque, particular, joint_rows)
            if found is not None:
                y, torque = found
                return Resolution(torque, particular + basis.dot(y), inverse_condition, 0.0, False)  # Eq. (26)
            if policy == "stop":
                raise TorqueBoundsInfeasible(
                    f"resolver '{name}' (infeasible='stop'): no torque within bounds realises the task "
                    f"acceleration {np.round(command, 6).tolist()}"
                    + (" within the joint limits" if limits is not None else "")
                    + (f" within its {', '.join(constraint_names)}" if constraints is not None else "")
                )
            range_rows = range_basis(inertia_basis)  # U, orthonormal, spans the range of HZ
            if policy == "exceed":
                # The task kept, and the resolver's own rows (always feasible with the torques free); not the joint limits.
                own = None
                if constraints is not None:
                    own_rows, own_upper = constraints
                    own = (
                        own_rows.dot(np.linalg.solve(inertia, range_rows)),  # q̈ = p + H⁻¹U z
                        own_upper - own_rows.dot(particular),
                        np.full(own_count, -np.inf),
                    )
                z, utilisation = minmax(range_rows, tilde_torque, own)
                if utilisation is None:  # pragma: no cover - the barrier alone is always feasible
                    z, _ = minmax(range_rows, tilde_torque)
                y = range_basis.coordinates(range_rows.dot(z))
                torque = tilde_torque + inertia_basis.dot(y)  # Eq. (27)
                acceleration = particular + basis.dot(y)
                return Resolution(
                    torque,
                    acceleration,
                    inverse_condition,
                    0.0,
                    True,
                    limiting_bounds(torque, acceleration, joint_bounds, constraints),
                )
            # τ = rest + H J⁺ a + U z realises the task acceleration a (J q̈ + J̇q̇ = a).
            pseudo_inverse = np.linalg.pinv(terms.jacobian)
            task_torque = inertia.dot(pseudo_inverse)  # H J⁺, n × m
            rest_torque = tilde_torque - task_torque.dot(command)  # b − H J⁺ J̇q̇
            rows = np.hstack([task_torque, range_rows])[bounded] / spread[:, None]
            row_upper = (upper - rest_torque[bounded]) / spread
            row_lower = (lower - rest_torque[bounded]) / spread
            torque_rows, torque_upper_rows, torque_lower_rows = rows, row_upper, row_lower
            if joint_rows is not None:
                # q̈ = H⁻¹(τ − b) = (p − J⁺ẍ) + J⁺ a + H⁻¹U z.
                acceleration_offset = particular - pseudo_inverse.dot(command)
                acceleration_coordinates = np.hstack([pseudo_inverse, np.linalg.solve(inertia, range_rows)])
                acceleration_rows, acceleration_upper, acceleration_lower = joint_rows(
                    acceleration_offset, acceleration_coordinates
                )
                rows = np.vstack([rows, acceleration_rows])
                row_upper = np.r_[row_upper, acceleration_upper]
                row_lower = np.r_[row_lower, acceleration_lower]
            found_task = None
            if policy == "scale":
                # Flacco, De Luca & Khatib (ICRA 2012): the largest s in [0, 1] with a torque within bounds.
                scaled_rows = np.hstack([rows[:, :m].dot(command)[:, None], rows[:, m:]])
                x, flag, _ = scaling.solve(A=scaled_rows, bupper=np.r_[1.0, row_upper], blower=np.r_[0.0, row_lower])
                if flag != _EXIT_INFEASIBLE:
                    found_task = float(np.clip(x[0], 0.0, 1.0)) * command, x[1:]
            # Not even s = 0 (the tip held on its path) has a torque within bounds, or the policy
            # asks for it: give up the direction too, for the least task error.
            if found_task is None:
                found_task = least_error_task(rows, row_upper, row_lower, command)
            within_joint_limits = True
            widened = 0.0  # by how much (in units of each joint's ā) each joint limits' row was widened

            def least_excess():
                """The least widening of the joint limits' rows a torque within bounds allows (a hair more)."""
                joint_part = (
                    acceleration_coordinates[joints] / joint_scale[:, None],
                    (joint_bounds.upper - acceleration_offset[joints]) / joint_scale,
                    (joint_bounds.lower - acceleration_offset[joints]) / joint_scale,
                )
                least = least_joint_excess(torque_rows, torque_upper_rows, torque_lower_rows, joint_part)
                if least is None:  # pragma: no cover - H is invertible: the box holds some torque
                    return None, None
                widen, point = least
                if widen.max() <= 1e-9:
                    # Within the joint limits after all (DAQP's least-error program called them infeasible).
                    return np.zeros_like(widen), point
                return widen * (1.0 + 1e-3) + 1e-6, point

            if found_task is None and constraints is not None:
                # The resolver's own rows yield first: each raised to the least value a torque within
                # bounds gives it, the tip left free (the barrier: energy out as fast as the bounds allow).
                least = _least_within_box(constraints[0], inertia, terms.bias_torque, box_upper, box_lower)
                least_raised = least + 1e-9 * (1.0 + np.abs(least))
                stages = [(least_raised, False, 0.0)]
                if limits is not None:
                    # The joint limits kept, the resolver's own rows given up; then the joint limits widened
                    # least for the torque limits, and the resolver's own rows back, raised; then the joint
                    # limits given up (always feasible: the least over the box).
                    stages += [(_DROPPED, False, 0.0), (least_raised, False, None), (least_raised, True, 0.0)]
                all_rows = joint_rows
                for raised, free_joints, widen in stages:
                    if widen is None:
                        widen, _ = least_excess()
                        if widen is None:  # pragma: no cover - H is invertible: the box holds some torque
                            continue
                    joint_rows = partial(all_rows, raised=raised, free_joints=free_joints, widen=widen)
                    acceleration_rows, acceleration_upper, acceleration_lower = joint_rows(
                        acceleration_offset, acceleration_coordinates
                    )
                    rows = np.vstack([rows[:nb], acceleration_rows])
                    row_upper = np.r_[row_upper[:nb], acceleration_upper]
                    row_lower = np.r_[row_lower[:nb], acceleration_lower]
                    found_task = least_error_task(rows, row_upper, row_lower, command)
                    if found_task is not None:
                        within_joint_limits = not free_joints and not np.any(widen)
                        widened = widen
                        break
            elif found_task is None and limits is not None:
                # No q̈ within the joint limits has a torque within bounds: the joint limits widened least
                # (every row by the same multiple of its joint's ā), for the least task error within them.
                widen, point = least_excess()
                if widen is not None:
                    joint_rows = partial(joint_rows, widen=widen)
                    acceleration_rows, acceleration_upper, acceleration_lower = joint_rows(
                        acceleration_offset, acceleration_coordinates
                    )
                    found_task = least_error_task(
                        np.vstack([torque_rows, acceleration_rows]),
                        np.r_[torque_upper_rows, acceleration_upper],
                        np.r_[torque_lower_rows, acceleration_lower],
                        command,
                    )
                    if found_task is None:
                        # DAQP's warm-started least-error program can call a feasible set infeasible (its
                        # proximal iterations; measured on baxter, where HiGHS and a cold start solve it): the
                        # LP's own point.
                        found_task = point
                    within_joint_limits, widened = not np.any(widen), widen
            # The rows the resolver's own optimum below keeps: none when the torque bounds alone are left.
            final_rows = joint_rows
            if found_task is None:
                within_joint_limits = joint_rows is None
                final_rows = None
                widened = 0.0
                # No q̈ within the joint limits has a torque within bounds: the torque bounds win.
                found_task = least_error_task(
                    torque_rows, torque_upper_rows, torque_lower_rows, command, program=torque_least_error
                )
            if found_task is None:  # pragma: no cover - H is invertible: every torque in the box is some (a, z)
                raise SolverFailure(f"resolver '{name}': DAQP found no torque in the box for the least task error")
            achieved, z = found_task
            # The resolver's own optimum at the achievable task acceleration; on the boundary
            # round-off may make that program infeasible, and then the first stage's z stands.
            shifted_particular = particular + pseudo_inverse.dot(achieved - command)
            shifted_tilde = rest_torque + task_torque.dot(achieved)
            found = optimum(
                terms,
                basis,
                inertia_basis,
                shifted_tilde,
                shifted_particular,
                final_rows,
            )
            if found is None:
                y = range_basis.coordinates(range_rows.dot(z))
                found = y, shifted_tilde + inertia_basis.dot(y)
            y, torque = found
            error = float(np.linalg.norm(achieved - command))
            acceleration = shifted_particular + basis.dot(y)
            limiting = limiting_bounds(torque, acceleration, joint_bounds, constraints)
            if np.any(widened):
                exceeded = "; ".join(limits.exceeded(joint_bounds, acceleration)) or "none beyond 1e-6 of ā"
                limiting = f"joint limits exceeded least for the torque limits ({exceeded}); " + limiting
            elif not within_joint_limits:
                exceeded = "; ".join(limits.exceeded(joint_bounds, acceleration)) if limits is not None else ""
                limiting = (
                    "joint limits given up for the torque limits" + (f" ({exceeded})" if exceeded else "") + "; "
                ) + limiting
            return Resolution(torque, acceleration, inverse_condition, error, True, limiting)

        def limiting_bounds(torque, acceleration, joint_bounds, constraints):
            """The bounds the answer of an infeasible step lies on, in one line."""
            found = torque_bounds_active(torque)
            if joint_bounds is not None:
                found += limits.active(joint_bounds, acceleration)
            if constraints is not None:
                own_rows, own_upper = constraints
                slack = own_upper - own_rows.dot(acceleration)
                found += [constraint_names[row] for row in np.flatnonzero(np.abs(slack) <= 1e-6)]
            return "; ".join(found) if found else "no bound within 1e-6 of its range"

        return step

    def _acceleration_constraints(self, robot: Robot):
        """``(k, function, names)``: this resolver's own k constraints G q̈ <= h on the joint acceleration, beside
        the torque bounds and the joint limits, as a function ``(terms, Z) -> (G (k × n), h (k))`` with unit rows,
        and a name for each; ``(0, None, ())`` when it has none."""
        return 0, None, ()

    def _optimum(self, robot: Robot, bounded, spread, midpoint, joint_rows_count: int):
        """``(terms, Z, HZ, τ̃, p, joint_rows) -> (y, τ)`` of this resolver's criterion with τ within bounds and
        q̈ = p + Z y within the rows on q̈ (``joint_rows(offset, rows)``, None: none), or None when none is."""
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
                task_error[rows], infeasible[rows] = resolution.task_error, resolution.infeasible
                conditions[rows] = resolution.jacobian_inverse_condition
                for index, text in resolution.failures.items():
                    failures[int(rows[index])] = text
                for index, text in resolution.limiting.items():
                    limiting[int(rows[index])] = text
        return StackResolution(torque, acceleration, conditions, task_error, infeasible, failures, limiting, basis)
