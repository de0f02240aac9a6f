r"""The whole movement as one nonlinear program: a direct transcription.

Grid and variables
    N intervals of length :math:`h = T/N` (N even, so the paper's switch from
    acceleration to deceleration at :math:`T/2` falls on a node). At each node
    :math:`t_k = kh` the joint positions :math:`q_k` and velocities :math:`v_k`;
    over each interval a constant joint acceleration :math:`a_k`. The
    decision vector is :math:`w = (q_0, v_0, a_0, q_1, v_1, a_1, \dots, q_N, v_N)`,
    :math:`3nN + 2n` numbers.

Integration (exact for a held acceleration, linear constraints)
    .. math::

        q_{k+1} = q_k + h v_k + \tfrac{h^2}{2} a_k, \qquad v_{k+1} = v_k + h a_k,

    so the motion :math:`q(t)` is piecewise quadratic and continuously
    differentiable; it is the held-acceleration analogue of the simulation's
    held torque.

Task (equality constraints at every node but the first)
    .. math:: p(q_k) = x_{ref}(t_k), \qquad k = 1, \dots, N,

    the task frame's origin (xy rows for planar arms, the 3-D position
    otherwise) on the reference path. Only positions are constrained: the
    task velocity follows from the integration (imposing it too would ask
    2m conditions of n joints per interval, infeasible for the paper's n = 3,
    m = 2).

Torque (Pinocchio's RNEA at each interval's midpoint)
    .. math::

        \tau_k = \mathrm{RNEA}\big(q_k + \tfrac h2 v_k + \tfrac{h^2}{8} a_k,\;
                 v_k + \tfrac h2 a_k,\; a_k\big),

    the inverse dynamics of the planned motion at :math:`t_k + h/2`, whose
    value is the interval's mean torque to :math:`O(h^2)`.

Cost (midpoint rule, second order in h)
    .. math:: f(w) = \sum_{k=0}^{N-1} h\, \|S(\tau_k - \tau_{mid})\|^2 .

Options
    start at rest at :math:`q_0` (bounds :math:`q_0 = q^0, v_0 = 0`); end at
    rest (:math:`v_N = 0`) or free; hard torque bounds
    :math:`\tau^- \le \tau \le \tau^+` as nonlinear inequalities on the
    inverse dynamics at the start, the midpoint and the end of every
    interval (:data:`BOUND_FRACTIONS`; bounding the midpoint alone let the
    torque between midpoints pass a limit by 0.1 % on the 1 ms grid); joint
    position and velocity limits of the URDF as bounds on every
    :math:`q_k, v_k`.

Derivatives are Pinocchio's analytical ones: ``computeRNEADerivatives``
(:math:`\partial\tau/\partial q, \partial\tau/\partial v, M`) chained through
the midpoint map, and the frame Jacobian (LOCAL_WORLD_ALIGNED, whose linear
rows are :math:`\partial p/\partial q`). The Hessian of the Lagrangian is the
Gauss-Newton matrix of the least-squares cost,
:math:`2h\sum_k J_k^\top S^\top S J_k` with :math:`J_k = \partial\tau_k/\partial(q_k, v_k, a_k)`,
without the constraints' curvature: positive semi-definite, block diagonal,
one 3n×3n block per interval.

Known artefact: interpolating positions only at the nodes, a held
acceleration may alternate from one interval to the next, and the optimum
uses that freedom a little: its torques carry a square ripple at the grid's
period whose amplitude falls linearly with h (short paper movement, joint 1:
±1.4 N·m at 10 ms, ±0.7 at 5 ms, ±0.26 at 2 ms; long movement: ±0.48, ±0.24,
±0.08), while the cost converges at second order. A C² piecewise-cubic
motion (linear acceleration) was tried instead and rejected: solved forward
from a clamped start its spline recurrence has a growing mode (eigenvalue
−2 − √3), and IPOPT found far worse, rippling solutions (panda: cost 2.6e6
against 246).

Here :math:`q_k` is Pinocchio's configuration itself, so only revolute and
prismatic joints (``robot.euclidean``), whose configurations add, are
supported. A transcription that sets :attr:`Transcription.ANGLES` (the
shooting one) holds one angle per joint instead: a continuous joint's
(cos θ, sin θ) is :meth:`Transcription.configurations` of its angle θ
(Pinocchio's ``integrate`` from the neutral configuration), so the
integration rows stay linear and the angle may wind past ±π.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ..errors import InvalidInput
from ..robot import Robot

__all__ = ["BOUND_FRACTIONS", "Evaluation", "Transcription", "TranscriptionSize"]

#: Where in each interval, as a fraction of h, the torque bounds are imposed.
BOUND_FRACTIONS = (0.0, 0.5, 1.0)

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class TranscriptionSize(NamedTuple):
    """How large a transcription is, counted before it is built (:meth:`Transcription.count`)."""

    intervals: int
    variables: int
    constraints: int
    jacobian_nonzeros: int
    hessian_nonzeros: int  # the upper triangle, as IPOPT takes it

    @property
    def nonzeros(self) -> int:
        return self.jacobian_nonzeros + self.hessian_nonzeros


@dataclass
class Evaluation:
    """Every model quantity at one decision vector (computed once, shared by f, g and their derivatives).

    Attributes:
        torque: τ_k (N×n) [N·m]. torque_jacobian: ∂τ_k/∂(q_k, v_k, a_k) (N×n×3n).
        task: p(q_k) for k = 1..N (N×m) [m]. task_jacobian: ∂p/∂q_k (N×m×n).
        bound_torque, bound_jacobian: the torque and its Jacobian at each of
            :data:`BOUND_FRACTIONS` of every interval (N×F×n, N×F×n×3n); empty without bounds.
    """

    torque: np.ndarray
    torque_jacobian: np.ndarray
    task: np.ndarray
    task_jacobian: np.ndarray
    bound_torque: np.ndarray
    bound_jacobian: np.ndarray


class Transcription:
    """The nonlinear program of the module docstring, for one robot, grid and reference.

    Args:
        robot: a robot with only revolute and prismatic joints and task ``xy`` or ``position``.
        duration: T [s]. intervals: N (even, > 0).
        reference: x_ref(t_k) for k = 0..N, (N+1)×m [m].
        q0: start configuration. root: S (n×n). midpoint: τ_mid (n) [N·m].
        end_at_rest: add v_N = 0. torque_bounds: add τ⁻ ≤ τ_k ≤ τ⁺ (finite limits only).
        joint_limits: bound q_k and v_k by the URDF's position and velocity limits.
    """

    def __init__(
        self,
        robot: Robot,
        duration: float,
        intervals: int,
        reference: np.ndarray,
        q0: np.ndarray,
        root: np.ndarray,
        midpoint: np.ndarray,
        *,
        end_at_rest: bool = True,
        torque_bounds: bool = False,
        joint_limits: bool = False,
    ):
        if not robot.euclidean and not self.ANGLES:
            raise InvalidInput(
                f"the direct transcription needs revolute or prismatic joints only; robot '{robot.name}' has "
                "continuous or multi-coordinate joints: use transcription 'shooting', or lock them (--lock)"
            )
        if robot.task not in ("xy", "position"):
            raise InvalidInput(f"optimize supports tasks xy and position, not '{robot.task}'")
        self.robot = robot
        self.model, self.data = robot.model, robot.model.createData()
        self.n, self.m = robot.nv, robot.m
        self.intervals = int(intervals)
        self.h = float(duration) / self.intervals
        self.times = self.h * np.arange(self.intervals + 1)
        self.reference = np.asarray(reference, float)
        self.q0 = self.angles(np.asarray(q0, float))
        #: The velocity the movement starts with (at rest; the receding horizon sets the measured one).
        self.v0 = np.zeros(robot.nv)
        self.root = np.asarray(root, float)
        self.midpoint = np.asarray(midpoint, float)
        self.end_at_rest = end_at_rest
        self.joint_limits = joint_limits
        bounded = np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)
        self.torque_bounds = bool(torque_bounds)
        if self.torque_bounds and not bounded.any():
            raise InvalidInput(
                f"robot '{robot.name}' has no finite torque limit to bound the torques by; give torque limits"
            )
        self.bounded_joints = np.flatnonzero(bounded) if self.torque_bounds else np.zeros(0, int)
        self.fractions = BOUND_FRACTIONS if self.torque_bounds else ()
        n, N = self.n, self.intervals
        self.size = 3 * n * N + 2 * n
        self._last_w = None
        self._last = None
        self._build_patterns()

    #: Whether q_k holds one angle per joint (continuous joints allowed) rather than the configuration (nq
    #: numbers), as :meth:`evaluate` needs: it hands q_k to Pinocchio.
    ANGLES = False

    def angles(self, configurations: np.ndarray) -> np.ndarray:
        """The program's q of a configuration or of rows of them (in time order): the configuration itself for
        revolute and prismatic joints; else one angle per joint, a continuous joint's unwrapped along the rows."""
        if self.robot.euclidean:
            return configurations
        angles = self.robot.joint_angles(configurations)
        if angles.ndim == 2:
            model = self.model
            continuous = [model.joints[j].idx_v for j in range(1, model.njoints) if model.joints[j].nq == 2]
            angles[:, continuous] = np.unwrap(angles[:, continuous], axis=0)
        return angles

    def configurations(self, angles: np.ndarray) -> np.ndarray:
        """Pinocchio's configuration of the program's q (one row or rows): ``integrate(neutral, q)``."""
        if self.robot.euclidean:
            return angles
        angles = np.asarray(angles, float)
        if angles.ndim == 1:
            return self.robot.configuration(angles)
        return np.array([self.robot.configuration(row) for row in angles])

    @staticmethod
    def count(robot: Robot, intervals: int, *, torque_bounds: bool = False) -> TranscriptionSize:
        """The size the transcription of ``intervals`` intervals would have, without building it.

        Variables :math:`3nN + 2n`; constraints :math:`(2n + m + bF)N` (b joints
        with finite limits under torque bounds, F = len(:data:`BOUND_FRACTIONS`));
        nonzeros of the constraint Jacobian :math:`(7n + mn + 3nbF)N` and of the
        Hessian's upper triangle :math:`\tfrac{3n(3n+1)}{2}N`, as
        :meth:`_build_patterns` lays them out.
        """
        n, m, N = robot.nv, robot.m, int(intervals)
        bounded = int(np.count_nonzero(np.isfinite(robot.torque_upper) & np.isfinite(robot.torque_lower)))
        bounded = bounded if torque_bounds else 0
        fractions = len(BOUND_FRACTIONS) if torque_bounds else 0
        return TranscriptionSize(
            intervals=N,
            variables=3 * n * N + 2 * n,
            constraints=(2 * n + m + bounded * fractions) * N,
            jacobian_nonzeros=(7 * n + m * n + 3 * n * bounded * fractions) * N,
            hessian_nonzeros=3 * n * (3 * n + 1) // 2 * N,
        )

    # -- layout ----------------------------------------------------------------
    def q_index(self, k: int) -> np.ndarray:
        return 3 * self.n * k + np.arange(self.n)

    def v_index(self, k: int) -> np.ndarray:
        return 3 * self.n * k + self.n + np.arange(self.n)

    def a_index(self, k: int) -> np.ndarray:
        return 3 * self.n * k + 2 * self.n + np.arange(self.n)

    def split(self, w) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a) of a decision vector: (N+1)×n, (N+1)×n, N×n."""
        w = np.asarray(w, float).reshape(-1)
        n, N = self.n, self.intervals
        blocks = w[: 3 * n * N].reshape(N, 3, n)
        q = np.vstack([blocks[:, 0], w[3 * n * N : 3 * n * N + n]])
        v = np.vstack([blocks[:, 1], w[3 * n * N + n :]])
        return q, v, blocks[:, 2].copy()

    def join(self, q, v, a) -> np.ndarray:
        """The decision vector of (q, v, a) as returned by :meth:`split`."""
        N = self.intervals
        blocks = np.stack([np.asarray(q)[:N], np.asarray(v)[:N], np.asarray(a)], axis=1)
        return np.concatenate([blocks.reshape(-1), np.asarray(q)[N], np.asarray(v)[N]])

    @property
    def constraint_count(self) -> int:
        return (2 * self.n + self.m + len(self.bounded_joints) * len(self.fractions)) * self.intervals

    # -- bounds ----------------------------------------------------------------
    def variable_bounds(self, joint_limits: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds on w: the fixed start (q0, v0), the end at rest, and the joint limits when asked
        (``joint_limits``: this transcription's choice when None; the phase-1 problem of
        :func:`torqueopt.optimal.shooting.least_excess` relaxes them and asks for none)."""
        lower, upper = np.full(self.size, -np.inf), np.full(self.size, np.inf)
        if self.joint_limits if joint_limits is None else joint_limits:
            q_low, q_high, speed = self.robot.joint_limits  # one per joint: none on a continuous joint's angle
            for k in range(self.intervals + 1):
                lower[self.q_index(k)], upper[self.q_index(k)] = q_low, q_high
                lower[self.v_index(k)], upper[self.v_index(k)] = -speed, speed
        lower[self.q_index(0)] = upper[self.q_index(0)] = self.q0
        lower[self.v_index(0)] = upper[self.v_index(0)] = self.v0
        if self.end_at_rest:
            lower[self.v_index(self.intervals)] = upper[self.v_index(self.intervals)] = 0.0
        return lower, upper

    def constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds on g: zero for the equalities, τ⁻, τ⁺ for the torque rows."""
        lower, upper = np.zeros(self.constraint_count), np.zeros(self.constraint_count)
        if self.torque_bounds:
            start = (2 * self.n + self.m) * self.intervals
            joints = self.bounded_joints
            repeats = self.intervals * len(self.fractions)
            lower[start:] = np.tile(self.robot.torque_lower[joints], repeats)
            upper[start:] = np.tile(self.robot.torque_upper[joints], repeats)
        return lower, upper

    # -- model evaluation ----------------------------------------------------------
    def evaluate(self, w) -> Evaluation:
        """Torques, task positions and their Jacobians at ``w`` (cached for the last w)."""
        w = np.asarray(w, float).reshape(-1)
        if self._last is not None and np.array_equal(w, self._last_w):
            return self._last
        model, data, h, n, N = self.model, self.data, self.h, self.n, self.intervals
        q, v, a = self.split(w)
        torque = np.empty((N, n))
        torque_jacobian = np.empty((N, n, 3 * n))
        fractions = self.fractions
        bound_torque = np.empty((N, len(fractions), n))
        bound_jacobian = np.empty((N, len(fractions), n, 3 * n))
        for k in range(N):
            self._inverse_dynamics(q[k], v[k], a[k], 0.5 * h, torque[k], torque_jacobian[k])
            for index, fraction in enumerate(fractions):
                if fraction == 0.5:
                    bound_torque[k, index], bound_jacobian[k, index] = torque[k], torque_jacobian[k]
                else:
                    self._inverse_dynamics(
                        q[k], v[k], a[k], fraction * h, bound_torque[k, index], bound_jacobian[k, index]
                    )
        task = np.empty((N, self.m))
        task_jacobian = np.empty((N, self.m, n))
        frame, rows = self.robot.frame_id, self.robot.task_rows
        for k in range(1, N + 1):
            pin.computeJointJacobians(model, data, q[k])
            task[k - 1] = pin.updateFramePlacement(model, data, frame).translation[rows]
            task_jacobian[k - 1] = pin.getFrameJacobian(model, data, frame, _LWA)[rows]
        self._last_w, self._last = (
            w.copy(),
            Evaluation(torque, torque_jacobian, task, task_jacobian, bound_torque, bound_jacobian),
        )
        return self._last

    def _inverse_dynamics(self, q, v, a, s: float, torque_out: np.ndarray, jacobian_out: np.ndarray) -> None:
        r"""RNEA at time s [s] into an interval, :math:`(q + s v + \tfrac{s^2}{2} a,\ v + s a,\ a)`, and its Jacobian.

        The Jacobian is Pinocchio's :math:`(\partial\tau/\partial q, \partial\tau/\partial v, M)`
        chained through that map to the interval's (q_k, v_k, a_k).
        """
        n = self.n
        d_q, d_v, inertia = pin.computeRNEADerivatives(self.model, self.data, q + s * v + 0.5 * s * s * a, v + s * a, a)
        torque_out[...] = self.data.tau
        jacobian_out[:, :n] = d_q
        jacobian_out[:, n : 2 * n] = s * d_q + d_v
        jacobian_out[:, 2 * n :] = 0.5 * s * s * d_q + s * d_v + inertia

    # -- the NLP's functions -----------------------------------------------------
    def objective(self, w) -> float:
        r""":math:`f = \sum_k h\|S(\tau_k - \tau_{mid})\|^2` on the transcription grid."""
        residual = (self.evaluate(w).torque - self.midpoint).dot(self.root.T)
        return float(self.h * np.sum(residual * residual))

    def gradient(self, w) -> np.ndarray:
        r""":math:`\nabla f = 2h\sum_k J_k^\top S^\top S(\tau_k - \tau_{mid})`."""
        evaluation = self.evaluate(w)
        weighted = (evaluation.torque - self.midpoint).dot(self.root.T).dot(self.root)  # SᵀS(τ − τmid), row-wise
        blocks = 2.0 * self.h * np.einsum("kij,ki->kj", evaluation.torque_jacobian, weighted)
        gradient = np.zeros(self.size)
        gradient[: 3 * self.n * self.intervals] = blocks.reshape(-1)
        return gradient

    def constraints(self, w) -> np.ndarray:
        """g(w): integration defects (2n per interval), task errors (m per node k ≥ 1), then the torques of the
        bounded joints at each of :data:`BOUND_FRACTIONS` of every interval."""
        evaluation = self.evaluate(w)
        q, v, a = self.split(w)
        h = self.h
        defect_q = q[1:] - q[:-1] - h * v[:-1] - 0.5 * h * h * a
        defect_v = v[1:] - v[:-1] - h * a
        integration = np.concatenate([defect_q, defect_v], axis=1).reshape(-1)
        task = (evaluation.task - self.reference[1:]).reshape(-1)
        parts = [integration, task]
        if self.torque_bounds:
            parts.append(evaluation.bound_torque[:, :, self.bounded_joints].reshape(-1))
        return np.concatenate(parts)

    def jacobian_values(self, w) -> np.ndarray:
        """Values of ∂g/∂w in the order of :attr:`jacobian_rows`, :attr:`jacobian_cols`."""
        evaluation = self.evaluate(w)
        parts = [self._integration_values, evaluation.task_jacobian.reshape(-1)]
        if self.torque_bounds:
            parts.append(evaluation.bound_jacobian[:, :, self.bounded_joints, :].reshape(-1))
        return np.concatenate(parts)

    def jacobian(self, w) -> np.ndarray:
        """∂g/∂w as a dense array (for tests and small problems)."""
        dense = np.zeros((self.constraint_count, self.size))
        np.add.at(dense, (self.jacobian_rows, self.jacobian_cols), self.jacobian_values(w))
        return dense

    def hessian_values(self, w, objective_factor: float) -> np.ndarray:
        r"""Gauss-Newton Hessian of the Lagrangian, :math:`\sigma\, 2h\sum_k J_k^\top S^\top S J_k`, upper triangles.

        In the order of :attr:`hessian_rows`, :attr:`hessian_cols`; the
        constraint multipliers do not enter (constraint curvature is neglected).
        """
        evaluation = self.evaluate(w)
        weighted_jacobian = np.einsum("ij,kjl->kil", self.root, evaluation.torque_jacobian)  # S J_k
        blocks = 2.0 * self.h * objective_factor * np.einsum("kil,kim->klm", weighted_jacobian, weighted_jacobian)
        return blocks[:, self._upper_rows, self._upper_cols].reshape(-1)

    # -- sparsity patterns --------------------------------------------------------
    def _build_patterns(self) -> None:
        n, m, N, h = self.n, self.m, self.intervals, self.h
        rows, cols, values = [], [], []
        identity = np.arange(n)
        for k in range(N):
            row_q = 2 * n * k + identity
            row_v = row_q + n
            for target, column_block, coefficient in (
                (row_q, self.q_index(k + 1), 1.0),
                (row_q, self.q_index(k), -1.0),
                (row_q, self.v_index(k), -h),
                (row_q, self.a_index(k), -0.5 * h * h),
                (row_v, self.v_index(k + 1), 1.0),
                (row_v, self.v_index(k), -1.0),
                (row_v, self.a_index(k), -h),
            ):
                rows.append(target)
                cols.append(column_block)
                values.append(np.full(n, coefficient))
        self._integration_values = np.concatenate(values)
        task_start = 2 * n * N
        for k in range(1, N + 1):
            block_rows = task_start + m * (k - 1) + np.arange(m)
            rows.append(np.repeat(block_rows, n))
            cols.append(np.tile(self.q_index(k), m))
        if self.torque_bounds:
            torque_start = task_start + m * N
            b = len(self.bounded_joints) * len(self.fractions)
            for k in range(N):
                block_rows = torque_start + b * k + np.arange(b)
                rows.append(np.repeat(block_rows, 3 * n))
                cols.append(np.tile(3 * n * k + np.arange(3 * n), b))
        self.jacobian_rows = np.concatenate(rows)
        self.jacobian_cols = np.concatenate(cols)
        self._upper_rows, self._upper_cols = np.triu_indices(3 * n)
        self.hessian_rows = np.concatenate([3 * n * k + self._upper_rows for k in range(N)])
        self.hessian_cols = np.concatenate([3 * n * k + self._upper_cols for k in range(N)])
