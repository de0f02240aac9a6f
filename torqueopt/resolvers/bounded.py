r"""Resolvers with hard torque bounds: a QP (``bounded-torque``) and the paper's LP (``minmax-torque``).

Both work in the null-space coordinates of Eq. (26): with the particular
solution :math:`p = J^\dagger(\ddot x - \dot J\dot q)`, an orthonormal basis
:math:`Z` of the null space of :math:`J` and :math:`y \in \mathbb{R}^{n-m}`,

.. math::

    \ddot q = p + Z y, \qquad
    \tau = \tilde\tau + H Z y, \qquad
    \tilde\tau = H p + \dot q\cdot C\cdot\dot q + g \quad\text{(Eq. (27), Eq. (28))},

so every :math:`y` realises the task and the bounds
:math:`\tau^- \le \tau \le \tau^+` are :math:`2\,n_b` general inequalities
on n − m variables (:math:`n_b` joints with finite limits; a joint without a
limit has no bound rows). Each row is divided by the joint's torque range
:math:`\tau^+_i - \tau^-_i`, so the solver's feasibility tolerance (DAQP's
``primal_tol``, :data:`FEASIBILITY_TOLERANCE`) is a fraction of each range.

The solver is DAQP (Arnström, Bemporad & Axehill, IEEE TAC 67(8), 2022), a
dual active-set method for small dense QPs that also solves LPs, called
through its ``daqp.Model`` workspace: each program is set up once per run
and only its numbers change at each step, with the previous step's active
set as the warm start. BENCHMARKS.md has the measurements behind the choice
(DAQP against proxsuite, quadprog and HiGHS on these problems) and the
comparison with a formulation in :math:`\ddot q` with the task as equality.

When no torque within the bounds realises the task, the ``infeasible``
option says what to do (the step is marked infeasible either way and its
task error recorded):

``scale`` (default)
    the largest task-acceleration scaling :math:`s \in [0, 1]` for which
    :math:`\ddot q = J^\dagger(s\ddot x - \dot J\dot q) + Z y` has a torque
    within bounds (an LP in :math:`(s, y)`), then the resolver's own optimum
    at :math:`s\ddot x`: the optimal task scaling of Flacco, De Luca &
    Khatib, "Motion control of redundant robots under joint constraints:
    saturation in the null space", ICRA 2012. The direction of the task
    acceleration is kept; task error :math:`(1 - s)\|\ddot x\|`.
``least-error``
    the task acceleration :math:`a` closest to :math:`\ddot x`,
    :math:`\min \|a - \ddot x\|` over the torques within bounds (a QP in
    :math:`(a, y)`; it is always feasible: H is invertible, so every torque
    in the box is some :math:`(a, y)`), then the resolver's optimum at
    :math:`a`. Task error :math:`\|a - \ddot x\|`.
``exceed``
    realise the task with the torque of least largest normalised excess
    (the ``minmax-torque`` LP); torques leave their bounds, the step is
    flagged, task error 0.
``stop``
    raise :class:`~torqueopt.errors.TorqueBoundsInfeasible`; inside
    :func:`torqueopt.simulate` the run stops there and says why.

With ``scale``, a state where even :math:`s = 0` has no torque within bounds
(the velocity or gravity torques alone beyond a limit while the tip is held
on its path) gets the ``least-error`` answer: the torque stays within bounds
and the tip leaves its path, the step flagged with its task error. Only
``stop`` ends a run, and only ``exceed`` leaves the bounds.

The LPs and the policies' programs use an orthonormal basis of the range of
:math:`HZ` instead of :math:`y` itself (see :class:`_RangeBasis`).
"""

from __future__ import annotations

import eigenpy
import numpy as np

from ..errors import InvalidInput, MissingDependency, NoRedundancy, SolverFailure, TorqueBoundsInfeasible
from ..linalg import JacobianSolver
from ..robot import Robot, TaskTerms
from .base import Resolution, Resolver, Step
from .damping import DEFAULT_DAMPING, DEFAULT_KINEMATIC_WEIGHT
from .null_space import torque_midpoint
from .options import Option, OptionValueError, choice_or_vector, number

__all__ = [
    "FEASIBILITY_TOLERANCE",
    "INFEASIBLE_POLICIES",
    "BoundedTorque",
    "MinMaxTorque",
    "torque_utilisation",
]

#: What a bounded resolver does when no torque within bounds realises the task.
INFEASIBLE_POLICIES = ("scale", "least-error", "exceed", "stop")
#: Feasibility tolerance of every bound row, as a fraction of the joint's torque range.
FEASIBILITY_TOLERANCE = 1e-9
#: How far inside each torque range [fraction of τ⁺ − τ⁻] the bounds given to DAQP lie.
BOUND_MARGIN = 10 * FEASIBILITY_TOLERANCE
#: ``torque_weight`` names: the identity, or the torque-range weight of Eq. (33).
TORQUE_WEIGHTS = ("unit", "range")
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


def _daqp():
    try:
        import daqp
    except ImportError:  # pragma: no cover - daqp is a core dependency
        raise MissingDependency("the bounded resolvers need the QP solver DAQP: pip install daqp") from None
    return daqp


def _policy(value) -> str:
    """Converter of the ``infeasible`` option."""
    text = str(value).strip() if isinstance(value, str) else value
    if text not in INFEASIBLE_POLICIES:
        raise OptionValueError(f"must be one of {', '.join(INFEASIBLE_POLICIES)}")
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
    """

    def __init__(self, hessian, cost, rows, upper, lower, bounds: int = 0, linear: bool = False):
        daqp = _daqp()
        self._model = daqp.Model()
        settings = {"primal_tol": FEASIBILITY_TOLERANCE}
        if linear:
            settings["eta_prox"] = 1e-12
        self._model.settings = settings
        self._linear = linear
        self._bounds = bounds
        self._cost = np.asarray(cost, dtype=float)
        self._rows = rows
        flag = self._model.setup(hessian, cost, rows, upper, lower, np.zeros(rows.shape[0] + bounds, dtype=np.int32))[0]
        if flag < 0:  # pragma: no cover - the shapes are ours
            raise SolverFailure(f"DAQP setup failed with exit flag {flag}")

    def solve(self, **numbers):
        """(x, exit flag, multipliers) after replacing the given numbers (H, f, A, bupper, blower)."""
        self._model.update(**numbers)
        x, _, flag, info = self._model.solve()
        if flag != _EXIT_OPTIMAL and flag != _EXIT_INFEASIBLE:
            raise SolverFailure(f"DAQP failed: {_EXIT_NAMES.get(flag, 'exit flag')} ({flag})")
        multipliers = info["lam"]
        if self._linear and flag == _EXIT_OPTIMAL:
            rows = numbers.get("A", self._rows)
            self._rows = rows
            stationarity = self._cost + rows.T.dot(multipliers[self._bounds :])
            stationarity[: self._bounds] += multipliers[: self._bounds]
            if np.abs(stationarity).max() > 1e-7 * (1.0 + np.abs(self._cost).max()):
                raise SolverFailure(
                    f"DAQP's LP answer fails its optimality certificate (stationarity residual "
                    f"{np.abs(stationarity).max():.2g})"
                )
        return x, flag, multipliers


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

    def solver(self, robot: Robot) -> Step:
        """The step ``(terms, ẍ) -> Resolution`` on ``robot``, with its DAQP programs set up once."""
        self.check(robot)
        n, m = robot.nv, robot.m
        r = n - m
        bounded = _bounded_joints(robot)
        upper, lower, spread = _solver_bounds(robot, bounded)
        midpoint = torque_midpoint(robot)
        decompose = JacobianSolver(m, n, self.singular_tolerance)
        optimum = self._optimum(robot, bounded, spread, midpoint)
        nb = spread.size
        # Largest scaling: max s over (s, y), 0 <= s <= 1 a simple bound on the first variable.
        scaling = _Program(
            np.zeros((1 + r, 1 + r)),
            np.r_[-1.0, np.zeros(r)],
            np.zeros((nb, 1 + r)),
            np.r_[1.0, np.ones(nb)],
            np.r_[0.0, -np.ones(nb)],
            bounds=1,
            linear=True,
        )
        # Least task error: min ½‖a − ẍ‖² over (a, y). Its Hessian is singular in y, as an
        # LP's (a zero matrix) is everywhere: DAQP then runs proximal-point iterations, whose
        # limit is an exact optimum.
        least_error = _Program(
            np.diag(np.r_[np.ones(m), np.zeros(r)]), np.zeros(n), np.zeros((nb, n)), np.ones(nb), -np.ones(nb)
        )
        minmax = _MinMax(bounded, spread, midpoint, r) if self.infeasible == "exceed" else None
        range_basis = _RangeBasis(n, r)
        policy = self.infeasible
        name = self.name

        def least_error_task(rows, row_upper, row_lower, command):
            """(a, z) of min ½‖a − ẍ‖² with τ = (rest) + H J⁺ a + U z within bounds."""
            x, flag, _ = least_error.solve(f=np.r_[-command, np.zeros(r)], A=rows, bupper=row_upper, blower=row_lower)
            if flag == _EXIT_INFEASIBLE:  # pragma: no cover - H is invertible: every torque in the box is some (a, z)
                raise SolverFailure(f"resolver '{name}': DAQP found no torque in the box for the least task error")
            return x[:m], x[m:]

        def step(terms: TaskTerms, task_acceleration: np.ndarray) -> Resolution:
            command = task_acceleration
            particular, basis, inverse_condition = decompose(terms.jacobian, command - terms.drift)
            inertia = terms.inertia
            inertia_basis = inertia.dot(basis)
            tilde_torque = inertia.dot(particular) + terms.bias_torque  # Eq. (28)
            found = optimum(terms, basis, inertia_basis, tilde_torque)
            if found is not None:
                y, torque = found
                return Resolution(torque, particular + basis.dot(y), inverse_condition, 0.0, False)  # Eq. (26)
            if policy == "stop":
                raise TorqueBoundsInfeasible(
                    f"resolver '{name}' (infeasible='stop'): no torque within bounds realises the task "
                    f"acceleration {np.round(command, 6).tolist()}"
                )
            range_rows = range_basis(inertia_basis)  # U, orthonormal, spans the range of HZ
            if policy == "exceed":
                z, _ = minmax(range_rows, tilde_torque)
                y = range_basis.coordinates(range_rows.dot(z))
                torque = tilde_torque + inertia_basis.dot(y)  # Eq. (27)
                return Resolution(torque, particular + basis.dot(y), inverse_condition, 0.0, True)
            # τ = rest + H J⁺ a + U z realises the task acceleration a (J q̈ + J̇q̇ = a).
            pseudo_inverse = np.linalg.pinv(terms.jacobian)
            task_torque = inertia.dot(pseudo_inverse)  # H J⁺, n × m
            rest_torque = tilde_torque - task_torque.dot(command)  # b − H J⁺ J̇q̇
            rows = np.hstack([task_torque, range_rows])[bounded] / spread[:, None]
            row_upper = (upper - rest_torque[bounded]) / spread
            row_lower = (lower - rest_torque[bounded]) / spread
            if policy == "scale":
                # Flacco, De Luca & Khatib (ICRA 2012): the largest s in [0, 1] with a torque within bounds.
                scaled_rows = np.hstack([rows[:, :m].dot(command)[:, None], rows[:, m:]])
                x, flag, _ = scaling.solve(A=scaled_rows, bupper=np.r_[1.0, row_upper], blower=np.r_[0.0, row_lower])
                if flag == _EXIT_INFEASIBLE:
                    # Not even s = 0 (the tip held on its path) has a torque within bounds:
                    # give up the direction too, for the least task error.
                    achieved, z = least_error_task(rows, row_upper, row_lower, command)
                else:
                    achieved, z = float(np.clip(x[0], 0.0, 1.0)) * command, x[1:]
            else:
                achieved, z = least_error_task(rows, row_upper, row_lower, command)
            # The resolver's own optimum at the achievable task acceleration; on the boundary
            # round-off may make that program infeasible, and then the first stage's z stands.
            shifted_particular = particular + pseudo_inverse.dot(achieved - command)
            shifted_tilde = rest_torque + task_torque.dot(achieved)
            found = optimum(terms, basis, inertia_basis, shifted_tilde)
            if found is None:
                y = range_basis.coordinates(range_rows.dot(z))
                found = y, shifted_tilde + inertia_basis.dot(y)
            y, torque = found
            error = float(np.linalg.norm(achieved - command))
            return Resolution(torque, shifted_particular + basis.dot(y), inverse_condition, error, True)

        return step

    def _optimum(self, robot: Robot, bounded, spread, midpoint):
        """``(terms, Z, HZ, τ̃) -> (y, τ)`` of this resolver's criterion with τ within bounds, or None when none is."""
        raise NotImplementedError


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
    r"""The LP :math:`\min_{z,t} t` s.t. :math:`|\tilde\tau_i + (Uz)_i - \tau_{mid,i}| \le t\,(\tau^+_i - \tau^-_i)`."""

    def __init__(self, bounded, spread, midpoint, redundancy: int):
        nb = spread.size
        self._bounded = bounded
        self._midpoint = midpoint[bounded]
        self._inverse_spread = 1.0 / spread
        self._inverse_spread_column = self._inverse_spread[:, None]
        self._r = redundancy
        sign = np.r_[-np.ones(nb), np.ones(nb)][:, None]
        rows = np.hstack([np.zeros((2 * nb, redundancy)), sign])
        upper = np.r_[np.zeros(nb), np.full(nb, np.inf)]
        lower = np.r_[np.full(nb, -np.inf), np.zeros(nb)]
        self._rows, self._upper, self._lower = rows, upper, lower
        # Views made once: each call writes the numbers into them in place.
        self._rows_plus, self._rows_minus = rows[:nb, :redundancy], rows[nb:, :redundancy]
        self._upper_plus, self._lower_minus = upper[:nb], lower[nb:]
        self.program = _Program(
            np.zeros((redundancy + 1, redundancy + 1)),
            np.r_[np.zeros(redundancy), 1.0],
            rows,
            upper,
            lower,
            linear=True,
        )

    def __call__(self, range_basis, tilde_torque):
        """(z, t) minimising the largest normalised torque t over τ = τ̃ + U z (U: ``range_basis``).

        Row i: (U_i z − t) ≤ −c_i and (U_i z + t) ≥ −c_i, with U_i and c_i = τ̃_i − τ_mid,i divided by the range.
        """
        bounded = self._bounded
        np.multiply(range_basis[bounded], self._inverse_spread_column, out=self._rows_plus)
        self._rows_minus[...] = self._rows_plus
        np.multiply(self._midpoint - tilde_torque[bounded], self._inverse_spread, out=self._upper_plus)
        self._lower_minus[...] = self._upper_plus
        x, flag, _ = self.program.solve(A=self._rows, bupper=self._upper, blower=self._lower)
        if flag != _EXIT_OPTIMAL:  # pragma: no cover - t large enough is always feasible
            raise SolverFailure("the min-max torque LP failed")
        return x[: self._r], x[self._r]


class BoundedTorque(_BoundedResolver):
    r"""Torque optimisation with hard torque bounds, by quadratic programming.

    .. math::

        \min_y\ \|S(\tau - \tau_{mid})\|^2 + \bar\mu^2\|y + K_D Z^\top\dot q\|^2
        \quad\text{s.t.}\quad \tau = \tilde\tau + H Z y,\quad \tau^- \le \tau \le \tau^+

    with :math:`\tau_{mid} = (\tau^+ + \tau^-)/2` (Eq. (29)), :math:`S = I`
    (``torque_weight='unit'``: the criterion of ``null-space``, Eq. (29), Eq. (30), Eq. (31)),
    the torque-range weight :math:`S = \mathrm{diag}(1/(\tau^+_i - \tau^-_i))`
    of Eq. (33) (``'range'``: that of ``weighted-null-space``; zero for an
    unbounded joint), or :math:`S^2 = \mathrm{diag}(w)` for a user vector
    :math:`w` (the diagonal of the weight matrix W of Eq. (32)).
    The kinematic term is that of ``damped-null-space``, with the same
    options and defaults: :math:`\bar\mu = \mu\|SHZ\|_F` with the
    dimensionless ``kinematic_weight`` :math:`\mu` (default 0.5) and the
    self-motion damping ``damping`` :math:`K_D` (default 10 1/s). With the
    bounds inactive the answer is that of ``damped-null-space``, and with
    :math:`\mu = 0` that of ``null-space`` / ``weighted-null-space``: the
    paper's criterion under hard bounds. The Hessian
    :math:`(SHZ)^\top SHZ + \bar\mu^2 I` is positive definite whenever S
    has no zero entry or :math:`\mu > 0`.
    """

    name = "bounded-torque"
    equations = (26, 29, 33)

    options = (
        Option(
            name="torque_weight",
            kind="'unit' | 'range' | vector (n)",
            unit="1/(N·m)² for a vector",
            default="unit",
            meaning=(
                "S of the criterion ‖S(τ − τ_mid)‖²: the identity, the torque range 1/(τ⁺ − τ⁻) of Eq. (33), "
                "or S² = diag(vector), the diagonal of W"
            ),
            convert=choice_or_vector(*TORQUE_WEIGHTS),
        ),
        Option(
            name="kinematic_weight",
            kind="number >= 0",
            unit="",
            default=DEFAULT_KINEMATIC_WEIGHT,
            meaning=(
                "μ of the kinematic term μ̄²‖y + K_D Zᵀq̇‖², μ̄ = μ‖SHZ‖_F, as in damped-null-space "
                "(0: the paper's torque criterion alone)"
            ),
            convert=number(0.0),
        ),
        Option(
            name="damping",
            kind="number >= 0",
            unit="1/s",
            default=DEFAULT_DAMPING,
            meaning="K_D of the kinematic term, as in damped-null-space: the self-motion velocity Zᵀq̇ is driven to 0",
            convert=number(0.0, unit="1/s"),
        ),
        INFEASIBLE_OPTION,
    )

    def weight_root(self, robot: Robot) -> np.ndarray:
        r"""The diagonal of S (n values, :math:`S^2 = W`)."""
        if isinstance(self.torque_weight, str):
            if self.torque_weight == "unit":
                return np.ones(robot.nv)
            spread = robot.torque_upper - robot.torque_lower
            return np.where(np.isfinite(spread), 1.0 / spread, 0.0)  # Eq. (33)
        weight = self.torque_weight
        if weight.shape != (robot.nv,) or (weight < 0).any():
            raise InvalidInput(
                f"option torque_weight={','.join(f'{w:g}' for w in weight)} of resolver '{self.name}' must be "
                f"{robot.nv} non-negative numbers, one per joint of robot '{robot.name}' (the diagonal of W)"
            )
        return np.sqrt(weight)

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.weight_root(robot)

    def _optimum(self, robot: Robot, bounded, spread, midpoint):
        r = robot.redundancy
        nb = spread.size
        root = self.weight_root(robot)[:, None]
        relative_weight2 = self.kinematic_weight**2
        damping = self.damping
        upper, lower, _ = _solver_bounds(robot, bounded)
        program = _Program(np.eye(r), np.zeros(r), np.zeros((nb, r)), np.ones(nb), -np.ones(nb))
        identity = np.eye(r)
        inverse_spread = (1.0 / spread)[:, None]

        def optimum(terms: TaskTerms, basis, inertia_basis, tilde_torque):
            weighted_basis = root * inertia_basis
            offset = (tilde_torque - midpoint)[:, None] * root  # S(τ̃ − τ_mid), Eq. (29), Eq. (32)
            hessian = weighted_basis.T.dot(weighted_basis)
            cost = weighted_basis.T.dot(offset).reshape(-1)
            if relative_weight2:
                # μ̄² = μ²‖SHZ‖_F² = μ² trace((SHZ)ᵀSHZ), damped-null-space's normalisation.
                mu2 = relative_weight2 * hessian.trace()
                hessian = hessian + mu2 * identity
                cost = cost + mu2 * damping * basis.T.dot(terms.joint_velocity)
            # DAQP's pivot and zero tolerances are absolute: scale the criterion to a unit Hessian
            # trace (the minimiser is the same), so that range weights on large limits stay well above them.
            scale = r / hessian.trace()
            rows = inertia_basis[bounded] * inverse_spread
            base = tilde_torque[bounded]
            y, flag, _ = program.solve(
                H=scale * hessian,
                f=scale * cost,
                A=rows,
                bupper=(upper - base) / spread,
                blower=(lower - base) / spread,
            )
            if flag == _EXIT_INFEASIBLE:
                return None
            return y, tilde_torque + inertia_basis.dot(y)

        return optimum


class MinMaxTorque(_BoundedResolver):
    r"""The paper's suggestion (Discussion): linear programming on the largest normalised torque.

    .. math::

        \min_y\ \max_i \frac{|\tau_i - \tau_{mid,i}|}{\tau^+_i - \tau^-_i}
        \quad\text{s.t.}\quad \tau = \tilde\tau + H Z y \quad\text{(Eq. (27), Eq. (28))}

    as the LP :math:`\min_{y,t} t` with :math:`\pm(\tau_i - \tau_{mid,i}) \le t(\tau^+_i - \tau^-_i)`
    over the joints with finite limits (an unbounded joint has no range to
    normalise by and is left out of the max; its torque is free). The
    optimum :math:`t^*` is the utilisation: every torque is within its bounds
    iff :math:`t^* \le 1/2` (:data:`FEASIBILITY_TOLERANCE` allowed). When
    :math:`t^* > 1/2` no torque within bounds realises the task and the
    ``infeasible`` policy applies (``exceed`` keeps the LP's torque, the
    least largest normalised excess, and flags the step).
    """

    name = "minmax-torque"
    equations = (26, 28)
    options = (INFEASIBLE_OPTION,)

    def _optimum(self, robot: Robot, bounded, spread, midpoint):
        minmax = _MinMax(bounded, spread, midpoint, robot.redundancy)
        ceiling = 0.5 - BOUND_MARGIN  # the LP's t may exceed its true value by DAQP's tolerance
        range_basis = _RangeBasis(robot.nv, robot.redundancy)

        def optimum(terms: TaskTerms, basis, inertia_basis, tilde_torque):
            range_rows = range_basis(inertia_basis)
            z, utilisation = minmax(range_rows, tilde_torque)
            if utilisation > ceiling:
                return None
            y = range_basis.coordinates(range_rows.dot(z))
            return y, tilde_torque + inertia_basis.dot(y)

        return optimum
