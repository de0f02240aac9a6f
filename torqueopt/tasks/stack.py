r"""A stack of prioritised tasks (Hanafusa, Yoshikawa & Nakamura, Eq. (7), Eq. (8), Eq. (9), Eq. (10), Eq. (11)).

For a high-priority task :math:`\dot x_h = J_h\dot q` Eq. (7) and a
low-priority one :math:`\dot x_l = J_l \dot q` Eq. (8), the joint rates

.. math::

    \dot q = J_h^\dagger \dot x_h + [J_l(I - J_h^\dagger J_h)]^\dagger
             (\dot x_l - J_l J_h^\dagger \dot x_h) \qquad \text{Eq. (11)}

realise :math:`\dot x_h` exactly and :math:`\dot x_l` as well as the
remaining freedom allows (least squares). Eq. (11) is Eq. (9) with the
null-space vector of Eq. (10); the projector :math:`B = I - J_h^\dagger J_h`
drops out by the identity :math:`B[CB]^\dagger = [CB]^\dagger` (B Hermitian
and idempotent). A deeper stack repeats the step, each task in the null
space of all above it (the recursion of Siciliano & Slotine, 1991):

.. math::

    \dot q_k = \dot q_{k-1} + (J_k P_{k-1})^\dagger(\dot x_k - J_k \dot q_{k-1}),\qquad
    P_k = P_{k-1} - (J_k P_{k-1})^\dagger J_k P_{k-1},

with :math:`\dot q_0 = 0`, :math:`P_0 = I`; for two tasks it is Eq. (11).

Its time derivative along the motion (:func:`~torqueopt.tasks.prioritised_accelerations`)
differentiates each step, the pseudoinverses by :func:`~torqueopt.tasks.pseudoinverse_rate`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import eigenpy
import numpy as np

from ..errors import InvalidInput
from .task import Task, identity

__all__ = [
    "TaskStack",
    "PriorityLevel",
    "priority_levels",
    "rates_through",
    "prioritised_rates",
    "prioritised_accelerations",
    "pseudoinverse",
    "undamped_pseudoinverse",
    "stacked_undamped_pseudoinverse",
    "pseudoinverse_workspace",
    "pseudoinverse_rate",
]


_THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV

#: Singular values below this are round-off whatever the scale (a task point that the null space cannot move).
ABSOLUTE_TOLERANCE = 1e-10


def pseudoinverse(matrix: np.ndarray, tolerance: float = 1e-10, damping: float = 0.0) -> np.ndarray:
    r"""Moore-Penrose pseudoinverse by SVD (Eq. (3) for full row rank), singular values below
    ``tolerance`` × the largest, or below :data:`ABSOLUTE_TOLERANCE`, dropped; with ``damping``
    λ > 0 the kept singular values inverted as damped least squares,
    :math:`\sigma/(\sigma^2 + \lambda^2)` (:math:`A^\top(AA^\top + \lambda^2 I)^{-1}` on the kept subspace).

    The absolute floor matters for projected Jacobians such as :math:`J_o(I - J^\dagger J)`
    of a point the null space cannot move (the tip itself): all their singular values are
    round-off, which a relative cutoff alone would invert. Damping keeps the cutoff rather than
    replacing it: a round-off σ of 1e-16 with λ = 1e-8 would otherwise be inverted to 1, and a tiny
    λ must behave like none.

    The SVD is Eigen's (``HhJacobiSVD`` through eigenpy, as :mod:`torqueopt.linalg`'s solvers), the
    few singular values handled as plain numbers: numpy's ``svd`` and its array arithmetic cost
    several times more on these small matrices."""
    if matrix.size == 0:
        return np.zeros(matrix.T.shape)
    svd = eigenpy.HhJacobiSVD(matrix, _THIN_UV)
    singular = svd.singularValues().reshape(-1).tolist()  # descending (one value comes as a 1×1 matrix)
    cutoff = max(tolerance * singular[0], ABSOLUTE_TOLERANCE)
    inverse_values = [
        (value / (value * value + damping * damping) if damping > 0.0 else 1.0 / value) if value > cutoff else 0.0
        for value in singular
    ]
    rows, columns = matrix.shape
    # eigenpy returns an n×1 factor as a vector: shaped back to (n, k) and (m, k)
    left, right = svd.matrixU().reshape(rows, len(singular)), svd.matrixV().reshape(columns, len(singular))
    return (right * inverse_values).dot(left.T)


def undamped_pseudoinverse(matrix: np.ndarray, tolerance: float = 1e-10, svd=None) -> np.ndarray:
    r""":func:`pseudoinverse` without damping, the same cutoff, applied by the SVD's own solve:
    :math:`V_r\Sigma_r^{-1}U_r^\top` over the r singular values kept, as Eigen's ``solve`` forms it for the identity
    once its rank threshold is the cutoff, instead of scaling V by a list and multiplying by :math:`U^\top` in
    numpy (a test holds the two equal, rank-deficient matrices included).

    ``svd``: an ``eigenpy.HhJacobiSVD`` of the matrix's shape (thin U and V) to decompose into, for a caller
    that keeps one from call to call; by default a new one."""
    if matrix.size == 0:
        return np.zeros(matrix.T.shape)
    rows = matrix.shape[0]
    svd = eigenpy.HhJacobiSVD(matrix, _THIN_UV) if svd is None else svd.compute(matrix)
    largest = svd.singularValues().reshape(-1).tolist()[0]  # descending (one value comes as a 1×1 matrix)
    if not largest > 0.0:
        return np.zeros(matrix.T.shape)
    # Eigen keeps σ >= threshold·σmax; the cutoff drops σ <= max(tolerance·σmax, ABSOLUTE_TOLERANCE)
    svd.setThreshold(math.nextafter(max(tolerance * largest, ABSOLUTE_TOLERANCE), math.inf) / largest)
    inverse = svd.solve(identity(rows))
    # eigenpy gives a result with one row or one column flat
    return inverse if inverse.ndim == 2 else inverse.reshape(matrix.shape[1], rows)


def stacked_undamped_pseudoinverse(matrix: np.ndarray, tolerance: float = 1e-10, rank_one: bool = False) -> np.ndarray:
    r""":func:`undamped_pseudoinverse` of each matrix of an (A, r, c) stack, the same cutoff
    (singular values at or below max(``tolerance``·σmax, 1e-10) dropped), by numpy's SVD.

    ``rank_one``: every matrix has rank one or less (up to round-off), as :math:`J_o(I - J^\dagger J)` when
    n − m = 1: then :math:`A = \sigma uv^\top` and :math:`A^\dagger = A^\top/\|A\|_F^2` (σ = ‖A‖_F), zero where
    σ is at or below 1e-10, without an SVD (the tests hold it to the SVD's)."""
    if rank_one:
        squared = np.einsum("bij,bij->b", matrix, matrix)
        kept = squared > ABSOLUTE_TOLERANCE * ABSOLUTE_TOLERANCE
        scale = kept / np.where(kept, squared, 1.0)
        return np.swapaxes(matrix, 1, 2) * scale[:, None, None]
    left, singular, right_t = np.linalg.svd(matrix, full_matrices=False)
    cutoff = np.maximum(tolerance * singular[:, :1], ABSOLUTE_TOLERANCE)
    kept = singular > cutoff
    reciprocal = kept / np.where(kept, singular, 1.0)
    return np.swapaxes(right_t, 1, 2) @ (reciprocal[:, :, None] * np.swapaxes(left, 1, 2))


def pseudoinverse_workspace(rows: int, columns: int):
    """A decomposition for :func:`undamped_pseudoinverse`'s ``svd`` of rows×columns matrices, allocated once."""
    return eigenpy.HhJacobiSVD(rows, columns, _THIN_UV)


def pseudoinverse_rate(matrix: np.ndarray, matrix_rate: np.ndarray, inverse: np.ndarray) -> np.ndarray:
    r"""The time derivative of :math:`A^\dagger` (``inverse``) as A moves at :math:`\dot A`, where A keeps its rank
    (Golub & Pereyra, 1973):

    .. math::

        \frac{d}{dt}A^\dagger = -A^\dagger\dot A A^\dagger + A^\dagger A^{\dagger\top}\dot A^\top(I - AA^\dagger)
        + (I - A^\dagger A)\dot A^\top A^{\dagger\top}A^\dagger.

    For A of full row rank :math:`AA^\dagger = I` and :math:`A^{\dagger\top}A^\dagger = (AA^\top)^{-1}`: the middle
    term drops and the last is :math:`(I - A^\dagger A)\dot A^\top(AA^\top)^{-1}`. Only the part of
    :math:`\dot A` along the matrices of A's rank enters (the rest is annihilated by the projectors), so a
    round-off component that would change the rank does not.
    """
    inverse_t = inverse.T
    return (
        -inverse.dot(matrix_rate).dot(inverse)
        + inverse.dot(inverse_t).dot(matrix_rate.T - matrix_rate.T.dot(matrix).dot(inverse))
        + (matrix_rate.T - inverse.dot(matrix.dot(matrix_rate.T))).dot(inverse_t).dot(inverse)
    )


class PriorityLevel(NamedTuple):
    r"""One step of the recursion at a configuration: what depends on the Jacobians alone, not on the velocities."""

    #: :math:`J_k` (m_k × n).
    jacobian: np.ndarray
    #: :math:`P_{k-1}` (n × n), the freedom the tasks above leave; None for the first task (:math:`P_0 = I`).
    projector: np.ndarray | None
    #: :math:`A_k = J_k P_{k-1}`.
    projected: np.ndarray
    #: :math:`A_k^\dagger`.
    inverse: np.ndarray


def priority_levels(
    jacobians: Sequence[np.ndarray],
    *,
    tolerance: float = 1e-10,
    damping: float = 0.0,
    first_inverse=None,
    final_projector: bool = True,
) -> tuple[list[PriorityLevel], np.ndarray | None]:
    r"""The recursion's pseudoinverses and projectors for :math:`J_1, J_2, \dots` (highest priority first):
    one :class:`PriorityLevel` per task, and :math:`P_K`, the projector onto the freedom left after every task.

    Args:
        tolerance: relative singular-value cutoff of every pseudoinverse.
        damping: damped least squares λ for the lower-priority inverses (0: none).
        first_inverse: :math:`J_1^\dagger`, when the caller already has it.
        final_projector: False when the caller does not read :math:`P_K` (None is returned in its place).
    """
    levels = []
    projector = None  # P_0 = I: A_1 = J_1
    for level, jacobian in enumerate(jacobians):
        projected = (
            jacobian if projector is None else jacobian.dot(projector)
        )  # for k = 2, J_l(I - J_h⁺J_h) of Eq. (10)
        if level == 0 and first_inverse is not None:
            inverse = first_inverse
        elif damping > 0.0 and level > 0:
            inverse = pseudoinverse(projected, tolerance, damping)
        else:
            inverse = undamped_pseudoinverse(projected, tolerance)
        levels.append(PriorityLevel(jacobian, projector, projected, inverse))
        if level == len(jacobians) - 1 and not final_projector:
            return levels, None
        dropped = inverse.dot(projected)
        projector = identity(jacobian.shape[1]) - dropped if projector is None else projector - dropped
    return levels, projector


def rates_through(levels: Sequence[PriorityLevel], velocities: Sequence[np.ndarray]) -> np.ndarray:
    r"""The joint rates [rad/s] of Eq. (11)'s recursion through ``levels`` (:func:`priority_levels`) for the
    desired task velocities :math:`\dot x_k`: :math:`\dot q_k = \dot q_{k-1} + A_k^\dagger(\dot x_k - J_k\dot q_{k-1})`."""
    rates = levels[0].inverse.dot(velocities[0])  # q̇_1 = J_1⁺ẋ_1
    for level, velocity in zip(levels[1:], velocities[1:]):
        # Eq. (11): the task's shortfall left by the tasks above it, through [J_k P_{k-1}]⁺.
        rates = rates + level.inverse.dot(velocity - level.jacobian.dot(rates))
    return rates


def prioritised_rates(
    jacobians: Sequence[np.ndarray], velocities: Sequence[np.ndarray], *, tolerance: float = 1e-10, damping: float = 0.0
):
    r"""Joint rates realising the task velocities in priority order, Eq. (11) and its recursion.

    Args:
        jacobians: :math:`J_1, J_2, \dots` (each m_k × n), highest priority first.
        velocities: the desired :math:`\dot x_k` (m_k values each).
        tolerance: relative singular-value cutoff of every pseudoinverse.
        damping: damped least squares λ for the lower-priority inverses (0: none).

    Returns:
        The joint rates q̇ [rad/s] and :math:`P_K`, the projector onto the
        freedom left after every task, as a pair.
    """
    levels, projector = priority_levels(jacobians, tolerance=tolerance, damping=damping)
    return rates_through(levels, velocities), projector


def prioritised_accelerations(
    jacobians: Sequence[np.ndarray],
    jacobian_rates: Sequence[np.ndarray],
    velocities: Sequence[np.ndarray],
    velocity_rates: Sequence[np.ndarray],
    *,
    tolerance: float = 1e-10,
    levels: Sequence[PriorityLevel] | None = None,
):
    r"""The joint rates of :func:`prioritised_rates` (no damping) and their time derivative along the motion.

    Each step of the recursion differentiated, with :math:`A_k = J_k P_{k-1}`:

    .. math::

        \ddot q_k = \ddot q_{k-1} + \dot A_k^\dagger e_k + A_k^\dagger(\ddot x_k - \dot J_k\dot q_{k-1} - J_k\ddot q_{k-1}),\quad
        e_k = \dot x_k - J_k\dot q_{k-1},\quad
        \dot P_k = \dot P_{k-1} - \dot A_k^\dagger A_k - A_k^\dagger\dot A_k,

        \dot A_k = \dot J_k P_{k-1} + J_k\dot P_{k-1},

    with :math:`\dot A_k^\dagger` by :func:`pseudoinverse_rate` (each :math:`A_k` keeping its rank along
    the motion, as it does away from the algorithmic singularities).

    Args:
        jacobians: :math:`J_1, J_2, \dots` (each m_k × n), highest priority first.
        jacobian_rates: their time derivatives :math:`\dot J_k` along the motion.
        velocities: the desired :math:`\dot x_k`.
        velocity_rates: their time derivatives :math:`\ddot x_k` along the motion.
        tolerance: relative singular-value cutoff of every pseudoinverse, as in :func:`prioritised_rates`.
        levels: the :func:`priority_levels` of ``jacobians`` (without damping), when the caller already has them.

    Returns:
        q̇ [rad/s] and q̈ [rad/s²], as a pair.
    """
    levels = priority_levels(jacobians, tolerance=tolerance)[0] if levels is None else levels
    n = jacobians[0].shape[1]
    rates, accelerations = np.zeros(n), np.zeros(n)
    projector_rate = None  # Ṗ_0 = 0
    last = len(levels) - 1
    for index, (level, jacobian_rate, velocity, velocity_rate) in enumerate(
        zip(levels, jacobian_rates, velocities, velocity_rates)
    ):
        jacobian, projected, inverse = level.jacobian, level.projected, level.inverse
        # Ȧ_k = J̇_k P_{k-1} + J_k Ṗ_{k-1}
        projected_rate = (
            jacobian_rate
            if projector_rate is None
            else jacobian_rate.dot(level.projector) + jacobian.dot(projector_rate)
        )
        inverse_rate = pseudoinverse_rate(projected, projected_rate, inverse)
        shortfall = velocity - jacobian.dot(rates)
        shortfall_rate = velocity_rate - jacobian_rate.dot(rates) - jacobian.dot(accelerations)
        # the time derivative of Eq. (11)'s step: d/dt (A_k⁺ e_k)
        accelerations = accelerations + inverse_rate.dot(shortfall) + inverse.dot(shortfall_rate)
        rates = rates + inverse.dot(shortfall)
        if index == last:
            break  # no task below reads Ṗ_k
        dropped_rate = inverse_rate.dot(projected) + inverse.dot(projected_rate)
        projector_rate = -dropped_rate if projector_rate is None else projector_rate - dropped_rate
    return rates, accelerations


class TaskStack:
    """Tasks in priority order, highest first; the lower ones act in the null space of those above.

    Args:
        tasks: Task objects (each with a target, or whose desired velocity is given by the resolver).
    """

    def __init__(self, tasks: Sequence[Task]):
        tasks = list(tasks.tasks if isinstance(tasks, TaskStack) else tasks)
        if not tasks or not all(isinstance(task, Task) for task in tasks):
            raise InvalidInput(f"a task stack needs one or more Task objects, got {tasks!r}")
        self.tasks = tasks

    @classmethod
    def of(cls, tasks) -> TaskStack:
        """A stack from a TaskStack, one Task, or a sequence of Tasks."""
        if isinstance(tasks, TaskStack):
            return tasks
        if isinstance(tasks, Task):
            return cls([tasks])
        return cls(tasks)

    def check(self, robot) -> None:
        for task in self.tasks:
            task.check(robot)

    @property
    def dimension(self) -> int:
        return sum(task.dimension for task in self.tasks)

    def __iter__(self):
        return iter(self.tasks)

    def __len__(self) -> int:
        return len(self.tasks)

    def __repr__(self) -> str:
        return f"TaskStack({self.tasks!r})"
