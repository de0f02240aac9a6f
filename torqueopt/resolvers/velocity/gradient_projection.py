r"""Gradient projection (Liégeois, 1977), Eq. (4) of the paper."""

from __future__ import annotations

import numpy as np

from ...robot import Robot
from ...tasks import FrameTask, Kinematics, PerConfiguration
from ..options import Option, number
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import Criterion, JointLimits, criterion_from
from .options import criterion_spec
from .pseudoinverse import StackedPseudoInverse

__all__ = [
    "GradientProjection",
    "projected_gradient_steps",
    "CriterionGain",
    "CRITERION_OPTION",
    "DEFAULT_GAINS",
    "gain_option",
]

#: Default gain k per named criterion, chosen on the paper's long movement
#: (see docs/discussion/kinematic.md, "Kinematic against kinetic resolution").
DEFAULT_GAINS = {"joint-limits": 10.0, "manipulability": 1.0}


#: The criterion p(q) of both gradient-projection resolvers (velocity and acceleration level).
CRITERION_OPTION = Option(
    name="criterion",
    kind="'joint-limits' | 'manipulability' | callable p(joint_angles)",
    unit="",
    default="joint-limits",
    meaning="the criterion p to minimise: Eq. (5), or p = −w of Eq. (6), or your own",
    convert=criterion_spec,
)


def gain_option(unit: str, meaning: str) -> Option:
    """The gain k of a gradient term, in ``unit``; its default depends on the criterion (:data:`DEFAULT_GAINS`)."""
    return Option(
        name="k",
        kind="number >= 0",
        unit=unit,
        default=None,
        meaning=meaning,
        convert=number(0.0),
        default_text="10 for joint-limits, 1 for manipulability and callables",
    )


class CriterionGain:
    """For resolvers with the options ``criterion`` and ``k``: the criterion object and its gain.

    Sets ``objective`` (a :class:`Criterion`) and ``gain`` (``k``, or the
    criterion's default gain), and checks the criterion against the robot.
    """

    def __init__(self, **options):
        super().__init__(**options)
        self.objective = criterion_from(self.criterion)
        self.gain = DEFAULT_GAINS.get(getattr(self.objective, "name", ""), 1.0) if self.k is None else self.k

    def check(self, robot: Robot) -> None:
        super().check(robot)
        self.objective.check(robot)


class GradientProjection(CriterionGain, VelocityResolver):
    r"""Resolved rate plus the projected gradient of a criterion p(q), Eq. (4).

    .. math::

        \dot q = J^\dagger \dot x - k\,(I - J^\dagger J)\,\frac{\partial p}{\partial q}

    Eq. (4) with its arbitrary constant equal to −k, so that k > 0 descends p:
    the self-motion lowers p at the rate
    :math:`\dot p = -k\,\|Z^\top \partial p/\partial q\|^2` while the task is
    realised exactly.

    Args:
        criterion: ``joint-limits`` (Eq. (5)), ``manipulability`` (p = −w,
            Eq. (6)), a :class:`Criterion`, or a callable ``p(joint_angles)``
            (gradient by central differences).
        k: gain [rad²/s per unit of p]; defaults to 10 for ``joint-limits``
            and 1 for ``manipulability`` and callables.
    """

    name = "gradient-projection"
    equations = (4, 5, 6)
    needs_redundancy = True
    options = (
        CRITERION_OPTION,
        gain_option("rad²/s per unit of p", "gain of the projected gradient, q̇ = J⁺ẋ − k(I − J⁺J)∂p/∂q"),
        POSITION_GAIN_OPTION,
    )

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of Eq. (4) in closed form, for the joint-limit criterion (analytic Hessian) on a position task, else None.

        With :math:`P = I - J^\dagger J`, :math:`u = J^\dagger c`, g = ∂p/∂q and its Hessian
        :math:`\nabla^2 p`, so that :math:`\dot q = u - kPg`, differentiating along the motion
        (:math:`\frac{d}{dt}J^\dagger = P\dot J^\top(JJ^\top)^{-1} - J^\dagger\dot J J^\dagger`,
        :math:`\dot P = -P\dot J^\top J^{\dagger\top} - J^\dagger\dot J P`):

        .. math::

            \ddot q = J^\dagger(\dot c - \dot J\dot q) + P\big(\dot J^\top J^{\dagger\top}(u + k g)
            - k\,\nabla^2 p\,\dot q\big),

        which for k = 0 is velocity-pinv's. :math:`\dot J` from Pinocchio's Jacobian time variation at (q, q̇);
        :math:`\nabla^2 p\,\dot q` from the criterion (:meth:`Criterion.curvature`): exact for the joint limits,
        a central difference of the analytic gradient along q̇ for the manipulability (its Hessian needs third
        derivatives of the kinematics). A callable's gradient is itself a difference: None, and the loop takes
        q̈ by its central difference. J, its SVD (whence J⁺) and k ∂p/∂q at q are those the rates computed
        there, when they did.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (4)'s rates and their closed-form q̈ (or None), sharing J, J⁺ and ∂p/∂q at each configuration."""
        rates, acceleration = projected_gradient_steps(robot, task, self.singular_tolerance, self.objective, self.gain)
        return rates, None if task.kind == "pose" or not self.objective.has_curvature else acceleration

    def stack_rate_function(self, robot: Robot):
        """Eq. (4) and the closed-form q̈ of :meth:`acceleration_function` on stacks (joint limits, position task)."""
        if robot.task == "pose" or not isinstance(self.objective, JointLimits):
            return None
        joints = self.objective._limits(robot.model)
        # ∂/∂θ of Eq. (5) is 2(θ − θ_mid)/half range²: a diagonal quadratic criterion
        return StackedGradientProjection(
            self.singular_tolerance,
            robot.nv,
            joints.q_index,
            joints.v_index,
            joints.middle,
            joints.curvature,
            self.gain,
        )


def projected_gradient_steps(robot: Robot, task: FrameTask, tolerance: float, criterion: Criterion, k: float):
    r"""The rates of Eq. (4), :math:`\dot q = J^\dagger c - k(I - J^\dagger J)\,\partial p/\partial q`, and their
    closed-form q̈ (:meth:`GradientProjection.acceleration_function`), sharing J, its SVD and k ∂p/∂q at each
    configuration; J⁺ by SVD, refused (SingularJacobian) below ``tolerance`` of σmin/σmax. The q̈ needs a
    position task and a criterion with :attr:`Criterion.has_curvature`.

    The rates are written :math:`J^\dagger(c + Jg_k) - g_k` with :math:`g_k = k\,\partial p/\partial q`, the same
    Eq. (4) with one product by J⁺, which the SVD applies itself: the explicit J⁺ is formed only for q̈.
    """
    solver = pseudoinverse_solver(robot, tolerance, null_space=False)

    @PerConfiguration
    def at_configuration(kinematics: Kinematics):
        jacobian = task.jacobian(kinematics)
        # Eq. (3) by SVD; the solver keeps it, and a value held here means it is still this J's
        inverse_condition = solver.inverse_condition(jacobian)
        return jacobian, criterion.scaled_gradient(kinematics, task, k, solver), inverse_condition

    def rates(kinematics: Kinematics, task_velocity: np.ndarray):
        jacobian, scaled_gradient, inverse_condition = at_configuration(kinematics)
        # Eq. (4) with k' = −k: J⁺ẋ − k(I − J⁺J)∂p/∂q = J⁺(ẋ + J k∂p/∂q) − k∂p/∂q
        return solver.solve(task_velocity + jacobian.dot(scaled_gradient)) - scaled_gradient, inverse_condition

    def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
        jacobian, scaled_gradient, _ = at_configuration(kinematics)
        pseudoinverse = solver.decomposed_pseudoinverse()  # J⁺ at this configuration, Eq. (3)
        jacobian_rate = task.jacobian_rate(kinematics, velocity)
        shifted = pseudoinverse.dot(command) + scaled_gradient  # u + k ∂p/∂q
        # J̇ᵀJ⁺ᵀ(u + k ∂p/∂q) − k ∇²p q̇ (row-vector products: no transposes)
        inner = shifted.dot(pseudoinverse).dot(jacobian_rate) - criterion.scaled_curvature(
            kinematics, task, velocity, k
        )
        # the derivative of Eq. (4) along the motion: J⁺(ċ − J̇q̇) + (I − J⁺J)·inner = J⁺(ċ − J̇q̇ − J·inner) + inner
        return pseudoinverse.dot(command_rate - jacobian_rate.dot(velocity) - jacobian.dot(inner)) + inner

    return rates, acceleration


class StackedGradientProjection(StackedPseudoInverse):
    r"""Eq. (4) with a diagonal quadratic criterion, :math:`\dot q = J^\dagger c - k(I - J^\dagger J)\,\partial p/\partial q`,
    and its :math:`\ddot q` per row of (B, m, n) stacks (:class:`StackedPseudoInverse` for :math:`J^\dagger`).

    The criterion is :math:`p = \tfrac12\sum_i w_i (q_{a_i} - \bar q_i)^2` over the configuration coordinates
    :math:`a_i` (joint velocity index :math:`b_i`): Liégeois's joint limits, Eq. (5), with :math:`\bar q` the
    mid-range and :math:`w = 2/\text{half range}^2`; a posture task below the robot's task (task priority,
    Eq. (11), whose :math:`[I(I - J^\dagger J)]^\dagger = I - J^\dagger J`) with :math:`\bar q` its target and w = 1.

    Args:
        tolerance: the smallest σmin/σmax of J a row may have.
        n: joints.
        q_index, v_index: :math:`a_i` and :math:`b_i`.
        centre: :math:`\bar q` [rad, m].
        curvature: :math:`w_i`, the diagonal of :math:`\partial^2 p/\partial q^2`.
        gain: k [rad²/s per unit of p].
    """

    def __init__(self, tolerance: float, n: int, q_index, v_index, centre, curvature, gain: float):
        super().__init__(tolerance)
        self.q_index, self.v_index = np.asarray(q_index, dtype=int), np.asarray(v_index, dtype=int)
        self.middle, self.curvature = np.asarray(centre, dtype=float), np.asarray(curvature, dtype=float)
        self.n, self.gain = n, gain

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, (J⁺, u + k ∂p/∂q)); a singular row gets a finite, unused answer."""
        particular, conditions, failures, pseudoinverse = super().rates(jacobian, command)
        gradient = np.zeros((configuration.shape[0], self.n))
        # ∂p/∂q: for the joint limits ∂/∂θ of Eq. (5)
        gradient[:, self.v_index] = self.curvature * (configuration[:, self.q_index] - self.middle)
        # (I − J⁺J) ∂p/∂q, Eq. (4)
        projected = gradient - np.einsum("bij,bj->bi", pseudoinverse, np.einsum("bij,bj->bi", jacobian, gradient))
        k = self.gain
        return particular - k * projected, conditions, failures, (pseudoinverse, particular + k * gradient)

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """J⁺(ċ − J̇q̇) + (I − J⁺J)(J̇ᵀJ⁺ᵀ(u + k ∂p/∂q) − k ∂²p/∂q² q̇) per row (see :meth:`GradientProjection.acceleration_function`)."""
        pseudoinverse, shifted = state
        inner = np.einsum("bji,bj->bi", jacobian_rate, np.einsum("bji,bj->bi", pseudoinverse, shifted))
        inner[:, self.v_index] -= self.gain * self.curvature * velocity[:, self.v_index]
        residual = command_rate - np.einsum("bij,bj->bi", jacobian_rate, velocity)
        return np.einsum("bij,bj->bi", pseudoinverse, residual) + (
            inner - np.einsum("bij,bj->bi", pseudoinverse, np.einsum("bij,bj->bi", jacobian, inner))
        )
