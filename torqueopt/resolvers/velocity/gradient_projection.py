r"""Gradient projection (Liégeois, 1977), Eq. (4) of the paper."""

from __future__ import annotations

import numpy as np

from ...linalg import cross_along, determinants
from ...robot import Robot
from ...tasks import FrameTask, Kinematics, PerConfiguration
from ..options import Option, number
from ..registry import register_resolver
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .criteria import Criterion, JointLimits, Manipulability, criterion_from
from .options import criterion_spec
from .pseudoinverse import StackedPseudoInverse, stacked_inverse

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


@register_resolver
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
        and for the manipulability in the closed form of its stacked step (``StackedManipulabilityGradient``),
        from the frame's Jacobian and its rate. A callable's gradient is itself a difference: None, and the loop takes
        q̈ by its central difference. J, its SVD (whence J⁺) and k ∂p/∂q at q are those the rates computed
        there, when they did.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (4)'s rates and their closed-form q̈ (or None): ``projected_gradient_steps``, sharing J, J⁺ and ∂p/∂q
        at each configuration. The batch takes the stacked form (:meth:`stack_rate_function`), which the tests hold
        to this one."""
        rates, acceleration = projected_gradient_steps(robot, task, self.singular_tolerance, self.objective, self.gain)
        return rates, None if task.kind == "pose" or not self.objective.has_curvature else acceleration

    def stack_rate_function(self, robot: Robot):
        """Eq. (4) and the closed-form q̈ of :meth:`acceleration_function` on stacks, for a position task: the joint
        limits (``StackedGradientProjection``) and the manipulability on robots whose joints each have one degree of
        freedom (``StackedManipulabilityGradient``). None (one movement at a time) for a pose task, a callable
        criterion, and the manipulability on a robot with a multi-degree-of-freedom joint."""
        if robot.task == "pose":
            return None
        if isinstance(self.objective, Manipulability):
            model = robot.model
            if any(model.nvs[joint] != 1 for joint in range(1, model.njoints)):
                return None
            return StackedManipulabilityGradient(self.singular_tolerance, robot.m, self.gain)
        if not isinstance(self.objective, JointLimits):
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
            kinematics, task, velocity, k, solver
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


class StackedManipulabilityGradient(StackedPseudoInverse):
    r"""Eq. (4) with the manipulability criterion, :math:`p = -w = -\sqrt{\det JJ^\top}` (Eq. (6)), and its
    :math:`\ddot q` per row of (B, m, n) stacks, for a position (or ``xy``) task of a robot whose joints each have
    one degree of freedom (:class:`StackedPseudoInverse` for :math:`J^\dagger`).

    The gradient :math:`\partial w/\partial q_k = w\,\mathrm{tr}(J^\dagger\,\partial J/\partial q_k)` contracts the
    task frame's kinematic Hessian, which the single-state step reads from Pinocchio
    (``getFrameKinematicHessian``). On stacks it is not a Pinocchio call: Pinocchio 4 does not expose the forest's
    ``kinematic_hessians`` tensor, and ``getFrameKinematicHessian`` returns a fresh 6 × N × N tensor of the whole
    forest (N its joints) per copy, five passes a step: more than this whole stacked step costs. The contraction is
    taken instead from the frame's Jacobian columns, all six rows of which the forest's pass gives
    (``frame_jacobian``), by the rule Pinocchio's Hessian follows
    (``computeJointKinematicHessians``): in world axes the column :math:`S_i` (a spatial motion) of a
    one-degree-of-freedom joint moves with its ancestors, :math:`\partial S_i/\partial q_k = S_k \times S_i` for k
    before i on the frame's support, and the frame's own point p moves at :math:`\partial p/\partial q_k = L_k`.
    With :math:`L_i, \omega_i` the frame Jacobian's (LOCAL_WORLD_ALIGNED) linear and angular columns, so that
    :math:`\partial L_i/\partial q_k = \omega_k\times L_i` for k ≤ i and :math:`\omega_i\times L_k` for k > i,
    :math:`\partial\omega_i/\partial q_k = \omega_k\times\omega_i` for k < i, and :math:`f_i` the i-th row of
    :math:`J^\dagger` written in the task's rows of a 3-vector, the triple products regroup into

    .. math::

        \mathrm{tr}\Big(J^\dagger\frac{\partial J}{\partial q_k}\Big)
        = -L_k\cdot\sum_{i\le k}\omega_i\times f_i + \omega_k\cdot\sum_{i>k} L_i\times f_i,

    n terms per row where the Hessian has n², held per row to Pinocchio's ``getFrameKinematicHessian``
    by tests/test_stack_manipulability.py. Its rate along the motion, the :math:`k\nabla^2p\,\dot q` of q̈
    (:meth:`GradientProjection.acceleration_function`), is the same sums differentiated in closed form,
    with :math:`\dot L, \dot\omega` the frame Jacobian's rate (the forest's pass at (q, q̇)),
    :math:`\frac{d}{dt}J^\dagger = (I - J^\dagger J)\dot J^\top G^{-1} - J^\dagger\dot J J^\dagger` and
    :math:`\dot w = \dot q\cdot\partial w/\partial q`, the formula the single-state step takes
    (:meth:`Manipulability.scaled_curvature`, the tests hold the two to each other and to differences).

    Args:
        tolerance: the smallest σmin/σmax of J a row may have.
        m: the task's rows (2 for ``xy``, 3 for ``position``).
        gain: k [rad²/s per unit of p].
    """

    def __init__(self, tolerance: float, m: int, gain: float):
        super().__init__(tolerance)
        self.m, self.gain = m, gain

    # The sums run on (3, n, B) stacks, a vector's components first and the batch last: numpy's loops then run over
    # n·B contiguous numbers, where on (B, 3, n) stacks they run over n at a time (5x the time per cross product).

    @staticmethod
    def _frame_columns(frame: np.ndarray):
        """The linear and angular columns, (3, n, B) each, of the frame's (B, 6, n) J or J̇ (the forest's, the
        columns off the frame's support zero)."""
        columns = np.ascontiguousarray(frame.transpose(1, 2, 0))
        return columns[:3], columns[3:]

    def _padded(self, pseudoinverse: np.ndarray) -> np.ndarray:
        """The rows :math:`f_i` of J⁺ (B, n, m) as a (3, n, B) stack, zero beyond the task's rows."""
        if self.m == 3:
            return np.ascontiguousarray(pseudoinverse.transpose(2, 1, 0))
        padded = np.zeros((3, pseudoinverse.shape[1], pseudoinverse.shape[0]))
        padded[: self.m] = pseudoinverse.transpose(2, 1, 0)
        return padded

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a singular row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with the frame's six rows of J."""
        jacobian_t = np.swapaxes(jacobian, 1, 2)
        gram = jacobian @ jacobian_t
        conditions, failures, determinant = self.conditions(gram)
        if determinant is None:
            determinant = determinants(gram)
        manipulability = np.sqrt(np.maximum(determinant, 0.0))  # Eq. (6), w = sqrt(det JJᵀ), before G is inverted
        gram_inverse = stacked_inverse(gram, failures, determinant.copy())
        pseudoinverse = jacobian_t @ gram_inverse  # Eq. (3)
        linear, angular = self._frame_columns(kinematics.frame_jacobian)
        weights = self._padded(pseudoinverse)
        traces, before, after = hessian_traces(linear, angular, weights, self.m == 2)  # tr(J⁺ ∂J/∂q_k), (n, B)
        # k ∂p/∂q = −k ∂w/∂q = −k w tr(J⁺ ∂J/∂q_k), p = −w of Eq. (6)
        gradient = (traces * (-self.gain * manipulability)).T
        particular = np.einsum("bij,bj->bi", pseudoinverse, command)
        # Eq. (4): J⁺c − (I − J⁺J) k ∂p/∂q
        projected = gradient - np.einsum("bij,bj->bi", pseudoinverse, np.einsum("bij,bj->bi", jacobian, gradient))
        sums = (linear, angular, weights, before, after, manipulability, traces)
        return particular - projected, conditions, failures, (pseudoinverse, gram_inverse, particular + gradient, sums)

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """J⁺(ċ − J̇q̇) + (I − J⁺J)(J̇ᵀJ⁺ᵀ(u + k ∂p/∂q) − k ∇²p q̇) per row (see
        :meth:`GradientProjection.acceleration_function`), k ∇²p q̇ by :meth:`scaled_curvature`.
        ``kinematics``: the forest's at the configuration and q̇, with the frame's six rows of J̇."""
        pseudoinverse, _, shifted, _ = state
        curvature = self.scaled_curvature(jacobian, jacobian_rate, velocity, state, kinematics)
        inner = np.einsum("bji,bj->bi", jacobian_rate, np.einsum("bji,bj->bi", pseudoinverse, shifted)) - curvature
        residual = command_rate - np.einsum("bij,bj->bi", jacobian_rate, velocity)
        return np.einsum("bij,bj->bi", pseudoinverse, residual) + (
            inner - np.einsum("bij,bj->bi", pseudoinverse, np.einsum("bij,bj->bi", jacobian, inner))
        )

    def scaled_curvature(self, jacobian, jacobian_rate, velocity, state, kinematics) -> np.ndarray:
        r""":math:`k\nabla^2 p\,\dot q` (B, n), the rate of k ∂p/∂q along the motion, in closed form: the
        gradient's sums of :meth:`rates` (``state``) differentiated in time, with the frame Jacobian's rate from
        ``kinematics`` (the forest's at (q, q̇)) and J̇ the task rows' (``jacobian_rate``)."""
        pseudoinverse, gram_inverse, _, sums = state
        linear, angular, weights, before, after, manipulability, traces = sums
        linear_rate, angular_rate = self._frame_columns(kinematics.frame_rate)
        # d/dt J⁺ = (I − J⁺J) J̇ᵀ G⁻¹ − J⁺ J̇ J⁺
        lifted = np.swapaxes(jacobian_rate, 1, 2) @ gram_inverse
        pseudoinverse_rate = (
            lifted - pseudoinverse @ (jacobian @ lifted) - pseudoinverse @ (jacobian_rate @ pseudoinverse)
        )
        weights_rate = self._padded(pseudoinverse_rate)
        planar = self.m == 2
        before_rate = _prefix_sums(_cross(angular_rate, weights, planar) + _cross(angular, weights_rate, planar))
        after_rate = _sums_after(_cross(linear_rate, weights, planar) + _cross(linear, weights_rate, planar))
        traces_rate = (
            _dot(angular_rate, after)
            + _dot(angular, after_rate)
            - _dot(linear_rate, before)
            - _dot(linear, before_rate)
        )
        # ẇ = q̇ · ∂w/∂q = w (q̇ · tr(J⁺ ∂J/∂q))
        manipulability_rate = manipulability * np.einsum("nb,bn->b", traces, velocity)
        # k ∇²p q̇ = −k d/dt (w tr(J⁺ ∂J/∂q_k)), p = −w of Eq. (6)
        return (-self.gain * (traces * manipulability_rate + traces_rate * manipulability)).T


def hessian_traces(linear: np.ndarray, angular: np.ndarray, weights: np.ndarray, planar: bool = False):
    r""":math:`\mathrm{tr}(W\,\partial J/\partial q_k)` (n, B) for a frame's LOCAL_WORLD_ALIGNED Jacobian J (6 × n,
    linear rows first) of a chain of one-degree-of-freedom joints and W (n × 6) zero in J's angular rows, from J's
    columns alone: ``linear`` :math:`L` and ``angular`` :math:`\omega` (3, n, B), ``weights`` the rows
    :math:`f_i` of W's linear part as the columns of a (3, n, B) stack (see ``StackedManipulabilityGradient``),

    .. math::

        \mathrm{tr}\Big(W\frac{\partial J}{\partial q_k}\Big)
        = -L_k\cdot\sum_{i\le k}\omega_i\times f_i + \omega_k\cdot\sum_{i>k} L_i\times f_i.

    Also returns the two sums (3, n, B), column k :math:`\sum_{i\le k}\omega_i\times f_i` and
    :math:`\sum_{i>k} L_i\times f_i`, which the rate of the traces reuses. ``planar``: the weights' third
    components are zero (an ``xy`` task), and the products skip them."""
    before = _prefix_sums(_cross(angular, weights, planar))
    after = _sums_after(_cross(linear, weights, planar))
    return _dot(angular, after) - _dot(linear, before), before, after


def _cross(a: np.ndarray, b: np.ndarray, planar: bool = False) -> np.ndarray:
    """a × b of (3, ...) stacks, a new array: ``linalg.cross_along`` on axis 0, or with ``planar`` (b's third
    component is zero) the products that remain, component by component."""
    if not planar:
        return cross_along(a, b, 0)
    out = np.empty(a.shape)
    np.multiply(a[2], b[1], out=out[0])
    np.negative(out[0], out=out[0])
    np.multiply(a[2], b[0], out=out[1])
    np.subtract(a[0] * b[1], a[1] * b[0], out=out[2])
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a · b of (3, n, B) stacks, (n, B)."""
    return np.einsum("inb,inb->nb", a, b)


def _prefix_sums(terms: np.ndarray) -> np.ndarray:
    """Σ_{i≤k} of the columns i of a (3, n, B) stack, in place (one addition per column: numpy's ``cumsum`` along
    the middle axis costs 2.5 times as much here)."""
    for column in range(1, terms.shape[1]):
        terms[:, column] += terms[:, column - 1]
    return terms


def _sums_after(terms: np.ndarray) -> np.ndarray:
    """Σ_{i>k} of the columns i of a (3, n, B) stack, a new array (zero in the last column)."""
    sums = np.empty_like(terms)
    sums[:, -1] = 0.0
    for column in range(terms.shape[1] - 2, -1, -1):
        np.add(sums[:, column + 1], terms[:, column + 1], out=sums[:, column])
    return sums
