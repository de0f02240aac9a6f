r"""The resolver contract.

A resolver maps a desired task acceleration :math:`\ddot x` [m/s², rad/s²]
at one state to joint torques. It is one abstract step: ``solver(robot)``
returns a robot-bound function

.. math::

    (\text{terms}, \ddot x) \mapsto \text{Resolution}(\tau, \ddot q, \sigma_{min}/\sigma_{max},
    \text{task error}, \text{infeasible})

where the terms (:class:`~torqueopt.robot.TaskTerms`) carry :math:`H`, the
bias torques, :math:`J`, :math:`\dot J\dot q` and :math:`\dot q`. What
depends only on the robot (torque midpoints, weights, workspaces, a QP
built once) is prepared in ``solver``; each step pays only for what changes.

Most resolvers of the paper write the joint acceleration as a particular
solution plus a null-space motion, Eq. (26),

.. math::

    \ddot q = J^\dagger(\ddot x - \dot J \dot q) + Z y,
    \qquad \tau = H \ddot q + \dot q \cdot C \cdot \dot q + g,

with :math:`Z` an orthonormal basis of the null space of :math:`J`
(:math:`I - J^\dagger J = Z Z^\top`): :class:`NullSpaceResolver` is that
family, whose members only choose :math:`y`; every choice realises the task
exactly. A resolver under inequalities (torque bounds) implements
``solver`` itself and may give up part of the task, saying so in the
resolution.

Each resolver declares its options (:class:`~torqueopt.resolvers.options.Option`)
in its class attribute ``options``; the constructor accepts exactly those, as
keywords, and checks them.
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar, NamedTuple

import numpy as np

from ..errors import NoRedundancy
from ..linalg import DEFAULT_SINGULAR_TOLERANCE, JacobianSolver
from ..robot import Robot, TaskTerms
from .options import Option, format_value, number, resolver_label, validate_options
from .stacks import StackResolution, StackStep, StackTerms, looped_stack_step, singular_rows, task_factorisation

__all__ = [
    "NullSpaceFunction",
    "NullSpaceResolver",
    "Objective",
    "Program",
    "Resolution",
    "Resolver",
    "SINGULAR_TOLERANCE_OPTION",
    "StackStep",
    "Step",
]


class Program(NamedTuple):
    r"""A quadratic or linear program a resolver solved at one state, with its answer (qpsolvers' ``Problem`` and
    ``Solution`` in one record).

    .. math::

        \min_x\ \tfrac12 x^\top P x + q^\top x \quad\text{s.t.}\quad l \le A x \le u,
        \qquad \tau = \tau_0 + T x .

    Attributes:
        hessian: P (v × v), zeros for a linear program.
        cost: q (v).
        rows: A (k × v), every constraint (simple bounds on variables as unit rows).
        lower: l (k), −inf where a row has no lower side.
        upper: u (k), +inf where a row has no upper side (l = u: an equality).
        solution: x (v), the answer the resolver used.
        multipliers: the solver's λ (k), or None when it gives none, in DAQP's convention:
            :math:`Px + q + A^\top\lambda = 0`, :math:`\lambda_i > 0` on an active upper side, :math:`< 0` on an
            active lower side, 0 on an inactive row.
        torque_offset: :math:`\tau_0` (n) [N·m] of the torque :math:`\tau_0 + T x` of a point x (the
            resolution's torque at the solution).
        torque_rows: T (n × v), the torque change of a unit change of each variable.
        variables: what x is, in words.
    """

    hessian: np.ndarray
    cost: np.ndarray
    rows: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    solution: np.ndarray
    multipliers: np.ndarray | None
    torque_offset: np.ndarray
    torque_rows: np.ndarray
    variables: str = ""


class Resolution(NamedTuple):
    r"""What a resolver returns at one state (a tuple: cheap to build at every step).

    Attributes:
        torque: joint torques τ [N·m].
        joint_acceleration: the joint acceleration q̈ these torques produce [rad/s²].
        jacobian_inverse_condition: σ_min/σ_max of the task Jacobian at this state, the
            reciprocal of its condition number (1: isotropic, toward 0: singular).
        task_error: :math:`\|J\ddot q + \dot J\dot q - \ddot x\|` [m/s², rad/s²], the part of the
            task acceleration the resolver gave up; 0 when it realised the task exactly.
        infeasible: True when no admissible torque (within the resolver's constraints)
            realises the task, so ``task_error`` is the least violation it found.
        limiting: on an infeasible step, the bounds its answer lies on, in one line
            ("torque limit (upper) of joint J; velocity limit (lower) of joint K"); empty otherwise.
        program: the :class:`~torqueopt.resolvers.Program` whose solution gives the torque, from a step that
            solves one and was asked for it (:meth:`Resolver.program_solver`); None otherwise (closed-form
            resolvers, and every step of :meth:`Resolver.solver`, which keep no record).
    """

    torque: np.ndarray
    joint_acceleration: np.ndarray
    jacobian_inverse_condition: float
    task_error: float = 0.0
    infeasible: bool = False
    limiting: str = ""
    program: Program | None = None


#: A robot-bound step: ``(terms, task_acceleration) -> Resolution``.
Step = Callable[[TaskTerms, np.ndarray], Resolution]
#: A criterion on one state's torques: ``(terms, torque) -> cost``.
Objective = Callable[[TaskTerms, np.ndarray], float]
#: A robot-bound choice of the null-space coordinates: ``(terms, Z, particular) -> y``.
NullSpaceFunction = Callable[[TaskTerms, np.ndarray, np.ndarray], np.ndarray]

#: The option every resolver accepts: the Jacobian's singular-value cutoff.
SINGULAR_TOLERANCE_OPTION = Option(
    name="singular_tolerance",
    kind="number > 0",
    unit="",
    default=DEFAULT_SINGULAR_TOLERANCE,
    meaning="relative singular-value cutoff: the task Jacobian counts as singular when σ_min/σ_max falls below it",
    convert=number(0.0, strict=True),
)


class Resolver(ABC):
    """Maps a desired task acceleration to joint torques.

    Subclasses set ``name``, declare their :attr:`options`, list the
    paper's equations they compute in :attr:`equations` (cited as ``Eq. (N)``
    in their docstring and at the lines that compute them), and implement
    :meth:`solver`. The constructor takes the declared
    options as keywords, checks them, and sets each as an attribute of the same
    name (the default when not given).
    """

    name: ClassVar[str]
    #: The options this resolver declares (``singular_tolerance`` is added for every resolver).
    options: ClassVar[tuple[Option, ...]] = ()
    #: True when the method is only defined with a null space (m < n).
    needs_redundancy: ClassVar[bool] = False
    #: The numbers N of the paper's equations, Eq. (N), that define this method (empty when it is not in the paper).
    equations: ClassVar[tuple[int, ...]] = ()

    def __init__(self, **options):
        self.settings = validate_options(self.name, self.declared_options(), options)
        for key, value in self.settings.items():
            setattr(self, key, value)

    @classmethod
    def declared_options(cls) -> tuple[Option, ...]:
        """This resolver's options, its own first, then ``singular_tolerance``."""
        return (*cls.options, SINGULAR_TOLERANCE_OPTION)

    @classmethod
    def summary(cls) -> str:
        """The first line of the class docstring: what the resolver does, in one line, as plain text
        (``:math:`W = H``` reads W = H, ````name```` reads name)."""
        line = (cls.__doc__ or cls.name).strip().splitlines()[0]
        return re.sub(r":\w+:`([^`]*)`|``([^`]*)``", lambda match: match.group(1) or match.group(2) or "", line)

    @property
    def needs_torque_limits(self) -> bool:
        """True when, with these options, the resolver divides by torque ranges (so every joint needs a limit)."""
        return False

    @property
    def label(self) -> str:
        """The name with, in brackets, the options that differ from their defaults, as ``bounded-torque[joint_limits=off]``.

        The bare name with every default. Two resolvers with the same label have the same settings, and
        ``torqueopt.resolvers.resolver_from_label`` makes one from it.
        """
        return resolver_label(self.name, self.declared_options(), self.settings)

    @property
    def spec(self) -> str:
        """The text that makes this resolver again in any process, for ``get_resolver(spec)`` (the atlas's workers).

        Its :attr:`label` when the registry holds its class under its name; else the class's import path with the
        same brackets, ``mypkg.module:MyResolver[gain=2]`` (a class defined inside a function has none: it is
        made only in the process that defined it).
        """
        cls = type(self)
        if vars(cls).get("_registered_name") == self.name:  # set by the registry (resolvers.registry)
            return self.label
        return cls.__module__ + ":" + cls.__qualname__ + self.label[len(self.name) :]

    def changed_settings(self) -> dict:
        """The options whose values differ from their defaults (those :attr:`label` names), as JSON-ready values."""
        from .options import label_value

        declared = {option.name: option for option in self.declared_options()}
        return {
            key: value
            for key, value in self.settings_for_file().items()
            if label_value(self.settings[key]) != label_value(declared[key].default)
        }

    def settings_for_file(self) -> dict:
        """The option values as JSON-ready values (vectors as lists), for a result's metadata."""
        return {key: value.tolist() if isinstance(value, np.ndarray) else value for key, value in self.settings.items()}

    def check(self, robot: Robot) -> None:
        """Raise if this resolver cannot serve the robot's task (or an option does not fit the robot)."""
        if robot.m > robot.nv:
            raise NoRedundancy(
                f"task '{robot.task}' has m={robot.m} coordinates but robot '{robot.name}' moves it with only "
                f"n={robot.nv} joints; choose a task with m <= n"
            )
        if self.needs_redundancy and robot.m == robot.nv:
            raise NoRedundancy(
                f"resolver '{self.name}' needs redundancy but task '{robot.task}' (m={robot.m}) on robot "
                f"'{robot.name}' (n={robot.nv}) leaves none; choose a task with m < n or resolver pinv / inertia-pinv"
            )

    def resolve(self, robot: Robot, terms: TaskTerms, task_acceleration: np.ndarray) -> Resolution:
        """Joint torques realising ``task_acceleration`` [m/s², rad/s²] at the state of ``terms``.

        Builds a solver for this one call; a loop should call :meth:`solver` once.

        Raises:
            SingularJacobian: the task Jacobian is singular at this state.
        """
        return self.solver(robot)(terms, task_acceleration)

    @abstractmethod
    def solver(self, robot: Robot) -> Step:
        """The robot-bound step ``(terms, ẍ) -> Resolution``.

        What depends only on the robot (torque midpoint, weights, workspaces)
        is computed once here, so a simulation builds one solver per run and
        each step pays only for what changes with the state; nothing carries
        over from one run to the next.
        """

    def program_solver(self, robot: Robot) -> Step:
        """The step of :meth:`solver` whose resolutions also carry the program each solved (``Resolution.program``).

        Its torques are those of :meth:`solver`, bit for bit; only the record is added, which costs copies a run
        does not need, so runs use :meth:`solver` and :func:`torqueopt.testing.check_resolver` uses this one to
        check each program's optimality (KKT) conditions. :meth:`solver` itself by default: a resolver that solves
        no program (or keeps no record of it) returns ``program`` None.
        """
        return self.solver(robot)

    def objective_function(self, robot: Robot) -> Objective | None:
        r"""The criterion this resolver minimises over the torques that realise the task, or None (it declares none).

        A function ``(terms, torque) -> cost`` (a float) on ``robot``: the resolver's torque is its least value over
        :math:`\tau = \tilde\tau + H Z y`, every y (Eq. (26), Eq. (27)), or, on a step that solved a program
        (``program_solver``), every y its constraints admit. Nothing steps with it;
        :func:`torqueopt.testing.check_resolver` holds each answer to it by finite differences.
        """
        return None

    def solver_for_run(self, robot: Robot, dt: float) -> Step:
        """The step of a run that holds each torque for ``dt`` [s]: :meth:`solver` unless the resolver looks a step ahead."""
        return self.solver(robot)

    def solver_for_movement(self, robot: Robot, dt: float, trajectory) -> Step:
        """The step of a run of ``dt`` [s] along ``trajectory`` (anchored), called once per step, in order, from
        t = 0: :meth:`solver_for_run` unless the resolver plans along the path ahead (``receding-horizon``)."""
        return self.solver_for_run(robot, dt)

    def batch_solver(self, robot: Robot, dt: float | None = None) -> StackStep:
        """The step on stacks of B states, ``(StackTerms, ẍ (B, m), movements) -> StackResolution``.

        By default :func:`~torqueopt.resolvers.stacks.looped_stack_step`: the
        single-state step of a run of ``dt`` (:meth:`solver_for_run`; :meth:`solver`
        when dt is None), row by row, one per movement. A resolver with a
        vectorised step overrides this beside its :meth:`solver`.
        """
        return looped_stack_step(self, robot, dt)

    def __repr__(self) -> str:
        given = ", ".join(
            f"{option.name}={format_value(self.settings[option.name])}"
            for option in self.declared_options()
            if self.settings[option.name] is not option.default
        )
        return f"{type(self).__name__}(name={self.name!r}{', ' if given else ''}{given})"


class NullSpaceResolver(Resolver):
    r"""The family :math:`\ddot q = J^\dagger(\ddot x - \dot J\dot q) + Z y`, Eq. (26): a member chooses y.

    Subclasses implement :meth:`null_space_function`. Every member realises the
    task exactly, so its resolutions have ``task_error`` 0 and are never
    infeasible.
    """

    def solver(self, robot: Robot) -> Step:
        coordinates_at = self.null_space_function(robot) if robot.nv > robot.m else None
        # None: y = 0 (pinv), or no null space to move in (m = n).
        decompose = JacobianSolver(robot.m, robot.nv, self.singular_tolerance, null_space=coordinates_at is not None)

        def solve(terms: TaskTerms, task_acceleration: np.ndarray) -> Resolution:
            particular, basis, inverse_condition = decompose(terms.jacobian, task_acceleration - terms.drift)
            if coordinates_at is None:
                acceleration = particular
            else:
                acceleration = particular + basis.dot(coordinates_at(terms, basis, particular))  # Eq. (26)
            # Eq. (20); with the choice of y this is Eq. (34), Eq. (35), Eq. (36) or Eq. (37).
            torque = terms.inertia.dot(acceleration) + terms.bias_torque
            return Resolution(torque, acceleration, inverse_condition, 0.0, False)

        return solve

    def batch_solver(self, robot: Robot, dt: float | None = None) -> StackStep:
        r"""Eq. (26) and Eq. (20) on stacks, with this resolver's :meth:`stack_null_space_function`.

        The looped default of :class:`Resolver` when the class that chooses y
        for one state (:meth:`null_space_function`) has no stacked choice of
        its own: a subclass that changes the choice never inherits its
        parent's vectorised one.
        """
        owner = _defining_class(type(self), "null_space_function")
        if _defining_class(type(self), "stack_null_space_function") is not owner:
            return super().batch_solver(robot, dt)
        redundant = robot.nv > robot.m
        coordinates_at = self.stack_null_space_function(robot) if redundant else None
        factor = task_factorisation(robot)
        tolerance = self.singular_tolerance

        def solve(terms: StackTerms, task_acceleration: np.ndarray, movements: np.ndarray) -> StackResolution:
            H = terms.inertia
            # Eq. (26)'s particular solution J⁺(ẍ − J̇q̇), a null-space basis Z and σ_min/σ_max of J.
            particular, basis, inverse_condition = factor(terms.jacobian, task_acceleration - terms.drift, redundant)
            acceleration = particular
            if coordinates_at is not None:
                y = coordinates_at(terms, basis, particular)
                if y is not None:
                    acceleration = particular + np.einsum("bij,bj->bi", basis, y)  # Eq. (26)
            torque = np.einsum("bij,bj->bi", H, acceleration) + terms.bias_torque  # Eq. (20)
            failures = singular_rows(inverse_condition, tolerance)
            return StackResolution(torque, acceleration, inverse_condition, failures=failures, basis=basis)

        return solve

    def stack_null_space_function(self, robot: Robot):
        r""":meth:`null_space_function` on stacks: ``(StackTerms, Z (B, n, n − m), particular (B, n)) -> y (B, n − m)``.

        Returns None (y = 0 at every state) or the function; a resolver
        without one is never asked (its stacks loop its single-state step).
        """
        return None

    @abstractmethod
    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        r"""How this resolver picks the null-space coordinates on ``robot``.

        Returns a function ``(terms, Z, particular) -> y`` (n − m values),
        where Z is an orthonormal basis of the null space of J and
        ``particular`` is :math:`J^\dagger(\ddot x - \dot J\dot q)` [rad/s²];
        or None for :math:`y = 0` at every state. What depends only on the
        robot (torque midpoint, weights, workspaces) is computed here, once.
        """


def joint_acceleration_of(terms: TaskTerms, torque: np.ndarray) -> np.ndarray:
    """q̈ = H⁻¹(τ − b) [rad/s²], Eq. (20) solved for the acceleration (what a criterion in q̈ reads)."""
    return np.linalg.solve(terms.inertia, torque - terms.bias_torque)


def null_space_projector(terms: TaskTerms) -> np.ndarray:
    """I − J⁺J = Z Zᵀ, the projector onto the null space of the task Jacobian (whatever basis Z a step took)."""
    jacobian = terms.jacobian
    return np.eye(jacobian.shape[1]) - np.linalg.pinv(jacobian) @ jacobian


def _defining_class(cls: type, name: str) -> type | None:
    """The class of ``cls``'s method resolution order that defines attribute ``name``."""
    return next((base for base in cls.__mro__ if name in vars(base)), None)
