r"""Obstacle avoidance through the null space (Maciejewski & Klein, 1985), Eq. (12), Eq. (13)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...errors import InvalidInput
from ...robot import Robot
from ...robot_copies import RobotForest
from ...tasks import (
    FrameTask,
    Kinematics,
    PerConfiguration,
    pseudoinverse_workspace,
    stacked_undamped_pseudoinverse,
    undamped_pseudoinverse,
)
from ...tasks.task import identity
from ..options import Option, number
from ..registry import register_resolver
from .base import POSITION_GAIN_OPTION, VelocityResolver, pseudoinverse_solver
from .options import obstacle as obstacle_option
from .options import obstacle_text
from .pseudoinverse import StackedPseudoInverse

__all__ = [
    "ObstacleAvoidance",
    "StackedObstacleAvoidance",
    "activation",
    "activation_rate",
]


def activation(clearance: float, influence: float, critical: float) -> float:
    r"""Maciejewski & Klein's homogeneous-term gain :math:`\alpha_h(d)`: 0 beyond ``influence`` [m],
    1 within ``critical`` [m], a smooth (C¹) cubic step between."""
    if clearance >= influence:
        return 0.0
    if clearance <= critical:
        return 1.0
    s = (influence - clearance) / (influence - critical)
    return s * s * (3.0 - 2.0 * s)


def activation_rate(clearance: float, influence: float, critical: float) -> float:
    r""":math:`\alpha_h'(d)` [1/m] of :func:`activation`: 0 beyond ``influence`` and within ``critical``, and
    :math:`-6s(1 - s)/(d_i - d_c)` between, with :math:`s = (d_i - d)/(d_i - d_c)`."""
    if clearance >= influence or clearance <= critical:
        return 0.0
    s = (influence - clearance) / (influence - critical)
    return -6.0 * s * (1.0 - s) / (influence - critical)


@register_resolver
class ObstacleAvoidance(VelocityResolver):
    r"""Resolved rate that moves the arm's closest point away from an obstacle, Eq. (13).

    .. math::

        \dot q = J^\dagger\dot x + \alpha_h(d)\,[J_o(I - J^\dagger J)]^\dagger(\dot x_o - J_o J^\dagger \dot x)

    where :math:`x_o` is the point of the arm closest to the obstacle,
    :math:`J_o` its Jacobian, :math:`\dot x_o = v_o \hat n` the repulsive
    velocity along the outward normal (:class:`torqueopt.tasks.ObstacleTask`),
    and :math:`\alpha_h(d)` (Maciejewski & Klein's gain on the homogeneous
    solution) switches the term on smoothly as the clearance d falls below
    ``influence``. Eq. (12) is the null-space vector
    :math:`\dot\phi = [J_o(I - J^\dagger J)]^\dagger(\dot x_o - J_o J^\dagger\dot x)`.

    Args:
        obstacle: an ObstacleTask, or numbers (x, y), (x, y, z) or (x, y, z, radius) [m].
        speed: repulsive speed :math:`v_o` [m/s]; the obstacle task's own by default.
        influence: clearance [m] beyond which the obstacle is ignored.
        critical: clearance [m] within which the avoidance acts fully.
    """

    name = "obstacle-avoidance"
    equations = (12, 13)
    needs_redundancy = True
    options = (
        Option(
            name="obstacle",
            kind="ObstacleTask | x,y | x,y,z | x,y,z,radius",
            unit="m",
            default=None,
            meaning="the point or sphere obstacle (centre in world axes, radius)",
            convert=obstacle_option,
            default_text="none (required)",
            text=obstacle_text,
        ),
        Option(
            name="speed",
            kind="number >= 0",
            unit="m/s",
            default=None,
            meaning="repulsive speed v_o of the closest point, ẋ_o = v_o n̂",
            convert=number(0.0, unit="m/s"),
            default_text="the obstacle task's (0.5)",
        ),
        Option(
            name="influence",
            kind="number > 0",
            unit="m",
            default=0.5,
            meaning="clearance beyond which the obstacle is ignored (α_h = 0)",
            convert=number(0.0, strict=True, unit="m"),
        ),
        Option(
            name="critical",
            kind="number >= 0",
            unit="m",
            default=0.1,
            meaning="clearance within which the avoidance acts fully (α_h = 1); below influence",
            convert=number(0.0, unit="m"),
        ),
        POSITION_GAIN_OPTION,
    )

    def __init__(self, **options):
        super().__init__(**options)
        if not self.critical < self.influence:
            raise InvalidInput(
                f"option critical={self.critical:g} of resolver 'obstacle-avoidance' must be below influence={self.influence:g} [m]"
            )

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if self.obstacle is None:
            raise InvalidInput(
                "resolver 'obstacle-avoidance' needs the option obstacle: an ObstacleTask or x,y[,z[,radius]] [m]"
            )
        self.obstacle.check(robot)

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of Eq. (13) in closed form on a position task (else None: the loop's central difference).

        With :math:`p = J^\dagger c`, :math:`N = I - J^\dagger J`, :math:`B = J_o N`,
        :math:`e = \dot x_o - J_o p` and :math:`\dot\phi = B^\dagger e` (Eq. (12)), the rates are
        :math:`p + \alpha_h\dot\phi` and

        .. math::

            \ddot q = \dot p + \dot\alpha_h\dot\phi + \alpha_h(\dot B^\dagger e + B^\dagger\dot e),\quad
            \dot p = J^\dagger(\dot c - \dot J p) + N\dot J^\top J^{\dagger\top}p,\quad
            \dot e = v_o\dot{\hat n} - \dot J_o p - J_o\dot p,\quad
            \dot B = \dot J_o N - J_o(X + X^\top),\ X = J^\dagger\dot J N,

        from :math:`\frac{d}{dt}J^\dagger = -J^\dagger\dot J J^\dagger + N\dot J^\top(JJ^\top)^{-1}` (J of full row
        rank, :math:`(JJ^\top)^{-1} = J^{\dagger\top}J^\dagger`), so that
        :math:`\dot N = -\frac{d}{dt}(J^\dagger J) = -(X + X^\top)`; :math:`\dot B^\dagger` by
        :func:`~torqueopt.tasks.pseudoinverse_rate` (B of constant rank),
        :math:`\dot\alpha_h = \alpha_h'(d)\,\hat n\cdot v_p`, and the closest point's own velocity :math:`v_p`,
        :math:`\dot{\hat n}`, :math:`\dot J_o` from :meth:`~torqueopt.tasks.ObstacleTask.point_rates`;
        :math:`\dot J` from Pinocchio's Jacobian time variation at (q, q̇). It is the derivative where the closest
        point moves smoothly; at the instant it passes from one segment to another (or onto a segment's end) the
        rates have a kink and this is the derivative on one side of it. The tests hold it to a five-point
        difference of the rates and, run for run, to the loop's central difference.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (13)'s rates and their closed-form q̈ (None for a pose task), sharing what both read at a
        configuration: :meth:`general_step_functions`. The batch takes the stacked form (:meth:`stack_rate_function`),
        which the tests hold to this one."""
        return self.general_step_functions(robot, task)

    def general_step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (13)'s rates and their closed-form q̈ (None for a pose task) for any task, sharing what both read at a
        configuration: the step where the stacked form does not apply, and the reference the tests hold it to."""
        solver = pseudoinverse_solver(robot, self.singular_tolerance, null_space=False)
        workspace = pseudoinverse_workspace(3, robot.nv)  # of [J_o(I − J⁺J)]⁺, kept for the run
        obstacle, influence, critical = self.obstacle, self.influence, self.critical
        speed = obstacle.speed if self.speed is None else self.speed

        @PerConfiguration
        def at_configuration(kinematics: Kinematics):
            """What Eq. (13) reads at q whatever ẋ: J⁺, σmin/σmax, α_h, and J_o, ẋ_o, [J_o(I − J⁺J)]⁺ where α_h > 0;
            and for q̈ the closest point, I − J⁺J and J_o(I − J⁺J)."""
            jacobian = task.jacobian(kinematics)
            inverse, inverse_condition = solver.pseudoinverse(jacobian)  # Eq. (3) by SVD
            closest = obstacle.closest_point(kinematics)
            gain = activation(closest.clearance, influence, critical)
            projector = identity(robot.nv) - inverse.dot(jacobian)
            if gain == 0.0:
                return inverse, inverse_condition, gain, None, None, None, (closest, projector, None)
            point_jacobian = obstacle.point_jacobian(kinematics, closest)
            projected = point_jacobian.dot(projector)
            projected_inverse = undamped_pseudoinverse(projected, svd=workspace)
            return (
                inverse, inverse_condition, gain, point_jacobian, speed * closest.normal, projected_inverse,
                (closest, projector, projected),
            )  # fmt: skip

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            inverse, inverse_condition, gain, point_jacobian, repulsion, projected_inverse, _ = at_configuration(
                kinematics
            )
            particular = inverse.dot(task_velocity)  # J⁺ẋ
            if gain == 0.0:
                return particular, inverse_condition
            # Eq. (12): φ̇ = [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ), with ẋ_o = v_o n̂
            phi = projected_inverse.dot(repulsion - point_jacobian.dot(particular))
            # Eq. (13): J⁺ẋ + α_h [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺ẋ)
            return particular + gain * phi, inverse_condition

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            inverse, _, gain, point_jacobian, repulsion, projected_inverse, configuration = at_configuration(kinematics)
            closest, projector, projected = configuration
            jacobian_rate = task.jacobian_rate(kinematics, velocity)
            particular = inverse.dot(command)
            # d/dt J⁺c, with d/dt J⁺ = −J⁺J̇J⁺ + (I − J⁺J)J̇ᵀ(JJᵀ)⁻¹ for J of full row rank and (JJᵀ)⁻¹ = J⁺ᵀJ⁺
            particular_rate = inverse.dot(command_rate - jacobian_rate.dot(particular)) + projector.dot(
                jacobian_rate.T.dot(inverse.T.dot(particular))
            )
            if gain == 0.0:
                return particular_rate  # beyond the influence α_h and its rate are 0
            point_velocity, normal_rate, point_jacobian_rate = obstacle.point_rates(kinematics, closest, velocity)
            gain_rate = activation_rate(closest.clearance, influence, critical) * float(
                closest.normal.dot(point_velocity)
            )
            # Ḃ = J̇_o N + J_o Ṅ, with Ṅ = −d/dt(J⁺J) = −(X + Xᵀ), X = J⁺J̇N, from the same d/dt J⁺
            turn = inverse.dot(jacobian_rate.dot(projector))
            projected_rate = point_jacobian_rate.dot(projector) - point_jacobian.dot(turn + turn.T)
            shortfall = repulsion - point_jacobian.dot(particular)  # e of Eq. (12)
            shortfall_rate = (
                speed * normal_rate - point_jacobian_rate.dot(particular) - point_jacobian.dot(particular_rate)
            )
            phi = projected_inverse.dot(shortfall)  # Eq. (12)
            phi_rate = pseudoinverse_rate_times(projected, projected_rate, projected_inverse, shortfall, phi)
            phi_rate += projected_inverse.dot(shortfall_rate)
            # d/dt of Eq. (13)
            return particular_rate + gain_rate * phi + gain * phi_rate

        return rates, acceleration if task.kind != "pose" else None

    def stack_rate_function(self, robot: Robot):
        """Eq. (13) and the closed-form q̈ of :meth:`acceleration_function` on stacks (``StackedObstacleAvoidance``),
        with every option (the obstacle's own ``frame`` among them), on a position task; None for a pose task (the
        loop has no closed-form q̈ there either) and for joints whose configuration does not add: one movement at
        a time."""
        if robot.task == "pose" or not robot.euclidean:
            return None
        speed = self.obstacle.speed if self.speed is None else self.speed
        return StackedObstacleAvoidance(
            RobotForest(robot), self.obstacle, speed, self.influence, self.critical, self.singular_tolerance
        )


#: The smallest positive double: x / max(y, it) is x / y for every y > 0, and 0 for x = y = 0.
_SMALLEST = 5e-324


class _Closest(NamedTuple):
    """The closest point of every row of a stack, what Eq. (13)'s rates and q̈ read of it, rows last (each
    coordinate a contiguous block over the rows)."""

    point: np.ndarray  # (3, B) x_o [m]
    normal: np.ndarray  # (3, B) n̂
    distance: np.ndarray  # (B,) ‖x_o − c‖ [m]
    columns: np.ndarray  # (n, B) the joints that move the segment's body (its joint's support)
    # every segment's c − a [m] (a its start, its joint's origin), axis u = b − a [m], (c − a)·u and ‖u‖² [m²] (x_o
    # is inside the segment, sliding along it, where 0 < (c − a)·u < ‖u‖²), (8, (segments + 1)·B), read by ``segment``
    segments: np.ndarray
    picks: np.ndarray  # (B,) each row's closest segment's place in ``segments``' columns
    zeros: np.ndarray  # (1, B) zeros

    def segment(self):
        """c − a (3, B), u (3, B), (c − a)·u (B,) and ‖u‖² (B,) of each row's closest segment."""
        picked = np.take(self.segments, self.picks, axis=1)
        return picked[0:3], picked[3:6], picked[6], picked[7]


class _Homogeneous(NamedTuple):
    """What the rates leave to q̈ of the homogeneous term of Eq. (13), every row's, rows last."""

    closest: _Closest
    gain: np.ndarray  # (B,) α_h
    slope: np.ndarray  # (B,) α_h' [1/m]
    world: np.ndarray  # (6, n, B) J_O of the joints that move the closest segment's body
    point_jacobian: np.ndarray  # (3, n, B) J_o
    crossing: np.ndarray  # (3, 3, B) [−x_o]×: a × x_o = [−x_o]× a
    projector: np.ndarray  # (n, n, B) N = I − J⁺J
    projected: np.ndarray  # (3, n, B) B = J_o N
    projected_inverse: np.ndarray | None  # (n, 3, B) B⁺, None when B has rank one or less
    scale: np.ndarray | None  # (B,) 1/‖B‖²_F (0 where B is dropped) when B has rank one or less, else None
    shortfall: np.ndarray  # (3, B) e of Eq. (12)
    phi: np.ndarray  # (n, B) φ̇ = B⁺e, Eq. (12)
    velocity: np.ndarray  # (n, B) q̇ of Eq. (13), of which the rates return the (B, n) copy ``returned``
    returned: np.ndarray


def _rows_last(stack: np.ndarray) -> np.ndarray:
    """A (B, …) stack as a contiguous (…, B) one, the rows axis last."""
    return stack.transpose((*range(1, stack.ndim), 0)).copy()


def _times(matrices: np.ndarray, other: np.ndarray) -> np.ndarray:
    """The product of each row's matrices of two (r, k, B), (k, c, B) stacks, rows last: (r, c, B). One einsum
    whose inner loop runs over the rows, where products of stacks of small matrices pay a set-up per matrix."""
    return np.einsum("ikb,kjb->ijb", matrices, other)


def _apply(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Each row's matrix (r, k, B) times its vector (k, B): (r, B), rows last."""
    return np.einsum("ijb,jb->ib", matrices, vectors)


def _apply_transposed(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Each row's transposed matrix, of (k, r, B), times its vector (k, B): (r, B), rows last."""
    return np.einsum("jib,jb->ib", matrices, vectors)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a·b of each row's vectors of (3, B) stacks."""
    return np.einsum("ib,ib->b", a, b)


#: The signs that make a 2×2 matrix reversed in both axes, ((d, c), (b, a)), its adjugate ((d, −b), (−c, a)).
_ADJUGATE_SIGNS = np.array([[1.0, -1.0], [-1.0, 1.0]])[:, :, None]

#: Where each entry of :math:`[-p]_\times` sits in (p_0, p_1, p_2, −p_0, −p_1, −p_2, 0): (ω × p) = [−p]×ω.
_CROSS_BY = np.array([[6, 2, 4], [5, 6, 0], [1, 3, 6]])


def _crossing(vectors: np.ndarray, zeros: np.ndarray) -> np.ndarray:
    r"""The matrices :math:`[-p]_\times` (3, 3, B) of vectors p (3, B), rows last: :math:`[-p]_\times a = a\times p`,
    so that the cross products of a stack's columns with p are one product of stacks (``_times``). ``zeros``:
    (1, B) zeros."""
    return np.take(np.concatenate((vectors, -vectors, zeros)), _CROSS_BY, axis=0)


class StackedObstacleAvoidance(StackedPseudoInverse):
    r"""Eq. (13), :math:`\dot q = J^\dagger c + \alpha_h(d)\,[J_o(I - J^\dagger J)]^\dagger(\dot x_o - J_oJ^\dagger c)`,
    and its closed-form :math:`\ddot q` (:meth:`ObstacleAvoidance.acceleration_function`) per row of (B, m, n)
    stacks (:class:`StackedPseudoInverse` for :math:`J^\dagger`, σmin/σmax and the singular rows).

    The closest point of each row (:meth:`torqueopt.tasks.ObstacleTask.closest_point`, on every segment of every
    row at once) from the joints' origins the forest computes with J in the same pass (``reads_joints``) and the
    end frame's position; its Jacobian :math:`J_o = J_v + J_\omega\times x_o` and, along q̇,
    :math:`\dot J_o = \dot J_v + \dot J_\omega\times x_o + J_\omega\times v_p` (as ``point_kinematics``, with the
    point's own velocity :math:`v_p`, its slide along its segment included,
    :meth:`torqueopt.tasks.ObstacleTask.point_rates`) from the world-frame Jacobian columns of the joints that move
    the closest segment's body (``RobotForest.support_columns``, one row of columns per segment, gathered per row).

    The homogeneous term is computed on every row, with the rows last (each operation a few passes over the
    rows rather than one small matrix at a time), and added with :math:`\alpha_h` and :math:`\dot\alpha_h`, which
    are 0 beyond the influence: such a row moves by :math:`J^\dagger c` alone, as in the single-state step, and
    no row is computed when none is within it.

    Args:
        forest: the robot's forest (its support columns and frame placements).
        obstacle: the obstacle (centre, radius, and the frame that ends the chain).
        speed: the repulsive speed :math:`v_o` [m/s].
        influence, critical: the clearances [m] of :func:`activation`.
        tolerance: the smallest σmin/σmax of J a row may have.
    """

    reads_joints = True

    def __init__(
        self, forest: RobotForest, obstacle, speed: float, influence: float, critical: float, tolerance: float
    ):
        super().__init__(tolerance)
        robot = forest.robot
        chain, frame_id = obstacle.chain(robot.model, robot.frame)
        self.segments = len(chain)
        # a chain of consecutive joints (a serial arm's) is read by a slice
        consecutive = chain == list(range(chain[0], chain[0] + len(chain)))
        self.chain = slice(chain[0], chain[0] + len(chain)) if consecutive else chain
        # the end frame is the task frame, whose position the forest gives, or another one placed from its joint's
        self.end_frame = None if frame_id == robot.frame_id else frame_id
        self.forest, self.center, self.radius = forest, obstacle.center, obstacle.radius
        self.speed, self.influence, self.critical = speed, influence, critical
        # segment i moves with joint chain[i]'s body: the columns of that joint's support, (n, segments)
        self.segment_columns = np.array([forest.support_columns(joint) for joint in chain]).T.copy()
        self.rank_one = robot.nv - robot.m == 1
        self.identity = np.eye(robot.nv)[:, :, None]
        self._count = None

    def _per_count(self, count: int):
        """For stacks of ``count`` rows: the rows' indices, (1, count) zeros, and the columns of each segment's
        joints for each row, (n, segments·count), kept while the count stays."""
        if self._count is None or self._count[0].size != count:
            self._count = (np.arange(count), np.zeros((1, count)), np.repeat(self.segment_columns, count, axis=1))
        return self._count

    def _closest(self, kinematics):
        """Every row's clearance d [m] (B,) to its closest point on the chain's segments (the first of equals), and
        the closest point (:class:`_Closest`). The segments are (3, segments, B) arrays (each coordinate a
        contiguous block, so that each operation is one pass over the stack), written in one (14, segments + 1, B)
        block from which one gather picks every row's closest segment."""
        joints = kinematics.joints
        end = kinematics.tip if self.end_frame is None else self.forest.frame_points(joints, self.end_frame)
        count, segments = end.shape[0], self.segments
        # the block: each segment's closest point x_o (0:3), x_o − c (3:6), c − a (6:9), axis u (9:12), (c − a)·u,
        # ‖u‖², in its first columns; 0:3 holds the corners (each segment's start a and the end) until x_o
        block = np.empty((14, segments + 1, count))
        corners, offsets, to_center, axis = block[0:3], block[3:6, :-1], block[6:9, :-1], block[9:12, :-1]
        corners[:, :segments] = joints.origins[:, self.chain].T
        corners[:, segments] = end.T
        start = corners[:, :-1]
        np.subtract(corners[:, 1:], start, out=axis)
        np.subtract(self.center[:, None, None], start, out=to_center)
        length_squared = np.einsum("ijb,ijb->jb", axis, axis, out=block[13, :-1])
        along = np.einsum("ijb,ijb->jb", to_center, axis, out=block[12, :-1])
        # s_i = (c − a_i)·u_i/‖u_i‖² clipped to [0, 1], 0 on a segment of no length (whose u_i = 0 gives 0/5e-324)
        fraction = along / np.maximum(length_squared, _SMALLEST)
        np.minimum(np.maximum(fraction, 0.0, out=fraction), 1.0, out=fraction)  # np.clip's Python costs more
        points = start  # x_o = a + s u, written over a
        points += fraction * axis
        np.subtract(points, self.center[:, None, None], out=offsets)
        distances = np.sqrt(np.einsum("ijb,ijb->jb", offsets, offsets))
        # the first of equals, as the single-state loop's strict comparison
        rows, zeros, columns = self._per_count(count)
        # the closest segment's place in a (segments + 1, B) array, raveled: segment·B + row (argmin's first of
        # equals is the strict comparison's)
        picks = distances.argmin(axis=0)
        picks *= count
        picks += rows
        distance = distances.ravel().take(picks)  # the rows of distances are those of the block's first segments
        picked = np.take(block[:6].reshape(6, -1), picks, axis=1)
        normal = picked[3:6] / np.maximum(distance, _SMALLEST)
        if not distance.all():
            normal[0, distance == 0.0] = 1.0  # a point on the obstacle's centre: offset 0, n̂ = (1, 0, 0)
        closest = _Closest(
            picked[0:3], normal, distance, np.take(columns, picks, axis=1), block[6:].reshape(8, -1), picks, zeros,
        )  # fmt: skip
        return distance - self.radius, closest

    def _activation(self, clearance: np.ndarray):
        """α_h(d) and α_h'(d) [1/m] of every row (:func:`activation`, :func:`activation_rate`): s clipped to
        [0, 1] is 0 exactly where d ≥ ``influence`` and 1 where d ≤ ``critical``, where the cubic step gives 0 and 1
        and its slope (−)0."""
        influence, critical = self.influence, self.critical
        s = influence - clearance
        s /= influence - critical
        np.minimum(np.maximum(s, 0.0, out=s), 1.0, out=s)
        squared = s * s
        gain = 3.0 - 2.0 * s
        gain *= squared
        slope = squared - s
        slope *= 6.0 / (influence - critical)
        return gain, slope

    def _pseudoinverse(self, jacobian: np.ndarray, command: np.ndarray):
        r"""J (m, n, B), J⁺ (n, m, B) and p = J⁺c (n, B) rows last, σmin/σmax (B,) and the singular rows; for m = 2
        :math:`J^\dagger = J^\top G^{-1}`, :math:`G = JJ^\top` in closed form on the rows (the conditions and
        singular rows :class:`StackedPseudoInverse`'s), else :class:`StackedPseudoInverse`'s J⁺."""
        if jacobian.shape[1] != 2:
            particular, conditions, failures, inverse = super().rates(jacobian, command)
            return _rows_last(jacobian), _rows_last(inverse), _rows_last(particular), conditions, failures
        jacobian_rows = _rows_last(jacobian)
        gram = np.einsum("ikb,jkb->ijb", jacobian_rows, jacobian_rows)
        conditions, failures, determinant = self.conditions(gram.transpose(2, 0, 1))
        # G⁻¹ = ((d, −b), (−b, a))/(ad − b²), a singular row's the identity (a finite, unused answer)
        gram_inverse = gram[::-1, ::-1] * _ADJUGATE_SIGNS
        if failures:
            rows = list(failures)
            gram_inverse[:, :, rows], determinant[rows] = np.eye(2)[:, :, None], 1.0
        gram_inverse /= determinant
        inverse = np.einsum("kib,kjb->ijb", jacobian_rows, gram_inverse)  # Eq. (3)
        return jacobian_rows, inverse, _apply(inverse, command.T.copy()), conditions, failures

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a singular row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with every joint's."""
        jacobian_rows, inverse, particular, conditions, failures = self._pseudoinverse(jacobian, command)
        clearance, closest = self._closest(kinematics)
        gain, slope = self._activation(clearance)
        if failures:
            gain[list(failures)] = 0.0  # a singular row's J⁺ is not read
        if not gain.any():
            return particular.T.copy(), conditions, failures, (jacobian_rows, inverse, particular, None)
        # J_O of the joints that move the closest segment's body, (6, n, B), and J_o = J_v + J_ω × x_o
        world = _rows_last(kinematics.joints.jacobian)
        world *= closest.columns
        crossing = _crossing(closest.point, closest.zeros)
        point_jacobian = _times(crossing, world[3:])
        point_jacobian += world[:3]
        # N = I − J⁺J, B = J_o N
        projector = self.identity - _times(inverse, jacobian_rows)
        projected = _times(point_jacobian, projector)
        # e of Eq. (12): ẋ_o − J_o J⁺c, with ẋ_o = v_o n̂
        shortfall = self.speed * closest.normal
        shortfall -= _apply(point_jacobian, particular)
        if self.rank_one:
            # B = σuvᵀ: B⁺ = Bᵀ/‖B‖²_F, zero at σ ≤ 1e-10 (as stacked_undamped_pseudoinverse's rank_one)
            squared = np.einsum("ijb,ijb->b", projected, projected)
            scale = (squared > 1e-20) / np.maximum(squared, 1e-20)
            projected_inverse = None
            phi = _apply_transposed(projected, shortfall)  # Eq. (12)
            phi *= scale
        else:
            scale = None
            projected_inverse = stacked_undamped_pseudoinverse(projected.transpose(2, 0, 1)).transpose(1, 2, 0)
            phi = _apply(projected_inverse, shortfall)  # Eq. (12)
        # Eq. (13): J⁺c + α_h [J_o(I − J⁺J)]⁺(ẋ_o − J_o J⁺c), the term 0 where α_h = 0
        velocity = gain * phi
        velocity += particular
        returned = velocity.T.copy()
        homogeneous = _Homogeneous(
            closest, gain, slope, world, point_jacobian, crossing, projector, projected, projected_inverse, scale,
            shortfall, phi, velocity, returned,
        )  # fmt: skip
        return returned, conditions, failures, (jacobian_rows, inverse, particular, homogeneous)

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """The time derivative of Eq. (13) per row (see :meth:`ObstacleAvoidance.acceleration_function`).
        ``kinematics``: the forest's at the configuration and q̇, with every joint's and their rates."""
        jacobian_rows, inverse, particular, homogeneous = state
        jacobian_rate_rows = _rows_last(jacobian_rate)
        # d/dt J⁺c = J⁺(ċ − J̇p) + (I − J⁺J)J̇ᵀJ⁺ᵀp, p = J⁺c, for J of full row rank
        turned = _apply_transposed(jacobian_rate_rows, _apply_transposed(inverse, particular))
        residual = command_rate.T - _apply(jacobian_rate_rows, particular)
        particular_rate = _apply(inverse, residual)
        particular_rate += turned
        particular_rate -= _apply(inverse, _apply(jacobian_rows, turned))
        if homogeneous is None:
            return particular_rate.T.copy()  # beyond the influence α_h and its rate are 0
        closest, gain, slope, world, point_jacobian, crossing, projector, projected, projected_inverse = homogeneous[:9]
        scale, shortfall, phi = homogeneous[9:12]
        v = homogeneous.velocity if velocity is homogeneous.returned else _rows_last(velocity)
        # the body's angular velocity ω and the material point's velocity J_o q̇
        angular_velocity = _apply(world[3:], v)
        material_velocity = _apply(point_jacobian, v)
        to_center, axis, along, length_squared = closest.segment()
        # inside the segment ṡ = ((c − a)·(ω × u) − v_a·u)/‖u‖², at an end 0; the joint origin a moves at
        # v_a = J_o q̇ − ω × (x_o − a), and x_o − a is along u: v_a·u = J_o q̇·u
        inside = (along > 0.0) & (along < length_squared)
        slide = _dot(to_center, _apply(_crossing(axis, closest.zeros), angular_velocity))
        slide -= _dot(material_velocity, axis)
        slide /= np.maximum(length_squared, _SMALLEST)
        slide = np.where(inside, slide, 0.0)
        point_velocity = slide * axis
        point_velocity += material_velocity  # v_p = J_o q̇ + ṡu
        normal = closest.normal
        normal_speed = _dot(normal, point_velocity)
        normal_rate = point_velocity - normal * normal_speed
        normal_rate /= closest.distance
        # J̇_o = J̇_v + J̇_ω × x_o + J_ω × v_p: the material point's Jacobian rate and the slide's J_ω × ṡu
        world_rate = _rows_last(kinematics.joints.rate)
        world_rate *= closest.columns
        point_jacobian_rate = _times(crossing, world_rate[3:])
        point_jacobian_rate += _times(_crossing(point_velocity, closest.zeros), world[3:])
        point_jacobian_rate += world_rate[:3]
        gain_rate = slope * normal_speed  # α̇_h = α_h'(d) n̂·v_p
        # Ḃ = J̇_o N + J_o Ṅ, with Ṅ = −(X + Xᵀ), X = J⁺J̇N
        turn = _times(inverse, _times(jacobian_rate_rows, projector))
        turn = turn + turn.transpose(1, 0, 2)
        projected_rate = _times(point_jacobian_rate, projector)
        projected_rate -= _times(point_jacobian, turn)
        shortfall_rate = self.speed * normal_rate
        shortfall_rate -= _apply(point_jacobian_rate, particular)
        shortfall_rate -= _apply(point_jacobian, particular_rate)
        if scale is not None:
            # B⁺ = Bᵀ/‖B‖²_F of constant rank one: d/dt B⁺ = (Ḃᵀ − 2⟨B, Ḃ⟩B⁺)/‖B‖²_F, and B⁺ė = Bᵀė/‖B‖²_F
            phi_rate = _apply_transposed(projected_rate, shortfall)
            phi_rate += _apply_transposed(projected, shortfall_rate)
            phi_rate -= (2.0 * np.einsum("ijb,ijb->b", projected, projected_rate)) * phi
            phi_rate *= scale
        else:
            phi_rate = _pseudoinverse_rate_times(projected, projected_rate, projected_inverse, shortfall, phi)
            phi_rate += _apply(projected_inverse, shortfall_rate)
        # d/dt of Eq. (13), the term 0 where α_h = 0
        phi_rate *= gain
        phi_rate += gain_rate * phi
        particular_rate += phi_rate
        return particular_rate.T.copy()


def pseudoinverse_rate_times(matrix, matrix_rate, inverse, vector, inverse_times_vector) -> np.ndarray:
    r""":math:`\frac{d}{dt}A^\dagger\,e` of one matrix, :func:`~torqueopt.tasks.pseudoinverse_rate` applied to a
    vector e (``vector``, with :math:`y = A^\dagger e` given) in matrix-vector products, as
    :func:`_pseudoinverse_rate_times` on stacks: :math:`A^\dagger(-\dot Ay + A^{\dagger\top}\dot A^\top(e - Ay) - A\,w) + w`
    with :math:`w = \dot A^\top A^{\dagger\top}y`."""
    along = matrix_rate.T.dot(inverse.T.dot(inverse_times_vector))  # ȦᵀA⁺ᵀy
    inside = inverse.T.dot(matrix_rate.T.dot(vector - matrix.dot(inverse_times_vector)))
    inside -= matrix_rate.dot(inverse_times_vector)
    inside -= matrix.dot(along)
    return inverse.dot(inside) + along


def _pseudoinverse_rate_times(matrix, matrix_rate, inverse, vector, inverse_times_vector) -> np.ndarray:
    r""":math:`\frac{d}{dt}A^\dagger\,e` per row, :func:`~torqueopt.tasks.pseudoinverse_rate` applied to a vector e
    (``vector``, with :math:`y = A^\dagger e` given) in matrix-vector products on stacks with the rows last:
    :math:`A^\dagger(-\dot Ay + A^{\dagger\top}\dot A^\top(e - Ay) - A\,w) + w` with
    :math:`w = \dot A^\top A^{\dagger\top}y`."""
    along = _apply_transposed(matrix_rate, _apply_transposed(inverse, inverse_times_vector))  # ȦᵀA⁺ᵀy
    residual = vector - _apply(matrix, inverse_times_vector)
    inside = (
        _apply_transposed(inverse, _apply_transposed(matrix_rate, residual))
        - _apply(matrix_rate, inverse_times_vector)
        - _apply(matrix, along)
    )
    return _apply(inverse, inside) + along
