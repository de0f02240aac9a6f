r"""The whole movement by multiple shooting, with exact derivatives from CasADi.

The nonlinear program is the one of :mod:`torqueopt.optimal.transcription`,
variable for variable and row for row (so its bounds, warm start and mapping to
the simulation grid are shared), written as CasADi expressions instead of
numpy arrays:

- state :math:`(q_k, v_k)` at the knots :math:`t_k = kh`, N even so the
  reference's switch at :math:`T/2` is a knot; the control over each interval
  is a held joint acceleration :math:`a_k`, integrated exactly (the shooting
  step is :math:`q_{k+1} = q_k + h v_k + \tfrac{h^2}{2}a_k`,
  :math:`v_{k+1} = v_k + h a_k`, the continuity defects are the equality
  rows). Held rather than piecewise linear: the linear (C²) motion's
  recurrence has a growing mode (the transcription module's docstring);
- the torque :math:`\tau = \mathrm{RNEA}(q, v, a)` is in the problem, the
  CasADi twin of Pinocchio's of :mod:`torqueopt.optimal.symbolic`, at each
  interval's midpoint for the cost and at its start, midpoint and end for the
  torque bounds;
- the task frame's position equals the reference at every knot but the first;
- the URDF's joint position and velocity limits bound every knot.

What differs from that module is the derivatives: the Hessian of the
Lagrangian is exact (the constraints' curvature included, where the
Gauss-Newton matrix left it out), computed by CasADi's algorithmic
differentiation. One stage function (the three torques and the stage cost of
one interval) and one task function are built per robot and mapped over the
N intervals (``Function.map``), so the expression graph is one interval's,
whatever N. The NLP takes the step h, the reference, the weight S and the
midpoint torque as parameters: one built solver serves every path, duration
and start of a robot with the same N and options. Built solvers are kept in
memory; with ``compiled=True`` the NLP's functions are generated as C,
compiled once and kept on disk (:func:`cache_directory`), keyed by a digest of
the model and the options; without a compiler CasADi's virtual machine
evaluates the same functions.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..progress import command_name, said_if_slow
from .ipopt import _STATUS, SolverOutput, _iteration_callback, call_solver
from .symbolic import _casadi, configuration_expression, model_digest, symbolic_dynamics
from .transcription import Transcription

__all__ = [
    "EXCESS_TOLERANCE",
    "INFEASIBLE_MESSAGES",
    "Feasibility",
    "ShootingTranscription",
    "cache_directory",
    "least_excess",
    "solve_shooting",
]

#: IPOPT returns that mean the constraints could not be met (the problem is reported ``infeasible``).
#: A failed restoration phase counts when the point it stopped at still violates the constraints.
INFEASIBLE_MESSAGES = ("Infeasible_Problem_Detected", "Local_Infeasibility", "Restoration_Failed")

#: The most solvers kept at once (each holds its NLP's expression graph or library: megabytes on a seven-joint
#: arm); the least recently used goes first.
MAX_KEPT_SOLVERS = 16


class _KeptSolvers(OrderedDict):
    """Built nlpsol objects by key, at most :data:`MAX_KEPT_SOLVERS`, the least recently used dropped first."""

    def __getitem__(self, key):
        self.move_to_end(key)
        return super().__getitem__(key)

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > MAX_KEPT_SOLVERS:
            self.popitem(last=False)


_SOLVERS = _KeptSolvers()  # by the key of ShootingTranscription.key and the solver's options


def cache_directory() -> Path:
    """Where compiled NLP functions are kept: $TORQUEOPT_CACHE, else $XDG_CACHE_HOME/torqueopt, else ~/.cache/torqueopt."""
    if os.environ.get("TORQUEOPT_CACHE"):
        return Path(os.environ["TORQUEOPT_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "torqueopt"


class ShootingTranscription(Transcription):
    """:class:`Transcription`'s program, with its functions as CasADi expressions (see the module docstring).

    Same arguments as :class:`Transcription`; ``robot.model`` may hold
    revolute, prismatic and continuous joints (:data:`~torqueopt.optimal.symbolic.SUPPORTED_JOINTS`):
    q_k holds one angle per joint (:attr:`Transcription.ANGLES`), a continuous
    joint's configuration is (cos θ, sin θ) of it in the expressions.
    """

    ANGLES = True

    @property
    def key(self) -> str:
        """What the built solver depends on: the model, the frame, N, the options and the bounded joints."""
        parts = [
            model_digest(self.model, self.robot.frame_id),
            repr(self.robot.task_rows),
            str(self.intervals),
            str(self.end_at_rest),
            repr(self.bounded_joints.tolist()),
            repr(self.fractions),
        ]
        return hashlib.sha256("|".join(parts).encode()).hexdigest()[:24]

    def parameters(self) -> np.ndarray:
        """The NLP's parameter vector: h, the reference at knots 1..N (m per knot), S (column-major), τ_mid."""
        return np.concatenate(
            [[self.h], self.reference[1:].reshape(-1), self.root.reshape(-1, order="F"), self.midpoint]
        )

    def nlp(self) -> dict:
        """The NLP as CasADi MX expressions: {"x": w, "p": parameters, "f": cost, "g": constraints}."""
        casadi = _casadi()
        n, m, N = self.n, self.m, self.intervals
        model, frame = self.model, self.robot.frame_id
        q, v, a = casadi.SX.sym("q", n), casadi.SX.sym("v", n), casadi.SX.sym("a", n)
        h, root, midpoint = casadi.SX.sym("h"), casadi.SX.sym("S", n, n), casadi.SX.sym("tau_mid", n)
        rows = list(range(3))[self.robot.task_rows]
        # Continuous joints: the configuration of the angles; revolute and prismatic joints: the angles themselves.
        configuration = (
            (lambda angles: angles)
            if self.robot.euclidean
            else (lambda angles: configuration_expression(model, angles))
        )

        def torque_at(s):
            return symbolic_dynamics(model, frame, configuration(q + s * v + 0.5 * s * s * a), v + s * a, a)[0]

        torque_mid = torque_at(0.5 * h)  # the interval's mean torque to O(h²), as in the transcription
        residual = root @ (torque_mid - midpoint)
        bounded = [int(joint) for joint in self.bounded_joints]
        bound_rows = [torque_mid[bounded] if f == 0.5 else torque_at(f * h)[bounded] for f in self.fractions]
        stage = casadi.Function(
            "stage",
            [q, v, a, h, root, midpoint],
            [h * casadi.sumsqr(residual), casadi.vertcat(*bound_rows) if bound_rows else casadi.SX(0, 1)],
        )
        position = symbolic_dynamics(model, frame, configuration(q), v, a)[2]
        task = casadi.Function("task", [q], [position[rows]])

        w = casadi.MX.sym("w", self.size)
        p = casadi.MX.sym("p", 1 + m * N + n * n + n)
        step = p[0]
        reference = casadi.reshape(p[1 : 1 + m * N], m, N)
        root_p = casadi.reshape(p[1 + m * N : 1 + m * N + n * n], n, n)
        midpoint_p = p[1 + m * N + n * n :]
        blocks = casadi.reshape(w[: 3 * n * N], 3 * n, N)
        q_k, v_k, a_k = blocks[:n, :], blocks[n : 2 * n, :], blocks[2 * n :, :]
        q_next = casadi.horzcat(q_k[:, 1:], w[3 * n * N : 3 * n * N + n])
        v_next = casadi.horzcat(v_k[:, 1:], w[3 * n * N + n :])
        costs, torques = stage.map(N)(q_k, v_k, a_k, step, casadi.repmat(root_p, 1, N), casadi.repmat(midpoint_p, 1, N))
        defect_q = q_next - q_k - step * v_k - 0.5 * step * step * a_k
        defect_v = v_next - v_k - step * a_k
        parts = [
            casadi.reshape(casadi.vertcat(defect_q, defect_v), -1, 1),
            casadi.reshape(task.map(N)(q_next) - reference, -1, 1),
        ]
        if bounded:
            parts.append(casadi.reshape(torques, -1, 1))
        return {"x": w, "p": p, "f": casadi.sum2(costs), "g": casadi.vertcat(*parts)}

    def solver(self, compiled: bool = False, options: dict | None = None, keep: bool = True):
        """The IPOPT solver of :meth:`nlp` (built once per :attr:`key` and options when ``keep``; compiled to C
        when asked and a compiler exists)."""
        casadi = _casadi()
        library = _compiled_library(self, casadi) if compiled else None
        key = (self.key, library, repr(sorted((options or {}).items())))
        if keep and key in _SOLVERS:
            return _SOLVERS[key]
        base = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "calc_lam_p": False}
        base.update(options or {})
        if library is not None:
            solver = casadi.nlpsol("shooting", "ipopt", str(library), base)
        else:
            # expanded to SX: measured 1.7x faster per iteration than the MX graph of mapped functions (panda)
            solver = casadi.nlpsol("shooting", "ipopt", self.nlp(), {**base, "expand": True})
        if keep:
            _SOLVERS[key] = solver
        return solver


def _compiled_library(problem: ShootingTranscription, casadi) -> Path | None:
    """The shared library of the NLP's functions, from the cache or compiled now; None without a C compiler or a
    writable cache (and working) directory."""
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    directory = cache_directory()
    library = directory / f"shooting_{problem.key}.so"
    if library.exists():
        return library
    if compiler is None:
        return None
    source = directory / f"shooting_{problem.key}.c"
    # Seconds on planar3, minutes on a seven-joint arm's long window: say so when it takes long.
    compiling = said_if_slow(
        f"{command_name('torqueopt')}: compiling the program's functions for robot '{problem.robot.name}' "
        f"({problem.intervals} intervals), once: kept in {directory}"
    )
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with compiling:
            generator = casadi.nlpsol("shooting", "ipopt", problem.nlp(), {"print_time": False})
            # generate_dependencies writes to the working directory: write there, then move the file into the cache.
            written = generator.generate_dependencies(source.name, {})
            Path(written).replace(source)
            partial = library.with_suffix(f".{os.getpid()}.so")
            command = [compiler, "-O1", "-fPIC", "-shared", str(source), "-o", str(partial), "-lm"]
            result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            return None
        partial.replace(library)  # atomic: a concurrent process sees no half-written library
    except OSError:  # a cache or working directory that cannot be written: the virtual machine instead
        return None
    return library


def solve_shooting(
    problem: ShootingTranscription,
    w0: np.ndarray,
    *,
    tolerance: float = 1e-8,
    max_iterations: int = 500,
    max_time: float | None = None,
    compiled: bool = False,
    verbose: bool = False,
    on_iteration=None,
    ipopt_options: dict | None = None,
) -> SolverOutput:
    """Solve ``problem`` from ``w0`` with IPOPT and the exact Hessian (arguments as :func:`~torqueopt.optimal.ipopt.solve_transcription`;
    ``ipopt_options``: more of IPOPT's options, ``{"ipopt.mu_init": 1e-6}``).

    A return of :data:`INFEASIBLE_MESSAGES` is status ``infeasible`` (a failed
    restoration only when the point it stopped at violates the constraints by
    more than the tolerance), never an iteration limit.
    """
    casadi = _casadi()
    options = {"ipopt.tol": float(tolerance), "ipopt.max_iter": int(max_iterations)}
    options["ipopt.print_level"] = 5 if verbose else 0
    options.update(ipopt_options or {})
    if max_time is not None:
        options["ipopt.max_wall_time"] = float(max_time)
    if on_iteration is not None:
        # a solver of its own: nlpsol keeps the callback by reference, alive as long as this frame
        counter = _iteration_callback(casadi, problem.size, problem.constraint_count, on_iteration)
        options["iteration_callback"] = counter
    solver = problem.solver(compiled, options, keep=on_iteration is None)
    lower_x, upper_x = problem.variable_bounds()
    lower_g, upper_g = problem.constraint_bounds()
    start = np.clip(np.asarray(w0, float), lower_x, upper_x)
    began = time.perf_counter()
    answer = call_solver(solver, x0=start, p=problem.parameters(), lbx=lower_x, ubx=upper_x, lbg=lower_g, ubg=upper_g)
    seconds = time.perf_counter() - began
    stats = solver.stats()
    message = str(stats.get("return_status", "unknown"))
    solution = np.asarray(answer["x"]).reshape(-1)
    g = np.asarray(answer["g"]).reshape(-1)
    violation = max(
        float(np.max(np.maximum(lower_g - g, 0.0), initial=0.0)),
        float(np.max(np.maximum(g - upper_g, 0.0), initial=0.0)),
        float(np.max(np.maximum(lower_x - solution, 0.0), initial=0.0)),
        float(np.max(np.maximum(solution - upper_x, 0.0), initial=0.0)),
    )
    status = _STATUS.get(message, "failed")
    if message in INFEASIBLE_MESSAGES and (message != "Restoration_Failed" or violation > tolerance):
        status = "infeasible"
    return SolverOutput(
        w=solution,
        lam_g=np.asarray(answer["lam_g"]).reshape(-1),
        lam_x=np.asarray(answer["lam_x"]).reshape(-1),
        status=status,
        message=message,
        iterations=int(stats.get("iter_count", 0)),
        seconds=seconds,
        objective=float(answer["f"]),
        constraint_violation=violation,
    )


@dataclass
class Feasibility:
    """The phase-1 problem's answer (:func:`least_excess`).

    Attributes:
        excess: the least excess t* over the limits of any motion that follows the path (the phase-1 optimum;
            a fraction of each limit's half range, see :func:`least_excess`). 0 when a motion within every limit
            was found.
        status: how the phase-1 solve ended (one of :data:`~torqueopt.optimal.ipopt.STATUSES`); only a
            ``converged`` or ``acceptable`` positive ``excess`` is evidence that no motion within the limits exists (of a
            local minimum: the problem is not convex).
        message: IPOPT's return status. binding: the limits at t* (kind, joint, time), the first few.
        w: the phase-1 point (a feasible start for the problem when ``excess`` is 0).
        iterations, seconds: the phase-1 solve's.
    """

    excess: float
    status: str
    message: str
    binding: list
    w: np.ndarray
    iterations: int
    seconds: float

    @property
    def answered(self) -> bool:
        """True when the phase-1 solve ended at a local minimum (``converged``, or ``acceptable``: IPOPT's looser
        tolerances)."""
        return self.status in ("converged", "acceptable")

    @property
    def proves_infeasible(self) -> bool:
        """True when the phase-1 solve ended at a local minimum (:attr:`answered`) above :data:`EXCESS_TOLERANCE`."""
        return self.answered and self.excess > EXCESS_TOLERANCE

    def evidence(self) -> str:
        """One line: what the phase-1 solve found."""
        if not self.answered:
            return f"phase-1 (least excess over the limits) did not converge ({self.message})"
        if not self.proves_infeasible:
            return "phase-1 found a motion within every limit"
        where = "; ".join(self.binding) or "no binding limit"
        # a local minimum of a nonconvex problem: the least excess found, not a bound on every motion
        return f"the least excess over the limits of a motion along the path is {self.excess:.3g} of a half range ({where})"

    def record(self) -> dict:
        """The JSON-ready record (``OptimalResult.feasibility``)."""
        return {
            "excess": self.excess,
            "status": self.status,
            "solver_message": self.message,
            "binding": list(self.binding),
            "iterations": self.iterations,
            "seconds": self.seconds,
            "proves_infeasible": self.proves_infeasible,
            "evidence": self.evidence(),
        }


#: A phase-1 local minimum above this (a fraction of a limit's half range) is taken as evidence that the limits
#: cannot all be met (``infeasible``).
EXCESS_TOLERANCE = 1e-6


def _limit_scales(problem: ShootingTranscription) -> dict:
    """Per kind of limit, (centre, half range) per bounded quantity: torque rows, joint positions, joint speeds."""
    robot = problem.robot
    joints = problem.bounded_joints
    low, high = robot.torque_lower[joints], robot.torque_upper[joints]
    q_low, q_high, speed = robot.joint_limits
    limited = np.isfinite(q_low) & np.isfinite(q_high)
    if not problem.joint_limits:
        limited[:] = False
    fast = np.isfinite(speed) & problem.joint_limits
    return {
        "torque": (0.5 * (high + low), 0.5 * (high - low)),
        "position": (
            np.where(limited, 0.5 * (q_high + q_low), 0.0),
            np.where(limited, 0.5 * (q_high - q_low), 1.0),
            limited,
        ),
        "speed": (np.where(fast, speed, 1.0), fast),
    }


def _phase_one_solver(problem: ShootingTranscription, options: dict):
    """IPOPT on the phase-1 program of :func:`least_excess` (built once per :attr:`ShootingTranscription.key`
    and options)."""
    key = ("phase-1", problem.key, repr(sorted(options.items())))
    if key in _SOLVERS:
        return _SOLVERS[key]
    casadi = _casadi()
    nlp = problem.nlp()
    program = casadi.Function("program", [nlp["x"], nlp["p"]], [nlp["g"]])
    n, N = problem.n, problem.intervals
    equalities = (2 * n + problem.m) * N
    w, t = casadi.MX.sym("w", problem.size), casadi.MX.sym("t")
    bounded = len(problem.bounded_joints) * len(problem.fractions) * N
    # parameters: the program's, then per torque row (centre, half range), per joint (centre, half range, speed)
    p = casadi.MX.sym("p", nlp["p"].numel() + 2 * bounded + 3 * n)
    base = nlp["p"].numel()
    g = program(w, p[:base])
    centre, half = p[base : base + bounded], p[base + bounded : base + 2 * bounded]
    q_centre, q_half = (
        p[base + 2 * bounded : base + 2 * bounded + n],
        p[base + 2 * bounded + n : base + 2 * bounded + 2 * n],
    )
    speed = p[base + 2 * bounded + 2 * n :]
    blocks = casadi.reshape(w[: 3 * n * N], 3 * n, N)
    q_all = casadi.horzcat(blocks[:n, :], w[3 * n * N : 3 * n * N + n])
    v_all = casadi.horzcat(blocks[n : 2 * n, :], w[3 * n * N + n :])
    # Each limit, scaled to its half range: |(x − centre)/half| ≤ 1 + t.
    torque = (g[equalities:] - centre) / half if bounded else casadi.MX(0, 1)
    position = casadi.reshape((q_all - casadi.repmat(q_centre, 1, N + 1)) / casadi.repmat(q_half, 1, N + 1), -1, 1)
    velocity = casadi.reshape(v_all / casadi.repmat(speed, 1, N + 1), -1, 1)
    scaled = casadi.vertcat(torque, position, velocity)
    constraints = casadi.vertcat(g[:equalities], scaled - t, scaled + t)
    base_options = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "calc_lam_p": False, "expand": True}
    solver = casadi.nlpsol(
        "phase_one",
        "ipopt",
        {"x": casadi.vertcat(w, t), "p": p, "f": t, "g": constraints},
        {**base_options, **options},
    )
    _SOLVERS[key] = solver
    return solver


def least_excess(
    problem: ShootingTranscription,
    w0: np.ndarray,
    *,
    tolerance: float = 1e-8,
    max_iterations: int = 500,
    max_time: float | None = None,
) -> Feasibility:
    r"""The phase-1 problem: the least excess over the limits of any motion that follows the path.

    .. math::

        \min_{w, t \ge 0} t \quad\text{s.t.}\quad \text{the integration and task rows of } g(w) = 0,\quad
        \left|\frac{x_i(w) - c_i}{r_i}\right| \le 1 + t

    for every limited quantity :math:`x_i` (each bounded joint's torque at every bound point, under torque
    bounds; each joint's position and speed at every knot, under joint limits) with centre :math:`c_i` and
    half range :math:`r_i` (the speed limit for speeds). The path, the start at rest and the end at rest
    stay hard: t* is how far beyond its limits, as a fraction of each one's half range, the best motion
    along the path must go. t* > 0 at a converged solve means no motion within the limits exists near
    ``w0``'s (the program is nonconvex: evidence, not a certificate); t* = 0 gives a motion within every
    limit, a feasible start for the problem itself.
    """
    options = {"ipopt.tol": float(tolerance), "ipopt.max_iter": int(max_iterations)}
    if max_time is not None:
        options["ipopt.max_wall_time"] = float(max_time)
    solver = _phase_one_solver(problem, options)
    scales = _limit_scales(problem)
    torque_centre, torque_half = scales["torque"]
    repeats = problem.intervals * len(problem.fractions)
    q_centre, q_half, limited = scales["position"]
    speed, fast = scales["speed"]
    parameters = np.concatenate(
        [
            problem.parameters(),
            np.tile(torque_centre, repeats),
            np.tile(torque_half, repeats),
            q_centre,
            q_half,
            speed,
        ]
    )
    lower_x, upper_x = problem.variable_bounds(joint_limits=False)
    equalities = (2 * problem.n + problem.m) * problem.intervals
    free_rows = np.concatenate(
        [
            np.zeros(len(torque_centre) * repeats, bool),
            np.tile(~limited, problem.intervals + 1),
            np.tile(~fast, problem.intervals + 1),
        ]
    )
    upper_scaled = np.where(free_rows, np.inf, 1.0)
    lower_g = np.concatenate(
        [np.zeros(equalities), np.full(len(free_rows), -np.inf), np.where(free_rows, -np.inf, -1.0)]
    )
    upper_g = np.concatenate([np.zeros(equalities), upper_scaled, np.full(len(free_rows), np.inf)])
    start = np.clip(np.asarray(w0, float), lower_x, upper_x)
    g0 = np.asarray(solver.get_function("nlp_g")(np.append(start, 0.0), parameters)).reshape(-1)[equalities:]
    excess0 = float(np.max(np.abs(g0[: len(free_rows)]) - 1.0, initial=0.0, where=~free_rows))
    began = time.perf_counter()
    answer = call_solver(
        solver,
        x0=np.append(start, max(excess0, 0.0)),
        p=parameters,
        lbx=np.append(lower_x, 0.0),
        ubx=np.append(upper_x, np.inf),
        lbg=lower_g,
        ubg=upper_g,
    )
    stats = solver.stats()
    x = np.asarray(answer["x"]).reshape(-1)
    seconds = time.perf_counter() - began
    message = str(stats.get("return_status", "unknown"))
    g = np.asarray(answer["g"]).reshape(-1)[equalities:]
    excess = float(x[-1])
    scaled = g[: len(free_rows)] + excess  # the first block is scaled − t
    binding = (
        _binding(problem, np.where(free_rows, 0.0, np.abs(scaled)), excess, scales) if excess > EXCESS_TOLERANCE else []
    )
    return Feasibility(
        excess=excess,
        status=_STATUS.get(message, "failed"),
        message=message,
        binding=binding,
        w=x[:-1],
        iterations=int(stats.get("iter_count", 0)),
        seconds=seconds,
    )


def _binding(problem: ShootingTranscription, scaled: np.ndarray, excess: float, scales: dict, most: int = 3) -> list:
    """The limits reached at the phase-1 optimum (scaled value ≥ 1 + t* − 1e-6), largest first, as text."""
    n, N, h = problem.n, problem.intervals, problem.h
    names = problem.robot.joint_names
    torque_rows = len(scales["torque"][0]) * N * len(problem.fractions)
    bounded = len(problem.bounded_joints)
    texts = []
    for row in np.argsort(-scaled)[:most]:
        if scaled[row] < 1.0 + excess - 1e-6:
            break
        if row < torque_rows:
            interval, rest = divmod(int(row), bounded * len(problem.fractions))
            fraction, joint = divmod(rest, bounded)
            joint = int(problem.bounded_joints[joint])
            texts.append(f"torque of {names[joint]} at t = {(interval + problem.fractions[fraction]) * h:.3g} s")
        else:
            kind, index = (
                ("position", row - torque_rows)
                if row < torque_rows + n * (N + 1)
                else ("speed", row - torque_rows - n * (N + 1))
            )
            knot, joint = divmod(int(index), n)
            texts.append(f"{kind} of {names[joint]} at t = {knot * h:.3g} s")
    return texts
