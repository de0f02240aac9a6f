r"""Baillieul's extended Jacobian (1985), Eq. (14), Eq. (15), for one degree of redundancy."""

from __future__ import annotations

import math
import operator
from functools import cache, partial

import eigenpy
import numpy as np

from ...checks import Refused, number_in_interval
from ...errors import NoRedundancy, SingularJacobian
from ...linalg import InverseCondition, cross_along, determinants
from ...robot import Robot
from ...robot_copies import stacked_cross
from ...tasks import FrameTask, Kinematics, PerConfiguration
from ..options import Option
from ..registry import register_resolver
from .base import POSITION_GAIN_OPTION, VelocityResolver, VelocityStack
from .criteria import JointLimits, PostureDistance, _traces_and_rates, criterion_from
from .options import criterion_spec
from .pseudoinverse import StackedPseudoInverse

__all__ = [
    "ExtendedJacobian",
    "null_vector",
    "signed_cofactors",
    "signed_cofactors_rate",
]


def null_vector(jacobian: np.ndarray) -> np.ndarray:
    r"""The generalised cross product of the rows of an m×(m+1) Jacobian, or of each of a (…, m, m+1) stack:
    :math:`n_i = (-1)^i \det J_{\setminus i}`.

    It spans the one-dimensional null space of J (:math:`J n = 0`, each row's
    product is the determinant of a matrix with a repeated row) and is what the
    paper calls "taking cross products of columns of J"; for m = 2 it is the
    cross product of J's two rows, by components.
    """
    m, n = jacobian.shape[-2:]
    if m == 2:
        return cross_along(jacobian[..., 0, :], jacobian[..., 1, :], jacobian.ndim - 2)
    minors = np.swapaxes(jacobian[..., _minor_columns(n)], -3, -2)  # (…, n, m, m): minor i is J without column i
    return _alternating_signs(n) * determinants(minors)


@cache
def _minor_columns(n: int) -> np.ndarray:
    """(n, n − 1) indices: row i lists every column but i (built once per n, read-only)."""
    columns = np.array([[j for j in range(n) if j != i] for i in range(n)], dtype=int).reshape(n, n - 1)
    columns.setflags(write=False)
    return columns


@cache
def _alternating_signs(n: int) -> np.ndarray:
    """(−1)^i for i < n (built once per n, read-only)."""
    signs = (-1.0) ** np.arange(n)
    signs.setflags(write=False)
    return signs


def signed_cofactors(matrix: np.ndarray) -> np.ndarray:
    r""":math:`(-1)^m` times the cofactor matrix of an n×n matrix :math:`A = [J;\ l^\top]` (n = m + 1): row a < m is
    :math:`K_a = \partial((-1)^m\det A)/\partial J_a` and the last row is :func:`null_vector` of J, since
    :math:`(-1)^m\det A = l\cdot n_J`. Row r is :math:`(-1)^{m+r}` :func:`null_vector` of A without row r (the
    cofactors by minors, exact where A is singular)."""
    n = matrix.shape[0]
    if n == 3:  # row r is A_{r+1} × A_{r+2} (indices mod 3), on floats (numpy costs more per call on 3-vectors)
        a, b, c = matrix.tolist()
        return np.array((_cross(b, c), _cross(c, a), _cross(a, b)))
    return _row_signs(n) * null_vector(matrix[_minor_columns(n)])


def signed_cofactors_rate(matrix: np.ndarray, rate: np.ndarray) -> np.ndarray:
    r"""The rate of :func:`signed_cofactors` as A moves at :math:`\dot A`: :func:`null_vector` is linear in each
    row, so row r is the sum over A's other rows i of :math:`(-1)^{m+r}` :func:`null_vector` of A without row r
    and with row i replaced by :math:`\dot A_i` (the product rule, exact)."""
    n = matrix.shape[0]
    if n == 3:  # the rate of A_{r+1} × A_{r+2}: Ȧ_{r+1} × A_{r+2} + A_{r+1} × Ȧ_{r+2}, on floats
        (a, b, c), (da, db, dc) = matrix.tolist(), rate.tolist()
        pairs = ((db, c, b, dc), (dc, a, c, da), (da, b, a, db))
        return np.array([[x + y for x, y in zip(_cross(u, v), _cross(w, z))] for u, v, w, z in pairs])
    which, rows = _replaced_rows(n)
    return _row_signs(n) * null_vector(np.concatenate((matrix[None], rate[None]))[which, rows]).sum(axis=1)


def _cross(a, b) -> list:
    """a × b of two 3-vectors given as floats."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


@cache
def _replaced_rows(n: int) -> tuple[np.ndarray, np.ndarray]:
    """For :func:`signed_cofactors_rate`: (which, rows), (n, n − 1, n − 1) each, so that [A; Ȧ][which, rows][r, p] is A
    without row r with its p-th remaining row taken from Ȧ (built once per n, read-only)."""
    remaining = _minor_columns(n)  # row r: every row but r
    which = np.broadcast_to(np.eye(n - 1, dtype=int), (n, n - 1, n - 1)).copy()
    rows = np.broadcast_to(remaining[:, None, :], (n, n - 1, n - 1)).copy()
    for array in (which, rows):
        array.setflags(write=False)
    return which, rows


@cache
def _row_signs(n: int) -> np.ndarray:
    """(−1)^(n − 1 + r) for r < n as an (n, 1) column (built once per n, read-only)."""
    signs = ((-1.0) ** (n - 1) * _alternating_signs(n))[:, None]
    signs.setflags(write=False)
    return signs


@register_resolver
class ExtendedJacobian(VelocityResolver):
    r"""Baillieul's extended Jacobian for n − m = 1, Eq. (14), Eq. (15).

    With :math:`n_J` spanning the null space of J and p(q) a criterion,

    .. math::

        G(q) = \frac{\partial p}{\partial q}\cdot n_J \quad\text{Eq. (14)},\qquad
        J_{ex}\dot q = \begin{bmatrix}\dot x\\ 0\end{bmatrix},\quad
        J_{ex} = \begin{bmatrix} J \\ \partial G/\partial q\end{bmatrix} \quad\text{Eq. (15)},

    solved for :math:`\dot q` directly. The rates keep G constant along the
    motion, so the arm stays on the surface :math:`G(q) = G(q_0)` (the
    stationary points of p over the self-motion when :math:`G(q_0) = 0`):
    the configuration is a function of the tip position, and a closed tip
    path brings the joints back (the method is repeatable, unlike the
    pseudoinverse). :math:`\partial G/\partial q` is analytic: Jacobi's formula on
    :math:`G = (-1)^m\det[J;\ \nabla p^\top]`, with the cofactors
    (:func:`~torqueopt.resolvers.velocity.signed_cofactors`), the criterion's
    Hessian and Pinocchio's kinematic Hessian.

    The method has singularities of its own where :math:`J_{ex}` loses rank
    while J does not: where :math:`\partial G/\partial q` becomes orthogonal
    to :math:`n_J`, i.e. where the surface G = G(q_0) folds over the tip
    path. Near one the rates grow without bound; the run stops, saying so,
    when the alignment :math:`|\partial G/\partial q \cdot n_J| / (\|\partial G/\partial q\|\,\|n_J\|)`
    (1 far from it, 0 at it) falls below ``algorithmic_tolerance``, and a
    run stopped earlier by the speed or torque ceilings reports the
    alignment where it stopped.

    Args:
        criterion: ``joint-limits`` (Eq. (5), the default), a Criterion with
            a Hessian, or a callable ``p(joint_angles)`` (derivatives by differences).
        algorithmic_tolerance: the alignment below which the run stops as singular.
    """

    name = "extended-jacobian"
    equations = (14, 15)
    needs_redundancy = True
    options = (
        Option(
            name="criterion",
            kind="'joint-limits' | callable p(joint_angles)",
            unit="",
            default="joint-limits",
            meaning="the criterion p whose gradient along the null space, G of Eq. (14), is held",
            convert=lambda value: _hessian_criterion(criterion_spec(value)),
        ),
        Option(
            name="algorithmic_tolerance",
            kind="number in [0, 1)",
            unit="",
            default=0.05,
            meaning="the alignment |∂G/∂q·n|/(|∂G/∂q| |n|) below which the run stops at an algorithmic singularity",
            convert=partial(number_in_interval, low=0.0, high=1.0, high_open=True),
        ),
        POSITION_GAIN_OPTION,
    )

    def __init__(self, **options):
        super().__init__(**options)
        self.objective = criterion_from(self.criterion)

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if robot.redundancy != 1:
            raise NoRedundancy(
                f"resolver 'extended-jacobian' needs exactly one degree of redundancy (n − m = 1); task "
                f"'{robot.task}' on robot '{robot.name}' leaves {robot.redundancy}: {_one_redundancy_hint(robot)}"
            )
        self.objective.check(robot)

    def extended_row(self, kinematics: Kinematics, task: FrameTask):
        r"""(G, ∂G/∂q, n_J) at the kinematics' configuration, Eq. (14) (the row by :meth:`row_and_cofactors`)."""
        g_row, cofactors, matrix = self.row_and_cofactors(kinematics, task)
        return float(matrix[-1].dot(cofactors[-1])), g_row, cofactors[-1]  # Eq. (14): G = ∂g/∂θ · n_J

    def row_and_cofactors(self, kinematics: Kinematics, task: FrameTask, jacobian: np.ndarray | None = None):
        r"""(∂G/∂q, :math:`[K;\ n_J]`, A) at the kinematics' configuration (``jacobian``: the task's J there, if read).

        :math:`G = \nabla p\cdot n_J = (-1)^m\det A` with :math:`A = [J;\ \nabla p^\top]` (Eq. (14)), so Jacobi's
        formula gives the row, :math:`\partial G/\partial q_k = \sum_a K_a\cdot\partial J_a/\partial q_k
        + n_J\cdot\nabla^2 p_{:,k}`, with :math:`[K;\ n_J]` A's signed cofactors (:func:`signed_cofactors`, exact
        where A is singular, as it is on G = 0) and :math:`\partial J/\partial q` Pinocchio's kinematic Hessian."""
        jacobian = task.jacobian(kinematics) if jacobian is None else jacobian
        matrix = np.concatenate((jacobian, self.objective.gradient(kinematics, task)[None]))
        cofactors = signed_cofactors(matrix)  # [K; n_J]
        # ∂G/∂θ, the last row of J_ex in Eq. (15): Σ_a K_a·∂J_a/∂θ (traces of Kᵀ ∂J/∂θ_k) + n_J·∇²p
        g_row = task.jacobian_derivative_traces(kinematics, cofactors[:-1].T)
        g_row += cofactors[-1].dot(self.objective.hessian(kinematics, task))
        return g_row, cofactors, matrix

    def closed_curvature(
        self, kinematics: Kinematics, task: FrameTask, velocity: np.ndarray, matrix=None, cofactors=None
    ):
        r"""(:math:`\dot J`, :math:`\dot q^\top\nabla^2 G\,\dot q`) at the kinematics' configuration along q̇, the
        curvature in closed form, for a criterion of constant Hessian (``joint-limits``, a posture's distance) on a
        position task of a robot whose joints each have one degree of freedom (``matrix``, ``cofactors``: A and
        its signed cofactors there, if computed).

        :math:`\dot q^\top\nabla^2 G\,\dot q = \dot q\cdot\frac{d}{dt}\frac{\partial G}{\partial q}` along
        :math:`q + t\dot q`, with the row of :meth:`row_and_cofactors` differentiated term by term:
        :math:`\sum_a \dot K_a\cdot\partial J_a/\partial q_k + K_a\cdot\frac{d}{dt}\partial J_a/\partial q_k
        + \dot n_J\cdot\nabla^2 p_{:,k}`; :math:`[\dot K;\ \dot n_J]` by :func:`signed_cofactors_rate` with
        :math:`\dot A = [\dot J;\ (\nabla^2 p\,\dot q)^\top]`, and the two sums over the kinematic Hessian and its rate
        from the frame Jacobian's columns and their rates (Pinocchio's ``getFrameJacobianTimeVariation``), as
        the manipulability's curvature takes them (``criteria._traces_and_rates``, whose docstring derives
        them); the stacked form's closed form (``StackedExtendedJacobian``) in another arrangement."""
        if matrix is None:
            _, cofactors, matrix = self.row_and_cofactors(kinematics, task)
        frame = task.frame_id(kinematics)
        frame_jacobian = kinematics.frame_jacobian(frame)
        frame_rate = kinematics.frame_jacobian_time_variation(frame, velocity)
        jacobian_rate = frame_rate[task.rows]
        gradient_rate = self.objective.hessian(kinematics, task).dot(velocity)  # ∇²p q̇
        cofactors_rate = signed_cofactors_rate(matrix, np.concatenate((jacobian_rate, gradient_rate[None])))
        _, traces_rate = _traces_and_rates(
            frame_jacobian.T.tolist(), frame_rate.T.tolist(), cofactors[:-1].T.tolist(), cofactors_rate[:-1].T.tolist()
        )
        normal_rate, speeds = cofactors_rate[-1].tolist(), velocity.tolist()
        # q̇·(Σ_a K̇_a·∂J_a/∂q + K_a·d/dt ∂J_a/∂q) + ṅ_J·∇²p q̇, on floats
        curvature = sum(map(operator.mul, traces_rate, speeds)) + sum(
            map(operator.mul, normal_rate, gradient_rate.tolist())
        )
        return jacobian_rate, curvature

    def differenced_curvature(self, kinematics: Kinematics, task: FrameTask, velocity: np.ndarray) -> float:
        r""":math:`\dot q^\top\nabla^2 G\,\dot q` by a central difference of the row :math:`\partial G/\partial q`
        along :math:`\dot q/|\dot q|` (step ``CURVATURE_STEP``): for a criterion without a constant Hessian, and
        the plain reference :meth:`closed_curvature` is held to. It leaves the kinematics at their configuration,
        updated again."""
        speed = math.sqrt(velocity.dot(velocity))
        if speed == 0.0:
            return 0.0
        robot, q, step = kinematics.robot, kinematics.q, CURVATURE_STEP / speed
        forward = self.row_and_cofactors(kinematics.update(robot.integrate(q, step * velocity)), task)[0]
        backward = self.row_and_cofactors(kinematics.update(robot.integrate(q, -step * velocity)), task)[0]
        kinematics.update(q)
        return float((forward - backward).dot(velocity)) / (2.0 * step)

    def alignment(self, kinematics: Kinematics, task: FrameTask) -> float:
        r""":math:`|\partial G/\partial q\cdot n_J|/(\|\partial G/\partial q\|\,\|n_J\|)`: 1 far from, 0 at an algorithmic singularity."""
        g_row, cofactors, _ = self.row_and_cofactors(kinematics, task)
        return _alignment(g_row, cofactors[-1])

    def stop_diagnosis(self, kinematics: Kinematics, task: FrameTask) -> str:
        return (
            f"the extended Jacobian's alignment |∂G/∂q·n|/(|∂G/∂q| |n|) there is {self.alignment(kinematics, task):.3g} "
            "(0 at its algorithmic singularity)"
        )

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ from Eq. (15) differentiated along the motion, on a position task (None for ``pose``).

        The rates keep :math:`J\dot q = c` and :math:`\frac{\partial G}{\partial q}\dot q = 0`; their time
        derivatives give

        .. math::

            J_{ex}\ddot q = \begin{bmatrix} \dot c - \dot J\dot q \\ -\dot q^\top \nabla^2 G\,\dot q \end{bmatrix},

        with :math:`\dot J` from Pinocchio's Jacobian time variation at (q, q̇). The curvature
        :math:`\dot q^\top\nabla^2 G\,\dot q` of G along the motion needs third derivatives of the kinematics
        (:math:`\partial G/\partial q` already holds the kinematic Hessian), which Pinocchio does not give: for
        ``joint-limits`` or a posture's distance on a position task of a robot whose joints add it is taken in
        closed form from the task frame's Jacobian and its rate (:meth:`closed_curvature`), else by a central
        difference of the row :math:`\partial G/\partial q` along :math:`\dot q/|\dot q|`
        (:meth:`differenced_curvature`, step ``CURVATURE_STEP`` = 1e-5 rad), two evaluations of the row instead of
        the loop's four of the whole rate map. The batch's stacked form (``StackedExtendedJacobian``) takes the
        closed form for the same cases; the tests hold both to differences.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (15)'s rates and their q̈ (None for ``pose``): :meth:`lu_step_functions`. The batch takes the stacked
        form (:meth:`stack_rate_function`), which the tests hold to this one."""
        return self.lu_step_functions(robot, task)

    def lu_step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (15)'s rates and their q̈ (None for ``pose``) for any n = m + 1 and any criterion with a Hessian,
        sharing J_ex's LU factors and A's cofactors at each configuration; the curvature by :meth:`closed_curvature`
        where the stacked form applies, else by :meth:`differenced_curvature`: the reference the tests hold the
        stacked form to."""
        condition_of = InverseCondition(robot.m, robot.nv, self.singular_tolerance)
        tolerance = self.algorithmic_tolerance
        closed_form = task.kind != "pose" and robot.euclidean and _diagonal_quadratic(self.objective, robot) is not None

        @PerConfiguration
        def at_configuration(kinematics: Kinematics):
            jacobian = task.jacobian(kinematics)
            inverse_condition = condition_of(jacobian)  # J itself must keep full rank
            g_row, cofactors, matrix = self.row_and_cofactors(kinematics, task, jacobian)
            alignment = _alignment(g_row, cofactors[-1])
            if not alignment >= tolerance:
                raise _algorithmic_singularity(alignment, tolerance)
            # J_ex of Eq. (15), by Eigen's LU with partial pivoting (numpy's solve costs more than a 3×3 LU)
            return eigenpy.PartialPivLU(np.concatenate((jacobian, g_row[None]))), inverse_condition, matrix, cofactors

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            extended, inverse_condition, _, _ = at_configuration(kinematics)
            # Eq. (15): J_ex q̇ = [ẋ; 0], inverted directly
            return extended.solve(np.concatenate((task_velocity, _ZERO))), inverse_condition

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            extended, _, matrix, cofactors = at_configuration(kinematics)
            if closed_form:
                jacobian_rate, curvature = self.closed_curvature(kinematics, task, velocity, matrix, cofactors)
            else:
                jacobian_rate = task.jacobian_rate(kinematics, velocity)
                curvature = self.differenced_curvature(kinematics, task, velocity)  # q̇ᵀ∇²G q̇
            # Eq. (15) differentiated: J_ex q̈ = [ċ − J̇q̇; −q̇ᵀ∇²G q̇]
            return extended.solve(np.append(command_rate - jacobian_rate.dot(velocity), -curvature))

        return rates, None if task.kind == "pose" else acceleration

    def stack_rate_function(self, robot: Robot):
        """Eq. (15)'s rates and their q̈ on stacks (``StackedExtendedJacobian``), for a position task (``xy``,
        ``position``) on a robot whose joints add (``Robot.euclidean``), with a diagonal quadratic criterion:
        ``joint-limits`` (Eq. (5)) or a posture's distance (``PostureDistance``). Else None (one movement at a
        time): a callable's derivatives are differences of its values, which have no stacked form."""
        criterion = _diagonal_quadratic(self.objective, robot)
        if robot.task == "pose" or not robot.euclidean or criterion is None:
            return None
        return StackedExtendedJacobian(robot, self.singular_tolerance, self.algorithmic_tolerance, *criterion)


#: The last entry of Eq. (15)'s right-hand side, [ẋ; 0].
_ZERO = np.zeros(1)


#: Step [rad] of the central difference of ∂G/∂q along q̇ in :meth:`ExtendedJacobian.acceleration_function`
#: (where its curvature has no closed form, and the plain reference the tests hold the closed form to):
#: its O(δ²) truncation and its round-off ε|∂G/∂q|/δ balance near 1e-5 (at 15 random planar3 states the
#: q̈ agreed with a five-point difference of the rates to 4e-11 of its size, against 8e-10 at 1e-6, 2e-9 at 1e-4).
CURVATURE_STEP = 1e-5


def stacked_row_cofactors(jacobian: np.ndarray, last: np.ndarray) -> np.ndarray:
    r"""The cofactors of the first m rows of :math:`M = [J;\ l^\top]` ((m+1)×(m+1)) on (B, m, m+1) and (B, m+1)
    stacks, (B, m, m+1): row a is :math:`C_a = (-1)^a\,` :func:`null_vector` of M without row a, so that
    :math:`\partial\det M/\partial J_a = C_a`, :math:`\operatorname{adj}M = [C_0 \dots C_{m-1}\ (-1)^m n_J]`
    and :math:`M^{-1} = \operatorname{adj}M/\det M`."""
    m, n = jacobian.shape[1:]
    if m == 2:  # C_0 = J_1 × l, C_1 = l × J_0
        cofactors = np.empty_like(jacobian)
        cofactors[:, 0] = stacked_cross(jacobian[:, 1], last)
        cofactors[:, 1] = stacked_cross(last, jacobian[:, 0])
        return cofactors
    others = jacobian[:, _minor_columns(m)]  # (B, m, m − 1, n): J without row a
    matrices = np.concatenate((others, np.broadcast_to(last[:, None, None, :], (last.shape[0], m, 1, n))), axis=2)
    return _alternating_signs(m)[:, None] * null_vector(matrices)


def adjugate_times(jacobian: np.ndarray, last: np.ndarray, weights: np.ndarray) -> np.ndarray:
    r""":math:`\sum_a w_a C_a` (B, m+1) for (B, m) weights, :math:`C_a` the cofactors of ``stacked_row_cofactors``:
    :math:`\operatorname{adj}[J;\ l^\top]\,[w;\ 0]`. For m = 2 one cross product,
    :math:`(w_0 J_1 - w_1 J_0)\times l`."""
    if jacobian.shape[1] == 2:
        combined = weights[:, 0, None] * jacobian[:, 1] - weights[:, 1, None] * jacobian[:, 0]
        return stacked_cross(combined, last)
    return np.einsum("ba,bak->bk", weights, stacked_row_cofactors(jacobian, last))


class StackedExtendedJacobian(VelocityStack):
    r"""Eq. (14), Eq. (15) and their :math:`\ddot q` per row of (B, m, m+1) stacks, for a diagonal quadratic
    criterion :math:`p = \tfrac12\sum_i w_i (q_{a_i} - \bar q_i)^2` (Eq. (5)'s joint limits, a posture's distance).

    With :math:`A = [J;\ \nabla p^\top]`, :math:`G = \nabla p\cdot n_J = (-1)^m\det A` (Eq. (14)), and Jacobi's
    formula gives the row of Eq. (15), :math:`\partial G/\partial q_k = \sum_a K_a\cdot\partial J_a/\partial q_k
    + n_J\cdot\nabla^2 p_{:,k}`, with :math:`K_a = \partial G/\partial J_a` the (signed) cofactors of A's rows
    (``stacked_row_cofactors``). The kinematic Hessian of the task point (linear rows, J the point's Jacobian,
    :math:`\omega_j` its angular columns, the joints of its support in chain order) is
    :math:`\partial J_j/\partial q_k = \omega_{\min(j,k)}\times J_{\max(j,k)}` (``pin.getFrameKinematicHessian``'s,
    from the joint Jacobians' brackets :math:`\partial S_j/\partial q_k = [S_k, S_j]`, k before j), so with
    :math:`K_j` the 3-vectors of K's columns (zero outside the task rows)

    .. math::

        \frac{\partial G}{\partial q_k} = J_k\cdot\sum_{j\le k} K_j\times\omega_j
        + \omega_k\cdot\sum_{j>k} J_j\times K_j + w_k\,n_{J,k}.

    :math:`J_{ex}^{-1} = \operatorname{adj}J_{ex}/\det J_{ex}` by the cofactors of :math:`J_{ex} = [J;\ \partial G/\partial q]`,
    :math:`\det J_{ex} = (-1)^m\,\partial G/\partial q\cdot n_J`; rows where J is singular or the alignment falls
    below the cutoff fail with the single-state step's words.

    :math:`\ddot q` solves :math:`J_{ex}\ddot q = [\dot c - \dot J\dot q;\ -\ddot G]` (see
    :meth:`ExtendedJacobian.acceleration_function`), with the curvature :math:`\ddot G = \dot q^\top\nabla^2 G\,\dot q`
    in closed form: along
    :math:`q + s\dot q`, with :math:`'` for d/ds, :math:`g = \nabla p` (:math:`g' = \nabla^2 p\,\dot q`,
    :math:`g'' = 0`) and :math:`n_J` multilinear in J's rows,

    .. math::

        \ddot G = 2\,g'\cdot n_J' + \sum_a K_a\cdot J_a'' + 2\sum_{a<b} g\cdot n_J(J;\ J_a', J_b'),\qquad
        n_J' = \sum_a n_J(J;\ J_a'),

    (:math:`n_J(J;\ X_a)`: with row a replaced by X), :math:`J' = \dot J` Pinocchio's, and the third-order
    kinematics in closed form from the point's columns and their rates (the joints numbered parent first, as
    Pinocchio numbers them),
    :math:`J_j' = \Omega_{<j}\times J_j + \omega_j\times P_{\ge j}`,

    .. math::

        J_j'' = \Omega_{<j}'\times J_j + \Omega_{<j}\times J_j' + \omega_j'\times P_{\ge j} + \omega_j\times P_{\ge j}',
        \qquad \Omega_{<j} = \sum_{k<j}\dot q_k\omega_k,\quad P_{\ge j} = \sum_{k\ge j}\dot q_k J_k,

    contracted with K as triple products summed over the joints before and after each (the rates' sums reused):
    :math:`\sum_a K_a\cdot J_a'' = \sum_k \dot q_k\big(\omega_k'\cdot\sum_{j>k} J_j\times K_j
    + \omega_k\cdot\sum_{j>k} J_j'\times K_j + J_k\cdot\sum_{j\le k} K_j\times\omega_j'
    + J_k'\cdot\sum_{j\le k} K_j\times\omega_j\big)`. It agrees with a five-point difference of the row to
    1e-12 of its size, the central difference of the row (``CURVATURE_STEP``) to about 1e-10 (that difference's
    round-off); tests/test_stack_extended_jacobian.py holds it to both.

    J (all six rows: :math:`\omega_j` are its angular columns) and :math:`\dot J` are the task frame's from the
    batch's forest pass (``frame_jacobian``, ``frame_rate``), the task's rows read from them. Every stack is held
    component-first, the batch axis last ((6, n, B), (n, B), ...: one copy of each input), so each product runs
    along the batch: on (B, 3, n) stacks numpy's loops would run over runs of three.
    The sums are taken in the order of the batch-first einsums they replaced, so that on two task rows the figures
    are those bit for bit (on three, round-off apart).

    Args:
        robot: a robot whose joints add, with a position task of m rows and m + 1 joints.
        tolerance: the smallest σmin/σmax of J a row may have.
        algorithmic_tolerance: the smallest alignment :math:`|\partial G/\partial q\cdot n_J|/(|\partial G/\partial q|\,|n_J|)`.
        q_index, v_index: the configuration coordinates :math:`a_i` of the criterion's terms and their joints.
        centre: :math:`\bar q` [rad, m].
        curvature: :math:`w_i`, the diagonal of :math:`\nabla^2 p`.
    """

    def __init__(
        self, robot: Robot, tolerance: float, algorithmic_tolerance: float, q_index, v_index, centre, curvature
    ):
        self.conditions = StackedPseudoInverse(tolerance).conditions
        self.algorithmic_tolerance = algorithmic_tolerance
        self.rows, self.m, self.n = robot.task_rows, robot.m, robot.nv
        self.q_index, self.v_index = np.asarray(q_index, dtype=int), np.asarray(v_index, dtype=int)
        self.centre, self.curvature = np.asarray(centre, dtype=float), np.asarray(curvature, dtype=float)
        self.sign = (-1.0) ** self.m
        # which rows of [J; J̇] make each matrix of the curvature: J with row a replaced by J̇'s, for each a, then
        # with the two rows of each pair a < b replaced
        m = self.m
        single = [[int(row == a) for row in range(m)] for a in range(m)]
        pairs = [[int(row in (a, b)) for row in range(m)] for a in range(m) for b in range(a + 1, m)]
        self.choices, self.row_numbers = np.array(single + pairs, dtype=int), np.arange(m)
        every = np.arange(self.n)
        self.every_joint = np.array_equal(self.q_index, every) and np.array_equal(self.v_index, every)

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a failed row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with the frame's whole J; J is read from there (its task
        rows are ``jacobian``'s). Held component-first, the batch axis last (see the class)."""
        frame = _batch_last(kinematics.frame_jacobian)  # (6, n, B)
        linear, angular, task = frame[:3], frame[3:], frame[self.rows]
        conditions, failures, _ = self.conditions(_gram(jacobian, task))
        gradient = self._gradient(configuration)
        normal = _null_vectors(task)  # n_J, (n, B)
        cofactors, before, after = self._cofactor_sums(task, gradient, linear, angular)
        # ∂G/∂q_k = J_k·Σ_{j≤k} K_j × ω_j + ω_k·Σ_{j>k} J_j × K_j + w_k n_k, the last row of J_ex in Eq. (15)
        g_row = _sum_first(linear * before) + _sum_first(angular * after)
        if self.every_joint:
            g_row += self.curvature[:, None] * normal
        else:
            g_row[self.v_index] += self.curvature[:, None] * normal[self.v_index]
        product = _dot_first(g_row, normal)
        scale = np.sqrt(_dot_first(g_row, g_row) * _dot_first(normal, normal))
        alignment = np.where(scale > 0.0, np.abs(product) / np.where(scale > 0.0, scale, 1.0), 0.0)
        algorithmic = ~(alignment >= self.algorithmic_tolerance)
        if algorithmic.any():
            for row in np.flatnonzero(algorithmic).tolist():
                if row not in failures:  # J's own rank is checked first, as in the single-state step
                    failures[row] = str(_algorithmic_singularity(float(alignment[row]), self.algorithmic_tolerance))
        determinant = self.sign * product  # det J_ex = (−1)^m ∂G/∂q·n_J
        if failures:
            determinant[list(failures)] = 1.0
        # Eq. (15): q̇ = J_ex⁻¹ [ẋ; 0] = Σ_a ẋ_a C_a / det J_ex
        velocity = _adjugate_times(task, g_row, command.T) / determinant
        state = (task, linear, angular, gradient, normal, cofactors, before, after, g_row, determinant)
        return np.ascontiguousarray(velocity.T), conditions, failures, state

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """J_ex⁻¹ [ċ − J̇q̇; −q̇ᵀ∇²G q̇] per row, the curvature in closed form (see the class).
        ``kinematics``: the forest's at the configuration and q̇, with the frame's whole J̇ (J̇ read from there)."""
        task, linear, angular, gradient, normal, cofactors, before, after, g_row, determinant = state
        frame_rate, joint_velocity = _batch_last(kinematics.frame_rate), np.ascontiguousarray(velocity.T)
        sums = linear, angular, gradient, cofactors, before, after
        curvature = self._curvature(task, frame_rate, joint_velocity, *sums)
        # Eq. (15) differentiated: J_ex q̈ = [ċ − J̇q̇; −q̇ᵀ∇²G q̇], by adj J_ex / det J_ex
        drift = _sum_first(np.swapaxes(frame_rate[self.rows] * joint_velocity, 0, 1))  # J̇q̇, (m, B)
        last = (self.sign * curvature) * normal  # the last column of adj J_ex is (−1)^m n_J
        acceleration = (_adjugate_times(task, g_row, command_rate.T - drift) - last) / determinant
        return np.ascontiguousarray(acceleration.T)

    def _cofactor_sums(self, task, gradient, linear, angular):
        """(K, Σ_{j≤k} K_j × ω_j, Σ_{j>k} J_j × K_j): the cofactors as (3, n, B) columns and the row's sums."""
        # K_a = ∂G/∂J_a: the cofactors of [J; ∇pᵀ]'s rows, G = (−1)^m det [J; ∇pᵀ] (Eq. (14)), as 3-vectors
        cofactors = np.zeros_like(linear)
        cofactors[self.rows] = self.sign * _row_cofactors(task, gradient)
        before = _sums_up_to(cross_along(cofactors, angular, 0))
        after = _sums_after(cross_along(linear, cofactors, 0))
        return cofactors, before, after

    def _curvature(self, task, frame_rate, velocity, linear, angular, gradient, cofactors, before, after) -> np.ndarray:
        """q̇ᵀ∇²G q̇ per row in closed form (see the class), reusing the row's cofactors and sums; every stack
        component-first, the batch axis last (q̇ (n, B))."""
        linear_rate, angular_rate = frame_rate[:3], frame_rate[3:]
        # Σ_j K_j·J_j'' with J_j'' = Ω'_{<j} × J_j + Ω_{<j} × J'_j + ω'_j × P_{≥j} + ω_j × P'_{≥j}, each term a triple
        # product summed over the joints before or after: Σ_k q̇_k (ω'_k·Σ_{j>k} J_j × K_j + ω_k·Σ_{j>k} J'_j × K_j
        # + J_k·Σ_{j≤k} K_j × ω'_j + J'_k·Σ_{j≤k} K_j × ω_j), the rates' sums reused
        rate_after = _sums_after(cross_along(linear_rate, cofactors, 0))
        rate_before = _sums_up_to(cross_along(cofactors, angular_rate, 0))
        per_joint = (
            _sum_first(angular_rate * after)
            + _sum_first(angular * rate_after)
            + _sum_first(linear * rate_before)
            + _sum_first(linear_rate * before)
        )
        curvature = _dot_first(per_joint, velocity)
        # n_J with one row of J replaced by its rate (their sum n_J'), and with two (the pairs a < b)
        choices = np.stack((task, frame_rate[self.rows]))[self.choices, self.row_numbers]  # (pairs, m, n, B)
        replaced = _null_vectors(np.moveaxis(choices, 0, 2))  # (n, pairs, B)
        m = self.m
        if self.every_joint:
            gradient_rate = self.curvature[:, None] * velocity  # g' = ∇²p q̇
        else:
            gradient_rate = np.zeros_like(velocity)
            gradient_rate[self.v_index] = self.curvature[:, None] * velocity[self.v_index]
        curvature += 2.0 * _dot_first(gradient_rate, replaced[:, :m].sum(axis=1))  # 2 g'·n_J'
        curvature += 2.0 * _dot_first(gradient, replaced[:, m:].sum(axis=1))
        return curvature

    def _gradient(self, configuration) -> np.ndarray:
        """∂p/∂q of each row, (n, B): ∂/∂θ of Eq. (5) (or of the posture's distance), zero for the joints without
        a term."""
        coordinates = _batch_last(configuration)
        if self.every_joint:
            return self.curvature[:, None] * (coordinates - self.centre[:, None])
        gradient = np.zeros((self.n, coordinates.shape[1]))
        gradient[self.v_index] = self.curvature[:, None] * (coordinates[self.q_index] - self.centre[:, None])
        return gradient


def _batch_last(stack: np.ndarray) -> np.ndarray:
    """A (B, ...) stack as a contiguous (..., B) one: products on a few hundred rows of short vectors cost several
    times more along a strided axis of length three than along the batch."""
    return np.ascontiguousarray(np.moveaxis(stack, 0, -1))


def _sum_first(terms: np.ndarray) -> np.ndarray:
    """Σ_i X_i over axis 0, one term after the other: the order numpy's einsum sums a strided axis in (the
    spatial components; the joints of the forest's J and J̇, whose component axis is the contiguous one)."""
    total = terms[0] + terms[1]
    for term in terms[2:]:
        total += term
    return total


def _pair_sum(terms: np.ndarray) -> np.ndarray:
    """Σ_k X_k over axis 0, the even and the odd terms apart and then together: the order numpy's einsum sums a
    contiguous axis of up to four terms in (the joints of the row and q̇), so that the sums are those of the
    batch-first einsums this layout replaced, bit for bit."""
    even, odd = terms[0], terms[1]
    for k in range(2, terms.shape[0]):
        if k % 2:
            odd = odd + terms[k]
        else:
            even = even + terms[k]
    return even + odd


def _dot_first(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a·b over axis 0 of (k, B) stacks (:func:`_pair_sum`'s order)."""
    return _pair_sum(a * b)


def _null_vectors(task: np.ndarray) -> np.ndarray:
    """:func:`null_vector` of (m, n, ...) stacks of J, (n, ...): for two rows one cross product on the components."""
    if task.shape[0] == 2:
        return cross_along(task[0], task[1], 0)
    return np.moveaxis(null_vector(np.ascontiguousarray(np.moveaxis(task, (0, 1), (-2, -1)))), -1, 0)


def _row_cofactors(task: np.ndarray, last: np.ndarray) -> np.ndarray:
    """:func:`stacked_row_cofactors` of (m, n, B) and (n, B) stacks, (m, n, B)."""
    if task.shape[0] == 2:  # C_0 = J_1 × l, C_1 = l × J_0
        cofactors = np.empty_like(task)
        cofactors[0] = cross_along(task[1], last, 0)
        cofactors[1] = cross_along(last, task[0], 0)
        return cofactors
    return _batch_last(stacked_row_cofactors(_batch_first(task), np.ascontiguousarray(last.T)))


def _adjugate_times(task: np.ndarray, last: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """:func:`adjugate_times` of (m, n, B), (n, B) and (m, B) stacks, (n, B)."""
    if task.shape[0] == 2:
        return cross_along(weights[0] * task[1] - weights[1] * task[0], last, 0)
    return adjugate_times(_batch_first(task), np.ascontiguousarray(last.T), np.ascontiguousarray(weights.T)).T


def _batch_first(stack: np.ndarray) -> np.ndarray:
    """A (..., B) stack as a contiguous (B, ...) one."""
    return np.ascontiguousarray(np.moveaxis(stack, -1, 0))


def _sums_up_to(columns: np.ndarray) -> np.ndarray:
    """Σ_{j≤k} X_j along axis 1 of (3, n, B) stacks, in place (one add per joint: numpy's cumsum on these short
    rows costs several times more)."""
    for k in range(1, columns.shape[1]):
        columns[:, k] += columns[:, k - 1]
    return columns


def _sums_after(columns: np.ndarray) -> np.ndarray:
    """Σ_{j>k} X_j along axis 1 of (3, n, B) stacks (zero at the last joint), a new array."""
    sums = np.empty_like(columns)
    sums[:, -1] = 0.0
    for k in range(columns.shape[1] - 2, -1, -1):
        np.add(sums[:, k + 1], columns[:, k + 1], out=sums[:, k])
    return sums


def _gram(jacobian: np.ndarray, task: np.ndarray) -> np.ndarray:
    """JJᵀ (B, m, m) of J given (B, m, n) and as a (m, n, B) stack; for two rows by three dot products on the
    batch axis (a view of a (2, 2, B) array, whose entries the conditions read contiguous)."""
    if task.shape[0] != 2:
        return jacobian @ np.swapaxes(jacobian, 1, 2)
    first, second = task
    gram = np.empty((2, 2, task.shape[2]))
    gram[0, 0] = _sum_first(first * first)
    gram[0, 1] = gram[1, 0] = _sum_first(first * second)
    gram[1, 1] = _sum_first(second * second)
    return np.moveaxis(gram, 2, 0)


def _diagonal_quadratic(criterion, robot: Robot):
    """(q_index, v_index, centre, curvature) of a criterion p = ½ Σ w_i (q_{a_i} − c_i)² on ``robot``: the joint
    limits of Eq. (5), or a posture's distance on a robot whose joints add; else None."""
    if isinstance(criterion, JointLimits):
        joints = criterion._limits(robot.model)
        return joints.q_index, joints.v_index, joints.middle, joints.curvature
    if isinstance(criterion, PostureDistance) and robot.euclidean:
        criterion.posture.check(robot)
        every = np.arange(robot.nv)
        return every, every, robot.configuration(criterion.posture.target), np.ones(robot.nv)
    return None


def _algorithmic_singularity(alignment: float, tolerance: float) -> SingularJacobian:
    """What stops a run where J_ex's alignment falls below ``tolerance`` (an algorithmic singularity)."""
    return SingularJacobian(
        f"extended Jacobian is singular (an algorithmic singularity of Baillieul's method): "
        f"∂G/∂q is orthogonal to the null space of J, |∂G/∂q·n|/(|∂G/∂q| |n|) = {alignment:.3g} "
        f"is below the cutoff {tolerance:.3g}"
    )


def _alignment(g_row: np.ndarray, normal: np.ndarray) -> float:
    """|∂G/∂q·n_J| / (|∂G/∂q| |n_J|), on floats (numpy costs more per call on these short vectors)."""
    row, normal = g_row.tolist(), normal.tolist()
    scale = math.sqrt(sum(map(operator.mul, row, row))) * math.sqrt(sum(map(operator.mul, normal, normal)))
    return abs(sum(map(operator.mul, row, normal))) / scale if scale > 0 else 0.0


def _hessian_criterion(value):
    if value == "manipulability":
        raise Refused("has no Hessian here; the extended Jacobian needs one: use joint-limits or a callable")
    return value


def _one_redundancy_hint(robot: Robot) -> str:
    """How to reach n − m = 1 with what torqueopt has: a task with m = n − 1, or locking joints."""
    from ...robot import TASK_DIMENSIONS

    n = robot.nv
    fitting = [task for task, m in TASK_DIMENSIONS.items() if m == n - 1]
    if fitting:
        return f"choose the task {fitting[0]} (m = {n - 1})"
    if robot.redundancy > 1:
        extra = robot.redundancy - 1
        return (
            f"lock {extra} joint{'s' if extra > 1 else ''} of the chain (--lock NAME,...) so that n = {robot.m + 1}, "
            "or choose a resolver that takes any redundancy (velocity-pinv, gradient-projection)"
        )
    return f"no task torqueopt has (m = {', '.join(str(m) for m in TASK_DIMENSIONS.values())}) has m = {n - 1}"
