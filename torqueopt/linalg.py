r"""Small dense linear algebra on top of Eigen's SVD (through eigenpy), and the inverse condition every loop records.

The pseudoinverse is SVD-based with an explicit rank cutoff, as in the paper
(which used LINPACK's SVD). The null space of the task Jacobian is kept as an
orthonormal basis :math:`Z` (n × (n − m)), so that
:math:`I - J^\dagger J = Z Z^\top` is never formed and never needs a second,
round-off-sensitive pseudoinverse.

The inverse condition :math:`\sigma_{min}/\sigma_{max}` of a matrix
(:func:`inverse_condition_number`, or :func:`inverse_condition_number_of` its
singular values) is computed here once, for one matrix or a stack of them,
for every module that records or checks it.
"""

from __future__ import annotations

import eigenpy
import numpy as np

from .errors import SingularJacobian

__all__ = [
    "JacobianSolver",
    "InverseCondition",
    "LeastSquares",
    "DEFAULT_SINGULAR_TOLERANCE",
    "inverse_condition_number",
    "inverse_condition_number_of",
    "singular_message",
    "determinants",
    "cross_along",
]

#: Relative singular-value cutoff: a task Jacobian whose smallest singular
#: value falls below this fraction of its largest is treated as singular.
DEFAULT_SINGULAR_TOLERANCE = 1e-6

_FULL_UV = eigenpy.DecompositionOptions.ComputeFullU | eigenpy.DecompositionOptions.ComputeFullV
_THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV


class JacobianSolver:
    r"""SVD :math:`J = U \Sigma V^\top` of m×n task Jacobians (m <= n), one workspace for every call.

    Calling it with an m×n Jacobian J and an m-vector r returns
    :math:`(J^\dagger r,\ Z,\ \sigma_{min}/\sigma_{max})`, with Z an
    orthonormal basis of the null space of J (n×(n−m); None when built with
    ``null_space=False``), all fresh at each call.

    Raises:
        SingularJacobian: when :math:`\sigma_{min} < \text{tolerance}\cdot\sigma_{max}`,
            since then no joint acceleration realises every task direction
            and the pseudoinverse would return torques that look fine but
            are dominated by round-off.
    """

    def __init__(self, rows: int, columns: int, tolerance: float = DEFAULT_SINGULAR_TOLERANCE, null_space: bool = True):
        self._svd = eigenpy.HhJacobiSVD(rows, columns, _FULL_UV)
        #: J's singular values (largest first) at the last :meth:`inverse_condition`.
        self.singular_values: list[float] = []
        self._rows = rows
        self._identity = np.eye(rows)
        self._tolerance = tolerance
        self._null_space = null_space
        # eigenpy returns a length-1 result as a 1×1 matrix; longer ones are already flat.
        self._flatten = columns == 1

    def __call__(self, jacobian: np.ndarray, vector: np.ndarray):
        svd = self._svd.compute(jacobian)
        inverse_condition = _checked_inverse_condition(svd.singularValues().tolist(), self._tolerance)
        particular = svd.solve(vector)
        if self._flatten:
            particular = particular.reshape(-1)
        basis = svd.matrixV()[:, self._rows :] if self._null_space else None
        return particular, basis, inverse_condition

    def pseudoinverse(self, jacobian: np.ndarray):
        r""":math:`(J^\dagger,\ \sigma_{min}/\sigma_{max})`, :math:`J^\dagger = V_m \Sigma^{-1} U^\top` (n×m, Eq. (3)),
        raising SingularJacobian as a call does."""
        inverse_condition = self.inverse_condition(jacobian)
        return self.decomposed_pseudoinverse(), inverse_condition

    def inverse_condition(self, jacobian: np.ndarray) -> float:
        r""":math:`\sigma_{min}/\sigma_{max}` of J alone, raising SingularJacobian as a call does.

        The solver keeps this decomposition of J until its next call: :meth:`solve` and
        :meth:`decomposed_pseudoinverse` read it (a caller that caches per configuration decomposes there and
        solves later, with one SVD per configuration), and its singular values in :attr:`singular_values`."""
        self.singular_values = self._svd.compute(jacobian).singularValues().tolist()
        return _checked_inverse_condition(self.singular_values, self._tolerance)

    def solve(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`J^\dagger r` for the J of the last :meth:`inverse_condition` (or of any call), Eq. (3)."""
        particular = self._svd.solve(vector)
        return particular.reshape(-1) if self._flatten else particular

    def decomposed_pseudoinverse(self) -> np.ndarray:
        r""":math:`J^\dagger` (n×m, Eq. (3)) for the J of the last :meth:`inverse_condition` (or of any call)."""
        return self._svd.solve(self._identity)


class InverseCondition:
    r""":math:`\sigma_{min}/\sigma_{max}` of m×n task Jacobians, raising SingularJacobian below ``tolerance``, by
    Eigen's SVD without its singular vectors: for a caller that needs J's rank and condition, not
    :math:`J^\dagger`. The singular values are those :class:`JacobianSolver` computes, bit for bit (the tests
    hold them equal)."""

    def __init__(self, rows: int, columns: int, tolerance: float = DEFAULT_SINGULAR_TOLERANCE):
        self._svd = eigenpy.HhJacobiSVD(rows, columns, 0)
        self._tolerance = tolerance

    def __call__(self, jacobian: np.ndarray) -> float:
        return _checked_inverse_condition(self._svd.compute(jacobian).singularValues().tolist(), self._tolerance)


class PseudoInverse:
    r""":math:`J^\dagger = V_m \Sigma^{-1} U^\top` (n×m) of m×n matrices of full row rank, by Eigen's SVD, one workspace."""

    def __init__(self, rows: int, columns: int):
        self._svd = eigenpy.HhJacobiSVD(rows, columns, _THIN_UV)
        self._identity = np.eye(rows)

    def __call__(self, matrix: np.ndarray) -> np.ndarray:
        return self._svd.compute(matrix).solve(self._identity)


def _checked_inverse_condition(singular_values, tolerance: float) -> float:
    r"""σ_min/σ_max of singular values sorted largest first, or SingularJacobian below ``tolerance``.

    Above the cutoff every singular value is far above Eigen's own rank
    threshold (min(m, n)·ε), so the SVD's ``solve`` is exactly
    :math:`V_m \Sigma^{-1} U^\top r`.
    """
    ratio = inverse_condition_number_of(singular_values)
    if not ratio >= tolerance:
        raise SingularJacobian(singular_message(ratio, tolerance))
    return ratio


def inverse_condition_number_of(singular_values):
    r""":math:`\sigma_{min}/\sigma_{max}` from singular values sorted largest first (along the last axis), 0 where
    :math:`\sigma_{max} = 0`: the reciprocal of the condition number, in [0, 1].

    A float for one sequence (a list or a 1-D array), an array for a stack of them (…, k).
    """
    if isinstance(singular_values, np.ndarray) and singular_values.ndim > 1:
        largest = singular_values[..., 0]
        return np.divide(singular_values[..., -1], largest, out=np.zeros_like(largest), where=largest > 0)
    largest = singular_values[0]
    return float(singular_values[-1] / largest) if largest > 0 else 0.0


def inverse_condition_number(matrix: np.ndarray):
    r""":math:`\sigma_{min}/\sigma_{max}` of a matrix (a float) or of each matrix of a stack (…, r, c) (an array),
    0 for a zero matrix; by numpy's SVD (:func:`inverse_condition_number_of`)."""
    return inverse_condition_number_of(np.linalg.svd(matrix, compute_uv=False))


def determinants(matrices: np.ndarray) -> np.ndarray:
    r"""det of each k×k matrix of a (…, k, k) stack: by the Leibniz formula for k <= 3, elementwise on the
    stack, else by LAPACK (``np.linalg.det``, whose per-call cost dominates for these small matrices).

    For k = 3, the rule of Sarrus: :math:`a(ei - fh) - b(di - fg) + c(dh - eg)`.
    """
    size = matrices.shape[-1]
    if size == 1:
        return matrices[..., 0, 0].copy()
    if size == 2:
        return matrices[..., 0, 0] * matrices[..., 1, 1] - matrices[..., 0, 1] * matrices[..., 1, 0]
    if size == 3:
        (a, b, c), (d, e, f), (g, h, i) = (
            (matrices[..., row, 0], matrices[..., row, 1], matrices[..., row, 2]) for row in range(3)
        )
        return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return np.linalg.det(matrices)


#: The components of a 3-vector twice over up to the fifth, (0, 1, 2, 0, 1): slices 1:4 and 2:5 are its cyclic shifts.
_TWICE = np.array([0, 1, 2, 0, 1])


def cross_along(a: np.ndarray, b: np.ndarray, axis: int) -> np.ndarray:
    r"""a × b along ``axis`` (>= 0) of stacks of 3-vectors (broadcast), a new array:
    :math:`a_{i+1}b_{i+2} - a_{i+2}b_{i+1}` (indices mod 3), the cyclic shifts read as views of each operand taken
    once as (0, 1, 2, 0, 1), five numpy calls for any stack. For stacks with the components first (axis 0, the
    rows last) the takes copy whole blocks; along a later axis they copy one short run per row, which costs more
    than a product by components (``robot_copies.stacked_cross``) on a few hundred rows."""
    a, b = a.take(_TWICE, axis), b.take(_TWICE, axis)
    leading = (slice(None),) * axis
    first, second = (*leading, slice(1, 4)), (*leading, slice(2, 5))
    product = a[first] * b[second]
    product -= a[second] * b[first]
    return product


def singular_message(inverse_condition: float, tolerance: float) -> str:
    """What :class:`~torqueopt.errors.SingularJacobian` says of a Jacobian whose σ_min/σ_max fell below ``tolerance``."""
    return (
        f"task Jacobian is singular: smallest/largest singular value {inverse_condition:.3g} "
        f"is below the cutoff {tolerance:.3g}"
    )


class LeastSquares:
    r"""Minimum-norm :math:`y` minimising :math:`\|A y - b\|` for r×c matrices A, with relative rank cutoff.

    Singular values of A below ``tolerance`` times the largest are dropped,
    so directions that only round-off supports never enter the answer. One
    object keeps its SVD from call to call, so a loop allocates it once.
    """

    def __init__(self, rows: int, columns: int, tolerance: float = 1e-12):
        self._svd = eigenpy.HhJacobiSVD(rows, columns, _THIN_UV)
        self._svd.setThreshold(tolerance)

    def __call__(self, matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        return self._svd.compute(matrix).solve(rhs).reshape(-1)
