r"""The resolver contract as a function a user's test suite calls: :func:`check_resolver` (docs/resolvers/contract.md).

The registry's own tests run it on every registered resolver; at seeded random states (q, q̇, ẍ) away from
singular Jacobians it checks each promise against something the resolver does not compute itself: its options'
``declaration`` (complete, set as attributes, made again from its ``spec``), the ``task`` (Pinocchio's ABA from
the torque alone, J q̈ + J̇q̇ = ẍ up to the error it reports), the ``objective`` it declares (KKT by finite
differences over the null space, or under its ``program``'s constraints), the ``program`` it solved (its
solution gives the torque, spans the null space, meets its KKT conditions with the solver's and with nnls
multipliers), ``batch`` rows against single steps, and each of its ``options`` changing the step. A
velocity-level resolver has ``rates`` (J q̇ = ẋ, affine in ẋ) in place of ``task``, and no objective or batch check.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .errors import InvalidInput
from .resolvers import Resolver, get_resolver
from .resolvers.base import SINGULAR_TOLERANCE_OPTION, Program, _defining_class
from .resolvers.options import format_value
from .resolvers.stacks import StackTerms
from .robot import Robot

__all__ = [
    "ContractViolation",
    "ContractReport",
    "ProgramResiduals",
    "check_resolver",
    "contract_states",
    "program_residuals",
]

#: The least σ_min of the task Jacobian at a contract state: the checks need a well-posed task.
_LEAST_SINGULAR_VALUE = 1e-3
#: Largest admitted distance [rad/s²] from the resolver's q̈ to its criterion's minimum, relative to 1 + ‖q̈‖.
OBJECTIVE_TOLERANCE = 1e-6
#: Batch rows against single steps, relative to 1 + the largest entry.
BATCH_TOLERANCE = 1e-9
#: Largest admitted KKT residual of a recorded program, each relative to the size of the terms its condition
#: compares (:func:`program_residuals`). The solvers answer far inside it (DAQP accepts a row beyond its bound by
#: 1e-9 of the row, its LP iterations stop within 3e-8 of the vertex; the residuals measured on the bounded
#: resolvers are below 1e-13), and a solution moved by 1e-5 of its size leaves it (about 5e-6 at a QP's interior
#: optimum; an LP's vertex moved breaks a row), as does a multiplier on the wrong side.
PROGRAM_TOLERANCE = 1e-6


class ContractViolation(AssertionError):
    """A resolver breaks its contract: the message has one line per failed check, each naming the check."""


class ContractReport(NamedTuple):
    """What :func:`check_resolver` checked on a resolver that met its contract.

    Attributes:
        resolver: the resolver's label.
        checks: the names of the checks that ran, in this order (``declaration``, ``task``, ``program``,
            ``objective``, ``batch``, ``options``).
        states: how many states each step check used.
        options: the options shown to change the result, as ``name=value``.
        unchecked: what was not checked and why, one line each.
    """

    resolver: str
    checks: tuple[str, ...]
    states: int
    options: tuple[str, ...]
    unchecked: tuple[str, ...]


class ProgramResiduals(NamedTuple):
    r"""The KKT conditions of a :class:`~torqueopt.resolvers.Program` at its solution (:func:`program_residuals`).

    Each is a residual relative to the size of the terms its condition compares, so that the same program with
    its objective or a row multiplied by any factor gives the same numbers; a condition holds when its residual
    is at most :data:`PROGRAM_TOLERANCE`.

    Attributes:
        stationarity: :math:`\|Px + q + A^\top\lambda\|_\infty` over the largest of
            :math:`|P||x| + |q| + |A|^\top|\lambda|` (the terms that cancel).
        primal: the largest excess of a row beyond a bound, over that row's :math:`|a_i||x|` plus its bound.
        dual: the largest multiplier on a side the row does not have (:math:`\lambda_i > 0` with
            :math:`u_i = +\infty`, :math:`< 0` with :math:`l_i = -\infty`), its term :math:`|\lambda_i|\|a_i\|_\infty`
            relative as in ``stationarity``.
        complementarity: the largest, over the sides with a multiplier, of the smaller of that multiplier's
            relative term and the side's relative slack: a multiplier is negligible or its side active.
        multipliers: the λ (k) checked: the solver's, or those fitted by non-negative least squares on the
            active sides (``scipy.optimize.nnls``: dual feasible and complementary by construction).
    """

    stationarity: float
    primal: float
    dual: float
    complementarity: float
    multipliers: np.ndarray


def program_residuals(program: Program, multipliers: np.ndarray | None = None) -> ProgramResiduals:
    r"""The KKT residuals of ``program`` at its solution, with ``multipliers`` (λ, DAQP's signs as
    :class:`~torqueopt.resolvers.Program` says), or, when None, with the non-negative multipliers of its active
    sides that best balance the objective's gradient (non-negative least squares: the check owes nothing to the
    solver's multipliers).

    A side is active when its relative slack is at most :data:`PROGRAM_TOLERANCE`.
    """
    rows, x = np.asarray(program.rows, dtype=float), np.asarray(program.solution, dtype=float)
    lower, upper = np.asarray(program.lower, dtype=float), np.asarray(program.upper, dtype=float)
    gradient = program.hessian @ x + program.cost
    values = rows @ x
    has_upper, has_lower = np.isfinite(upper), np.isfinite(lower)
    # A row's size: its terms |a_i||x| and its finite bounds; rounding and the solver's feasibility tolerance
    # are relative to it.
    bound_size = np.maximum(np.where(has_upper, np.abs(upper), 0.0), np.where(has_lower, np.abs(lower), 0.0))
    row_size = np.abs(rows) @ np.abs(x) + bound_size
    upper_slack = np.where(has_upper, upper - values, np.inf) / _positive(row_size)
    lower_slack = np.where(has_lower, values - lower, np.inf) / _positive(row_size)
    primal = float(max(0.0, -upper_slack.min(initial=np.inf), -lower_slack.min(initial=np.inf)))
    if multipliers is None:
        multipliers = _fitted_multipliers(
            rows, gradient, upper_slack <= PROGRAM_TOLERANCE, lower_slack <= PROGRAM_TOLERANCE
        )
    multipliers = np.asarray(multipliers, dtype=float)
    stationarity_terms = (
        np.abs(program.hessian) @ np.abs(x) + np.abs(program.cost) + np.abs(rows).T @ np.abs(multipliers)
    )
    size = _positive(np.array(stationarity_terms.max(initial=0.0)))
    stationarity = float(np.abs(gradient + rows.T @ multipliers).max(initial=0.0) / size)
    weight = np.abs(multipliers) * np.abs(rows).max(axis=1, initial=0.0) / size  # each multiplier's share
    on_upper, on_lower = multipliers > 0, multipliers < 0
    dual = float(max(weight[on_upper & ~has_upper].max(initial=0.0), weight[on_lower & ~has_lower].max(initial=0.0)))
    slack = np.where(on_upper, upper_slack, np.where(on_lower, lower_slack, 0.0))
    sides = (on_upper & has_upper) | (on_lower & has_lower)  # (those without a bound are dual's)
    complementarity = float(np.minimum(weight, np.maximum(slack, 0.0))[sides].max(initial=0.0))
    return ProgramResiduals(stationarity, primal, dual, complementarity, multipliers)


def _positive(size: np.ndarray) -> np.ndarray:
    """``size`` with its zeros replaced by 1 (a row, or a gradient, that is zero everywhere: nothing to be relative to)."""
    return np.where(size > 0.0, size, 1.0)


def _fitted_multipliers(rows, gradient, upper_active, lower_active) -> np.ndarray:
    """λ with λ_i ≥ 0 on active upper sides, ≤ 0 on active lower ones, 0 elsewhere, least ‖gradient + Aᵀλ‖."""
    from scipy.optimize import nnls

    sides = np.vstack([rows[upper_active], -rows[lower_active]])  # G x <= h, one row per active side
    multipliers = np.zeros(rows.shape[0])
    if sides.shape[0]:
        fitted, _ = nnls(sides.T, -gradient)
        count = int(upper_active.sum())
        multipliers[upper_active] += fitted[:count]
        multipliers[lower_active] -= fitted[count:]
    return multipliers


def contract_states(robot: Robot, count: int = 6, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``count`` seeded states (q, q̇ [rad/s], ẍ [m/s², rad/s²]) with σ_min(J) >= 1e-3.

    Joint coordinates are drawn within the joint limits where the robot has them, else in [−π, π]; q̇ in
    [−1.5, 1.5] rad/s; ẍ in [−2, 2].
    """
    rng = np.random.default_rng(seed)
    low, high = np.full(robot.nv, -np.pi), np.full(robot.nv, np.pi)
    if robot.euclidean:  # a configuration is then the neutral one plus the joint coordinates
        neutral = pin.neutral(robot.model)
        lower = robot.model.lowerPositionLimit - neutral
        upper = robot.model.upperPositionLimit - neutral
        limited = np.isfinite(lower) & np.isfinite(upper) & (upper > lower) & (upper - lower < 1e10)
        low = np.where(limited, np.maximum(lower, low), low)
        high = np.where(limited, np.minimum(upper, high), high)
    states = []
    for _ in range(50 * count):
        q = robot.configuration(rng.uniform(low, high))
        v = rng.uniform(-1.5, 1.5, robot.nv)
        task_acceleration = rng.uniform(-2.0, 2.0, robot.m)
        if np.linalg.svd(robot.terms(q, v).jacobian, compute_uv=False)[-1] >= _LEAST_SINGULAR_VALUE:
            states.append((q, v, task_acceleration))
            if len(states) == count:
                return states
    raise InvalidInput(
        f"robot '{robot.name}' gave fewer than {count} states with a well-conditioned task Jacobian in "
        f"{50 * count} draws; check its task '{robot.task}'"
    )


def check_resolver(
    resolver: str | type | Resolver,
    robot: Robot,
    *,
    states: int = 6,
    seed: int = 0,
    options: Mapping[str, object] | None = None,
) -> ContractReport:
    """Run the resolver contract (the module's checks) on ``resolver`` with ``robot``; raise if it breaks it.

    Args:
        resolver: a Resolver object, a Resolver class, or what :func:`torqueopt.get_resolver` takes.
        robot: the robot and task to check it on (:func:`torqueopt.load_robot`).
        states: how many seeded random states each step check uses.
        seed: the seed of those states.
        options: for the ``options`` check, another value per option: ``{name: value}`` replaces the value
            chosen by default (twice a number, another of the named choices), ``{name: None}`` leaves the
            option out (one that matters only in some situations, say). Options not named get the default
            choice; one without a default choice is listed in the report's ``unchecked``.

    Returns:
        A :class:`ContractReport` of what was checked.

    Raises:
        ContractViolation: one line per failed check, each naming the check, the state and the numbers.
        NoRedundancy, InvalidInput: the resolver refuses the robot (its own ``check``).
    """
    resolver = get_resolver(resolver)
    checks, failures, unchecked = ["declaration"], _declaration_failures(resolver), []
    resolver.check(robot)
    drawn = contract_states(robot, states, seed)
    if getattr(resolver, "level", "torque") == "torque":
        changed = _torque_contract(resolver, robot, drawn, options or {}, checks, failures, unchecked)
    else:
        checks += ["rates", "options"]
        rate_failures, rates = _rate_failures(resolver, robot, drawn)
        option_failures, changed, skipped = _option_failures(
            resolver, robot, drawn, None, rates, {"position_gain": None, **(options or {})}
        )
        failures += rate_failures + option_failures
        unchecked += [*skipped, "objective, batch: not checked on velocity-level resolvers"]
    if failures:
        raise ContractViolation(
            f"resolver '{resolver.label}' on robot '{robot.name}' (task {robot.task}) breaks its contract:\n"
            + "\n".join(failures)
        )
    return ContractReport(resolver.label, tuple(checks), states, tuple(changed), tuple(unchecked))


def _torque_contract(resolver, robot, drawn, options, checks, failures, unchecked) -> list[str]:
    """The checks of a torque-level resolver (task, program, objective, batch, options), each appending to
    ``checks``, ``failures`` and ``unchecked``; returns the options shown to change the step."""
    terms = [robot.terms(q, v) for q, v, _ in drawn]
    resolutions = []
    for index, ((_, _, task_acceleration), state_terms) in enumerate(zip(drawn, terms)):
        try:
            resolutions.append(resolver.solver(robot)(state_terms, task_acceleration))
        except Exception as error:
            failures.append(f"task: state {index}: the step raised {type(error).__name__}: {error}")
            resolutions.append(None)
    checks.append("task")
    failures += _task_failures(robot, drawn, terms, resolutions)
    programs = [None] * len(drawn)
    if _defining_class(type(resolver), "program_solver") is not Resolver:
        program_failures, programs = _program_failures(resolver, robot, drawn, terms, resolutions)
        if any(program is not None for program in programs) or program_failures:
            checks.append("program")
            failures += program_failures
        else:
            unchecked.append("program: its program_solver's steps return none (Resolution.program)")
    try:
        objective = resolver.objective_function(robot)
    except Exception as error:
        failures.append(f"objective: objective_function raised {type(error).__name__}: {error}")
        objective = False
    if objective is False:
        pass
    elif objective is not None and robot.redundancy > 0:
        checks.append("objective")
        failures += _objective_failures(resolver, objective, drawn, terms, resolutions, programs)
    elif objective is None:
        unchecked.append("objective: the resolver declares none (Resolver.objective_function)")
    else:
        unchecked.append(f"objective: robot '{robot.name}' leaves task '{robot.task}' no null space")
    checks += ["batch", "options"]
    failures += _batch_failures(resolver, robot, drawn, terms, resolutions)
    option_failures, changed, skipped = _option_failures(resolver, robot, drawn, terms, resolutions, options)
    failures += option_failures
    unchecked += skipped
    return changed


def _declaration_failures(resolver: Resolver) -> list[str]:
    cls = type(resolver)
    declared = cls.declared_options()
    names = [option.name for option in declared]
    failures = []
    if len(set(names)) != len(names):
        failures.append(f"declaration: options declared twice: {sorted({n for n in names if names.count(n) > 1})}")
    if declared[-1] is not SINGULAR_TOLERANCE_OPTION:
        failures.append("declaration: declared_options() must end with singular_tolerance (Resolver's own)")
    given = resolver.changed_settings()
    for option in declared:
        if not (option.kind and option.meaning and isinstance(option.unit, str)):
            failures.append(f"declaration: option {option.name} needs a kind, a meaning and a unit ('' for none)")
        if option.default is not None:
            try:
                option.convert(option.default)
            except Exception as error:
                failures.append(
                    f"declaration: option {option.name}'s default {format_value(option.default)} is refused by "
                    f"its own converter: {error}"
                )
        held = resolver.settings.get(option.name, resolver)
        if getattr(resolver, option.name, resolver) is not held or (
            option.name not in given and held is not option.default
        ):
            failures.append(
                f"declaration: the constructor does not set attribute {option.name} to its value (its default "
                "when not given); call Resolver.__init__ with the options"
            )
    try:
        again = get_resolver(resolver.spec)
    except Exception as error:
        local = "<locals>" in type(resolver).__qualname__
        failures.append(
            f"declaration: its spec '{resolver.spec}' does not make it again ({type(error).__name__}: {error}); "
            + ("define the class at module level, " if local else "")
            + "the atlas's workers make it from that text"
        )
    else:
        if type(again) is not type(resolver) or again.label != resolver.label:
            failures.append(f"declaration: its spec '{resolver.spec}' makes {again!r}, not {resolver!r}")
    return failures


def _scale(array) -> float:
    return 1.0 + float(np.abs(array).max())


def _task_failures(robot, drawn, terms, resolutions) -> list[str]:
    failures = []
    data = robot.model.createData()
    for index, ((q, v, task_acceleration), state, resolution) in enumerate(zip(drawn, terms, resolutions)):
        if resolution is None:
            continue
        torque, acceleration = np.asarray(resolution.torque), np.asarray(resolution.joint_acceleration)
        if torque.shape != (robot.nv,) or acceleration.shape != (robot.nv,):
            failures.append(f"task: state {index}: torque {torque.shape} and q̈ {acceleration.shape}, not ({robot.nv},)")
            continue
        # What the torque does, from the torque alone (less the joints' damping and friction the robot models).
        produced = robot.forward_dynamics(q, v, torque, data)
        if np.abs(produced - acceleration).max() > 1e-8 * _scale(produced):
            failures.append(
                f"task: state {index}: the torque produces q̈ = {_vector(produced)} (ABA), not the reported "
                f"{_vector(acceleration)}"
            )
        shortfall = float(np.linalg.norm(state.jacobian @ produced + state.drift - task_acceleration))
        tolerance = 1e-8 * _scale(task_acceleration)
        if not math.isclose(float(resolution.task_error), shortfall, abs_tol=tolerance):
            failures.append(
                f"task: state {index}: ‖J q̈ + J̇q̇ − ẍ‖ = {shortfall:.3g}, but the resolution reports task_error "
                f"{float(resolution.task_error):.3g}"
            )
        elif not resolution.infeasible and shortfall > tolerance:
            failures.append(f"task: state {index}: ‖J q̈ + J̇q̇ − ẍ‖ = {shortfall:.3g} on a step not marked infeasible")
    return failures


def _objective_failures(resolver, objective, drawn, terms, resolutions, programs) -> list[str]:
    failures = []
    for index, (state, resolution, program) in enumerate(zip(terms, resolutions, programs)):
        if resolution is None or resolution.infeasible:
            continue
        if program is not None:
            failures += _constrained_objective_failures(index, objective, state, resolution, program)
            continue
        null_space_basis = np.linalg.svd(state.jacobian)[2][state.jacobian.shape[0] :].T
        directions = state.inertia @ null_space_basis  # the torque change of a unit null-space acceleration
        torque = np.asarray(resolution.torque)
        scale = 1.0 + float(np.linalg.norm(resolution.joint_acceleration))
        step = 1e-3 * scale  # [rad/s²]: central differences are exact on a quadratic criterion

        def cost(y, state=state, torque=torque, directions=directions):
            return objective(state, torque + directions @ y)

        gradient, curvature = _differences(cost, directions.shape[1], step)
        eigenvalues = np.linalg.eigvalsh(curvature)
        if not eigenvalues.min() > 0:
            failures.append(
                f"objective: state {index}: the criterion's curvature over the null space has eigenvalue "
                f"{eigenvalues.min():.3g}: its torque is no minimum"
            )
            continue
        newton = np.linalg.solve(curvature, -gradient)  # y of the criterion's minimum, from the resolver's torque
        if np.linalg.norm(newton) > OBJECTIVE_TOLERANCE * scale:
            failures.append(
                f"objective: state {index}: the minimum of its criterion lies {np.linalg.norm(newton):.3g} rad/s² "
                f"away in the null space (gradient {_vector(gradient)} by finite differences, tolerance "
                f"{OBJECTIVE_TOLERANCE:g} x (1 + ‖q̈‖))"
            )
    return failures


def _constrained_objective_failures(index, objective, state, resolution, program) -> list[str]:
    """The declared criterion's KKT conditions at the step's torque under its program's constraints: its gradient in
    the program's variables x (central differences through τ + T δx) balanced by non-negative multipliers of the
    active sides (nnls), up to a Newton step that moves q̈ by nothing."""
    directions = program.torque_rows  # the torque change of a unit change of each variable
    torque = np.asarray(resolution.torque)
    scale = 1.0 + float(np.linalg.norm(resolution.joint_acceleration))
    step = 1e-3 * (1.0 + float(np.abs(program.solution).max(initial=0.0)))  # exact on a quadratic criterion

    def cost(change):
        return objective(state, torque + directions @ change)

    gradient, curvature = _differences(cost, directions.shape[1], step)
    eigenvalues = np.linalg.eigvalsh(curvature)
    if eigenvalues.min() < -1e-9 * max(eigenvalues.max(), 0.0):
        return [
            f"objective: state {index}: the criterion's curvature in its program's variables has eigenvalue "
            f"{eigenvalues.min():.3g}: its torque is no minimum"
        ]
    at_optimum = program._replace(hessian=np.zeros_like(program.hessian), cost=gradient)
    residual = gradient + program.rows.T @ program_residuals(at_optimum).multipliers
    newton = np.linalg.lstsq(curvature, -residual, rcond=None)[0]  # the step left to the criterion's minimum
    distance = float(np.linalg.norm(np.linalg.solve(state.inertia, directions @ newton)))  # in q̈ [rad/s²]
    if distance > OBJECTIVE_TOLERANCE * scale:
        return [
            f"objective: state {index}: the minimum of its criterion under its program's constraints lies "
            f"{distance:.3g} rad/s² away (gradient {_vector(gradient)} in {program.variables or 'its variables'} by "
            f"finite differences, tolerance {OBJECTIVE_TOLERANCE:g} x (1 + ‖q̈‖))"
        ]
    return []


def _program_failures(resolver, robot, drawn, terms, resolutions) -> tuple[list[str], list]:
    """The ``program`` check: the recording step's torques are the plain step's, each program's solution gives the
    torque, its variables span the null space, and it meets its KKT conditions (the solver's multipliers, then
    multipliers fitted by nnls). Returns the failures and each state's program (None where there is none)."""
    failures, programs = [], []
    for index, ((_, _, task_acceleration), state, plain) in enumerate(zip(drawn, terms, resolutions)):
        programs.append(None)
        if plain is None:
            continue
        try:
            # A step of its own per state, as the plain resolutions were made: no warm start carried over.
            recorded = resolver.program_solver(robot)(state, task_acceleration)
        except Exception as error:
            failures.append(f"program: state {index}: the recording step raised {type(error).__name__}: {error}")
            continue
        if not np.array_equal(np.asarray(recorded.torque), np.asarray(plain.torque)):
            failures.append(
                f"program: state {index}: the recording step gives torque {_vector(recorded.torque)}, its solver "
                f"{_vector(plain.torque)}: recording must change nothing"
            )
            continue
        program = recorded.program
        if program is None:
            continue
        programs[index] = program
        failures += _program_state_failures(index, state, recorded, program)
    return failures, programs


def _program_state_failures(index, state, resolution, program) -> list[str]:
    torque = np.asarray(resolution.torque)
    solution, directions = np.asarray(program.solution), np.asarray(program.torque_rows)
    failures = []
    own = program.torque_offset + directions @ solution
    if np.abs(own - torque).max() > BATCH_TOLERANCE * _scale(torque):
        failures.append(
            f"program: state {index}: its solution gives torque {_vector(own)}, the step returns {_vector(torque)}"
        )
    accelerations = np.linalg.solve(state.inertia, directions)  # q̈ per unit of each variable
    singular_values = np.linalg.svd(accelerations, compute_uv=False)
    rank = int((singular_values > 1e-9 * singular_values.max(initial=0.0)).sum())
    off_task = np.abs(state.jacobian @ accelerations).max(initial=0.0)
    redundancy = state.jacobian.shape[1] - state.jacobian.shape[0]
    if rank != redundancy or off_task > 1e-9 * np.abs(state.jacobian).max() * _scale(accelerations):
        failures.append(
            f"program: state {index}: its variables move q̈ by H⁻¹T of rank {rank} with ‖J H⁻¹ T‖ = {off_task:.3g}, "
            f"not over the null space of J (rank {redundancy}, J H⁻¹ T = 0)"
        )
    checked = [("its solver's multipliers", program.multipliers)] if program.multipliers is not None else []
    for source, multipliers in [*checked, ("multipliers fitted by nnls", None)]:
        residuals = program_residuals(program, multipliers)
        for condition in ("stationarity", "primal", "dual", "complementarity"):
            value = getattr(residuals, condition)
            if value > PROGRAM_TOLERANCE:
                failures.append(
                    f"program: state {index}: KKT {_CONDITIONS[condition]} residual {value:.3g} with {source} "
                    f"(tolerance {PROGRAM_TOLERANCE:g}, relative)"
                )
    return failures


_CONDITIONS = {
    "stationarity": "stationarity",
    "primal": "primal feasibility",
    "dual": "dual feasibility",
    "complementarity": "complementary slackness",
}


def _differences(cost, size: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Gradient and Hessian of ``cost`` at y = 0 by central differences of width ``step``."""
    unit = np.eye(size) * step
    centre = cost(np.zeros(size))
    plus = np.array([cost(unit[i]) for i in range(size)])
    minus = np.array([cost(-unit[i]) for i in range(size)])
    gradient = (plus - minus) / (2 * step)
    hessian = np.diag((plus - 2 * centre + minus) / step**2)
    for i in range(size):
        for j in range(i + 1, size):
            mixed = (
                cost(unit[i] + unit[j]) - cost(unit[i] - unit[j]) - cost(unit[j] - unit[i]) + cost(-unit[i] - unit[j])
            )
            hessian[i, j] = hessian[j, i] = mixed / (4 * step**2)
    return gradient, hessian


def _rate_failures(resolver, robot, drawn) -> tuple[list[str], list]:
    """A velocity-level resolver's rates at the states: J q̇ = ẋ, and affine in ẋ (what the loop differentiates)."""
    from .kinematic import joint_rates

    failures, rates = [], []
    for index, (q, _, task_velocity) in enumerate(drawn):
        try:
            rate = joint_rates(robot, resolver, q, task_velocity)
        except Exception as error:
            failures.append(f"rates: state {index}: joint_rates raised {type(error).__name__}: {error}")
            rates.append(None)
            continue
        rates.append(rate)
        jacobian = robot.terms(q, np.zeros(robot.nv)).jacobian
        if np.abs(jacobian @ rate - task_velocity).max() > 1e-8 * _scale(task_velocity):
            failures.append(
                f"rates: state {index}: J q̇ = {_vector(jacobian @ rate)}, not the commanded ẋ = {_vector(task_velocity)}"
            )
        other = np.roll(task_velocity, 1) - 0.5
        mixed = joint_rates(robot, resolver, q, 0.25 * task_velocity + 0.75 * other)
        expected = 0.25 * rate + 0.75 * joint_rates(robot, resolver, q, other)
        if np.abs(mixed - expected).max() > 1e-8 * _scale(rate):
            failures.append(
                f"rates: state {index}: the rates are not affine in ẋ (f(¼a + ¾b) − ¼f(a) − ¾f(b) = "
                f"{_vector(mixed - expected)}), which the loop's time derivative assumes"
            )
    return failures, rates


def _batch_failures(resolver, robot, drawn, terms, resolutions) -> list[str]:
    stack = StackTerms(*(np.stack([getattr(state, field) for state in terms]) for field in StackTerms._fields))
    accelerations = np.stack([task_acceleration for _, _, task_acceleration in drawn])
    try:
        batch = resolver.batch_solver(robot)(stack, accelerations, np.arange(len(drawn)))
    except Exception as error:
        return [f"batch: its step on stacks raised {type(error).__name__}: {error}"]
    failures = []
    for index, resolution in enumerate(resolutions):
        if resolution is None:
            continue
        if batch.failures and index in batch.failures:
            failures.append(
                f"batch: state {index}: the stacked step failed ({batch.failures[index]}), the single did not"
            )
            continue
        for field in ("torque", "joint_acceleration"):
            single, stacked = np.asarray(getattr(resolution, field)), getattr(batch, field)[index]
            if np.abs(single - stacked).max() > BATCH_TOLERANCE * _scale(single):
                failures.append(
                    f"batch: state {index}: {field} {_vector(stacked)} on stacks, {_vector(single)} in a single step"
                )
        error = 0.0 if batch.task_error is None else float(batch.task_error[index])
        infeasible = False if batch.infeasible is None else bool(batch.infeasible[index])
        if abs(error - float(resolution.task_error)) > BATCH_TOLERANCE * _scale(resolution.task_error):
            failures.append(
                f"batch: state {index}: task_error {error:.6g} on stacks, {resolution.task_error:.6g} single"
            )
        if infeasible != bool(resolution.infeasible):
            failures.append(f"batch: state {index}: infeasible {infeasible} on stacks, {resolution.infeasible} single")
    return failures


def _other_value(option):
    """A valid value of ``option`` other than its default (twice a number, another named choice), or None."""
    default = option.default
    candidates = []
    if isinstance(default, (int, float)) and not isinstance(default, bool):
        candidates += [2.0 * default, 0.5 * default, 1.0] if default else [1.0, 0.5]
    candidates += [choice for choice in re.findall(r"'([^']+)'", option.kind) if choice != default]
    for candidate in candidates:
        try:
            value = option.convert(candidate)
        except Exception:
            continue
        if format_value(value) != format_value(default):
            return candidate  # as a user gives it: the constructor converts it again
    return None


def _option_failures(resolver, robot, drawn, terms, resolutions, chosen):
    unknown = sorted(set(chosen) - {option.name for option in resolver.declared_options()})
    if unknown:
        raise InvalidInput(
            f"options {', '.join(unknown)} given to check_resolver are not declared by resolver '{resolver.name}'; "
            f"its options: {', '.join(option.name for option in resolver.declared_options())}"
        )
    failures, changed, skipped = [], [], []
    given = {name: _given_value(resolver, name, value) for name, value in resolver.changed_settings().items()}
    for option in type(resolver).options:
        if option.name in chosen and chosen[option.name] is None:
            skipped.append(f"options: {option.name} left out by the caller")
            continue
        value = chosen[option.name] if option.name in chosen else _other_value(option)
        if value is None:
            skipped.append(f"options: {option.name} has no default other value; give one in options=")
            continue
        shown = f"{option.name}={format_value(value)}"
        try:
            variant = type(resolver)(**{**given, option.name: value})
            shown = f"{option.name}={format_value(variant.settings[option.name])}"
            variant.check(robot)
            differs = differs_somewhere(variant, robot, drawn, terms, resolutions)
        except Exception as error:  # the user's code: one line, not a traceback
            failures.append(f"options: {shown} raised {type(error).__name__}: {error}")
            continue
        if differs:
            changed.append(shown)
        else:
            failures.append(
                f"options: {shown} changed no {'torque' if terms is not None else 'rate'} at {len(drawn)} states "
                f"(from {format_value(option.default)}): the step ignores it"
            )
    return failures, changed, skipped


def _given_value(resolver, name: str, file_value):
    """The value of option ``name`` to make ``resolver`` again: the object it holds when its converter takes it back
    (a task, a vector), else the value its files write (a criterion's name)."""
    option = next(option for option in resolver.declared_options() if option.name == name)
    try:
        option.convert(resolver.settings[name])
    except Exception:
        return file_value
    return resolver.settings[name]


def differs_somewhere(variant, robot, drawn, terms, answers) -> bool:
    """True when ``variant`` answers otherwise than ``answers`` at one of the states, at least: its torque (the
    resolutions of a torque step, with the states' ``terms``) or its joint rates (velocity level, ``terms`` None)."""
    if terms is None:
        from .kinematic import joint_rates

        ours = [
            None if answer is None else joint_rates(robot, variant, q, xd) for (q, _, xd), answer in zip(drawn, answers)
        ]
        theirs = answers
    else:
        step = variant.solver(robot)
        ours = [
            None if answer is None else step(state, xdd).torque
            for (_, _, xdd), state, answer in zip(drawn, terms, answers)
        ]
        theirs = [None if answer is None else answer.torque for answer in answers]
    # An option "changes" the answer beyond what the solver's own tolerance moves: a program solved again from
    # another warm start differs by that much (5.4e-7 N·m measured on bounded-torque's steps on planar3's joint
    # bounds), and a closed-form step by round-off.
    return any(
        a is not None and np.abs(np.asarray(a) - np.asarray(b)).max() > OPTION_EFFECT * _scale(b)
        for a, b in zip(ours, theirs)
    )


#: The least relative change of a torque (or rate) at which an option counts as acting on the step.
OPTION_EFFECT = 1e-6


def _vector(array) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in np.asarray(array, dtype=float).ravel()) + "]"
