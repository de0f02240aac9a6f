r"""Small dense linear algebra on top of Eigen's SVD (through eigenpy).

The pseudoinverse is SVD-based with an explicit rank cutoff, as in the paper
(which used LINPACK's SVD). The null space of the task Jacobian is kept as an
orthonormal basis :math:`Z` (n × (n − m)), so that
:math:`I - J^\dagger J = Z Z^\top` is never formed and never needs a second,
round-off-sensitive pseudoinverse.
"""

from __future__ import annotations

import eigenpy
import numpy as np

from .errors import SingularJacobian

__all__ = ["JacobianDecomposition", "LeastSquares", "least_squares", "solve_positive_definite", "DEFAULT_SINGULAR_TOLERANCE"]

#: Relative singular-value cutoff: a task Jacobian whose smallest singular
#: value falls below this fraction of its largest is treated as singular.
DEFAULT_SINGULAR_TOLERANCE = 1e-6

_FULL_UV = eigenpy.DecompositionOptions.ComputeFullU | eigenpy.DecompositionOptions.ComputeFullV
_THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV


class JacobianDecomposition:
    r"""SVD :math:`J = U \Sigma V^\top` of an m×n task Jacobian (m <= n).

    Attributes:
        singular_values: the m singular values, largest first.
        null_space_basis: orthonormal basis of the null space of J (n×(n−m)).
        condition: :math:`\sigma_{min} / \sigma_{max}` (0 at a singularity).

    Args:
        svd: an ``eigenpy.HhJacobiSVD`` made by :meth:`workspace`, reused
            from one call to the next in a loop (a fresh one when None); its
            results are copied out, so decompositions never share memory.

    Raises:
        SingularJacobian: when :math:`\sigma_{min} < \text{tolerance}\cdot\sigma_{max}`,
            since then no joint acceleration realises every task direction
            and the pseudoinverse would return torques that look fine but
            are dominated by round-off.
    """

    def __init__(self, jacobian: np.ndarray, tolerance: float = DEFAULT_SINGULAR_TOLERANCE, svd=None):
        rows = jacobian.shape[0]
        if svd is None:
            svd = eigenpy.HhJacobiSVD(jacobian, _FULL_UV)
        else:
            svd.compute(jacobian)
        singular_values = svd.singularValues()
        largest = singular_values[0]
        self.condition = singular_values[-1] / largest if largest > 0 else 0.0
        if not self.condition >= tolerance:
            raise SingularJacobian(
                f"task Jacobian is singular: smallest/largest singular value {self.condition:.3g} "
                f"is below the cutoff {tolerance:.3g}"
            )
        self.singular_values = singular_values
        self._u = svd.matrixU()
        v = svd.matrixV()
        self._v_range = v[:, :rows]
        self.null_space_basis = v[:, rows:]

    @staticmethod
    def workspace(rows: int, columns: int):
        """An SVD of an m×n matrix to pass as ``svd``, so a loop allocates it once."""
        return eigenpy.HhJacobiSVD(rows, columns, _FULL_UV)

    def pseudo_inverse_apply(self, vector: np.ndarray) -> np.ndarray:
        r""":math:`J^\dagger r = V_m \Sigma^{-1} U^\top r`."""
        return self._v_range.dot(self._u.T.dot(vector) / self.singular_values)


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


def least_squares(matrix: np.ndarray, rhs: np.ndarray, tolerance: float = 1e-12) -> np.ndarray:
    r"""Minimum-norm :math:`y` minimising :math:`\|A y - b\|`, with relative rank cutoff; see :class:`LeastSquares`."""
    return LeastSquares(*matrix.shape, tolerance)(matrix, rhs)


def solve_positive_definite(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """:math:`A^{-1} b` for a symmetric positive definite A and a vector b, by Cholesky (Eigen's LLT).

    Raises:
        numpy.linalg.LinAlgError: A is not positive definite.
    """
    factor = eigenpy.LLT(matrix)
    if factor.info() != eigenpy.ComputationInfo.Success:
        raise np.linalg.LinAlgError(f"matrix is not positive definite: {matrix.tolist()}")
    return factor.solve(rhs).reshape(-1)
