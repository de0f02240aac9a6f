"""The velocity-level methods' stacked forms (the batch's) on one state, for the tests that hold them to the general
single-state steps that :func:`torqueopt.simulate` takes (at 1e-12; the extended Jacobian's q̈ at 1e-9, its general
step taking the curvature by a central difference)."""

from __future__ import annotations

import numpy as np

from torqueopt.errors import SingularJacobian
from torqueopt.robot_copies import RobotForest
from torqueopt.tasks import FrameTask, Kinematics, PerConfiguration


def stack_of_one(stack, robot, task: FrameTask):
    """The single-state pair (rates, q̈) of ``VelocityResolver.step_functions`` from a method's stacked form:
    ``stack`` (a ``VelocityStack``) on a stack of one state, its kinematics from a forest of one copy of ``robot``
    (the batch's own pass). A row the stack finds undefined raises SingularJacobian with the stack's words.

    q̈ reads what the rates computed at the same configuration for the same command (the loop evaluates them
    there first); for another command it takes the rates again."""
    forest, rows = RobotForest(robot, 1), task.rows
    last: list = [None, None, None, None]  # the kinematics, its revision, the command, the stack's state

    @PerConfiguration
    def at_configuration(kinematics: Kinematics):
        q = kinematics.q[None]
        found = forest.kinematics(
            q, inverse_inertia=stack.reads_inverse_inertia, joints=stack.reads_joints, inertia=stack.reads_inertia
        )
        return q, found._replace(jacobian=found.jacobian[:, rows], frame_jacobian=found.jacobian)

    def rates(kinematics: Kinematics, task_velocity: np.ndarray):
        q, found = at_configuration(kinematics)
        velocity, conditions, failures, state = stack.rates(found.jacobian, task_velocity[None], q, found)
        if failures:
            raise SingularJacobian(failures[0])
        last[:] = kinematics, kinematics.revision, task_velocity, state
        return velocity[0], float(conditions[0])

    def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
        q, found = at_configuration(kinematics)
        if not (last[0] is kinematics and last[1] == kinematics.revision and np.array_equal(last[2], command)):
            rates(kinematics, command)
        moving = forest.kinematics(
            q, velocity[None], found.tip, inertia_rate=stack.reads_inertia_rate, joints=stack.reads_joints
        )
        moving = moving._replace(
            jacobian=moving.jacobian[:, rows], rate=moving.rate[:, rows],
            frame_jacobian=moving.jacobian, frame_rate=moving.rate,
        )  # fmt: skip
        return stack.acceleration(found.jacobian, moving.rate, velocity[None], command_rate[None], last[3], moving)[0]

    return rates, acceleration


def stacked_steps(resolver, robot, task: FrameTask):
    """``resolver``'s stacked form on a stack of one state (:func:`stack_of_one`), or None where the batch has no
    stack for it: joints that do not add, a task other than the robot's own position task, no
    ``stack_rate_function``."""
    if not robot.euclidean or task.kind == "pose" or task.frame != robot.frame or task.kind != robot.task:
        return None
    stack = resolver.stack_rate_function(robot)
    return None if stack is None else stack_of_one(stack, robot, task)
