r"""Terms providers: the task terms of one state or of a stack of states, the one place the engine calls Pinocchio.

A provider gives, for (B, nq) configurations and (B, n) velocities,
:meth:`terms` ``-> (StackTerms, task position (B, m))``: :math:`H`,
:math:`b = \dot q\cdot C\cdot\dot q + g` (Eq. (20)), :math:`J`,
:math:`\dot J\dot q` (Eq. (18)) and the task frame's position rows. Two
providers compute the same numbers:

* :class:`PinocchioTerms`, Pinocchio's frame calls on one data
  (:meth:`Robot.terms_function`), looped over a stack's rows: as
  :class:`TermRows` (:meth:`~PinocchioTerms.rows`) for a resolver's
  single-state step (what :func:`torqueopt.simulate` runs, a stack of one), or
  as :class:`StackTerms` (:meth:`~PinocchioTerms.terms`);
* :class:`ForestTerms`, the forest of :mod:`torqueopt.robot_copies` (copies of the
  robot in one Pinocchio model: a few calls per pass of many states), for
  B > 1 on robots whose joints all add.

:func:`terms_provider` picks one. Both serve the position tasks (``xy``,
``position``); the tests hold the forest to Pinocchio's frame calls.
"""

from __future__ import annotations

import numpy as np

from .resolvers.stacks import StackTerms
from .robot import Robot, TaskTerms
from .robot_copies import RobotForest

__all__ = ["ForestTerms", "PinocchioTerms", "TermRows", "terms_provider"]


class TermRows(tuple):
    """The task terms of each row of a stack as one state's :class:`~torqueopt.robot.TaskTerms` (what a resolver's
    single-state step reads, row by row), with the stacked fields the loop reads (H, J, J q̇) made when asked for."""

    __slots__ = ()

    def row(self, index: int) -> TaskTerms:
        """Row ``index``'s terms."""
        return self[index]

    def _stacked(self, name: str) -> np.ndarray:
        return np.array([getattr(row, name) for row in self])

    inertia = property(lambda self: self._stacked("inertia"))
    jacobian = property(lambda self: self._stacked("jacobian"))
    task_velocity = property(lambda self: self._stacked("task_velocity"))


class PinocchioTerms:
    """Task terms from Pinocchio's frame calls on one data of the robot (a fresh one when None).

    ``reference_rotation`` is the rotation a ``pose`` task's x is measured about
    (:meth:`Robot.task_coordinates`); position tasks read x straight off the
    frame's placement.
    """

    def __init__(self, robot: Robot, data=None, reference_rotation: np.ndarray | None = None):
        self.robot = robot
        self.data = robot.model.createData() if data is None else data
        #: ``(q, v) -> TaskTerms`` of one state; its inertia and bias are views of the data (see Robot.terms_function).
        self.one = robot.terms_function(self.data)
        if robot.task == "pose":
            task_coordinates = robot.task_coordinates
            self.position = lambda terms: task_coordinates(terms.placement, reference_rotation)
        else:
            rows = robot.task_rows
            self.position = lambda terms: terms.placement.translation[rows]

    def rows(self, q: np.ndarray, v: np.ndarray):
        """(TermRows, task positions (B, m)) of every row of (B, nq) and (B, n) stacks, one state at a time.

        Each row owns its inertia (in the data's column-major layout, so that a step makes the same BLAS calls as
        on the data) and bias.
        """
        one, position = self.one, self.position
        found = []
        for configuration, velocity in zip(q, v):
            terms = one(configuration, velocity)
            found.append(
                terms._replace(inertia=np.array(terms.inertia, order="F"), bias_torque=terms.bias_torque.copy())
            )
        return TermRows(found), np.array([position(terms) for terms in found])

    def stack_of_one(self):
        """``(q, v) -> (TaskTerms, x)`` of one state: the terms of a stack of one held as its row (what ``simulate``
        calls at every step), which keep their views of the data (its step reads them before the next call)."""
        one, position = self.one, self.position
        if self.robot.task == "pose":

            def terms_with_pose(q: np.ndarray, v: np.ndarray):
                terms = one(q, v)
                return terms, position(terms)

            return terms_with_pose
        rows = self.robot.task_rows

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
        for row in range(count):
            terms = one(q[row], v[row])
            inertia[row], bias[row] = terms.inertia, terms.bias_torque
            jacobian[row], drift[row] = terms.jacobian, terms.drift
            position[row] = self.position(terms)
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
