r"""The resolver contract.

Every resolver of the paper writes the joint acceleration as a particular
solution plus a null-space motion, Eq. (26):

.. math::

    \ddot q = J^\dagger(\ddot x - \dot J \dot q) + Z y,
    \qquad \tau = H \ddot q + \dot q \cdot C \cdot \dot q + g,

where :math:`Z` is an orthonormal basis of the null space of :math:`J`
(:math:`I - J^\dagger J = Z Z^\top`) and :math:`y` are the null-space
coordinates. A resolver only chooses :math:`y`; every choice realises the
task exactly, :math:`J\ddot q + \dot J \dot q = \ddot x`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import NoRedundancy
from ..linalg import DEFAULT_SINGULAR_TOLERANCE, JacobianSolver
from ..robot import Robot, TaskTerms

__all__ = ["Resolution", "Resolver"]


@dataclass(frozen=True)
class Resolution:
    """What a resolver returns at one state.

    Attributes:
        torque: joint torques τ [N·m].
        joint_acceleration: the joint acceleration q̈ these torques produce [rad/s²].
        jacobian_condition: σ_min/σ_max of the task Jacobian at this state.
    """

    torque: np.ndarray
    joint_acceleration: np.ndarray
    jacobian_condition: float


class Resolver(ABC):
    """Maps a desired task acceleration to joint torques.

    Subclasses set :attr:`name`, document their equation, and implement
    :meth:`null_space_solver`.
    """

    name: ClassVar[str]
    #: True when the method is only defined with a null space (m < n).
    needs_redundancy: ClassVar[bool] = False

    def __init__(self, singular_tolerance: float = DEFAULT_SINGULAR_TOLERANCE):
        self.singular_tolerance = singular_tolerance

    def check(self, robot: Robot) -> None:
        """Raise if this resolver cannot serve the robot's task."""
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

        Raises:
            SingularJacobian: the task Jacobian is singular at this state.
        """
        return Resolution(*self.solver(robot)(terms, task_acceleration))

    def solver(self, robot: Robot):
        """:meth:`resolve` for one robot as a function ``(terms, ẍ) -> (τ, q̈, condition)``.

        What depends only on the robot (torque midpoint, weights, SVD
        workspaces) is computed once here, so a simulation builds one solver
        per run and each step pays only for what changes with the state;
        nothing carries over from one run to the next.
        """
        coordinates_at = self.null_space_solver(robot) if robot.nv > robot.m else None
        # None: y = 0 (pinv), or no null space to move in (m = n).
        decompose = JacobianSolver(robot.m, robot.nv, self.singular_tolerance, null_space=coordinates_at is not None)

        def solve(terms: TaskTerms, task_acceleration: np.ndarray):
            particular, basis, condition = decompose(terms.jacobian, task_acceleration - terms.drift)
            if coordinates_at is None:
                acceleration = particular
            else:
                acceleration = particular + basis.dot(coordinates_at(terms, basis, particular))
            torque = terms.inertia.dot(acceleration) + terms.bias_torque
            return torque, acceleration, condition

        return solve

    @abstractmethod
    def null_space_solver(self, robot: Robot):
        r"""How this resolver picks the null-space coordinates on ``robot``.

        Returns a function ``(terms, Z, particular) -> y`` (n − m values),
        where Z is an orthonormal basis of the null space of J and
        ``particular`` is :math:`J^\dagger(\ddot x - \dot J\dot q)` [rad/s²];
        or None for :math:`y = 0` at every state. What depends only on the
        robot (torque midpoint, weights, workspaces) is computed here, once.
        """

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"
