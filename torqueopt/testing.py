r"""The resolver contract as a function a user's test suite calls: :func:`check_resolver`.

The registry's own tests run it on every registered resolver (``tests/test_resolvers.py``); a resolver of
your own meets the same contract when ::

    from torqueopt.testing import check_resolver

    def test_my_resolver(planar3):
        check_resolver(MyResolver(), torqueopt.load_robot("planar3"))

passes. At seeded random states (q, q̇, ẍ), away from singular Jacobians, it checks, each against something
the resolver does not compute itself:

``declaration``
    the options are declared completely (a kind, a unit, a meaning, a default the option's own converter
    accepts; ``singular_tolerance`` last), the constructor sets each as an attribute, and the resolver's
    :attr:`~torqueopt.Resolver.spec` makes it again (what the atlas's Dask workers receive).
``task``
    the torque produces the joint acceleration the resolution reports (Pinocchio's ABA from the torque alone),
    :math:`J\ddot q + \dot J\dot q = \ddot x` up to the ``task_error`` it reports as given up (exactly,
    unless it says ``infeasible``).
``objective``
    where the resolver declares the criterion it minimises (:meth:`~torqueopt.Resolver.objective_function`), its
    torque is that criterion's least value over the torques that realise the task,
    :math:`\tau + H Z y`: the first-order (KKT) condition by central finite differences of the criterion in
    y, the Newton step to the minimum (from finite differences of the gradient too) is zero, and the
    curvature is positive (a minimum, not a saddle). Z is an orthonormal basis of the null space of J from
    numpy's SVD, not the resolver's.
``batch``
    its step on stacks (:meth:`~torqueopt.Resolver.batch_solver`) gives, row by row, what its single-state
    step gives (1e-9).
``options``
    each of its own options, set to another value, changes the torque at some state (an option the
    resolver ignores is a broken promise).

Velocity-level resolvers (``level = "velocity"``) have no torque step: on them the ``task`` check is ``rates``
(``torqueopt.kinematic.joint_rates`` gives q̇ with :math:`J\dot q = \dot x`, affine in :math:`\dot x` as
the loop's time derivative assumes) and the ``options`` check compares joint rates (``position_gain``, which
acts only in closed loop, is left out).
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
from .resolvers.base import SINGULAR_TOLERANCE_OPTION
from .resolvers.options import format_value
from .resolvers.stacks import StackTerms
from .robot import Robot

__all__ = ["ContractViolation", "ContractReport", "check_resolver", "contract_states"]

#: The least σ_min of the task Jacobian at a contract state: the checks need a well-posed task.
_LEAST_SINGULAR_VALUE = 1e-3
#: Largest admitted distance [rad/s²] from the resolver's q̈ to its criterion's minimum, relative to 1 + ‖q̈‖.
OBJECTIVE_TOLERANCE = 1e-6
#: Batch rows against single steps, relative to 1 + the largest entry.
BATCH_TOLERANCE = 1e-9


class ContractViolation(AssertionError):
    """A resolver breaks its contract: the message has one line per failed check, each naming the check."""


class ContractReport(NamedTuple):
    """What :func:`check_resolver` checked on a resolver that met its contract.

    Attributes:
        resolver: the resolver's label.
        checks: the names of the checks that ran (``declaration``, ``task``, ``objective``, ``batch``,
            ``options``).
        states: how many states each step check used.
        options: the options shown to change the result, as ``name=value``.
        unchecked: what was not checked and why, one line each.
    """

    resolver: str
    checks: tuple[str, ...]
    states: int
    options: tuple[str, ...]
    unchecked: tuple[str, ...]


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
    failures: list[str] = []
    unchecked: list[str] = []
    checks = ["declaration"]
    failures += _declaration_failures(resolver)
    changed: list[str] = []
    if getattr(resolver, "level", "torque") == "torque":
        resolver.check(robot)
        drawn = contract_states(robot, states, seed)
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
        try:
            objective = resolver.objective_function(robot)
        except Exception as error:
            failures.append(f"objective: objective_function raised {type(error).__name__}: {error}")
            objective = False
        if objective is False:
            pass
        elif objective is not None and robot.redundancy > 0:
            checks.append("objective")
            failures += _objective_failures(resolver, objective, drawn, terms, resolutions)
        elif objective is None:
            unchecked.append("objective: the resolver declares none (Resolver.objective_function)")
        else:
            unchecked.append(f"objective: robot '{robot.name}' leaves task '{robot.task}' no null space")
        checks.append("batch")
        failures += _batch_failures(resolver, robot, drawn, terms, resolutions)
        checks.append("options")
        option_failures, changed, skipped = _option_failures(resolver, robot, drawn, terms, resolutions, options or {})
        failures += option_failures
        unchecked += skipped
    else:
        resolver.check(robot)
        drawn = contract_states(robot, states, seed)
        checks += ["rates", "options"]
        rate_failures, rates = _rate_failures(resolver, robot, drawn)
        failures += rate_failures
        option_failures, changed, skipped = _option_failures(
            resolver, robot, drawn, None, rates, {"position_gain": None, **(options or {})}
        )
        failures += option_failures
        unchecked += skipped
        unchecked.append("objective, batch: not checked on velocity-level resolvers")
    if failures:
        raise ContractViolation(
            f"resolver '{resolver.label}' on robot '{robot.name}' (task {robot.task}) breaks its contract:\n"
            + "\n".join(failures)
        )
    return ContractReport(resolver.label, tuple(checks), states, tuple(changed), tuple(unchecked))


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


def _objective_failures(resolver, objective, drawn, terms, resolutions) -> list[str]:
    failures = []
    for index, (state, resolution) in enumerate(zip(terms, resolutions)):
        if resolution is None or resolution.infeasible:
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
    return any(
        a is not None and np.abs(np.asarray(a) - np.asarray(b)).max() > 1e-9 * _scale(b) for a, b in zip(ours, theirs)
    )


def _vector(array) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in np.asarray(array, dtype=float).ravel()) + "]"
