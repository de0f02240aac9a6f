r"""Scalar criteria :math:`p(q)` to minimise through the null space (gradient projection, extended Jacobian).

* :class:`JointLimits`, Eq. (5) (Liégeois): :math:`p = \sum_i \big((q_i - q_i^{mid})/(q_i^{mid} - q_i^{max})\big)^2`,
  dimensionless, over the joints with finite limits.
* :class:`Manipulability`, Eq. (6) (Yoshikawa): :math:`p = -w`, :math:`w = \sqrt{\det(JJ^\top)}`
  of the task Jacobian, so minimising p keeps the arm away from singularities.
  Its gradient is analytic, :math:`\partial w/\partial q_k = w\,\mathrm{tr}(J^\dagger\,\partial J/\partial q_k)`,
  with :math:`\partial J/\partial q_k` from Pinocchio's kinematic Hessian.
* :class:`CallableCriterion`: any function of the joint angles, gradient and
  Hessian by central differences.

Gradients are with respect to the joint velocity coordinates (the tangent
space), n values.
"""

from __future__ import annotations

import math
import operator
import threading
from abc import ABC, abstractmethod
from typing import NamedTuple

import eigenpy
import numpy as np

from ...errors import InvalidInput
from ...tasks import FrameTask, Kinematics
from ...tasks.task import identity

__all__ = [
    "Criterion",
    "JointLimits",
    "PostureDistance",
    "Manipulability",
    "CallableCriterion",
    "criterion_from",
    "CRITERIA",
]

_THIN_UV = eigenpy.DecompositionOptions.ComputeThinU | eigenpy.DecompositionOptions.ComputeThinV

#: Joint position limits beyond this magnitude [rad, m] are treated as absent.
_NO_LIMIT = 1.0e10


class Criterion(ABC):
    """A scalar function p(q) of the configuration, with its gradient (and Hessian when known)."""

    name: str

    def check(self, robot) -> None:
        """Raise if the criterion cannot be computed on ``robot``."""

    @abstractmethod
    def value(self, kinematics: Kinematics, task: FrameTask) -> float:
        """p at the kinematics' configuration."""

    @abstractmethod
    def gradient(self, kinematics: Kinematics, task: FrameTask) -> np.ndarray:
        """∂p/∂q (n values)."""

    def scaled_gradient(self, kinematics: Kinematics, task: FrameTask, gain: float, decomposition=None) -> np.ndarray:
        """k ∂p/∂q (n values) for the gain k: :meth:`gradient` times k, or a criterion's own faster form of it.

        ``decomposition``: a ``torqueopt.linalg.JacobianSolver`` that has just decomposed the task
        Jacobian at this configuration (its singular values and J⁺), for a criterion that reads them; or None.
        """
        return gain * self.gradient(kinematics, task)

    def hessian(self, kinematics: Kinematics, task: FrameTask) -> np.ndarray:
        """∂²p/∂q² (n×n); needed by the extended Jacobian."""
        raise InvalidInput(
            f"criterion '{self.name}' has no Hessian; the extended Jacobian needs one (use joint-limits or a callable)"
        )

    #: True when :meth:`~torqueopt.resolvers.velocity.Criterion.curvature` gives ∇²p v to the accuracy of a closed-form q̈ (about 1e-10).
    has_curvature: bool = False

    def curvature(self, kinematics: Kinematics, task: FrameTask, v: np.ndarray) -> np.ndarray:
        r""":math:`\nabla^2 p\,v` (n values), the rate of ∂p/∂q along the motion at joint velocity v
        (only for criteria with :attr:`has_curvature`)."""
        return self.hessian(kinematics, task).dot(v)

    def scaled_curvature(
        self, kinematics: Kinematics, task: FrameTask, v: np.ndarray, gain: float, decomposition=None
    ) -> np.ndarray:
        r""":math:`k\,\nabla^2 p\,v` for the gain k: :meth:`curvature` times k, or a criterion's own faster form of it.
        ``decomposition``: as :meth:`scaled_gradient`'s."""
        return gain * self.curvature(kinematics, task, v)


class _LimitedJoints(NamedTuple):
    """The joints with an Eq. (5) term: their q and v coordinates, mid-range [rad, m] and half range [rad, m]."""

    q_index: np.ndarray
    v_index: np.ndarray
    middle: np.ndarray
    half_range: np.ndarray
    #: 2 / half range², the diagonal of ∂²p/∂q² [1/rad²].
    curvature: np.ndarray
    #: ∂²p/∂q² (n×n, read-only): constant.
    hessian: np.ndarray
    #: Every joint has a term and its q coordinate is its v coordinate: the gradient needs no scatter.
    every_joint: bool


class JointLimits(Criterion):
    r"""Liégeois's joint-limit criterion, Eq. (5): squared distances from mid-range, scaled by half-range."""

    name = "joint-limits"

    def __init__(self):
        self._key = None
        self._scaled: tuple[float, np.ndarray] | None = None

    def _limits(self, model) -> _LimitedJoints:
        if self._key != id(model):
            index, middle, half_range = [], [], []
            for joint in range(1, model.njoints):
                joint_model = model.joints[joint]
                if joint_model.nq != 1 or joint_model.nv != 1:
                    continue  # continuous and multi-dof joints carry no Eq. (5) term
                low, high = model.lowerPositionLimit[joint_model.idx_q], model.upperPositionLimit[joint_model.idx_q]
                if not (abs(low) < _NO_LIMIT and abs(high) < _NO_LIMIT and high > low):
                    continue
                index.append((joint_model.idx_q, joint_model.idx_v))
                middle.append(0.5 * (low + high))
                half_range.append(0.5 * (high - low))
            index = np.array(index, dtype=int).reshape(-1, 2)
            half_range = np.array(half_range)
            curvature = 2.0 / half_range**2
            hessian = np.zeros((model.nv, model.nv))
            hessian[index[:, 1], index[:, 1]] = curvature
            hessian.setflags(write=False)
            every = np.arange(model.nv)
            self._joints = _LimitedJoints(
                index[:, 0], index[:, 1], np.array(middle), half_range, curvature, hessian,
                model.nq == model.nv and np.array_equal(index[:, 0], every) and np.array_equal(index[:, 1], every),
            )  # fmt: skip
            self._key = id(model)
            self._scaled = None
        return self._joints

    def check(self, robot) -> None:
        if self._limits(robot.model).q_index.size == 0:
            raise InvalidInput(f"criterion 'joint-limits' needs finite joint limits; robot '{robot.name}' has none")

    def normalised_distance(self, robot, q: np.ndarray) -> np.ndarray:
        r""":math:`(q_i - q_i^{mid})/(q_i^{max} - q_i^{mid})` for each joint with limits (−1 and 1 at the limits)."""
        joints = self._limits(robot.model)
        return (q[joints.q_index] - joints.middle) / joints.half_range

    def value(self, kinematics, task=None) -> float:
        joints = self._limits(kinematics.model)
        # Eq. (5), with θ_mid − θ_max = −half range (squared, so the sign drops)
        return float(np.sum(((kinematics.q[joints.q_index] - joints.middle) / joints.half_range) ** 2))

    def gradient(self, kinematics, task=None) -> np.ndarray:
        joints = self._limits(kinematics.model)
        if joints.every_joint:
            return joints.curvature * (kinematics.q - joints.middle)  # ∂/∂θ of Eq. (5)
        gradient = np.zeros(kinematics.nv)
        gradient[joints.v_index] = joints.curvature * (kinematics.q[joints.q_index] - joints.middle)  # ∂/∂θ of Eq. (5)
        return gradient

    def scaled_gradient(self, kinematics, task, gain: float, decomposition=None) -> np.ndarray:
        """k ∂p/∂q as (k · 2/half range²) ∘ (q − mid-range) when every joint has limits: the gain joins the
        constant diagonal once per gain, two array operations per configuration instead of three."""
        joints = self._limits(kinematics.model)
        if not joints.every_joint:
            return gain * self.gradient(kinematics, task)
        if self._scaled is None or self._scaled[0] != gain:
            self._scaled = (gain, gain * joints.curvature)
        return self._scaled[1] * (kinematics.q - joints.middle)  # k ∂/∂θ of Eq. (5)

    has_curvature = True

    def hessian(self, kinematics, task=None) -> np.ndarray:
        return self._limits(kinematics.model).hessian

    def curvature(self, kinematics, task, v: np.ndarray) -> np.ndarray:
        r""":math:`\nabla^2 p\,v`, the diagonal Hessian of Eq. (5) times v."""
        joints = self._limits(kinematics.model)
        if joints.every_joint:
            return joints.curvature * v
        rate = np.zeros(kinematics.nv)
        rate[joints.v_index] = joints.curvature * v[joints.v_index]
        return rate


class PostureDistance(Criterion):
    r""":math:`p = \tfrac12\|e\|^2` of a posture task's error :math:`e = q^* - q` (joint angles, [rad, m]), whose
    Jacobian is the identity: :math:`\partial p/\partial q = -e`, :math:`\nabla^2 p = I`.

    Gradient projection, Eq. (4), with this p and the posture's gain is task priority, Eq. (11), with the
    posture below the robot's task (:class:`~torqueopt.resolvers.velocity.TaskPriority`).
    """

    name = "posture"
    has_curvature = True

    def __init__(self, posture):
        self.posture = posture
        self._scaled: tuple[int, float, np.ndarray, np.ndarray] | None = None

    def value(self, kinematics, task=None) -> float:
        error = self.posture.error(kinematics)
        return 0.5 * float(error.dot(error))

    def gradient(self, kinematics, task=None) -> np.ndarray:
        return -self.posture.error(kinematics)

    def scaled_gradient(self, kinematics, task, gain: float, decomposition=None) -> np.ndarray:
        """k ∂p/∂q = k(q − q*) straight from the configuration where every joint adds (``Robot.euclidean``:
        the joint angles are q minus a constant), q* the target as a configuration; else k times
        :meth:`gradient`."""
        robot = kinematics.robot
        if not robot.euclidean:
            return gain * self.gradient(kinematics, task)
        if self._scaled is None or self._scaled[:2] != (id(robot.model), gain):
            self.posture.check(robot)
            self._scaled = (id(robot.model), gain, np.full(robot.nv, gain), robot.configuration(self.posture.target))
        _, _, gains, target = self._scaled
        return gains * (kinematics.q - target)

    def hessian(self, kinematics, task=None) -> np.ndarray:
        return np.eye(kinematics.nv)

    def curvature(self, kinematics, task, v: np.ndarray) -> np.ndarray:
        return v


class Manipulability(Criterion):
    r"""Minus Yoshikawa's manipulability, :math:`p = -w = -\sqrt{\det(JJ^\top)}` (Eq. (6)), of the task Jacobian."""

    name = "manipulability"

    def __init__(self):
        # Per thread, as a resolver (and its criterion) may serve runs in several threads at once: the kinematics
        # the curvature's differences move, apart from those of the caller ("offsets"), one SVD object per
        # shape of J, refactored at each configuration ("svd"), and the model whose joints were checked for the
        # closed-form curvature ("simple").
        self._workspaces = threading.local()

    def __getstate__(self):
        # the workspaces are rebuilt on first use, and do not pickle: a copy leaves them behind
        return {key: value for key, value in self.__dict__.items() if key != "_workspaces"}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._workspaces = threading.local()

    def value(self, kinematics, task) -> float:
        jacobian = task.jacobian(kinematics)
        return -manipulability(jacobian)

    def gradient(self, kinematics, task) -> np.ndarray:
        r""":math:`-\partial w/\partial q`, with w and :math:`J^\dagger` from one SVD of J (Eigen's, through eigenpy)."""
        return self._decomposed_gradient(kinematics, task, 1.0)

    def _decomposed_gradient(self, kinematics, task, gain: float) -> np.ndarray:
        """−k ∂w/∂q with w and J⁺ from the criterion's own SVD of J."""
        singular_values, pseudo = self._decomposition(task.jacobian(kinematics))
        return self._scaled_gradient(kinematics, task, gain, singular_values, pseudo)

    def scaled_gradient(self, kinematics, task, gain: float, decomposition=None) -> np.ndarray:
        r""":math:`-k\,\partial w/\partial q`; w and :math:`J^\dagger` from ``decomposition`` (the SVD the resolver
        already made of J at this configuration) when given, else as :meth:`gradient` makes them."""
        if decomposition is None:
            return gain * self.gradient(kinematics, task)
        singular_values = decomposition.singular_values
        return self._scaled_gradient(kinematics, task, gain, singular_values, decomposition.decomposed_pseudoinverse())

    @staticmethod
    def _scaled_gradient(kinematics, task, gain: float, singular_values, pseudo) -> np.ndarray:
        """−k ∂w/∂q from J's singular values and J⁺ at the kinematics' configuration."""
        w = math.prod(singular_values)  # Eq. (6) as the product of J's singular values
        # ∂w/∂q_k = w tr(J⁺ ∂J/∂q_k) = w Σ_ij J⁺_ij D_jik, from d det(JJᵀ) = 2 det(JJᵀ) tr(J⁺ dJ); p = −w, Eq. (6)
        return task.jacobian_derivative_traces(kinematics, pseudo, -gain * w)

    has_curvature = True

    def curvature(self, kinematics, task, v: np.ndarray) -> np.ndarray:
        r""":math:`\nabla^2 p\,v`, the rate of ∂p/∂q along the motion at joint velocity v, in closed form
        (:meth:`scaled_curvature` with k = 1)."""
        return self.scaled_curvature(kinematics, task, v, 1.0)

    def scaled_curvature(self, kinematics, task, v: np.ndarray, gain: float, decomposition=None) -> np.ndarray:
        r""":math:`k\nabla^2 p\,v = -k\,\frac{d}{dt}\big(w\,\mathrm{tr}(J^\dagger\,\partial J/\partial q_k)\big)` in
        closed form, the formula of the stacked step (``StackedManipulabilityGradient``, whose docstring derives
        it) on one state. With :math:`L_i, \omega_i` the frame Jacobian's (LOCAL_WORLD_ALIGNED) linear and angular
        columns, :math:`f_i` the rows of :math:`J^\dagger` written in the task's rows of a 3-vector,
        :math:`B_k = \sum_{i\le k}\omega_i\times f_i` and :math:`A_k = \sum_{i>k} L_i\times f_i`:

        .. math::

            \mathrm{tr}\Big(J^\dagger\frac{\partial J}{\partial q_k}\Big) = \omega_k\cdot A_k - L_k\cdot B_k,
            \qquad \frac{d}{dt}\mathrm{tr}\Big(J^\dagger\frac{\partial J}{\partial q_k}\Big)
            = \dot\omega_k\cdot A_k + \omega_k\cdot\dot A_k - \dot L_k\cdot B_k - L_k\cdot\dot B_k,

        :math:`\dot L, \dot\omega` the columns of the frame Jacobian's rate along v (Pinocchio's
        ``getFrameJacobianTimeVariation``), :math:`\dot f_i` the rows of
        :math:`\frac{d}{dt}J^\dagger = (I - J^\dagger J)\dot J^\top J^{\dagger\top}J^\dagger - J^\dagger\dot J J^\dagger`
        and :math:`\dot w = w\,v\cdot\mathrm{tr}(J^\dagger\,\partial J/\partial q)`. The stack's sums run here on
        floats (``_traces_and_rates``). J⁺ and w from ``decomposition`` (the SVD the
        resolver made of J at this configuration) when given, else from the criterion's own SVD. A pose task or a
        robot with a multi-degree-of-freedom joint, which the sums do not cover, takes
        :meth:`differenced_curvature`."""
        model, rows = kinematics.model, task.dimension
        simple = getattr(self._workspaces, "simple", None)
        if simple is None or simple[0] is not model:
            simple = self._workspaces.simple = (model, all(model.nvs[joint] == 1 for joint in range(1, model.njoints)))
        if task.kind == "pose" or not simple[1]:
            return self.differenced_curvature(kinematics, task, v, gain)
        frame = task.frame_id(kinematics)
        frame_jacobian = kinematics.frame_jacobian(frame)
        frame_rate = kinematics.frame_jacobian_time_variation(frame, v)
        jacobian, jacobian_rate = frame_jacobian[:rows], frame_rate[:rows]
        if decomposition is None:
            singular_values, pseudo = self._decomposition(jacobian)
        else:
            singular_values, pseudo = decomposition.singular_values, decomposition.decomposed_pseudoinverse()
        w = math.prod(singular_values)  # Eq. (6) as the product of J's singular values
        # d/dt J⁺ = (I − J⁺J) J̇ᵀ G⁻¹ − J⁺ J̇ J⁺, with G⁻¹ = (JJᵀ)⁻¹ = J⁺ᵀJ⁺
        lifted = jacobian_rate.T.dot(pseudo.T.dot(pseudo))
        pseudo_rate = lifted - pseudo.dot(jacobian.dot(lifted) + jacobian_rate.dot(pseudo))
        traces, traces_rate = _traces_and_rates(
            frame_jacobian.T.tolist(), frame_rate.T.tolist(), pseudo.tolist(), pseudo_rate.tolist()
        )
        # k ∇²p v = −k d/dt (w tr(J⁺ ∂J/∂q_k)) = −k (ẇ tr + w d/dt tr), ẇ = w (v · tr); p = −w of Eq. (6)
        scale = -gain * w
        along = scale * sum(map(operator.mul, traces, v.tolist()))
        return np.array([along * trace + scale * rate for trace, rate in zip(traces, traces_rate)])

    def _decomposition(self, jacobian: np.ndarray):
        """J's singular values (a list) and J⁺ by the criterion's own SVD (one object per shape of J and thread)."""
        workspaces = self._workspaces
        shape_and_svd = getattr(workspaces, "svd", None)
        if shape_and_svd is None or shape_and_svd[0] != jacobian.shape:
            shape_and_svd = workspaces.svd = (jacobian.shape, eigenpy.HhJacobiSVD(*jacobian.shape, _THIN_UV))
        svd = shape_and_svd[1].compute(jacobian)
        return svd.singularValues().reshape(-1).tolist(), svd.solve(identity(jacobian.shape[0]))

    def differenced_curvature(self, kinematics, task, v: np.ndarray, gain: float) -> np.ndarray:
        r""":math:`k\nabla^2 p\,v` by a central difference of the analytic :meth:`gradient` along :math:`v/|v|`
        (step ``CURVATURE_STEP`` = 1e-5 rad): the plain reference the tests hold :meth:`scaled_curvature` to, and
        its form for a pose task or a multi-degree-of-freedom joint. The differences move a ``Kinematics`` of
        the criterion's own: the caller's stay at their configuration, with what was computed there."""
        speed = math.hypot(*v.tolist())
        if speed == 0.0:
            return np.zeros(kinematics.nv)
        robot, q, step = kinematics.robot, kinematics.q, CURVATURE_STEP / speed
        offsets = getattr(self._workspaces, "offsets", None)
        if offsets is None or offsets.robot is not robot:
            offsets = self._workspaces.offsets = Kinematics(robot)
        offset, scale = step * v, 0.5 * gain / step
        # k(∂p/∂q(q ⊕ δ) − ∂p/∂q(q ⊖ δ)) / 2δ, the k/2δ carried as the gradients' gain
        forward = self._decomposed_gradient(offsets.update(robot.integrate(q, offset)), task, scale)
        backward = self._decomposed_gradient(offsets.update(robot.integrate(q, -offset)), task, scale)
        return forward - backward


#: Step [rad] of :meth:`Manipulability.differenced_curvature`'s central difference: its O(δ²) truncation and its round-off
#: ε|∂p/∂q|/δ balance near 1e-5.
CURVATURE_STEP = 1e-5


def manipulability(jacobian: np.ndarray) -> float:
    r"""Yoshikawa's :math:`w = \sqrt{\det(JJ^\top)}`, Eq. (6), as the product of J's singular values."""
    return float(np.prod(np.linalg.svd(jacobian, compute_uv=False)))


def _traces_and_rates(columns, column_rates, weights, weight_rates):
    r"""The traces :math:`\mathrm{tr}(J^\dagger\,\partial J/\partial q_k) = \omega_k\cdot A_k - L_k\cdot B_k` and their
    rates :math:`\dot\omega_k\cdot A_k + \omega_k\cdot\dot A_k - \dot L_k\cdot B_k - L_k\cdot\dot B_k`
    (:meth:`Manipulability.scaled_curvature`), two lists of n floats, on floats: numpy's cost per call on
    3-vectors is many times theirs.

    Args:
        columns, column_rates: the frame Jacobian's columns and their rates, n lists (L, ω) of 6 floats.
        weights, weight_rates: the rows :math:`f_i` of J⁺ and of its rate, n lists of m ≤ 3 floats (the task's
            rows of a 3-vector, the rest zero).
    """
    padding = (0.0,) * (3 - len(weights[0]))
    n = len(columns)
    # A_k = Σ_{i>k} L_i × f_i and Ȧ_k (L̇_i × f_i + L_i × ḟ_i summed), from the last column back; the products
    # written out, as a function call per 3-vector costs more than its arithmetic
    after = [None] * n
    ax = ay = az = dax = day = daz = 0.0
    for k in range(n - 1, -1, -1):
        after[k] = (ax, ay, az, dax, day, daz)
        lx, ly, lz, _, _, _ = columns[k]
        rx, ry, rz, _, _, _ = column_rates[k]
        fx, fy, fz = (*weights[k], *padding)
        gx, gy, gz = (*weight_rates[k], *padding)
        ax, ay, az = ax + ly * fz - lz * fy, ay + lz * fx - lx * fz, az + lx * fy - ly * fx
        dax += ry * fz - rz * fy + ly * gz - lz * gy
        day += rz * fx - rx * fz + lz * gx - lx * gz
        daz += rx * fy - ry * fx + lx * gy - ly * gx
    # B_k = Σ_{i≤k} ω_i × f_i and Ḃ_k, from the first column on, and the traces and their rates
    traces, traces_rate = [], []
    bx = by = bz = dbx = dby = dbz = 0.0
    for k in range(n):
        lx, ly, lz, wx, wy, wz = columns[k]
        rx, ry, rz, vx, vy, vz = column_rates[k]
        fx, fy, fz = (*weights[k], *padding)
        gx, gy, gz = (*weight_rates[k], *padding)
        bx, by, bz = bx + wy * fz - wz * fy, by + wz * fx - wx * fz, bz + wx * fy - wy * fx
        dbx += vy * fz - vz * fy + wy * gz - wz * gy
        dby += vz * fx - vx * fz + wz * gx - wx * gz
        dbz += vx * fy - vy * fx + wx * gy - wy * gx
        ax, ay, az, dax, day, daz = after[k]
        traces.append(wx * ax + wy * ay + wz * az - lx * bx - ly * by - lz * bz)
        traces_rate.append(
            vx * ax + vy * ay + vz * az + wx * dax + wy * day + wz * daz
            - rx * bx - ry * by - rz * bz - lx * dbx - ly * dby - lz * dbz
        )  # fmt: skip
    return traces, traces_rate


class CallableCriterion(Criterion):
    """A user function ``p(joint_angles) -> float``; gradient and Hessian by central differences.

    Args:
        function: of one coordinate per joint [rad, m] (as :meth:`Robot.joint_angles`).
        step: difference step [rad, m].
    """

    def __init__(self, function, step: float = 1e-6, name: str | None = None):
        if not callable(function):
            raise InvalidInput(f"criterion {function!r} is not callable")
        self.function = function
        self.step = float(step)
        self.name = name or getattr(function, "__name__", "callable")

    def _call(self, robot, q) -> float:
        value = float(self.function(robot.joint_angles(q)))
        if not np.isfinite(value):
            raise InvalidInput(f"criterion '{self.name}' returned {value} at q = {q.tolist()}; it must be finite")
        return value

    def value(self, kinematics, task=None) -> float:
        return self._call(kinematics.robot, kinematics.q)

    def gradient(self, kinematics, task=None) -> np.ndarray:
        robot, q, h = kinematics.robot, kinematics.q, self.step
        gradient = np.empty(robot.nv)
        for k in range(robot.nv):
            step = np.zeros(robot.nv)
            step[k] = h
            gradient[k] = (
                self._call(robot, robot.integrate(q, step)) - self._call(robot, robot.integrate(q, -step))
            ) / (2 * h)
        return gradient

    def hessian(self, kinematics, task=None) -> np.ndarray:
        robot, q, n = kinematics.robot, kinematics.q, kinematics.robot.nv
        h = self.step**0.5 * 1e-1  # a larger step: second differences lose twice the digits
        hessian = np.empty((n, n))
        for i in range(n):
            for k in range(n):
                values = []
                for si, sk in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                    step = np.zeros(n)
                    step[i] += si * h
                    step[k] += sk * h
                    values.append(self._call(robot, robot.integrate(q, step)))
                hessian[i, k] = (values[0] - values[1] - values[2] + values[3]) / (4 * h * h)
        return hessian


CRITERIA = {"joint-limits": JointLimits, "manipulability": Manipulability}


def criterion_from(spec) -> Criterion:
    """A Criterion from its name (``joint-limits``, ``manipulability``), a Criterion, or a callable."""
    if isinstance(spec, Criterion):
        return spec
    if isinstance(spec, str):
        try:
            return CRITERIA[spec]()
        except KeyError:
            raise InvalidInput(
                f"unknown criterion '{spec}': choose one of {', '.join(CRITERIA)}, or give a callable p(joint_angles)"
            ) from None
    if callable(spec):
        return CallableCriterion(spec)
    raise InvalidInput(f"criterion {spec!r} is neither a name ({', '.join(CRITERIA)}) nor a callable")
