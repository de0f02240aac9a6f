r"""The bounded resolvers' programs, solved by DAQP: one workspace per program, the min-max torque LP, the range basis.

Each program is set up once per run (``_Program``) and only its
numbers change at each step, with the previous step's active set as the
warm start; every LP answer is certified by its own multipliers. The LPs
run on an orthonormal basis of the range of :math:`HZ` (``_RangeBasis``)
rather than on :math:`y` of Eq. (26) itself.
"""

from __future__ import annotations

from typing import NamedTuple

import eigenpy
import numpy as np

from ...errors import MissingDependency, SolverFailure
from ..base import Program

__all__ = [
    "BOUND_MARGIN",
    "FEASIBILITY_TOLERANCE",
    "BoundProgram",
    "minmax_torque_rows",
    "solve_program",
    "torque_bound_rows",
    "with_rows",
]

#: Feasibility tolerance of every bound row, as a fraction of the joint's torque range.
FEASIBILITY_TOLERANCE = 1e-9
#: The variables of the min-max LP a step records (``Resolution.program``).
MINMAX_VARIABLES = "(z, t): τ = τ̃ + U z with U an orthonormal basis of the range of HZ; t the largest normalised torque"
#: How far inside each torque range [fraction of τ⁺ − τ⁻] the bounds given to DAQP lie.
BOUND_MARGIN = 10 * FEASIBILITY_TOLERANCE


def _lapack_solve(matrix, right_side):
    """LAPACK's gesv (numpy's solve costs 5x on 2 × 2), imported on the first call: scipy.linalg's import takes
    0.3-0.6 s, which every start of the command line would otherwise pay."""
    global _lapack_solve
    from scipy.linalg.lapack import dgesv

    _lapack_solve = dgesv
    return dgesv(matrix, right_side)


_THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV
_EXIT_OPTIMAL = 1
_EXIT_INFEASIBLE = -1
_EXIT_NAMES = {
    -2: "cycling",
    -3: "unbounded",
    -4: "iteration limit",
    -5: "non-convex",
    -6: "overdetermined initial active set",
}


def _exit_words(flag: int) -> str:
    """DAQP's exit flag in words, with the number: 'cycling (-2)'."""
    return f"{_EXIT_NAMES.get(flag, 'exit flag')} ({flag})"


def _daqp():
    try:
        import daqp
    except ImportError:  # pragma: no cover - daqp is a core dependency
        raise MissingDependency("the bounded resolvers need the QP solver DAQP: pip install daqp") from None
    return daqp


class BoundProgram(NamedTuple):
    r"""A bounded resolver's program: :math:`\min_x \tfrac12 x^\top H x + f^\top x` s.t. :math:`l \le A x \le u`.

    What a resolver returns for one state (``rows`` (k × v)), or for a stack
    with a leading batch axis on every array (``rows`` (B, k, v)); ``row(i)``
    is one movement's program. ``hessian`` or ``cost`` None keep the numbers
    the workspace was set up with (an LP's zero Hessian, a fixed cost). A
    workspace's first ``bounds`` rows of ``upper``/``lower`` are simple bounds on
    the first variables (:class:`_Program`).
    """

    hessian: np.ndarray | None
    cost: np.ndarray | None
    rows: np.ndarray
    upper: np.ndarray
    lower: np.ndarray

    def row(self, index: int) -> BoundProgram:
        """Movement ``index``'s program of a stacked one."""
        return BoundProgram(*(None if field is None else field[index] for field in self))


def solve_program(workspace: _Program, program: BoundProgram):
    """(x, exit flag) of ``program`` in its DAQP ``workspace``: warm start, then a cold start, then HiGHS
    (:meth:`_Program.solve`, the one place where the fall-backs live)."""
    numbers = {"A": program.rows, "bupper": program.upper, "blower": program.lower}
    if program.hessian is not None:
        numbers["H"] = program.hessian
    if program.cost is not None:
        numbers["f"] = program.cost
    x, flag, _ = workspace.solve(**numbers)
    return x, flag


def torque_bound_rows(inertia_basis, tilde_torque, bounded, upper, lower, spread):
    r"""(rows, upper, lower) of the torque bounds :math:`\tau^- \le \tilde\tau + HZ y \le \tau^+` on y, each row
    divided by its joint's range (Eq. (27)): ``inertia_basis`` HZ (n × r) or a stack (B, n, r), ``tilde_torque``
    τ̃ (n) or (B, n); ``upper``, ``lower`` and ``spread`` of the ``bounded`` joints (:func:`~torqueopt.resolvers.bounded.infeasible.solver_bounds`)."""
    rows = inertia_basis[..., bounded, :] * (1.0 / spread)[:, None]
    base = tilde_torque[..., bounded]
    return rows, (upper - base) / spread, (lower - base) / spread


def with_rows(program_rows, extra):
    """(rows, upper, lower) followed by the ``extra`` (rows, upper, lower), for one state or a stack."""
    rows, upper, lower = program_rows
    return (
        np.concatenate([rows, extra[0]], axis=-2),
        np.concatenate([upper, extra[1]], axis=-1),
        np.concatenate([lower, extra[2]], axis=-1),
    )


def minmax_torque_rows(range_rows, tilde_torque, bounded, middle, inverse_spread):
    r"""(:math:`U_i/(\tau^+_i - \tau^-_i)`, :math:`(\tau_{mid,i} - \tilde\tau_i)/(\tau^+_i - \tau^-_i)`) of the
    bounded joints, for the min-max LP's rows :math:`\pm(\tilde\tau_i + U_i z - \tau_{mid,i}) \le t(\tau^+_i - \tau^-_i)`:
    ``range_rows`` U (n × r) or a stack (B, n, r), ``tilde_torque`` τ̃ (n) or (B, n), ``middle`` the bounded joints'
    τ_mid and ``inverse_spread`` their 1/(τ⁺ − τ⁻)."""
    return range_rows[..., bounded, :] * inverse_spread[:, None], (middle - tilde_torque[..., bounded]) * inverse_spread


class _Program:
    r"""One DAQP workspace: set up once with the problem's shape, then only its numbers change.

    An LP (``linear=True``, zero Hessian) is solved by DAQP's proximal-point
    iterations; their default stopping rule can end a few iterations short of
    the optimum on these degenerate LPs (measured: 1e-5 short of the largest
    task scaling on panda), so LPs run with a tight proximal tolerance and
    every LP answer is certified by its own multipliers: dual feasibility and
    stationarity :math:`c + A^\top\lambda = 0` of the LP itself, not of the
    last proximal subproblem. An answer that fails the certificate raises
    :class:`~torqueopt.errors.SolverFailure` rather than being used.

    Even with the tight tolerance the proximal iterations stop up to about
    3e-8 from the vertex (measured on planar3's min-max LP), which is the
    LP's answer's own noise: a run and its batched twin, at states equal to
    1e-13, then differ by that much. A certified LP answer is therefore moved
    onto the exact vertex of its active rows (those with a nonzero
    multiplier, on the side the multiplier's sign says, one per variable),
    when that vertex is within the rows' tolerance and near DAQP's answer;
    otherwise (a degenerate vertex) DAQP's answer stands.
    """

    def __init__(self, hessian, cost, rows, upper, lower, bounds: int = 0, linear: bool = False):
        daqp = _daqp()
        self._model = daqp.Model()
        settings = {"primal_tol": FEASIBILITY_TOLERANCE}
        if linear:
            settings["eta_prox"] = 1e-12
        self._model.settings = self._settings = settings
        self._hessian = hessian
        self._linear = linear
        self._bounds = bounds
        self._cost = np.asarray(cost, dtype=float)
        self._stationarity_tolerance = 1e-7 * (1.0 + np.abs(self._cost).max())
        self._rows = rows
        self._upper, self._lower = np.asarray(upper, dtype=float), np.asarray(lower, dtype=float)
        flag = self._model.setup(hessian, cost, rows, upper, lower, np.zeros(rows.shape[0] + bounds, dtype=np.int32))[0]
        if flag < 0:  # pragma: no cover - the shapes are ours
            raise SolverFailure(f"DAQP setup failed with exit flag {flag}")

    def solve(self, **numbers):
        """(x, exit flag, multipliers) after replacing the given numbers (H, f, A, bupper, blower).

        A program on which DAQP fails (cycling, its iteration limit) from the previous step's active set is
        solved again by DAQP from a cold start, in a new workspace that the next steps warm-start from. An LP it
        still fails on is solved by HiGHS (:func:`_highs_lp`; measured on ``minmax-torque``'s LP on tiago and
        baxter, where the run used to stop), a QP by HiGHS's QP solver (:func:`_casadi_qp`; measured on
        ``energy-bounded-torque``'s QP on a tiago circle, which cycles from a cold start too); their answers meet
        the same checks (and an LP's, the same certificate). Where those fail too,
        :class:`~torqueopt.errors.SolverFailure` says so.
        """
        self._model.update(**numbers)
        self._hessian = numbers.get("H", self._hessian)
        self._cost = np.asarray(numbers.get("f", self._cost), dtype=float)
        x, _, flag, info = self._model.solve()
        rows = self._rows = numbers.get("A", self._rows)
        upper = self._upper = numbers.get("bupper", self._upper)
        lower = self._lower = numbers.get("blower", self._lower)
        bounds = self._bounds
        if flag != _EXIT_OPTIMAL and flag != _EXIT_INFEASIBLE:
            failure = f"DAQP failed: {_exit_words(flag)}"
            x, flag, info = self._cold_solve()
            if flag in (_EXIT_OPTIMAL, _EXIT_INFEASIBLE):
                multipliers = info["lam"]
            elif self._linear:
                x, flag, multipliers = _highs_lp(self._cost, rows, upper, lower, bounds, failure)
            else:
                failure += f", and from a cold start: {_exit_words(flag)}"
                x, flag, multipliers = _casadi_qp(self._hessian, self._cost, rows, upper, lower, bounds, failure)
        else:
            multipliers = info["lam"]
        if flag == _EXIT_OPTIMAL:
            # DAQP's updated workspace can miss an infeasible row whose coefficients are near zero (a torque
            # the null space barely moves, held beyond its bound by the task: measured on planar3's joint 3,
            # its row of HZ 5e-5 of the largest) and report the unconstrained optimum, which breaks that row
            # (by 23 % of the limit there). Such an answer is infeasible.
            values = rows.dot(x)
            excess = max((values - upper[bounds:]).max(), (lower[bounds:] - values).max())
            if bounds:
                excess = max(excess, (x[:bounds] - upper[:bounds]).max(), (lower[:bounds] - x[:bounds]).max())
            if excess > BOUND_MARGIN:
                return x, _EXIT_INFEASIBLE, multipliers
        if self._linear and flag == _EXIT_OPTIMAL:
            stationarity = self._cost + rows.T.dot(multipliers[bounds:])
            if bounds:
                stationarity[:bounds] += multipliers[:bounds]
            residual = np.abs(stationarity).max()
            if residual > self._stationarity_tolerance:
                raise SolverFailure(
                    f"DAQP's LP answer fails its optimality certificate (stationarity residual {residual:.2g})"
                )
            x = self._vertex(x, multipliers)
        self._multipliers = multipliers
        return x, flag, multipliers

    def solved(self, solution, torque_offset, torque_rows, variables: str) -> Program:
        r"""The program of the last :meth:`solve` with its ``solution`` x, as a :class:`~torqueopt.resolvers.Program`
        (copies: the workspace's numbers change at the next step), its simple bounds written as unit rows.

        ``torque_offset`` :math:`\tau_0` and ``torque_rows`` T give the torque :math:`\tau_0 + T x` of a point x.
        """
        bounds, rows = self._bounds, np.array(self._rows, dtype=float)
        if bounds:
            rows = np.vstack([np.eye(bounds, rows.shape[1]), rows])
        hessian = np.array(self._hessian, dtype=float)
        return Program(
            hessian, self._cost.copy(), rows, self._lower.copy(), self._upper.copy(), np.array(solution, dtype=float),
            np.array(self._multipliers, dtype=float), np.array(torque_offset, dtype=float),
            np.array(torque_rows, dtype=float), variables,
        )  # fmt: skip

    def _cold_solve(self):
        """(x, exit flag, info) of the current program in a new DAQP workspace, no active set carried over."""
        model = _daqp().Model()
        model.settings = self._settings
        sense = np.zeros(self._rows.shape[0] + self._bounds, dtype=np.int32)
        flag = model.setup(self._hessian, self._cost, self._rows, self._upper, self._lower, sense)[0]
        if flag < 0:  # pragma: no cover - the shapes are ours
            raise SolverFailure(f"DAQP setup failed with exit flag {flag}")
        self._model = model
        x, _, flag, info = model.solve()
        return x, flag, info

    def _vertex(self, x, multipliers):
        """The exact vertex of the LP's active rows when it is one and is as feasible as DAQP's ``x``; else ``x``.

        (A row is active at a finite bound only: DAQP never activates an infinite one.)"""
        active = multipliers.nonzero()[0]
        if active.size != x.size:
            return x
        rows = self._rows if not self._bounds else np.vstack([np.eye(self._bounds, x.size), self._rows])
        upper, lower = self._upper, self._lower
        side = np.where(multipliers[active] > 0, upper[active], lower[active])
        _, _, vertex, singular = _lapack_solve(rows[active], side)
        if singular:
            return x
        values = rows.dot(vertex)
        tolerance = FEASIBILITY_TOLERANCE
        if (
            (values - upper).max() <= tolerance
            and (lower - values).max() <= tolerance
            and np.abs(vertex - x).max() <= 1e-6 * (1.0 + np.abs(x).max())
        ):
            return vertex
        return x


def _highs_lp(cost, rows, upper, lower, bounds: int, failure: str):
    r"""(x, exit flag, multipliers) of DAQP's LP form by HiGHS (``scipy.optimize.linprog``), with DAQP's signs.

    The LP is :math:`\min c^\top x` s.t. :math:`l_i \le x_i \le u_i` for the first ``bounds`` variables and
    :math:`l \le A x \le u` (rows of ``upper``/``lower`` after the first ``bounds``). The multipliers follow
    DAQP's convention, :math:`c + [I; A]^\top\lambda = 0` with :math:`\lambda > 0` on an active upper bound
    and :math:`< 0` on an active lower one: from HiGHS's marginals (the objective's sensitivity to each bound),
    :math:`\lambda = -\partial f^*/\partial u - \partial f^*/\partial l`.
    """
    from scipy.optimize import linprog

    upper_rows, lower_rows = upper[bounds:], lower[bounds:]
    has_upper, has_lower = np.isfinite(upper_rows), np.isfinite(lower_rows)
    inequality_rows = np.vstack([rows[has_upper], -rows[has_lower]])
    inequality_bounds = np.r_[upper_rows[has_upper], -lower_rows[has_lower]]
    box = [(lower[i] if np.isfinite(lower[i]) else None, upper[i] if np.isfinite(upper[i]) else None)
           for i in range(bounds)]  # fmt: skip
    box += [(None, None)] * (cost.size - bounds)
    answer = linprog(cost, A_ub=inequality_rows, b_ub=inequality_bounds, bounds=box, method="highs")
    if answer.status == 2:
        return np.zeros(cost.size), _EXIT_INFEASIBLE, np.zeros(bounds + rows.shape[0])
    if answer.status != 0:
        raise SolverFailure(f"{failure}; HiGHS too: {answer.message}")
    multipliers = np.zeros(bounds + rows.shape[0])
    marginals = answer.ineqlin.marginals
    multipliers[bounds:][has_upper] -= marginals[: has_upper.sum()]
    multipliers[bounds:][has_lower] += marginals[has_upper.sum() :]
    multipliers[:bounds] = -answer.upper.marginals[:bounds] - answer.lower.marginals[:bounds]
    return answer.x, _EXIT_OPTIMAL, multipliers


def _casadi_qp(hessian, linear_term, rows, upper, lower, bounds: int, failure: str):
    r"""(x, exit flag, multipliers) of DAQP's QP form by HiGHS's QP solver (through CasADi's ``conic``).

    The QP is :math:`\min \tfrac12 x^\top H x + f^\top x` s.t. :math:`l_i \le x_i \le u_i` for the first
    ``bounds`` variables and :math:`l \le A x \le u`. CasADi's multipliers already follow DAQP's convention,
    :math:`Hx + f + [I; A]^\top\lambda = 0` with :math:`\lambda > 0` on an active upper bound. (CasADi's own
    ``qrqp`` fails on the degenerate QP that made DAQP cycle on a tiago circle; its qpOASES answers it but prints
    its banner on standard output each time one is made.)
    """
    import casadi

    variables = linear_term.size
    hessian_matrix, row_matrix = casadi.DM(np.asarray(hessian, dtype=float)), casadi.DM(np.asarray(rows, dtype=float))
    solver = casadi.conic(
        "fallback", "highs", {"h": hessian_matrix.sparsity(), "a": row_matrix.sparsity()},
        {"highs": {"output_flag": False}, "error_on_fail": False},
    )  # fmt: skip
    box_lower, box_upper = np.full(variables, -np.inf), np.full(variables, np.inf)
    box_lower[:bounds], box_upper[:bounds] = lower[:bounds], upper[:bounds]
    answer = solver(
        h=hessian_matrix, g=linear_term, a=row_matrix, lba=lower[bounds:], uba=upper[bounds:], lbx=box_lower,
        ubx=box_upper,
    )  # fmt: skip
    status = solver.stats()
    if not status["success"]:
        if "INFEASIB" in str(status.get("return_status", "")).upper():
            return np.zeros(variables), _EXIT_INFEASIBLE, np.zeros(bounds + rows.shape[0])
        raise SolverFailure(f"{failure}; HiGHS too: {status.get('return_status', 'failed')}")
    multipliers = np.r_[np.asarray(answer["lam_x"]).ravel()[:bounds], np.asarray(answer["lam_a"]).ravel()]
    return np.asarray(answer["x"]).ravel(), _EXIT_OPTIMAL, multipliers


class _RangeBasis:
    r"""An orthonormal basis U of the range of :math:`G = HZ` (n × (n − m)), and y from a torque change in it.

    The LPs and the policies' programs run on :math:`\tau = \tilde\tau + U z`
    rather than on :math:`\tau = \tilde\tau + G y`: G's singular values span
    the inertia's range (on xarm7, from 4e-3 to 4e-6 per N·m of range), which
    no LP tolerance survives (DAQP reports such LPs unbounded), while U's
    rows are bounded by 1. Then :math:`y = G^+ U z` (Eigen's SVD, the same
    decomposition that gave U).
    """

    def __init__(self, rows: int, columns: int):
        # One column (n − m = 1): U = G/‖G‖, with no SVD (eigenpy returns a full U for a column).
        self._svd = eigenpy.HhJacobiSVD(rows, columns, _THIN_UV) if columns > 1 else None
        self._column = None

    def __call__(self, inertia_basis: np.ndarray) -> np.ndarray:
        if self._svd is None:
            self._column = inertia_basis[:, 0]
            return inertia_basis / np.linalg.norm(self._column)
        return self._svd.compute(inertia_basis).matrixU()

    def coordinates(self, torque_change: np.ndarray) -> np.ndarray:
        """y with G y = ``torque_change`` (a vector in the range of G, the G of the last call)."""
        if self._svd is None:
            column = self._column
            return np.array([column.dot(torque_change) / column.dot(column)])
        return self._svd.solve(torque_change)


class _MinMax:
    r"""The LP :math:`\min_{z,t} t` s.t. :math:`|\tilde\tau_i + (Uz)_i - \tau_{mid,i}| \le t\,(\tau^+_i - \tau^-_i)`.

    With ``extra_rows`` > 0 it also takes that many general rows on z
    (:math:`l \le A z \le u`, the joint limits' bounds on q̈), given at each
    call; then it can be infeasible.
    """

    def __init__(self, bounded, spread, midpoint, redundancy: int, extra_rows: int = 0):
        nb = spread.size
        self._bounded = bounded
        self._midpoint = midpoint[bounded]
        self._inverse_spread = 1.0 / spread
        self._r = redundancy
        sign = np.r_[-np.ones(nb), np.ones(nb), np.zeros(extra_rows)][:, None]
        rows = np.hstack([np.zeros((2 * nb + extra_rows, redundancy)), sign])
        upper = np.r_[np.zeros(nb), np.full(nb + extra_rows, np.inf)]
        lower = np.r_[np.full(nb, -np.inf), np.zeros(nb), np.full(extra_rows, -np.inf)]
        self._rows, self._upper, self._lower = rows, upper, lower
        # Views made once: each call writes the numbers into them in place.
        self._rows_plus, self._rows_minus = rows[:nb, :redundancy], rows[nb : 2 * nb, :redundancy]
        self._upper_plus, self._lower_minus = upper[:nb], lower[nb : 2 * nb]
        self._extra = extra_rows
        self._rows_extra, self._upper_extra, self._lower_extra = (
            rows[2 * nb :, :redundancy],
            upper[2 * nb :],
            lower[2 * nb :],
        )
        self.program = _Program(
            np.zeros((redundancy + 1, redundancy + 1)),
            np.r_[np.zeros(redundancy), 1.0],
            rows,
            upper,
            lower,
            linear=True,
        )

    def __call__(self, range_basis, tilde_torque, extra=None):
        """(z, t) minimising the largest normalised torque t over τ = τ̃ + U z (U: ``range_basis``).

        Row i: (U_i z − t) ≤ −c_i and (U_i z + t) ≥ −c_i, with U_i and c_i = τ̃_i − τ_mid,i divided by the range.
        ``extra``: (rows, upper, lower) of the extra rows on z (None: they bound nothing); t is
        None when they leave no z.
        """
        self._rows_plus[...], self._upper_plus[...] = minmax_torque_rows(
            range_basis, tilde_torque, self._bounded, self._midpoint, self._inverse_spread
        )
        self._rows_minus[...] = self._rows_plus
        self._lower_minus[...] = self._upper_plus
        if self._extra:
            if extra is None:
                self._rows_extra[...], self._upper_extra[...], self._lower_extra[...] = 0.0, np.inf, -np.inf
            else:
                self._rows_extra[...], self._upper_extra[...], self._lower_extra[...] = extra
        x, flag = solve_program(self.program, BoundProgram(None, None, self._rows, self._upper, self._lower))
        if flag != _EXIT_OPTIMAL:
            if self._extra and flag == _EXIT_INFEASIBLE:
                return x[: self._r], None
            raise SolverFailure("the min-max torque LP failed")  # pragma: no cover - t large enough is always feasible
        return x[: self._r], x[self._r]

    def solved(self, z, utilisation, tilde_torque, range_basis) -> Program:
        """The LP of the last call with its answer (z, t): τ = τ̃ + U z (t moves no torque)."""
        torque_rows = np.hstack([range_basis, np.zeros((range_basis.shape[0], 1))])
        return self.program.solved(np.r_[z, utilisation], tilde_torque, torque_rows, MINMAX_VARIABLES)
