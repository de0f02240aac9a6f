r"""IPOPT (shipped inside casadi's wheel) driven by a :class:`~torqueopt.optimal.transcription.Transcription`.

The transcription computes everything in numpy and Pinocchio; casadi only
carries the values to IPOPT. Its objective and constraints enter as
``casadi.Callback`` objects with sparse Jacobians (``has_jacobian`` /
``get_jacobian``), and the Gauss-Newton Hessian of the Lagrangian as the
``hess_lag`` function of ``nlpsol``; nothing is differentiated by casadi or
by finite differences.

Why IPOPT: an interior-point method with a sparse (MUMPS) factorisation of
the KKT matrix fits a transcription with thousands of variables and
block-banded Jacobians; on the short planar movement's transcription it
converges where scipy's SLSQP (dense) and trust-constr stop far from the
optimum. Why ``grad_f``, ``jac_g`` and ``hess_lag`` are given to ``nlpsol``
directly: with only the Callbacks' Jacobians, casadi's own construction of
them dominates the solve. The measurements behind both choices are in
BENCHMARKS.md, "Whole-path optimisation".
"""

from __future__ import annotations

import signal
import time
from dataclasses import dataclass

import numpy as np

from ..errors import MissingDependency
from ..progress import interrupt_deferred
from .transcription import Transcription

__all__ = ["STATUSES", "SolverOutput", "solve_transcription"]

#: The statuses a solve can end with, from IPOPT's return status.
STATUSES = ("converged", "acceptable", "iteration limit", "time limit", "infeasible", "failed")

_STATUS = {
    "Solve_Succeeded": "converged",
    "Solved_To_Acceptable_Level": "acceptable",
    "Maximum_Iterations_Exceeded": "iteration limit",
    "Maximum_WallTime_Exceeded": "time limit",
    "Maximum_CpuTime_Exceeded": "time limit",
    "Infeasible_Problem_Detected": "infeasible",
    "Local_Infeasibility": "infeasible",
}


@dataclass
class SolverOutput:
    """What IPOPT returned.

    Attributes:
        w: the last iterate (the solution when converged).
        lam_g: constraint multipliers. lam_x: bound multipliers (IPOPT's sign convention:
            ∇f + ∂gᵀλ_g + λ_x = 0 at a stationary point).
        status: one of :data:`STATUSES`. message: IPOPT's return status.
        iterations: IPOPT iterations. seconds: wall time of the solve [s].
        objective: f at w (the transcription's grid cost).
        constraint_violation: largest violation of g's bounds and w's bounds at w.
    """

    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    status: str
    message: str
    iterations: int
    seconds: float
    objective: float
    constraint_violation: float


def _casadi():
    try:
        import casadi
    except ImportError:
        raise MissingDependency("whole-path optimisation needs casadi (IPOPT): pip install casadi") from None
    return casadi


def _sparsity(casadi, rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]):
    """casadi Sparsity of the (rows, cols) pattern and the permutation from pattern order to its CCS order."""
    order = np.lexsort((rows, cols))
    column_starts = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=shape[1]))])
    sparsity = casadi.Sparsity(shape[0], shape[1], column_starts.astype(int).tolist(), rows[order].astype(int).tolist())
    return sparsity, order


def _function_class(casadi):
    class NumpyFunction(casadi.Callback):
        """A casadi Function computed in numpy: dense inputs, outputs of given sparsity, optional Jacobian."""

        def __init__(self, name, input_sizes, output_sparsity, evaluate, jacobian=None):
            casadi.Callback.__init__(self)
            self.input_sizes = input_sizes
            self.output_sparsity = output_sparsity
            self.evaluate = evaluate
            self.jacobian_function = jacobian
            self.construct(name, {})

        def get_n_in(self):
            return len(self.input_sizes)

        def get_n_out(self):
            return len(self.output_sparsity)

        def get_sparsity_in(self, i):
            return casadi.Sparsity.dense(self.input_sizes[i], 1)

        def get_sparsity_out(self, i):
            return self.output_sparsity[i]

        def eval(self, arguments):
            return self.evaluate(*[np.asarray(argument).reshape(-1) for argument in arguments])

        def has_jacobian(self):
            return self.jacobian_function is not None

        def get_jacobian(self, name, inames, onames, opts):
            # Inputs of a Jacobian function: the inputs, then the nominal outputs.
            return self.jacobian_function(name)

    return NumpyFunction


def call_solver(solver, **arguments):
    """``solver(**arguments)``, an IPOPT solve of CasADi's; a Ctrl-C heard during it is raised once it returns.

    CasADi reads Python's pending signals while IPOPT runs and drops a KeyboardInterrupt it finds there: the solve
    goes on, and so did the run that called it (a sweep of receding-horizon windows heard no Ctrl-C). Where Python's
    own handler is in place (in the main thread), it is replaced for the solve by one that keeps the signal, which
    is raised when the solve ends; a handler someone else installed (``torqueopt optimize``'s, which also stops IPOPT
    at its next iteration) is left as it is.
    """
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return solver(**arguments)
    with interrupt_deferred():
        return solver(**arguments)


def _iteration_callback(casadi, size: int, count: int, on_iteration):
    """A casadi Callback that nlpsol calls at each iteration with its outputs (x, f, g, multipliers);
    ``on_iteration(number)`` returning true stops the solve (a Ctrl-C the command line holds)."""

    class Iterations(casadi.Callback):
        def __init__(self):
            casadi.Callback.__init__(self)
            self.iteration = 0
            self.construct("iterations", {})

        def get_n_in(self):
            return casadi.nlpsol_n_out()

        def get_n_out(self):
            return 1

        def get_name_in(self, i):
            return casadi.nlpsol_out(i)

        def get_name_out(self, i):
            return "ret"

        def get_sparsity_in(self, i):
            name = casadi.nlpsol_out(i)
            rows = {"f": 1, "x": size, "lam_x": size, "g": count, "lam_g": count}.get(name, 0)
            return casadi.Sparsity.dense(rows, 1)

        def eval(self, arguments):
            stop = on_iteration(self.iteration)  # true: stop the solve here (IPOPT's User_Requested_Stop)
            self.iteration += 1
            return [1 if stop else 0]

    return Iterations()


def solve_transcription(
    problem: Transcription,
    w0: np.ndarray,
    *,
    hessian: str = "gauss-newton",
    tolerance: float = 1e-8,
    max_iterations: int = 500,
    max_time: float | None = None,
    verbose: bool = False,
    on_iteration=None,
) -> SolverOutput:
    """Solve ``problem`` from ``w0`` with IPOPT.

    Args:
        hessian: ``gauss-newton`` (the transcription's block Gauss-Newton
            matrix) or ``limited-memory`` (IPOPT's L-BFGS).
        tolerance: IPOPT's ``tol`` (scaled KKT error).
        max_iterations, max_time: work bounds (iterations; wall time [s]).
            Reaching one ends the solve with that status and the last iterate.
        verbose: print IPOPT's iteration log.
        on_iteration: called with the iteration number (0 for the start) at
            each of IPOPT's iterations, through nlpsol's ``iteration_callback``.
    """
    casadi = _casadi()
    NumpyFunction = _function_class(casadi)
    size, count = problem.size, problem.constraint_count
    scalar = casadi.Sparsity.dense(1, 1)
    jacobian_sparsity, jacobian_order = _sparsity(casadi, problem.jacobian_rows, problem.jacobian_cols, (count, size))
    hessian_sparsity, hessian_order = _sparsity(casadi, problem.hessian_rows, problem.hessian_cols, (size, size))
    keep = []  # casadi holds Callbacks by raw pointer: keep every one alive for the solve

    def gradient_function(name):
        function = NumpyFunction(
            name, [size, 1], [casadi.Sparsity.dense(1, size)], lambda w, f: [casadi.DM(problem.gradient(w)).T]
        )
        keep.append(function)
        return function

    def jacobian_function(name):
        function = NumpyFunction(
            name,
            [size, count],
            [jacobian_sparsity],
            lambda w, g: [casadi.DM(jacobian_sparsity, problem.jacobian_values(w)[jacobian_order])],
        )
        keep.append(function)
        return function

    objective = NumpyFunction("objective", [size], [scalar], lambda w: [problem.objective(w)], gradient_function)
    constraints = NumpyFunction(
        "constraints", [size], [casadi.Sparsity.dense(count, 1)], lambda w: [problem.constraints(w)], jacobian_function
    )
    keep += [objective, constraints]
    gradient_of_objective = NumpyFunction(
        "grad_f",
        [size, 0],
        [scalar, casadi.Sparsity.dense(size, 1)],
        lambda w, p: [problem.objective(w), problem.gradient(w)],
    )
    jacobian_of_constraints = NumpyFunction(
        "jac_g",
        [size, 0],
        [casadi.Sparsity.dense(count, 1), jacobian_sparsity],
        lambda w, p: [problem.constraints(w), casadi.DM(jacobian_sparsity, problem.jacobian_values(w)[jacobian_order])],
    )
    keep += [gradient_of_objective, jacobian_of_constraints]
    options = {
        "grad_f": gradient_of_objective,
        "jac_g": jacobian_of_constraints,
        "print_time": False,
        "ipopt.print_level": 5 if verbose else 0,
        "ipopt.sb": "yes",
        "ipopt.tol": float(tolerance),
        "ipopt.max_iter": int(max_iterations),
        "calc_lam_p": False,
    }
    if max_time is not None:
        options["ipopt.max_wall_time"] = float(max_time)
    if on_iteration is not None:
        counter = _iteration_callback(casadi, size, count, on_iteration)
        keep.append(counter)
        options["iteration_callback"] = counter
    if hessian == "limited-memory":
        options["ipopt.hessian_approximation"] = "limited-memory"
    else:
        lagrangian_hessian = NumpyFunction(
            "gauss_newton",
            [size, 0, 1, count],
            [hessian_sparsity],
            lambda w, p, sigma, lam: [
                casadi.DM(hessian_sparsity, problem.hessian_values(w, float(sigma[0]))[hessian_order])
            ],
        )
        keep.append(lagrangian_hessian)
        options["hess_lag"] = lagrangian_hessian
    w = casadi.MX.sym("w", size)
    solver = casadi.nlpsol("torque_transcription", "ipopt", {"x": w, "f": objective(w), "g": constraints(w)}, options)
    lower_x, upper_x = problem.variable_bounds()
    lower_g, upper_g = problem.constraint_bounds()
    start = np.clip(np.asarray(w0, float), lower_x, upper_x)
    began = time.perf_counter()
    answer = call_solver(solver, x0=start, lbx=lower_x, ubx=upper_x, lbg=lower_g, ubg=upper_g)
    seconds = time.perf_counter() - began
    stats = solver.stats()
    message = str(stats.get("return_status", "unknown"))
    solution = np.asarray(answer["x"]).reshape(-1)
    g = problem.constraints(solution)
    violation = max(
        float(np.max(np.maximum(lower_g - g, 0.0), initial=0.0)),
        float(np.max(np.maximum(g - upper_g, 0.0), initial=0.0)),
        float(np.max(np.maximum(lower_x - solution, 0.0), initial=0.0)),
        float(np.max(np.maximum(solution - upper_x, 0.0), initial=0.0)),
    )
    return SolverOutput(
        w=solution,
        lam_g=np.asarray(answer["lam_g"]).reshape(-1),
        lam_x=np.asarray(answer["lam_x"]).reshape(-1),
        status=_STATUS.get(message, "failed"),
        message=message,
        iterations=int(stats.get("iter_count", 0)),
        seconds=seconds,
        objective=problem.objective(solution),
        constraint_violation=violation,
    )
