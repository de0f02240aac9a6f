r"""``receding-horizon``: the whole-movement problem solved over a moving window, predictive control.

At each replanning instant :math:`t` (every ``replan_every`` control steps)
the resolver solves, from the measured state :math:`(q, \dot q)`, the
program of ``torqueopt.optimal.shooting`` over the next ``horizon``
seconds: knots :math:`t + kh` (:math:`h` = ``horizon_dt``, N
intervals), held joint accelerations, the task frame on the path at every
knot after the first, the torque :math:`\tau = \mathrm{RNEA}(q, \dot q, \ddot q)`
within the torque limits (joints with finite limits) at each interval's
start, midpoint and end, the URDF's position and velocity limits at every
knot (``joint_limits``), and the cost

.. math:: \sum_{k=0}^{N-1} h\,\|\tau_k - \tau_{mid}\|^2,

the paper's criterion (Eq. (29)) integrated over the window, with the
weighting of :func:`torqueopt.optimize` (S = I, :math:`\tau_{mid} = (\tau^+ + \tau^-)/2`).
The terminal condition is ``free``, ``rest`` (:math:`\dot q(t + Nh) = 0`) or a
bound [J] on the self-motion energy at the window's end (the kinetic energy beyond the least that
gives the tip its velocity, :func:`torqueopt.self_motion.self_motion_energy`).
With the path at every knot and held accelerations, the tip's knot velocities
follow from the path (:math:`\dot x_{k+1} \approx 2(x_{k+1} - x_k)/h - \dot x_k`),
so ``rest`` is feasible only in a window whose recurrence ends at zero (a
symmetric rest-to-rest window of even N, as the whole movement); inside the
movement the energy bound is the terminal condition that can hold.

The torque of each control step :math:`[t_j, t_j + \Delta t]` is the stored
plan's inverse dynamics at the step's midpoint (the first interval's torque
when :math:`h = \Delta t`; over several steps, the plan's as
:func:`torqueopt.optimize` maps its optimum to the simulation grid), so a
horizon of the whole movement planned once is the whole-movement optimum.
Each solve is warm-started from the previous plan shifted to the new knots
(the first from the path's inverse kinematics), IPOPT from a small barrier
parameter, or a moderate one where that plan had a variable at its bound
(:data:`WARM_AT_BOUNDS_OPTIONS`). The NLP is built once per
robot, knot count and options (CasADi, IPOPT with the exact Hessian), its
functions compiled to C for all but the smallest windows (:data:`COMPILE_FROM`);
a solve costs IPOPT's iterations only.

A solve that ends without an optimum (infeasible, iteration limit) hands
its step, and the steps until the next replanning instant, to the
``fallback`` resolver, and each such row says so in the result's
``limiting`` (``infeasible`` too when IPOPT proved the window infeasible);
``fallback='none'`` stops the run there instead.

Without a path (a single state: :func:`torqueopt.resolve`, the resolver
contract) the path over the horizon is the command's own, the tip moving
with the constant acceleration :math:`\ddot x` from its state, and the step
applies the plan's self-motion with the task realised exactly:
:math:`\ddot q = J^\dagger(\ddot x - \dot J\dot q) + (I - J^\dagger J)\,a_0` (Eq. (26)),
:math:`\tau = H\ddot q + b` (Eq. (20)). On a path the first interval's
acceleration meets the path at the next knot, not the command at this
instant, and its torque is charged and applied at the interval's midpoint,
not at its start: a one-step horizon solves ``bounded-torque[kinematic_weight=0]``'s
criterion under the same bounds, but for a task one step ahead, and the two
torques differ by O(Δt) (9.4e-4 of the largest at Δt = 1 ms, 9.3e-5 at
0.1 ms, on planar3; the tests). Along a path the rows report no task error:
the plan keeps the tip on the path's positions at the knots, and what it
misses is the result's tip error.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ..checks import Refused, check_rigid_joints
from ..errors import InvalidInput, SingularJacobian, SolverFailure, TorqueBoundsInfeasible, TorqueoptError
from ..linalg import inverse_condition_number
from ..robot import Robot, TaskTerms
from .base import Resolution, Resolver, Step
from .bounded.joint_limits import JOINT_LIMITS_OPTION
from .options import Option, number
from .registry import RESOLVERS, register_resolver

__all__ = ["RecedingHorizon", "HorizonSolve", "DEFAULT_KNOT_SPACING"]

#: The knot spacing ``horizon_dt='auto'`` aims at [s]. Twice the whole-movement optimum's default grid step: a
#: window's work grows with its knots, and at 10 ms the closed loop's cost is that of 5 ms knots within 0.07 %
#: (planar3's long line and a panda line, 0.5 s windows), its tip within 5e-6 m of the path; at 20 ms panda's
#: cost is 3 % higher (benchmarks/receding_horizon_speed.py ``knots``).
DEFAULT_KNOT_SPACING = 0.01
#: IPOPT's tolerance and iteration budget per window.
TOLERANCE = 1e-8
MAX_ITERATIONS = 200
#: IPOPT's options for a start from a near-optimal point, a small barrier parameter and the point kept where it is
#: (measured on planar3's long line, 0.5 s windows every 20 ms, median 5 iterations instead of 12, the same run to
#: 4e-10).
WARM_OPTIONS = {"ipopt.mu_init": 1e-6, "ipopt.warm_start_init_point": "yes"}
#: IPOPT's options for a start from a plan with variables at their bounds (joint speeds at their limits in panda's
#: windows). The small barrier parameter would start them with no bound multipliers and then take steps cut short by the
#: fraction-to-boundary rule for tens of iterations; a moderate one, left as soon as its subproblem is solved
#: loosely and decreased fast, converges in about a third of them (panda, 0.5 s windows: median 15 iterations
#: instead of 56; planar3, whose plans touch no bound, keeps :data:`WARM_OPTIONS`).
WARM_AT_BOUNDS_OPTIONS = {
    "ipopt.mu_init": 1e-2,
    "ipopt.barrier_tol_factor": 1000.0,
    "ipopt.mu_linear_decrease_factor": 0.05,
}
#: A bound multiplier above this (in IPOPT's unscaled units) marks a plan's variable as at its bound.
ACTIVE_MULTIPLIER = 1e-6
#: Windows of at least this many decision variables evaluate their NLP's functions as compiled C
#: (``torqueopt.optimal.shooting.solve_shooting``'s ``compiled``: once per robot, knot count and options, kept
#: on disk; CasADi's virtual machine where no C compiler exists). It pays from about 20 knots on planar3 (186
#: variables) and on panda at any size (benchmarks/receding_horizon_speed.py); a compile takes about 10 s on planar3,
#: minutes on panda, which the smallest windows (one control step, a few knots) would not earn back.
COMPILE_FROM = 150
#: A time within this fraction of a knot spacing short of a knot is taken at the knot by :func:`plan_state`: the
#: shifted start's knot times t + kh − t_plan fall a rounding error either side of the plan's knots, and one short
#: would take the previous interval's acceleration (a warm start off the integration rows by h·Δq̈: up to 6.5 rad/s
#: on panda's 20 ms knots).
KNOT_SNAP = 1e-9
#: The terminal conditions by name (a number is a bound on the self-motion energy [J]).
TERMINALS = ("free", "rest")


def _knot_spacing(value):
    """Converter of ``horizon_dt``: 'auto' or a number > 0 [s]."""
    if isinstance(value, str) and value.strip() == "auto":
        return "auto"
    return number(0.0, strict=True, unit="s")(value)


def _terminal(value):
    """Converter of ``terminal``: 'free', 'rest' or a bound >= 0 on the self-motion energy [J]."""
    if isinstance(value, str) and value.strip() in TERMINALS:
        return value.strip()
    try:
        return number(0.0, unit="J")(value)
    except Refused:
        raise Refused("must be 'free', 'rest' or a number >= 0 (a bound on the self-motion energy [J])") from None


def _fallback(value):
    """Converter of ``fallback``: a registered torque resolver's name, or 'none'."""

    text = str(value).strip()
    if text == "none":
        return text
    if text == "receding-horizon" or text not in RESOLVERS or getattr(RESOLVERS[text], "level", "torque") != "torque":
        local = [name for name, cls in RESOLVERS.items() if getattr(cls, "level", "torque") == "torque"]
        local = [name for name in local if name != "receding-horizon"]
        raise Refused(f"must be 'none' or a local torque resolver: {', '.join(local)}")
    return text


class HorizonSolve(NamedTuple):
    """One window's solve: the plan and how IPOPT ended.

    Attributes:
        time: the replanning instant t [s]. status: ``converged``, ``acceptable``, ``infeasible``, ... (as
            :func:`torqueopt.optimize`). message: IPOPT's return status. iterations: IPOPT's iterations.
            seconds: the solve's wall time [s].
        q, v, a: the plan at the knots t + kh, (N+1)×n, (N+1)×n, N×n. w, lam_g, lam_x: IPOPT's solution and
            multipliers. parameters: the NLP's parameter vector. reference: the path at the knots, (N+1)×m [m].
    """

    time: float
    status: str
    message: str
    iterations: int
    seconds: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    parameters: np.ndarray
    reference: np.ndarray


@register_resolver
class RecedingHorizon(Resolver):
    r"""Predictive control: the whole-movement torque optimum over a moving window of ``horizon`` seconds.

    See the module docstring for the program; Eq. (29)'s criterion
    integrated over the window, under the torque bounds and joint limits,
    replanned from the measured state.
    """

    name = "receding-horizon"
    equations = (20, 26, 29)

    options = (
        Option(
            name="horizon",
            kind="number > 0",
            unit="s",
            default=0.1,
            meaning="the window each solve plans over",
            convert=number(0.0, strict=True, unit="s"),
        ),
        Option(
            name="horizon_dt",
            kind="'auto' | number > 0",
            unit="s",
            default="auto",
            meaning=(
                "the knot spacing h of the window; 'auto': the multiple of the control step nearest 10 ms, "
                "at most the horizon (one knot interval per step for a one-step horizon)"
            ),
            convert=_knot_spacing,
        ),
        Option(
            name="replan_every",
            kind="whole number >= 1",
            unit="steps",
            default=1,
            meaning="control steps between solves; between them the stored plan's torques are applied",
            convert=lambda value: _whole(value),
        ),
        Option(
            name="terminal",
            kind="'free' | 'rest' | number >= 0",
            unit="J for a number",
            default="free",
            meaning="the window's end: free, at rest, or with its self-motion energy at most this bound",
            convert=_terminal,
        ),
        Option(
            name="fallback",
            kind="'none' | a local torque resolver's name",
            unit="",
            default="bounded-torque",
            meaning="the resolver of a step whose solve fails (reported in the row's limiting); 'none' stops the run",
            convert=_fallback,
        ),
        JOINT_LIMITS_OPTION,
    )

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if not robot.euclidean:
            raise InvalidInput(
                f"resolver '{self.name}' plans joint positions that add; robot '{robot.name}' has continuous or "
                "multi-coordinate joints: lock them (--lock) or use a URDF with limits on them"
            )
        if robot.task not in ("xy", "position"):
            raise InvalidInput(f"resolver '{self.name}' supports tasks xy and position, not '{robot.task}'")
        check_rigid_joints(robot)  # the window is the whole-movement problem's, without joint dynamics
        if self.fallback != "none":
            try:
                self.fallback_resolver().check(robot)
            except TorqueoptError as error:
                raise type(error)(
                    f"resolver '{self.name}' falls back to '{self.fallback}', which refuses: {error}; "
                    "give another fallback (e.g. fallback=pinv)"
                ) from None

    def fallback_resolver(self) -> Resolver | None:
        """The resolver of a step whose solve failed (None for ``fallback='none'``), with its defaults."""
        return None if self.fallback == "none" else RESOLVERS.lookup(self.fallback)()

    def knot_spacing(self, dt: float | None) -> float:
        """h [s]: ``horizon_dt``, or for 'auto' the multiple of ``dt`` nearest :data:`DEFAULT_KNOT_SPACING`, at most the horizon."""
        if self.horizon_dt != "auto":
            return float(self.horizon_dt)
        if dt is None:
            return min(DEFAULT_KNOT_SPACING, self.horizon)
        multiple = max(1, round(DEFAULT_KNOT_SPACING / dt))
        while multiple > 1 and multiple * dt > self.horizon * (1 + 1e-9):
            multiple -= 1
        return multiple * dt

    def solver(self, robot: Robot) -> Step:
        return self.solver_for_run(robot, None)

    def solver_for_run(self, robot: Robot, dt: float | None) -> Step:
        """The step without a path: the command's path over the horizon, the task realised exactly (module docstring)."""
        return CommandHorizonStep(self, robot, dt)

    def solver_for_movement(self, robot: Robot, dt: float, trajectory) -> Step:
        """The step of a run along ``trajectory``: replans over the path ahead (module docstring)."""
        return PathHorizonStep(self, robot, dt, trajectory)


def _whole(value) -> int:
    try:
        number_value = float(value)
    except (TypeError, ValueError):
        raise Refused("must be a whole number >= 1") from None
    if not (math.isfinite(number_value) and number_value >= 1 and number_value == int(number_value)):
        raise Refused("must be a whole number >= 1")
    return int(number_value)


class HorizonProgram:
    """The window's NLP for one robot, knot count and options, built once; :meth:`solve` from a state and a path.

    Holds a ``ShootingTranscription`` (``torqueopt.optimal.shooting``) whose start (q0, v0) and reference are
    set at each solve; its IPOPT solver is built at the first solve and kept (one per robot, N and options).
    """

    def __init__(self, resolver: RecedingHorizon, robot: Robot, spacing: float):
        from ..optimal.cost import weight_root
        from .null_space import torque_midpoint

        self.robot = robot
        self.intervals = max(1, round(resolver.horizon / spacing - 1e-9))
        self.h = spacing
        bounded = bool((np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)).any())
        terminal = resolver.terminal
        self.problem = _transcription(
            robot,
            self.intervals * spacing,
            self.intervals,
            np.zeros((self.intervals + 1, robot.m)),
            robot.configuration(np.zeros(robot.nv)),
            # Eq. (29)'s ‖τ − τ_mid‖² at every interval: S = I, the weighting optimize uses by default
            weight_root(robot, None),
            torque_midpoint(robot),
            end_at_rest=terminal == "rest",
            torque_bounds=bounded,
            joint_limits=resolver.joint_limits == "on",
            energy_bound=None if isinstance(terminal, str) else float(terminal),
        )
        self.data = robot.model.createData()
        #: Whether the NLP's functions run as compiled C (:data:`COMPILE_FROM`).
        self.compiled = self.problem.size >= COMPILE_FROM

    def warm_options(self, plan: HorizonSolve) -> dict:
        """IPOPT's options for a solve warm-started from ``plan``: :data:`WARM_AT_BOUNDS_OPTIONS` when a variable
        of it after the fixed start is at a bound, else :data:`WARM_OPTIONS`."""
        at_bounds = np.abs(plan.lam_x[2 * self.problem.n :]).max(initial=0.0) > ACTIVE_MULTIPLIER
        return WARM_AT_BOUNDS_OPTIONS if at_bounds else WARM_OPTIONS

    def solve(
        self, time: float, q, v, reference: np.ndarray, w0: np.ndarray | None, warm_options: dict | None = None
    ) -> HorizonSolve:
        """Plan from (q, v) with the task on ``reference`` (the path at the knots 0..N, (N+1)×m); ``w0`` the warm
        start (None: the path's inverse kinematics), ``warm_options`` IPOPT's options for it (None:
        :data:`WARM_OPTIONS`)."""
        from ..optimal.shooting import solve_shooting

        problem = self.problem
        problem.q0, problem.v0 = problem.angles(np.array(q, float)), np.asarray(v, float).copy()
        problem.reference = reference
        warm = w0 is not None
        if not warm:
            w0 = self.kinematic_start(q, v, reference)
        settings = {"tolerance": TOLERANCE, "max_iterations": MAX_ITERATIONS, "compiled": self.compiled}
        options = (WARM_OPTIONS if warm_options is None else warm_options) if warm else None
        solved = spent = solve_shooting(problem, w0, **settings, ipopt_options=options)
        if warm and solved.status not in _OPTIMAL and solved.message != PROVEN_INFEASIBLE:
            # The small barrier parameter can stop short (an iteration limit) where IPOPT's default start succeeds:
            # try again from the same point, as a cold start. Not after IPOPT found the window infeasible: on the
            # horizon curve's planar3 paths no such retry found a plan (0 of 1,567 on one path).
            solved = solve_shooting(problem, w0, **settings)
            solved.iterations += spent.iterations
            solved.seconds += spent.seconds
        plan_q, plan_v, plan_a = problem.split(solved.w)
        return HorizonSolve(
            time, solved.status, solved.message, solved.iterations, solved.seconds, plan_q, plan_v, plan_a,
            solved.w, solved.lam_g, solved.lam_x, problem.parameters(), reference,
        )  # fmt: skip

    def kinematic_start(self, q, v, reference) -> np.ndarray:
        """A first warm start: each knot's configuration by Gauss-Newton steps from the previous one onto the path,
        velocities and accelerations from their differences."""
        robot, data, h = self.robot, self.data, self.h
        model, frame, rows = robot.model, robot.frame_id, robot.task_rows
        configurations = [np.asarray(q, float)]
        for target in reference[1:]:
            current = configurations[-1].copy()
            for _ in range(3):
                pin.computeJointJacobians(model, data, current)
                error = target - pin.updateFramePlacement(model, data, frame).translation[rows]
                jacobian = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[rows]
                current = current + np.linalg.pinv(jacobian) @ error
            configurations.append(current)
        knots = np.array(configurations)
        velocities = np.vstack([np.asarray(v, float), np.diff(knots, axis=0) / h])
        accelerations = np.diff(velocities, axis=0) / h
        return self.problem.join(knots, velocities, accelerations)

    def shifted_start(self, plan: HorizonSolve, time: float) -> np.ndarray:
        """The previous plan at the new knots t + kh (its last knot held beyond its end): the warm start."""
        q, v, a = plan_states(plan, self.h, time + self.h * np.arange(self.intervals + 1) - plan.time)
        return self.problem.join(q, v, a[:-1])


def plan_state(plan: HorizonSolve, h: float, s: float):
    """(q, q̇, q̈) of the plan ``s`` [s] after its start: piecewise quadratic within it, its last knot at rest beyond."""
    last = len(plan.a) - 1
    knot = s / h + KNOT_SNAP  # a time a rounding error short of a knot is at that knot
    if knot >= last + 1:
        return plan.q[-1], plan.v[-1], np.zeros_like(plan.a[-1])
    k = min(max(int(knot // 1), 0), last)
    r = s - k * h
    return plan.q[k] + r * plan.v[k] + 0.5 * r * r * plan.a[k], plan.v[k] + r * plan.a[k], plan.a[k]


def plan_states(plan: HorizonSolve, h: float, s: np.ndarray):
    """:func:`plan_state` at each of the times ``s`` [s] (the same numbers): (q, q̇, q̈), each len(s)×n."""
    last = len(plan.a) - 1
    knot = s / h + KNOT_SNAP
    k = np.minimum(np.maximum((knot // 1).astype(int), 0), last)
    r = (s - k * h)[:, None]
    q = plan.q[k] + r * plan.v[k] + 0.5 * r * r * plan.a[k]
    v = plan.v[k] + r * plan.a[k]
    a = plan.a[k].copy()
    beyond = knot >= last + 1
    q[beyond], v[beyond], a[beyond] = plan.q[-1], plan.v[-1], 0.0
    return q, v, a


class _Fallback:
    """The fallback resolver's step and the row text of a failed solve."""

    def __init__(self, resolver: RecedingHorizon, robot: Robot, dt: float | None):
        local = resolver.fallback_resolver()
        self.name = resolver.fallback
        self.step = None if local is None else local.solver_for_run(robot, dt) if dt else local.solver(robot)

    def __call__(self, terms: TaskTerms, command, solved: HorizonSolve) -> Resolution:
        why = f"receding-horizon solve at t = {solved.time:.6g} s ended {solved.status} ({solved.message})"
        if self.step is None:
            raise SolverFailure(f"{why}; fallback 'none' stops the run")
        try:
            resolution = self.step(terms, command)
        except (SingularJacobian, TorqueBoundsInfeasible, SolverFailure) as error:
            raise type(error)(f"{why}; its fallback {self.name}: {error}") from None
        text = f"{why}: torque of {self.name}"
        if resolution.limiting:
            text += f" ({resolution.limiting})"
        return resolution._replace(infeasible=resolution.infeasible or solved.status == "infeasible", limiting=text)


_OPTIMAL = ("converged", "acceptable")
#: IPOPT's return that ends a warm window without a cold retry (its infeasibility detection converged).
PROVEN_INFEASIBLE = "Infeasible_Problem_Detected"


class PathHorizonStep:
    """The step of a run along a path: called once per control step, in order, from t = 0 (module docstring)."""

    def __init__(self, resolver: RecedingHorizon, robot: Robot, dt: float, trajectory):
        resolver.check(robot)
        self.robot, self.dt, self.trajectory = robot, dt, trajectory
        self.replan_every = resolver.replan_every
        self.program = HorizonProgram(resolver, robot, resolver.knot_spacing(dt))
        self.fallback = _Fallback(resolver, robot, dt)
        self.data = robot.model.createData()
        self.step_index = 0
        self.plan: HorizonSolve | None = None  # the plan the steps apply (None after a failed solve)
        self.warm: HorizonSolve | None = None  # the last plan that solved: the next solve's warm start
        self.failed: HorizonSolve | None = None  # the last failed solve, which the fallback rows report
        #: Every solve of the run, in order (its plan, status, iterations): what the tests and benchmarks read.
        self.solves: list[HorizonSolve] = []

    def __call__(self, terms: TaskTerms, command) -> Resolution:
        time = self.step_index * self.dt
        due = self.step_index % self.replan_every == 0
        self.step_index += 1
        program, plan = self.program, self.plan
        if plan is not None and time + self.dt > plan.time + program.intervals * program.h + 1e-12:
            due = True  # the plan ends within this step
        if due:
            knots = time + program.h * np.arange(program.intervals + 1)
            reference = np.asarray(self.trajectory.sample(knots).position, float)
            # From the last plan that solved, shifted (kept through failures); the first from the path's IK.
            w0, options = None, None
            if self.warm is not None:
                w0, options = program.shifted_start(self.warm, time), program.warm_options(self.warm)
            solved = program.solve(time, terms.configuration, terms.joint_velocity, reference, w0, options)
            self.solves.append(solved)
            if solved.status not in _OPTIMAL:
                self.plan, self.failed = None, solved
            else:
                self.plan = self.warm = plan = solved
        if plan is None:
            # No plan until the next replanning instant: the fallback's step, each row saying why.
            return self.fallback(terms, command, self.failed)
        # The step's torque: the plan's inverse dynamics at the step's midpoint (its mean to O(Δt²)).
        q, v, a = plan_state(plan, program.h, time + 0.5 * self.dt - plan.time)
        torque = pin.rnea(self.robot.model, self.data, q, v, a).copy()
        acceleration = np.linalg.solve(terms.inertia, torque - terms.bias_torque)  # Eq. (20)
        return Resolution(torque, acceleration, inverse_condition_number(terms.jacobian))


class CommandHorizonStep:
    """The step at a single state: the path is the command's, x + ẋs + ½ẍs², replanned at every call."""

    def __init__(self, resolver: RecedingHorizon, robot: Robot, dt: float | None):
        resolver.check(robot)
        self.robot = robot
        self.program = HorizonProgram(resolver, robot, resolver.knot_spacing(dt))
        self.fallback = _Fallback(resolver, robot, dt)
        self.offsets = self.program.h * np.arange(self.program.intervals + 1)
        self.last: HorizonSolve | None = None

    def __call__(self, terms: TaskTerms, command) -> Resolution:
        robot, s = self.robot, self.offsets[:, None]
        position = robot.task_position(terms.configuration)[: robot.m]
        reference = position + s * terms.task_velocity + 0.5 * s * s * np.asarray(command, float)
        solved = self.program.solve(0.0, terms.configuration, terms.joint_velocity, reference, None)
        self.last = solved
        if solved.status not in _OPTIMAL:
            return self.fallback(terms, command, solved)
        jacobian = terms.jacobian
        inverse = np.linalg.pinv(jacobian)
        # Eq. (26): the task part exact, the plan's first acceleration projected onto the null space.
        acceleration = inverse @ (command - terms.drift) + solved.a[0] - inverse @ (jacobian @ solved.a[0])
        torque = terms.inertia @ acceleration + terms.bias_torque  # Eq. (20)
        return Resolution(torque, acceleration, inverse_condition_number(jacobian))


def _transcription(robot, duration, intervals, reference, q0, root, midpoint, *, energy_bound=None, **options):
    """The window's ``ShootingTranscription``, with the terminal self-motion energy row when bounded."""
    if energy_bound is None:
        return _window_class(False)(robot, duration, intervals, reference, q0, root, midpoint, **options)
    return _window_class(True)(
        robot, duration, intervals, reference, q0, root, midpoint, energy_bound=energy_bound, **options
    )


@functools.cache
def _window_class(energy_bounded: bool):
    """The window's transcription class: its solver key and variable bounds computed once, since a window program
    keeps its model, N and options and changes only its start (q0, v0) and reference between solves."""
    from ..optimal.shooting import ShootingTranscription

    base = _energy_bounded_class() if energy_bounded else ShootingTranscription

    class WindowTranscription(base):
        @functools.cached_property
        def key(self) -> str:
            return base.key.fget(self)

        def variable_bounds(self, joint_limits: bool | None = None):
            """:class:`Transcription`'s bounds, the joint limits' part computed at the first call."""
            if joint_limits is not None:
                return super().variable_bounds(joint_limits)
            if "_bounds" not in self.__dict__:
                self._bounds = super().variable_bounds()
            lower, upper = (bounds.copy() for bounds in self._bounds)
            start, speed = self.q_index(0), self.v_index(0)
            lower[start] = upper[start] = self.q0
            lower[speed] = upper[speed] = self.v0
            return lower, upper

    return WindowTranscription


@functools.cache
def _energy_bounded_class():
    from ..optimal.shooting import ShootingTranscription
    from ..optimal.symbolic import _casadi, symbolic_dynamics

    class EnergyBoundedTranscription(ShootingTranscription):
        r"""The shooting program plus one row: the self-motion energy at the last knot,
        :math:`E_N = \tfrac12\dot q^\top H\dot q - \tfrac12\dot x^\top(JH^{-1}J^\top)^{-1}\dot x \le` the bound [J]."""

        def __init__(self, *arguments, energy_bound: float, **options):
            self.energy_bound = float(energy_bound)
            super().__init__(*arguments, **options)

        @property
        def key(self) -> str:
            return super().key + "-terminal-energy"

        def constraint_bounds(self):
            """The shooting program's bounds, then the energy row's (its g is the program's plus that row)."""
            lower, upper = super().constraint_bounds()
            return np.append(lower, -np.inf), np.append(upper, self.energy_bound)

        def nlp(self) -> dict:
            casadi = _casadi()
            nlp = super().nlp()
            n, N = self.n, self.intervals
            q, v, a = casadi.SX.sym("q", n), casadi.SX.sym("v", n), casadi.SX.sym("a", n)
            torque, _, position = symbolic_dynamics(self.model, self.robot.frame_id, q, casadi.SX.zeros(n), a)
            inertia = casadi.jacobian(torque, a)  # RNEA is affine in q̈: its Jacobian is H(q)
            rows = list(range(3))[self.robot.task_rows]
            jacobian = casadi.jacobian(position[rows], q)
            tip_velocity = jacobian @ v
            task_inertia_inverse = jacobian @ casadi.solve(inertia, jacobian.T)  # J H⁻¹ Jᵀ = Λ⁻¹
            energy = 0.5 * casadi.dot(v, inertia @ v) - 0.5 * casadi.dot(
                tip_velocity, casadi.solve(task_inertia_inverse, tip_velocity)
            )
            terminal = casadi.Function("terminal_energy", [q, v], [energy])
            w = nlp["x"]
            row = terminal(w[3 * n * N : 3 * n * N + n], w[3 * n * N + n :])
            return {**nlp, "g": casadi.vertcat(nlp["g"], row)}

    return EnergyBoundedTranscription
