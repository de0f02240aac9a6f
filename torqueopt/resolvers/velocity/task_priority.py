r"""Task-priority resolution (Hanafusa, Yoshikawa & Nakamura, 1981), Eq. (7), Eq. (8), Eq. (9), Eq. (10), Eq. (11)."""

from __future__ import annotations

import numpy as np

from ...robot import Robot
from ...tasks import (
    FrameTask,
    Kinematics,
    PerConfiguration,
    PostureTask,
    TaskStack,
    prioritised_accelerations,
    priority_levels,
    rates_through,
)
from ..options import LARGEST_WEIGHT, Option, number
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import PostureDistance
from .gradient_projection import StackedGradientProjection, projected_gradient_steps
from .options import task_stack

__all__ = ["TaskPriority"]


class TaskPriority(VelocityResolver):
    r"""The robot's task first; lower-priority tasks in what freedom is left, Eq. (11).

    .. math::

        \dot q = J_h^\dagger \dot x_h + [J_l(I - J_h^\dagger J_h)]^\dagger(\dot x_l - J_l J_h^\dagger\dot x_h)

    with :math:`\dot x_h` the commanded velocity of the robot's task (the
    trajectory) and :math:`\dot x_l` the desired velocity of each secondary
    task (:math:`k(x^* - x)` toward its target). The high-priority task is
    realised exactly; the low-priority one in the least-squares sense Eq. (10).
    Several secondary tasks are stacked by the recursion of
    :mod:`torqueopt.tasks.stack`.

    Args:
        secondary: a Task (with a target), a TaskStack, or a sequence of them, highest priority first;
            by default a :class:`~torqueopt.tasks.PostureTask` toward the robot's default configuration.
        damping: damped-least-squares λ for the secondary inverses, 0 for the plain pseudoinverse;
            λ > 0 bounds the rates near the algorithmic singularities where :math:`J_l(I - J_h^\dagger J_h)` loses rank.
    """

    name = "task-priority"
    equations = (7, 8, 9, 10, 11)
    needs_redundancy = True
    options = (
        Option(
            name="secondary",
            kind="Task | TaskStack | list of Tasks | FRAME:x,y[,z] (';' between tasks) | 'posture'",
            unit="m",
            default=None,
            meaning="the lower-priority task(s), each regulated to its target: ẋ_l = k(x* − x_l)",
            convert=task_stack,
            default_text="posture: every joint toward the robot's default configuration, gain 1/s",
        ),
        Option(
            name="damping",
            kind="number in [0, 1e6]",
            unit="",
            default=0.0,
            meaning="damped least squares λ of the lower-priority inverses (0: the plain pseudoinverse of Eq. (11))",
            convert=number(0.0, maximum=LARGEST_WEIGHT),
        ),
        POSITION_GAIN_OPTION,
    )

    def __init__(self, **options):
        super().__init__(**options)
        self.stack = TaskStack([PostureTask()]) if self.secondary is None else self.secondary

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.stack.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of Eq. (11) in closed form: without damping, on a position task, with secondary tasks whose
        :math:`\dot J` and desired-velocity rate are known (frame tasks other than ``pose``, posture); else None.

        The recursion's time derivative (:func:`~torqueopt.tasks.prioritised_accelerations`), with the
        derivative of each pseudoinverse of constant rank,
        :math:`\frac{d}{dt}A^\dagger = -A^\dagger\dot A A^\dagger + A^\dagger A^{\dagger\top}\dot A^\top(I - AA^\dagger)
        + (I - A^\dagger A)\dot A^\top A^{\dagger\top}A^\dagger` (for the robot's task, of full row rank,
        :math:`-J^\dagger\dot J J^\dagger + (I - J^\dagger J)\dot J^\top(JJ^\top)^{-1}`). :math:`\dot J` of each
        frame task from Pinocchio's Jacobian time variation at (q, q̇); a secondary task's
        :math:`\dot x_l = k(x^* - x_l)` moves at :math:`-kJ_l\dot q`. With damping λ > 0 the damped inverses'
        derivative is not taken here (None: the loop's central difference). The Jacobians, pseudoinverses and
        projectors of the recursion (:func:`~torqueopt.tasks.priority_levels`) and the secondary tasks' desired
        velocities at q are those the rates computed there, when they did.
        """
        return self.step_functions(robot, task)[1]

    @property
    def _below_postures_only(self) -> bool:
        """Posture tasks alone below the robot's task, without damping: Eq. (11) is then gradient projection."""
        return self.damping == 0.0 and all(isinstance(lower, PostureTask) for lower in self.stack)

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (11)'s rates and their closed-form q̈ (or None), sharing the recursion's levels at each configuration.

        Below posture tasks only (the default) and without damping, Eq. (11) is gradient projection, Eq. (4),
        toward the first posture's target (:meth:`stack_rate_function` says why), and runs as such
        (``projected_gradient_steps`` with the criterion ``PostureDistance``): one SVD per configuration, not two.
        """
        secondary, damping = self.stack, self.damping
        secondary.check(robot)
        if self._below_postures_only:
            posture = secondary.tasks[0]
            rates, acceleration = projected_gradient_steps(
                robot, task, self.singular_tolerance, PostureDistance(posture), posture.gain
            )
            return rates, None if task.kind == "pose" else acceleration
        solver = pseudoinverse_solver(robot, self.singular_tolerance, null_space=False)

        @PerConfiguration
        def at_configuration(kinematics: Kinematics):
            jacobian = task.jacobian(kinematics)
            # the high-priority task must keep full rank; J⁺ by SVD, Eq. (3)
            inverse, inverse_condition = solver.pseudoinverse(jacobian)
            jacobians = [jacobian] + [lower.jacobian(kinematics) for lower in secondary]
            levels, _ = priority_levels(jacobians, damping=damping, first_inverse=inverse, final_projector=False)
            return levels, [lower.desired_velocity(kinematics) for lower in secondary], inverse_condition

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            levels, lower_velocities, inverse_condition = at_configuration(kinematics)
            # Eq. (11) (and its recursion for deeper stacks), Eq. (7), Eq. (8), Eq. (9), Eq. (10) in the docstring
            return rates_through(levels, [task_velocity, *lower_velocities]), inverse_condition

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            levels, lower_velocities, _ = at_configuration(kinematics)
            velocity_rates = [command_rate] + [lower.desired_velocity_rate(kinematics, velocity) for lower in secondary]
            jacobian_rates = [task.jacobian_rate(kinematics, velocity)] + [
                lower.jacobian_rate(kinematics, velocity) for lower in secondary
            ]
            # the time derivative of Eq. (11) (and of its recursion for deeper stacks)
            return prioritised_accelerations(
                [level.jacobian for level in levels],
                jacobian_rates,
                [command, *lower_velocities],
                velocity_rates,
                levels=levels,
            )[1]

        closed_form = task.kind != "pose" and damping == 0.0 and all(lower.closed_form_rates for lower in secondary)
        return rates, acceleration if closed_form else None

    def stack_rate_function(self, robot: Robot):
        r"""Eq. (11) and its closed-form q̈ on stacks, for a position task whose secondary tasks are postures
        (the default) without damping; else None (one movement at a time).

        Below the robot's task, a posture task (:math:`J_l = I`, :math:`\dot x_l = k(q^* - q)`) acts through
        :math:`[I(I - J^\dagger J)]^\dagger = I - J^\dagger J` (an orthogonal projector is its own pseudoinverse),
        so Eq. (11) is :math:`\dot q = J^\dagger\dot x + k(I - J^\dagger J)(q^* - q)`: gradient projection,
        Eq. (4), with :math:`p = \tfrac12\|q - q^*\|^2` and gain k (``StackedGradientProjection``). It
        leaves no freedom, so every task below the first posture adds nothing.
        """
        secondary = self.stack
        # on stacks the configuration is the joint angles plus the neutral one (every joint adds: robot.euclidean)
        if robot.task == "pose" or not robot.euclidean or not self._below_postures_only:
            return None
        secondary.check(robot)
        posture = secondary.tasks[0]
        joints = np.arange(robot.nv)
        # ẋ_l = k(q* − q) = −k ∂p/∂q with p = ½‖q − q*‖² (q* the target as a configuration)
        return StackedGradientProjection(
            self.singular_tolerance, robot.nv, joints, joints, robot.configuration(posture.target),
            np.ones(robot.nv), posture.gain,
        )  # fmt: skip
