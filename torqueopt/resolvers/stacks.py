r"""A resolver's step on stacks of B states: the contract, the default loop, and the stacked factorisations.

:meth:`Resolver.batch_solver <torqueopt.resolvers.base.Resolver.batch_solver>`
returns a :data:`StackStep`,

.. math::

    (\text{StackTerms}, \ddot x_{1..B}, \text{movements}) \mapsto \text{StackResolution},

the resolver's :meth:`~torqueopt.resolvers.base.Resolver.solver` on (B, ...)
stacks. ``movements`` names the movement of each row (rows leave the batch
as their movements stop), so a resolver whose step keeps state from one step
to the next (a warm-started program, a look-ahead) keeps it per movement.

:func:`looped_stack_step` is the default: the single-state step, one step
function per movement, row by row, so every registered resolver runs on
stacks. A resolver with a vectorised step overrides ``batch_solver`` beside
its single-state step (the paper's resolvers and the remedies, with the
factorisations :func:`complete_qr` and :func:`two_row_qr` here); the tests
hold each to its own single-state step through ``simulate``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..errors import SingularJacobian, SolverFailure, TorqueBoundsInfeasible
from ..linalg import inverse_condition_number, inverse_condition_number_of, singular_message
from ..robot import Robot, TaskTerms
from ..robot_copies import stacked_cross

__all__ = [
    "HouseholderStack",
    "LoopedStackStep",
    "StackResolution",
    "StackStep",
    "StackTerms",
    "complete_qr",
    "complete_qr_by_lapack",
    "least_squares",
    "least_squares_by_svd",
    "looped_stack_step",
    "singular_rows",
    "two_row_qr",
]

#: What ends a movement when its resolver cannot resolve its state (the run keeps what it computed).
STOPPING_ERRORS = (SingularJacobian, TorqueBoundsInfeasible, SolverFailure)


class StackTerms(NamedTuple):
    r"""The task terms of B states, as :class:`~torqueopt.robot.TaskTerms` per row (no placement).

    Attributes:
        inertia: (B, n, n) :math:`H` [kg·m²]; bias_torque: (B, n) :math:`b` [N·m];
        jacobian: (B, m, n) :math:`J`; drift: (B, m) :math:`\dot J\dot q` [m/s²];
        joint_velocity: (B, n) :math:`\dot q` [rad/s]; configuration: (B, nq) q.
    """

    inertia: np.ndarray
    bias_torque: np.ndarray
    jacobian: np.ndarray
    drift: np.ndarray
    joint_velocity: np.ndarray
    configuration: np.ndarray

    def row(self, index: int) -> TaskTerms:
        """Row ``index`` as the single-state :class:`TaskTerms` (placement None: the stacks carry positions only).

        H is symmetric, so its transpose is H laid out column-major, as
        Pinocchio's data holds it: a single-state step then makes the same
        BLAS calls as inside ``simulate``, and gives the same numbers bit for bit.
        """
        return TaskTerms(
            self.inertia[index].T,
            self.bias_torque[index],
            self.jacobian[index],
            self.drift[index],
            None,
            self.joint_velocity[index],
            self.configuration[index],
        )


class StackResolution(NamedTuple):
    """What a resolver's step on stacks gives, per row (the fields of :class:`Resolution` stacked).

    Attributes:
        torque, joint_acceleration: (B, n) [N·m], [rad/s²]; unused where the row failed.
        jacobian_inverse_condition: (B,) σmin/σmax of each task Jacobian.
        task_error: (B,) the task acceleration given up (0 where realised), or None for all 0.
        infeasible: (B,) bool, or None for all False.
        failures: {row: why the resolver could not resolve it} (a singular Jacobian, an
            infeasible program); such a row's movement stops there.
        limiting: {row: the bounds an infeasible row's answer lay on}.
        basis: (B, n, n − m) an orthonormal null-space basis per row when the step has one, else None.
    """

    torque: np.ndarray
    joint_acceleration: np.ndarray
    jacobian_inverse_condition: np.ndarray
    task_error: np.ndarray | None = None
    infeasible: np.ndarray | None = None
    failures: dict | None = None
    limiting: dict | None = None
    basis: np.ndarray | None = None


#: A robot-bound step on stacks: ``(terms, task_accelerations, movements) -> StackResolution``.
StackStep = Callable[[StackTerms, np.ndarray, np.ndarray], StackResolution]


def singular_rows(inverse_conditions: np.ndarray, tolerance: float) -> dict:
    """{row: the singular-Jacobian message} for the rows whose σmin/σmax is below ``tolerance`` (or NaN)."""
    singular = ~(inverse_conditions >= tolerance)
    if not singular.any():
        return {}
    return {row: singular_message(inverse_conditions[row], tolerance) for row in np.flatnonzero(singular).tolist()}


class LoopedStackStep:
    """The default step on stacks: a resolver's single-state step (``solver_for_run``) row by row.

    One single-state step function per movement, made when the movement
    first comes, so a step that keeps state between calls keeps each
    movement's own. A row whose step raises one of ``STOPPING_ERRORS``
    is a failure (its message kept); its σmin/σmax comes from the SVD.
    Such a step gains nothing from stacked terms, so the batch gives it the
    single-state terms and RK4 of ``simulate``, row by row: its runs equal
    ``simulate``'s bit for bit.
    """

    def __init__(self, resolver, robot: Robot, dt: float | None = None):
        self.resolver, self.robot, self.dt = resolver, robot, dt
        self._steps: dict[int, Callable] = {}
        self.trajectories = None
        self._not_applied = np.full(robot.nv, np.nan)

    def along(self, trajectories) -> None:
        """Give each movement its path (anchored), by movement index: a step that plans ahead follows it
        (:meth:`Resolver.solver_for_movement <torqueopt.resolvers.base.Resolver.solver_for_movement>`)."""
        self.trajectories = list(trajectories)

    def _make_step(self, movement: int):
        resolver, robot = self.resolver, self.robot
        if self.dt is None:
            return resolver.solver(robot)
        if self.trajectories is not None:
            return resolver.solver_for_movement(robot, self.dt, self.trajectories[movement])
        return resolver.solver_for_run(robot, self.dt)

    def __call__(self, terms, task_accelerations: np.ndarray, movements: np.ndarray) -> StackResolution:
        """The step of each row of ``terms`` (a :class:`StackTerms`, or :class:`~torqueopt.terms.TermRows`).

        ``task_error`` and ``infeasible`` are None when every row realised its task; the rows of a stack of one are
        views of the step's own arrays (no copy per step).
        """
        torques, accelerations, conditions = [], [], []
        failures, limiting, shortfalls = {}, {}, {}
        steps = self._steps
        for row, movement in enumerate(movements.tolist()):
            solve = steps.get(movement)
            if solve is None:
                solve = steps[movement] = self._make_step(movement)
            state = terms.row(row)
            try:
                resolution = solve(state, task_accelerations[row])
            except STOPPING_ERRORS as error:
                failures[row] = str(error)
                torques.append(self._not_applied)
                accelerations.append(self._not_applied)
                conditions.append(inverse_condition_number(state.jacobian))
                continue
            torques.append(resolution.torque)
            accelerations.append(resolution.joint_acceleration)
            conditions.append(resolution.jacobian_inverse_condition)
            if resolution.task_error or resolution.infeasible:
                shortfalls[row] = resolution.task_error, resolution.infeasible
            if resolution.limiting:
                limiting[row] = resolution.limiting
        task_error = infeasible = None
        if shortfalls:
            task_error, infeasible = np.zeros(len(torques)), np.zeros(len(torques), dtype=bool)
            for row, (error, flag) in shortfalls.items():
                task_error[row], infeasible[row] = error, flag
        return StackResolution(
            _stacked(torques, self.robot.nv),
            _stacked(accelerations, self.robot.nv),
            np.array(conditions),
            task_error,
            infeasible,
            failures,
            limiting,
        )

    def stack_of_one(self) -> StackStep:
        """This step on a stack of one held as its row (what ``simulate`` steps), as a bare function
        ``(TaskTerms, ẍ (m,), movements) -> StackResolution`` of the row: (n,) torque and q̈, a float σmin/σmax."""
        solve = self._make_step(0)
        not_applied = self._not_applied

        def step(terms, task_acceleration: np.ndarray, movements=None) -> StackResolution:
            try:
                resolution = solve(terms, task_acceleration)
            except STOPPING_ERRORS as error:
                condition = inverse_condition_number(terms.jacobian)
                return StackResolution(not_applied, not_applied, condition, None, None, {0: str(error)}, None)
            task_error, infeasible = resolution.task_error, resolution.infeasible
            shortfall = task_error or infeasible
            return StackResolution(
                resolution.torque,
                resolution.joint_acceleration,
                resolution.jacobian_inverse_condition,
                np.array([task_error]) if shortfall else None,
                np.array([infeasible]) if shortfall else None,
                None,
                {0: resolution.limiting} if resolution.limiting else None,
            )

        return step


def _stacked(rows: list, n: int) -> np.ndarray:
    """The (B, n) stack of ``rows``."""
    return np.array(rows).reshape(len(rows), n)


def looped_stack_step(resolver, robot: Robot, dt: float | None = None) -> StackStep:
    """The default step on stacks, :class:`LoopedStackStep`: the single-state step row by row, one per movement."""
    return LoopedStackStep(resolver, robot, dt)


class HouseholderStack:
    r"""The Householder QR of every matrix of a (B, r, c) stack (r ≥ c), on the batch axis: c reflections,
    each a few numpy operations on the whole stack, instead of one LAPACK call per row.

    Column k's reflection :math:`P_k = I - 2 v_k v_k^\top` (:math:`\|v_k\| = 1`, acting on rows k..r−1)
    maps what is left of column k to :math:`\alpha_k e_k`, :math:`|\alpha_k|` its norm, with the sign
    that avoids cancellation (LAPACK's ``dgeqrf`` makes the same choice); so
    :math:`A = QR` with :math:`Q = P_0 P_1 \cdots P_{c-1}` orthogonal and R upper
    triangular. A zero column leaves its reflection the identity. Equal to
    numpy's ``qr`` to round-off (tests), and backward stable as it is.

    The work is laid out batch-last, (r, c, B), so that numpy's inner loops
    run over the B rows, not over c or r (a handful of entries each, where
    numpy's per-loop overhead would dominate): ``upper`` is R as (c, c, B), the
    vectors the methods take and give are (r, B) or (r, k, B).
    """

    __slots__ = ("reflectors", "upper")

    def __init__(self, matrix: np.ndarray):
        work = np.ascontiguousarray(matrix.transpose(1, 2, 0), dtype=float)  # (r, c, B), a copy reduced in place
        columns = work.shape[1]
        self.reflectors = []
        for k in range(columns):
            x = work[k:, k]
            norm = np.sqrt((x * x).sum(axis=0))
            lead = x[0]
            alpha = np.where(lead >= 0.0, -norm, norm)
            v = x.copy()
            v[0] -= alpha
            # ‖x − αe₁‖² = 2‖x‖(‖x‖ + |x₀|), without cancellation
            length = np.sqrt(2.0 * norm * (norm + np.abs(lead)))
            v /= np.where(length > 0.0, length, 1.0)
            if k + 1 < columns:
                rest = work[k:, k + 1 :]
                rest -= (2.0 * v)[:, None] * (v[:, None] * rest).sum(axis=0)
            work[k, k] = alpha
            work[k + 1 :, k] = 0.0  # what the reflection left below the diagonal: R is the top c rows
            self.reflectors.append(v)
        self.upper = work[:columns]

    def apply_transpose(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`Q^\top b` for (r, B) ``vector`` (a new array)."""
        out = np.array(vector, dtype=float)
        for k, v in enumerate(self.reflectors):
            part = out[k:]
            part -= (2.0 * (v * part).sum(axis=0)) * v
        return out

    def apply(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`Q b` for (r, B) ``vector``, or for the columns of an (r, k, B) stack (a new array)."""
        out = np.array(vector, dtype=float)
        for k in range(len(self.reflectors) - 1, -1, -1):
            v, part = self.reflectors[k], out[k:]
            if part.ndim == 2:
                part -= (2.0 * (v * part).sum(axis=0)) * v
            else:
                part -= (2.0 * v)[:, None] * (v[:, None] * part).sum(axis=0)
        return out

    def trailing_columns(self) -> np.ndarray:
        r"""The last r − c columns of Q, (r, r − c, B): an orthonormal basis of what the columns of A do not span."""
        rows, count = self.reflectors[0].shape
        columns = len(self.reflectors)
        unit = np.zeros((rows, rows - columns, count))
        unit[columns:] = np.eye(rows - columns)[:, :, None]
        return self.apply(unit)


def upper_solve(upper: np.ndarray, rhs: np.ndarray, transpose: bool = False) -> np.ndarray:
    r"""x with :math:`Rx = b` (or :math:`R^\top x = b`) for (c, c, B) upper-triangular R and (c, B) b, batch-last,
    by substitution on the batch axis; R's diagonal must have no zero (the callers guard it)."""
    size = rhs.shape[0]
    x = np.empty(rhs.shape)
    for i in range(size) if transpose else range(size - 1, -1, -1):
        if transpose:  # row i of Rᵀ: R[:i, i] · x[:i] + R[i, i] x[i]
            known = (upper[:i, i] * x[:i]).sum(axis=0) if i else 0.0
        else:
            known = (upper[i, i + 1 :] * x[i + 1 :]).sum(axis=0) if i + 1 < size else 0.0
        x[i] = (rhs[i] - known) / upper[i, i]
    return x


def complete_qr(J: np.ndarray, residual: np.ndarray, redundant: bool):
    r"""``(J⁺r, Z, σ_min/σ_max)`` per row of a (B, m, n) stack, from the complete QR of :math:`J^\top`.

    :math:`J^\top = QR` (:class:`HouseholderStack`, on the batch axis): the first m
    columns of Q span the row space of J, the rest (Z, orthonormal) its null
    space, and :math:`J^\dagger r = Q_m R^{-\top} r` is the minimum-norm
    solution of :math:`J\ddot q = r`. The inverse condition comes from the
    eigenvalues of the m×m :math:`JJ^\top` (σ² of J), half the cost of an SVD of R
    per row; squaring costs accuracy, a relative error of about
    :math:`\varepsilon/(\sigma_{min}/\sigma_{max})^2` (2e-4 at the cutoff 1e-6, which it only has to decide).
    Rows with a singular J get a finite, unused answer. :func:`complete_qr_by_lapack` is the
    same by numpy's LAPACK calls per row, the reference the tests hold it to.
    """
    m = J.shape[1]
    squared = np.linalg.eigvalsh(J @ np.swapaxes(J, 1, 2))  # σ² of J, smallest first
    conditions = inverse_condition_number_of(np.sqrt(np.maximum(squared[:, ::-1], 0.0)))
    factor = HouseholderStack(np.swapaxes(J, 1, 2))
    upper = factor.upper
    singular = conditions < 1e-12
    if singular.any():
        upper = np.where(singular, np.eye(m)[:, :, None], upper)
    coordinates = np.zeros((J.shape[2], J.shape[0]))
    coordinates[:m] = upper_solve(upper, residual.T, transpose=True)
    particular = factor.apply(coordinates).T  # Q [R⁻ᵀr; 0]
    return particular, factor.trailing_columns().transpose(2, 0, 1) if redundant else None, conditions


def complete_qr_by_lapack(J: np.ndarray, residual: np.ndarray, redundant: bool):
    r""":func:`complete_qr` by numpy's ``qr`` (LAPACK per row) and σ² from the eigenvalues of :math:`JJ^\top`: the
    readable reference of the batch's factorisation."""
    m = J.shape[1]
    squared = np.linalg.eigvalsh(J @ np.swapaxes(J, 1, 2))  # σ² of J, smallest first
    conditions = inverse_condition_number_of(np.sqrt(np.maximum(squared[:, ::-1], 0.0)))
    orthogonal, triangular = np.linalg.qr(np.swapaxes(J, 1, 2), mode="complete")
    upper = triangular[:, :m, :]
    upper = np.where((conditions < 1e-12)[:, None, None], np.eye(m), upper)
    particular = np.einsum(
        "bij,bj->bi", orthogonal[:, :, :m], np.linalg.solve(np.swapaxes(upper, 1, 2), residual[..., None])[..., 0]
    )
    return particular, orthogonal[:, :, m:] if redundant else None, conditions


def two_row_qr(J: np.ndarray, residual: np.ndarray, redundant: bool):
    r""":func:`complete_qr` for two-row Jacobians of two or three joints (the planar arm's xy task), in closed form.

    Gram-Schmidt with one re-orthogonalisation gives the row-space basis
    :math:`q_1, q_2` and :math:`R = \begin{pmatrix} r_{11} & r_{12}\\ 0 & r_{22}\end{pmatrix}`
    (:math:`J^\top = [q_1\ q_2] R`) to working accuracy; :math:`J^\dagger r = q_1 y_1 + q_2 y_2`
    with :math:`R^\top y = r`; for three joints the null space is spanned by
    :math:`z = q_1\times q_2`. The singular values of R are those of J:
    :math:`\sigma_{max}^2 = (s + \sqrt{s^2 - 4d^2})/2` with
    :math:`s = \|R\|_F^2`, :math:`d = r_{11}r_{22}`, and :math:`\sigma_{min} = d/\sigma_{max}`.
    Equal to the QR path to round-off, without a LAPACK call per row.
    """
    first, second = J[:, 0], J[:, 1]
    r11 = np.sqrt(np.einsum("bi,bi->b", first, first))
    safe11 = np.where(r11 > 0.0, r11, 1.0)
    q1 = first / safe11[:, None]
    r12 = np.einsum("bi,bi->b", q1, second)
    u = second - r12[:, None] * q1
    u -= np.einsum("bi,bi->b", q1, u)[:, None] * q1  # twice is enough: orthogonal to working accuracy
    r22 = np.sqrt(np.einsum("bi,bi->b", u, u))
    safe22 = np.where(r22 > 0.0, r22, 1.0)
    q2 = u / safe22[:, None]
    y1 = residual[:, 0] / safe11
    y2 = (residual[:, 1] - r12 * y1) / safe22
    particular = q1 * y1[:, None] + q2 * y2[:, None]
    frobenius = r11 * r11 + r12 * r12 + r22 * r22
    determinant = r11 * r22
    # σ_min/σ_max = d/σ_max² = 2d / (s + √(s² − 4d²)); 0 for a zero J (s = 0).
    denominator = frobenius + np.sqrt(np.maximum(frobenius * frobenius - 4.0 * determinant * determinant, 0.0))
    conditions = np.divide(2.0 * determinant, denominator, out=np.zeros_like(denominator), where=denominator > 0.0)
    if not (redundant and J.shape[2] == 3):
        return particular, None, conditions
    basis = stacked_cross(q1, q2)[:, :, None]  # z = q1 × q2, (B, 3, 1), unit: q1 ⊥ q2
    return particular, basis, conditions


def task_factorisation(robot: Robot):
    """The stacked factorisation for ``robot``'s task: :func:`two_row_qr` for two rows on two or three joints, else QR."""
    return two_row_qr if robot.m == 2 and robot.nv in (2, 3) else complete_qr


def least_squares(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    r"""Minimum-norm least squares per row of (B, r, c) stacks, rank cutoff 1e-12 relative (as linalg.LeastSquares).

    One column a: :math:`y = a^\top b / a^\top a` (0 for a zero column). More
    columns (r ≥ c): :math:`y = R^{-1}(Q^\top b)_{1..c}` from the Householder QR
    on the batch axis (:class:`HouseholderStack`), for the rows whose R has
    every :math:`|r_{kk}|` above 1e-8 of the largest (full column rank, far
    above the cutoff); the others, and wide stacks, by :func:`least_squares_by_svd`.
    """
    if matrix.shape[2] == 1:
        # One column a: y = aᵀb / aᵀa, or 0 for a zero column (the minimum-norm answer).
        column = matrix[:, :, 0]
        norm2 = np.einsum("bi,bi->b", column, column)
        safe = np.where(norm2 > 0.0, norm2, 1.0)
        return np.where(norm2 > 0.0, np.einsum("bi,bi->b", column, rhs) / safe, 0.0)[:, None]
    columns = matrix.shape[2]
    if matrix.shape[1] < columns or matrix.shape[0] == 0:
        return least_squares_by_svd(matrix, rhs)
    factor = HouseholderStack(matrix)
    diagonal = np.abs(np.diagonal(factor.upper))  # (B, c)
    full_rank = diagonal.min(axis=1) > 1e-8 * diagonal.max(axis=1)
    upper = factor.upper
    if not full_rank.all():
        upper = np.where(full_rank, upper, np.eye(columns)[:, :, None])
    y = upper_solve(upper, factor.apply_transpose(rhs.T)[:columns]).T
    if not full_rank.all():
        rows = ~full_rank
        y[rows] = least_squares_by_svd(matrix[rows], rhs[rows])
    return y


def least_squares_by_svd(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Minimum-norm least squares per row of (B, r, c) stacks by numpy's SVD, singular values below 1e-12 of the
    largest dropped: the reference of :func:`least_squares`."""
    u, s, vt = np.linalg.svd(matrix, full_matrices=False)
    keep = s > 1e-12 * s[:, :1]
    inverse = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    projected = np.einsum("bji,bj->bi", u, rhs) * inverse
    return np.einsum("bji,bj->bi", vt, projected)
