r"""Task-priority resolution (Hanafusa, Yoshikawa & Nakamura, 1981), Eq. (7), Eq. (8), Eq. (9), Eq. (10), Eq. (11)."""

from __future__ import annotations

import numpy as np

from ...linalg import cross_along
from ...robot import Robot
from ...robot_copies import RobotForest, point_kinematics
from ...tasks import (
    FrameTask,
    Kinematics,
    PerConfiguration,
    PostureTask,
    PriorityLevel,
    Task,
    TaskStack,
    prioritised_accelerations,
    priority_levels,
    pseudoinverse_workspace,
    rates_through,
    undamped_pseudoinverse,
)
from ...tasks.stack import ABSOLUTE_TOLERANCE, stacked_undamped_pseudoinverse
from ...tasks.task import identity
from ..options import LARGEST_WEIGHT, Option, number
from ..registry import register_resolver
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import PostureDistance
from .gradient_projection import StackedGradientProjection, projected_gradient_steps
from .options import task_stack
from .pseudoinverse import StackedPseudoInverse, stacked_inverse

__all__ = ["TaskPriority", "below_one_task_steps", "accelerations_below_one_task"]


@register_resolver
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
        velocities at q are those the rates computed there, when they did. Below one task the derivative is taken
        in fewer products (``accelerations_below_one_task``).
        """
        return self.step_functions(robot, task)[1]

    @property
    def _below_postures_only(self) -> bool:
        """Posture tasks alone below the robot's task, without damping: Eq. (11) is then gradient projection."""
        return self.damping == 0.0 and all(isinstance(lower, PostureTask) for lower in self.stack)

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (11)'s rates and their closed-form q̈ (or None), sharing the recursion's levels at each configuration.

        Below posture tasks only (the default) and without damping, Eq. (11) is gradient projection, Eq. (4), toward
        the first posture's target (:meth:`stack_rate_function` says why), and runs as such
        (``projected_gradient_steps`` with the criterion ``PostureDistance``): one SVD per configuration, not two;
        below one other task without damping, ``below_one_task_steps``. The batch takes the stacked form
        (:meth:`stack_rate_function`), which the tests hold to these.
        """
        secondary, damping = self.stack, self.damping
        secondary.check(robot)
        if self._below_postures_only:
            posture = secondary.tasks[0]
            rates, acceleration = projected_gradient_steps(
                robot, task, self.singular_tolerance, PostureDistance(posture), posture.gain
            )
            return rates, None if task.kind == "pose" else acceleration
        if len(secondary) == 1 and damping == 0.0:
            lower = secondary.tasks[0]
            rates, acceleration = below_one_task_steps(robot, task, lower, self.singular_tolerance)
            return rates, acceleration if task.kind != "pose" and secondary.tasks[0].closed_form_rates else None
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
        r"""Eq. (11) and its closed-form q̈ on stacks, for a position task without damping whose secondary tasks are
        postures (the default), or one frame task of kind ``xy`` or ``position``; else None (one movement at a
        time: damping, a ``pose`` frame task, an obstacle task, several tasks of which one is not a posture).

        Below the robot's task, a posture task (:math:`J_l = I`, :math:`\dot x_l = k(q^* - q)`) acts through
        :math:`[I(I - J^\dagger J)]^\dagger = I - J^\dagger J` (an orthogonal projector is its own pseudoinverse),
        so Eq. (11) is :math:`\dot q = J^\dagger\dot x + k(I - J^\dagger J)(q^* - q)`: gradient projection,
        Eq. (4), with :math:`p = \tfrac12\|q - q^*\|^2` and gain k (``StackedGradientProjection``). It
        leaves no freedom, so every task below the first posture adds nothing. Below one frame task,
        ``StackedPriorityBelowFrame``: ``below_one_task_steps`` on stacks.
        """
        secondary = self.stack
        # on stacks the configuration is the joint angles plus the neutral one (every joint adds: robot.euclidean)
        if robot.task == "pose" or not robot.euclidean or self.damping != 0.0:
            return None
        secondary.check(robot)
        lower = secondary.tasks[0]
        if len(secondary) == 1 and type(lower) is FrameTask and lower.kind != "pose":
            stack = StackedPriorityBelowFrameInPlane if (robot.nv, robot.m) == (3, 2) else StackedPriorityBelowFrame
            return stack(self.singular_tolerance, RobotForest(robot), lower, robot.nv - robot.m)
        if not self._below_postures_only:
            return None
        joints = np.arange(robot.nv)
        # ẋ_l = k(q* − q) = −k ∂p/∂q with p = ½‖q − q*‖² (q* the target as a configuration)
        return StackedGradientProjection(
            self.singular_tolerance, robot.nv, joints, joints, robot.configuration(lower.target),
            np.ones(robot.nv), lower.gain,
        )  # fmt: skip


def below_one_task_steps(robot: Robot, task: FrameTask, lower: Task, tolerance: float):
    r"""Eq. (11)'s rates below one task without damping, and their closed-form q̈ (:func:`accelerations_below_one_task`),
    sharing at each configuration J, :math:`J^\dagger` (refused, SingularJacobian, below ``tolerance`` of
    σmin/σmax), :math:`J_l`, the levels :func:`~torqueopt.tasks.priority_levels` gives for them (built here as it
    builds them, the lower SVD in one object for the run; the tests hold them equal) and :math:`\dot x_l`.
    """
    solver = pseudoinverse_solver(robot, tolerance, null_space=False)
    lower_svd = pseudoinverse_workspace(lower.dimension, robot.nv)
    identity_n = identity(robot.nv)

    @PerConfiguration
    def at_configuration(kinematics: Kinematics):
        jacobian = task.jacobian(kinematics)
        # the high-priority task must keep full rank; J⁺ by SVD, Eq. (3)
        inverse, inverse_condition = solver.pseudoinverse(jacobian)
        lower_jacobian = lower.jacobian(kinematics)
        projector = identity_n - inverse.dot(jacobian)  # I − J⁺J
        projected = lower_jacobian.dot(projector)  # J_l(I − J⁺J) of Eq. (10)
        levels = (
            PriorityLevel(jacobian, None, jacobian, inverse),
            PriorityLevel(lower_jacobian, projector, projected, undamped_pseudoinverse(projected, svd=lower_svd)),
        )
        return levels, lower.desired_velocity(kinematics), inverse_condition

    def rates(kinematics: Kinematics, task_velocity: np.ndarray):
        levels, lower_velocity, inverse_condition = at_configuration(kinematics)
        inverse, lower_level = levels[0].inverse, levels[1]
        first_rates = inverse.dot(task_velocity)
        # Eq. (11): J⁺ẋ_h + [J_l(I − J⁺J)]⁺(ẋ_l − J_l J⁺ẋ_h)
        return first_rates + lower_level.inverse.dot(
            lower_velocity - lower_level.jacobian.dot(first_rates)
        ), inverse_condition

    def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
        levels, lower_velocity, _ = at_configuration(kinematics)
        return accelerations_below_one_task(
            levels,
            task.jacobian_rate(kinematics, velocity),
            lower.jacobian_rate(kinematics, velocity),
            command,
            command_rate,
            lower_velocity,
            lower.desired_velocity_rate(kinematics, velocity),
        )

    return rates, acceleration


def accelerations_below_one_task(
    levels, jacobian_rate, lower_jacobian_rate, command, command_rate, lower_velocity, lower_velocity_rate
) -> np.ndarray:
    r"""q̈ [rad/s²] of Eq. (11) for the robot's task and one task below it: the q̈ of
    :func:`~torqueopt.tasks.prioritised_accelerations` (its readable reference, which the tests hold this to) in
    fewer products, from the two :func:`~torqueopt.tasks.priority_levels` of J (of full row rank) and
    :math:`J_l`, the rates :math:`\dot J`, :math:`\dot J_l`, c, ċ, :math:`\dot x_l` and :math:`\ddot x_l`.

    With :math:`P = I - J^\dagger J`, :math:`A = J_lP` and full row rank (:math:`JJ^\dagger = I`,
    :math:`J^{\dagger\top}J^\dagger J = J^{\dagger\top}`), the first level's derivatives are

    .. math::

        \ddot q_1 = J^\dagger(\dot c - \dot J\dot q_1) + P\dot J^\top J^{\dagger\top}\dot q_1,\quad
        \dot q_1 = J^\dagger c,\qquad \dot P = -(X + X^\top),\quad X = J^\dagger\dot J P,

    (the recursion's :math:`\dot J^\dagger c + J^\dagger\dot c` and :math:`-\dot J^\dagger J - J^\dagger\dot J`),
    and the second's, with :math:`e = \dot x_l - J_l\dot q_1`, :math:`y = A^\dagger e`,
    :math:`\dot A = \dot J_lP + J_l\dot P` and :func:`~torqueopt.tasks.pseudoinverse_rate` applied to e alone,

    .. math::

        \ddot q = \ddot q_1 + A^\dagger\big(\dot e - \dot Ay + A^{\dagger\top}\dot A^\top(e - Ay) - Az\big) + z,\quad
        z = \dot A^\top A^{\dagger\top}y,\quad \dot e = \ddot x_l - \dot J_l\dot q_1 - J_l\ddot q_1.
    """
    level, lower = levels
    inverse, projector = level.inverse, lower.projector
    lower_jacobian, projected, projected_inverse = lower.jacobian, lower.projected, lower.inverse
    first_rates = inverse.dot(command)
    # q̈_1 = J⁺(ċ − J̇q̇_1) + P J̇ᵀJ⁺ᵀq̇_1 (row-vector products: no transposes)
    first_accelerations = inverse.dot(command_rate - jacobian_rate.dot(first_rates)) + projector.dot(
        first_rates.dot(inverse).dot(jacobian_rate)
    )
    drop_rate = inverse.dot(jacobian_rate.dot(projector))  # X = J⁺J̇P, Ṗ = −(X + Xᵀ)
    # Ȧ = J̇_l P + J_l Ṗ
    projected_rate = lower_jacobian_rate.dot(projector) - lower_jacobian.dot(drop_rate + drop_rate.T)
    shortfall = lower_velocity - lower_jacobian.dot(first_rates)  # e of Eq. (11)
    shortfall_rate = (
        lower_velocity_rate - lower_jacobian_rate.dot(first_rates) - lower_jacobian.dot(first_accelerations)
    )
    particular = projected_inverse.dot(shortfall)  # y = A⁺e
    # Ȧ⁺e = −A⁺ȦA⁺e + A⁺A⁺ᵀȦᵀ(I − AA⁺)e + (I − A⁺A)ȦᵀA⁺ᵀA⁺e, with A⁺ė joined to its first two terms
    residual = shortfall - projected.dot(particular)
    along = particular.dot(projected_inverse).dot(projected_rate)  # z = ȦᵀA⁺ᵀy
    inner = (
        shortfall_rate
        - projected_rate.dot(particular)
        + residual.dot(projected_rate).dot(projected_inverse)
        - projected.dot(along)
    )
    return first_accelerations + projected_inverse.dot(inner) + along


def _mv(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Mx per row of (B, r, c) and (B, c) stacks."""
    return np.einsum("bij,bj->bi", matrices, vectors)


def _vm(vectors: np.ndarray, matrices: np.ndarray) -> np.ndarray:
    """xᵀM per row of (B, r) and (B, r, c) stacks (a row vector times a matrix: no transposes)."""
    return np.einsum("bi,bij->bj", vectors, matrices)


class StackedPriorityBelowFrame(StackedPseudoInverse):
    r"""Eq. (11) below one frame task (``xy`` or ``position``) and its closed-form :math:`\ddot q` per row of
    (B, m, n) stacks: ``below_one_task_steps`` and ``accelerations_below_one_task`` on stacks.

    .. math::

        \dot q = J^\dagger c + A^\dagger(\dot x_l - J_lJ^\dagger c),\qquad A = J_l(I - J^\dagger J),\qquad
        \dot x_l = k(x^* - x_l)\ (\text{zero without a target}).

    :math:`J^\dagger` as :class:`StackedPseudoInverse` forms it (a row whose σmin/σmax of J is below the tolerance
    fails, as the SVD's solver refuses it); the frame's position :math:`x_l`, Jacobian :math:`J_l` and its rate
    :math:`\dot J_l` from every joint's kinematics of the forest's pass (``RobotForest.frame_points``,
    ``point_kinematics``), the task's rows. :math:`A^\dagger` (``stacked_undamped_pseudoinverse``) drops, as
    ``undamped_pseudoinverse`` does, the singular values of A at or below :math:`\max(10^{-10}\sigma_{max}, 10^{-10})`: for one degree of redundancy
    (n − m = 1) :math:`I - J^\dagger J = zz^\top` and :math:`A = (J_lz)z^\top` has rank one, its one singular value
    :math:`\|A\|_F` (kept where above :math:`10^{-10}`, the relative cutoff never binding on it) and
    :math:`A^\dagger = A^\top/\|A\|_F^2` in closed form on the batch axis; more redundancy by numpy's SVD per row.
    A row where A loses rank goes on with the rank it has, as the single-state code does (its rates grow as
    :math:`1/\sigma` near there, until a ceiling stops the movement).

    Args:
        tolerance: the smallest σmin/σmax of J a row may have.
        forest: a forest of the robot (what its ``frame_points`` and ``support_columns`` read).
        lower: the frame task below the robot's task.
        redundancy: n − m.
    """

    reads_joints = True

    def __init__(self, tolerance: float, forest: RobotForest, lower: FrameTask, redundancy: int):
        super().__init__(tolerance)
        model = forest.robot.model
        self.forest, self.frame_id = forest, model.getFrameId(lower.frame)
        # the joints that move the frame: its parent joint's support
        self.columns = forest.support_columns(model.frames[self.frame_id].parentJoint)
        self.rows, self.target, self.gain = lower.rows, lower.target, lower.gain
        self.rank_one = redundancy == 1

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a singular row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with every joint's kinematics."""
        jacobian_t = np.swapaxes(jacobian, 1, 2)
        gram = jacobian @ jacobian_t
        conditions, failures, determinant = self.conditions(gram)
        inverse = jacobian_t @ stacked_inverse(gram, failures, determinant)  # J⁺, Eq. (3)
        first_rates = _mv(inverse, command)
        joints = kinematics.joints
        point = self.forest.frame_points(joints, self.frame_id)
        lower_jacobian = point_kinematics(joints, self.columns, point)[0][:, self.rows]
        if self.target is None:
            lower_velocity = np.zeros((jacobian.shape[0], lower_jacobian.shape[1]))
        else:
            lower_velocity = self.gain * (self.target - point[:, self.rows])  # ẋ_l = k(x* − x_l)
        projector = identity(jacobian.shape[2]) - inverse @ jacobian  # I − J⁺J
        projected = lower_jacobian @ projector  # J_l(I − J⁺J) of Eq. (10)
        projected_inverse = stacked_undamped_pseudoinverse(projected, rank_one=self.rank_one)
        shortfall = lower_velocity - _mv(lower_jacobian, first_rates)
        particular = _mv(projected_inverse, shortfall)
        # Eq. (11): J⁺ẋ_h + [J_l(I − J⁺J)]⁺(ẋ_l − J_l J⁺ẋ_h)
        velocity = first_rates + particular
        state = (inverse, projector, lower_jacobian, projected, projected_inverse, point, first_rates, shortfall,
                 particular)  # fmt: skip
        return velocity, conditions, failures, state

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """``accelerations_below_one_task`` per row (its docstring has the derivation). ``kinematics``: the
        forest's at the configuration and q̇, with every joint's kinematics and their rates."""
        inverse, projector, lower_jacobian, projected, projected_inverse, point, first_rates, shortfall, particular = (
            state
        )
        lower_jacobian_rate = point_kinematics(kinematics.joints, self.columns, point, velocity)[1][:, self.rows]
        # ẍ_l = −k J_l q̇ (zero without a target)
        lower_velocity_rate = 0.0 if self.target is None else -self.gain * _mv(lower_jacobian, velocity)
        # q̈_1 = J⁺(ċ − J̇q̇_1) + P J̇ᵀJ⁺ᵀq̇_1
        first_accelerations = _mv(inverse, command_rate - _mv(jacobian_rate, first_rates)) + _mv(
            projector, _vm(_vm(first_rates, inverse), jacobian_rate)
        )
        drop_rate = inverse @ (jacobian_rate @ projector)  # X = J⁺J̇P, Ṗ = −(X + Xᵀ)
        # Ȧ = J̇_l P + J_l Ṗ
        projected_rate = lower_jacobian_rate @ projector - lower_jacobian @ (drop_rate + np.swapaxes(drop_rate, 1, 2))
        shortfall_rate = (
            lower_velocity_rate - _mv(lower_jacobian_rate, first_rates) - _mv(lower_jacobian, first_accelerations)
        )
        # Ȧ⁺e = −A⁺ȦA⁺e + A⁺A⁺ᵀȦᵀ(I − AA⁺)e + (I − A⁺A)ȦᵀA⁺ᵀA⁺e, with A⁺ė joined to its first two terms
        residual = shortfall - _mv(projected, particular)
        along = _vm(_vm(particular, projected_inverse), projected_rate)  # z = ȦᵀA⁺ᵀy
        inner = (
            shortfall_rate
            - _mv(projected_rate, particular)
            + _vm(_vm(residual, projected_rate), projected_inverse)
            - _mv(projected, along)
        )
        return first_accelerations + _mv(projected_inverse, inner) + along


class StackedPriorityBelowFrameInPlane(StackedPriorityBelowFrame):
    r""":class:`StackedPriorityBelowFrame` for three joints and two task rows (planar3's ``xy`` task): one degree
    of redundancy, its null space spanned by the unit vector :math:`z \propto j_1\times j_2` (J's rows), so that
    :math:`I - J^\dagger J = zz^\top` and :math:`A = J_l(I - J^\dagger J) = bz^\top` with :math:`b = J_lz`, and
    Eq. (11) and its time derivative in vectors alone:

    .. math::

        \dot q = \dot q_1 + sz,\quad \dot q_1 = J^\dagger c = J^\top w,\quad w = (JJ^\top)^{-1}c,\quad
        s = \frac{b^\top e}{b^\top b},\quad e = \dot x_l - J_l\dot q_1,

        \ddot q = \ddot q_1 + s\dot z + \dot sz,\quad
        \ddot q_1 = J^\dagger(\dot c - \dot J\dot q_1) + z\,(\dot Jz)^\top w,\quad
        \dot z = -J^\dagger\dot Jz,

        \dot s = \frac{\dot b^\top e + b^\top\dot e - 2s\,b^\top\dot b}{b^\top b},\quad
        \dot b = \dot J_lz + J_l\dot z,\quad \dot e = \ddot x_l - \dot J_l\dot q_1 - J_l\ddot q_1,\quad
        \ddot x_l = -kJ_l\dot q

    (:math:`A^\dagger e = z\,b^\top e/b^\top b`; :math:`\dot z` from :math:`Jz = 0` and :math:`z^\top z = 1`):
    ``accelerations_below_one_task`` for this A of rank one. A's one singular value is :math:`\|b\|`, dropped
    (s = 0) at or below :math:`10^{-10}` as ``undamped_pseudoinverse`` drops it. :math:`J_l` and :math:`\dot J_l`
    enter only through their products with vectors, from the joints' world-frame :math:`J_O`, :math:`\dot J_O` as
    ``point_products`` forms them, J⁺ only in q̈; the q̈ of :class:`StackedPriorityBelowFrame` in fewer and
    smaller products (the tests hold both to the kinematic loop). Every quantity is held component-first, the
    batch axis last ((3, B) for a vector, (6, n, B) for :math:`J_O`): each numpy operation then runs over the
    batch, where numpy's product of (B, ·, ·) stacks calls BLAS once per row.
    """

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a singular row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with every joint's kinematics."""
        rows = self.rows
        task = np.ascontiguousarray(jacobian.transpose(1, 2, 0))  # J, (2, 3, B)
        gram = np.einsum("ijb,kjb->ikb", task, task)  # JJᵀ, (2, 2, B)
        conditions, failures, determinant = self.conditions(gram.transpose(2, 0, 1))
        gram_inverse = _inverse_pairs(gram, failures, determinant)
        multipliers = np.einsum("ijb,bj->ib", gram_inverse, command)  # w = (JJᵀ)⁻¹c
        first_rates = np.einsum("ijb,ib->jb", task, multipliers)  # q̇_1 = Jᵀw = J⁺c, Eq. (3)
        null = cross_along(task[0], task[1], 0)  # J's rows' cross product spans its null space
        length = np.sqrt(np.einsum("ib,ib->b", null, null))
        null /= np.where(length > 0.0, length, 1.0)  # z (a singular row's is unused)
        joints = kinematics.joints
        point = self.forest.frame_points(joints, self.frame_id).T  # (3, B)
        world = _component_first(joints.jacobian, self.columns)  # J_O of the columns that move the frame
        vectors = np.stack((first_rates, null), axis=1)  # (q̇_1, z), (3, 2, B)
        spatial = np.einsum("rjb,jkb->rkb", world, vectors)  # J_O(q̇_1, z)
        # J_l(q̇_1, z): linear rows J_O,v X + (J_O,ω X) × p, all rows
        products = spatial[:3] + cross_along(spatial[3:], point[:, None], 0)
        lower_first, lower_null = products[rows, 0], products[rows, 1]  # J_l q̇_1, b = J_l z
        if self.target is None:
            shortfall = -lower_first
        else:
            # e = k(x* − x_l) − J_l q̇_1
            shortfall = self.gain * (self.target[:, None] - point[rows]) - lower_first
        squared = np.einsum("ib,ib->b", lower_null, lower_null)
        # 1/‖b‖², zero where A's one singular value ‖b‖ is at or below the cutoff
        inverse_square = np.divide(1.0, squared, out=np.zeros_like(squared), where=squared > ABSOLUTE_TOLERANCE**2)
        share = np.einsum("ib,ib->b", lower_null, shortfall) * inverse_square  # s = bᵀe/bᵀb
        # Eq. (11): J⁺c + [J_l(I − J⁺J)]⁺(ẋ_l − J_l J⁺c) = q̇_1 + z bᵀe/bᵀb
        velocity = np.ascontiguousarray((first_rates + share * null).T)
        state = (task, gram_inverse, multipliers, vectors, point, spatial[3:], products, shortfall, share,
                 inverse_square)  # fmt: skip
        return velocity, conditions, failures, state

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """q̈ of the class docstring per row. ``kinematics``: the forest's at the configuration and q̇, with every
        joint's kinematics and their rates."""
        task, gram_inverse, multipliers, vectors, point, angular, products, shortfall, share, inverse_square = state
        null, rows = vectors[:, 1], self.rows  # z
        moved = np.einsum("ijb,jkb->ikb", jacobian_rate.transpose(1, 2, 0), vectors)  # J̇(q̇_1, z)
        # J⁺(ċ − J̇q̇_1) and J⁺J̇z in one product, J⁺ = Jᵀ(JJᵀ)⁻¹ (Eq. (3))
        moved[:, 0] = command_rate.T - moved[:, 0]
        solved = np.einsum("ijb,ikb->jkb", task, np.einsum("ijb,jkb->ikb", gram_inverse, moved))
        # q̈_1 = J⁺(ċ − J̇q̇_1) + z (J̇z)ᵀw
        first_accelerations = solved[:, 0] + np.einsum("ib,ib->b", moved[:, 1], multipliers) * null
        null_rate = -solved[:, 1]  # ż = −J⁺J̇z
        point_velocity = products[:, 0] + share * products[:, 1]  # ṗ = J_l q̇ (linear rows)
        world = _component_first(kinematics.joints.jacobian, self.columns)
        spatial = np.einsum("rjb,jkb->rkb", world, np.stack((null_rate, first_accelerations), axis=1))
        along = spatial[:3] + cross_along(spatial[3:], point[:, None], 0)  # J_l(ż, q̈_1)
        spatial_rate = np.einsum("rjb,jkb->rkb", _component_first(kinematics.joints.rate, self.columns), vectors)
        # J̇_l(q̇_1, z) = J̇_O,v Y + (J̇_O,ω Y) × p + (J_O,ω Y) × ṗ
        rate = spatial_rate[:3] + cross_along(spatial_rate[3:], point[:, None], 0)
        rate += cross_along(angular, point_velocity[:, None], 0)
        lower = products[rows, 1]  # b = J_l z
        lower_rate = rate[rows, 1] + along[rows, 0]  # ḃ = J̇_l z + J_l ż
        # ė = ẍ_l − J̇_l q̇_1 − J_l q̈_1, ẍ_l = −k J_l q̇ (zero without a target)
        shortfall_rate = -rate[rows, 0] - along[rows, 1]
        if self.target is not None:
            shortfall_rate -= self.gain * (products[rows, 0] + share * lower)
        # ṡ = (ḃᵀe + bᵀė − 2s bᵀḃ)/bᵀb
        share_rate = (
            np.einsum("ib,ib->b", lower_rate, shortfall - 2.0 * share * lower)
            + np.einsum("ib,ib->b", lower, shortfall_rate)
        ) * inverse_square
        return np.ascontiguousarray((first_accelerations + share * null_rate + share_rate * null).T)


def _component_first(stack: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """A (B, r, c) stack as a contiguous (r, c, B) array, its columns times ``columns`` (c,) (ones: as it is)."""
    moved = stack.transpose(1, 2, 0)
    return np.ascontiguousarray(moved) if columns.all() else moved * columns[:, None]


def _inverse_pairs(gram: np.ndarray, failures: dict, determinant: np.ndarray) -> np.ndarray:
    """The inverses (2, 2, B) of a (2, 2, B) stack of symmetric matrices, ((d, −b), (−b, a))/(ad − b²), from
    their determinants; a row in ``failures`` gets the identity (a finite, unused answer)."""
    inverse = np.empty_like(gram)
    inverse[0, 0], inverse[1, 1] = gram[1, 1], gram[0, 0]
    inverse[0, 1] = inverse[1, 0] = -gram[0, 1]
    if failures:
        rows = list(failures)
        inverse[:, :, rows], determinant[rows] = identity(2)[:, :, None], 1.0
    inverse /= determinant
    return inverse
