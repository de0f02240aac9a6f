r"""Terms providers: the task terms of one state or of a stack of states, the one place the engine calls Pinocchio.

A provider gives, for (B, nq) configurations and (B, n) velocities,
:meth:`terms` ``-> (StackTerms, task position (B, m))``: :math:`H`,
:math:`b = \dot q\cdot C\cdot\dot q + g` (Eq. (20)), :math:`J`,
:math:`\dot J\dot q` (Eq. (18)) and the task frame's position rows. Two
providers compute the same numbers:

* :class:`PinocchioTerms`, Pinocchio's frame calls on one data
  (:meth:`Robot.terms_function`): :meth:`PinocchioTerms.one` is what
  :func:`torqueopt.simulate` calls at every step (B = 1), and its
  :meth:`~PinocchioTerms.terms` loops it over a stack's rows;
* :class:`ForestTerms`, the forest of :mod:`torqueopt.robot_copies` (copies of the
  robot in one Pinocchio model: a few calls per pass of many states), for
  B > 1 on robots whose joints all add.

:func:`terms_provider` picks one. Both serve the position tasks (``xy``,
``position``); the tests hold the forest to Pinocchio's frame calls.
"""

from __future__ import annotations

import numpy as np

from .resolvers.stacks import StackTerms
from .robot import Robot
from .robot_copies import RobotForest

__all__ = ["ForestTerms", "PinocchioTerms", "terms_provider"]


class PinocchioTerms:
    """Task terms from Pinocchio's frame calls on one data of the robot (a fresh one when None)."""

    def __init__(self, robot: Robot, data=None):
        self.robot = robot
        self.data = robot.model.createData() if data is None else data
        #: ``(q, v) -> TaskTerms`` of one state; its inertia and bias are views of the data (see Robot.terms_function).
        self.one = robot.terms_function(self.data)

    def with_position(self, reference_rotation: np.ndarray | None = None):
        """``(q, v) -> (TaskTerms, x)``: :attr:`one` and the task coordinates x of the state.

        The B = 1 form of :meth:`terms`, what :func:`torqueopt.simulate` calls at
        every step. Position tasks read x straight off the frame's placement, a
        fresh SE3 that nothing writes again; ``pose`` gets
        :meth:`Robot.task_coordinates` about ``reference_rotation``.
        """
        robot, one = self.robot, self.one
        if robot.task == "pose":
            task_coordinates = robot.task_coordinates

            def terms_with_pose(q: np.ndarray, v: np.ndarray):
                terms = one(q, v)
                return terms, task_coordinates(terms.placement, reference_rotation)

            return terms_with_pose
        rows = robot.task_rows

        def terms_with_position(q: np.ndarray, v: np.ndarray):
            terms = one(q, v)
            return terms, terms.placement.translation[rows]

        return terms_with_position

    def terms(self, q: np.ndarray, v: np.ndarray):
        """(StackTerms, task positions) of every row of (B, nq) and (B, n) stacks, one state at a time."""
        robot, one = self.robot, self.one
        count, n, m = q.shape[0], robot.nv, robot.m
        inertia, bias = np.empty((count, n, n)), np.empty((count, n))
        jacobian, drift = np.empty((count, m, n)), np.empty((count, m))
        position = np.empty((count, m))
        rows = robot.task_rows
        for row in range(count):
            terms = one(q[row], v[row])
            inertia[row], bias[row] = terms.inertia, terms.bias_torque
            jacobian[row], drift[row] = terms.jacobian, terms.drift
            position[row] = terms.placement.translation[rows]
        return StackTerms(inertia, bias, jacobian, drift, v, q), position


#: Joints per forest pass of :class:`ForestTerms`: fewer than the forest's default (``FOREST_DOFS``, 48), because
#: Pinocchio's ``crba`` binding zeroes the whole forest's mass matrix before each pass and returns a copy of it,
#: work that grows with the square of the copies in a pass; 28 joints (9 copies of planar3, 4 of panda) cost fewer
#: instructions per movement than 48 on both arms (BENCHMARKS.md).
TERMS_FOREST_DOFS = 28


class ForestTerms:
    """Task terms of whole stacks from a :class:`~torqueopt.robot_copies.RobotForest` (robots whose joints all add),
    ``TERMS_FOREST_DOFS`` joints a pass."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.forest = RobotForest(robot, max(1, TERMS_FOREST_DOFS // robot.nv))

    def terms(self, q: np.ndarray, v: np.ndarray):
        """(StackTerms, task positions) of every row of (B, n) stacks, a few Pinocchio calls per forest pass."""
        rows = self.robot.task_rows
        H, b, jacobian, drift, tip = self.forest.terms(q, v)
        return StackTerms(H, b, jacobian[:, rows], drift[:, rows], v, q), tip[:, rows]


def terms_provider(robot: Robot, count: int):
    """The provider for ``count`` states at a time: the forest for several on a robot whose joints add, else Pinocchio."""
    if count > 1 and robot.euclidean:
        return ForestTerms(robot)
    return PinocchioTerms(robot)
