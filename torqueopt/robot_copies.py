r"""Many copies of one robot as one Pinocchio model: a batch's dynamics in a few calls.

A :class:`RobotForest` holds ``copies`` copies of a robot's kinematic tree,
side by side under one universe, in a single ``pin.Model``. Pinocchio then
computes the joint-space terms of every copy in one call per quantity: CRBA
gives a block-diagonal mass matrix whose diagonal blocks are the copies'
:math:`H`, ``nonLinearEffects`` the stacked bias torques :math:`b`,
``computeJointJacobiansTimeVariation`` the world-frame joint Jacobians and
their time derivatives, ``aba`` the stacked forward dynamics. The copies do
not interact: nothing couples two trees, so each block is exactly the single
robot's value at that copy's state.

The task frame's Jacobian and drift :math:`\dot J\dot q` (Eq. (18)) come from
the world-frame quantities by the rigid-body change of reference point that
``pin.getFrameJacobian`` and ``pin.getFrameClassicalAcceleration`` apply to
one frame (Pinocchio has no call that applies it to many frames at once), in
three batched numpy lines; the tests hold them to those Pinocchio calls.

This is the fast path of :mod:`torqueopt.batch`; :meth:`Robot.terms_function`
and :meth:`Robot.forward_dynamics` are the reference it is held to.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from .errors import InvalidInput
from .linalg import cross_along
from .robot import Robot
from .tasks.task import identity, rotations_view, translations_view

__all__ = [
    "FOREST_DOFS", "JointKinematics", "RobotForest", "TaskKinematics", "point_kinematics", "point_products",
    "stacked_cross",
]  # fmt: skip

#: Joints per forest: copies = FOREST_DOFS // n. The call overhead per copy
#: shrinks with the forest's size, but CRBA's instructions per copy and
#: Pinocchio's ``createData`` grow with it (BENCHMARKS.md), so a batch larger
#: than one forest goes through it in several passes.
FOREST_DOFS = 48


# Forest models per robot: a Robot is immutable, so its forest model is too and
# is built once. Pinocchio data are never shared: each RobotForest makes its
# own (its cost: BENCHMARKS.md), so two runs in threads cannot race.
_MODELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _forest_model(robot: Robot, copies: int) -> pin.Model:
    """``copies`` copies of the robot's tree under one universe, each with its task frame (frame 1 + copy)."""
    cached = _MODELS.setdefault(robot, {})
    if copies in cached:
        return cached[copies]
    model = robot.model
    forest = pin.Model()
    forest.name = f"{model.name} x {copies}"
    forest.gravity = model.gravity
    tip = model.frames[robot.frame_id]
    for copy in range(copies):
        joint_of = {0: 0}
        for joint in range(1, model.njoints):
            joint_of[joint] = forest.addJoint(
                joint_of[model.parents[joint]], model.joints[joint], model.jointPlacements[joint],
                f"{model.names[joint]}#{copy}",
            )  # fmt: skip
            forest.appendBodyToJoint(joint_of[joint], model.inertias[joint], pin.SE3.Identity())
        frame = pin.Frame(f"{tip.name}#{copy}", joint_of[tip.parentJoint], 0, tip.placement, pin.FrameType.OP_FRAME)
        forest.addFrame(frame, False)
    # Of the per-joint model vectors only the armature enters CRBA and RNEA (damping, friction,
    # rotor and limit vectors do not): it is the one copied to every tree.
    forest.armature = np.tile(model.armature, copies)
    cached[copies] = forest
    return forest


class JointKinematics(NamedTuple):
    r"""Every joint of S states, for tasks on other points than the task frame (:func:`point_kinematics`).

    ``jacobian``: the joints' world-frame Jacobian columns :math:`J_O` (S, 6, n), column i the spatial velocity
    (linear rows first, at the world origin) that joint i's unit rate gives every body it moves (Pinocchio's
    ``data.J``, no column masked); ``rate``: its time variation :math:`\dot J_O` along the state's v
    (``data.dJ``, S, 6, n) or None; ``origins`` (S, njoints, 3) [m] and ``rotations`` (S, njoints, 3, 3) the
    joints' placements in the world (``data.oMi``), row 0 the universe's, so a row's index is the joint's
    Pinocchio id. Fresh arrays the caller may keep.
    """

    jacobian: np.ndarray
    rate: np.ndarray | None
    origins: np.ndarray
    rotations: np.ndarray


class TaskKinematics(NamedTuple):
    r"""What :meth:`RobotForest.kinematics` gives for S states: the task frame's J (S, 6, n), :math:`\dot J`
    (S, 6, n) or None, the frame's position (S, 3) [m], and when asked :math:`H^{-1}` (S, n, n),
    :math:`\dot H\dot q` (S, n) [N·m], :math:`H` (S, n, n) [kg·m²] and every joint's kinematics (:class:`JointKinematics`). ``frame_jacobian``,
    ``frame_rate``: the frame's whole J and :math:`\dot J` (S, 6, n) where ``jacobian`` and ``rate`` hold a task's
    rows of them only (the batch's velocity-level lanes), else None."""

    jacobian: np.ndarray
    rate: np.ndarray | None
    tip: np.ndarray
    inverse_inertia: np.ndarray | None = None
    inertia_rate_velocity: np.ndarray | None = None
    joints: JointKinematics | None = None
    frame_jacobian: np.ndarray | None = None
    frame_rate: np.ndarray | None = None
    inertia: np.ndarray | None = None


class _Pass:
    """One Pinocchio data of a forest and views of what a pass reads from it (Eigen never reallocates them)."""

    __slots__ = (
        "bias", "coriolis", "data", "inertia", "inverse_inertia", "jacobian_columns", "jacobian_rate_columns",
        "origins", "rotations", "tip_columns",
    )  # fmt: skip

    def __init__(self, forest: pin.Model, copies: int, n: int):
        self.data = data = forest.createData()
        # Pinocchio's matrices are column-major: column c = copy·n + j of a (6, copies·n) matrix is
        # [:, j, copy] of an F-order reshape, and the diagonal blocks of M (Minv, C) are one strided view.
        self.inertia, self.inverse_inertia, self.coriolis = (
            np.lib.stride_tricks.as_strided(
                matrix, shape=(copies, n, n), strides=((n + copies * n * n) * 8, 8, copies * n * 8), writeable=False
            )
            for matrix in (data.M, data.Minv, data.C)
        )
        self.bias = data.nle.reshape(n, copies, order="F").T
        # J and J̇ batch-last, (6, n, copies): exactly the layout of Pinocchio's column-major 6 × copies·n
        self.jacobian_columns = data.J.reshape(6, n, copies, order="F")
        self.jacobian_rate_columns = data.dJ.reshape(6, n, copies, order="F")
        self.tip_columns = translations_view(data.oMf, 1, copies).T  # every copy's task frame position [m], (3, copies)
        # every copy's joints' placements, (copies, joints, ...): copy c's joint j is the forest's 1 + c·joints + j − 1
        joints = (forest.njoints - 1) // copies
        self.origins = translations_view(data.oMi, 1, copies * joints).reshape(copies, joints, 3)
        self.rotations = rotations_view(data.oMi, 1, copies * joints).reshape(copies, joints, 3, 3)


class RobotForest:
    r"""Copies of ``robot``'s tree in one Pinocchio model, computing the task terms of many states at once.

    :meth:`terms` takes (S, n) stacks of states for any S: the rows go
    through the forest ``copies`` at a time, each pass in its own Pinocchio
    data (a last, partly filled pass repeats a row in the unused trees), and
    come back as (S, ...) stacks. Only robots whose joints all add
    (:attr:`Robot.euclidean`) can be copied this way: a copy's q is then a
    slice of the forest's.
    """

    def __init__(self, robot: Robot, copies: int | None = None):
        if not robot.euclidean:
            raise InvalidInput(
                f"robot '{robot.name}' has joints whose configuration does not add (nq != nv): "
                "it cannot be copied into a forest"
            )
        model = robot.model
        self.robot = robot
        self.n = n = model.nv
        self.copies = copies = max(1, FOREST_DOFS // n) if copies is None else int(copies)
        self.model = _forest_model(robot, copies)
        self._pool: list[_Pass] = []  # this forest's own Pinocchio data, one per pass, made as needed
        # Joints outside the tip's support move other links, not the tip: their Jacobian columns are zero.
        support = set(model.supports[model.frames[robot.frame_id].parentJoint])
        mask = np.zeros(n)
        for joint in range(1, model.njoints):
            if joint in support:
                mask[model.idx_vs[joint] : model.idx_vs[joint] + model.nvs[joint]] = 1.0
        self._mask = None if mask.all() else mask

    def _forest_vectors(self, stack: np.ndarray, passes: int) -> np.ndarray:
        """The (passes, copies·n) forest vectors of an (S, n) ``stack``: one reshape when S fills the passes, else
        the last pass padded with its own first row (the unused trees compute a state nobody reads)."""
        stack = np.ascontiguousarray(stack)
        missing = passes * self.copies - stack.shape[0]
        if missing:
            stack = np.concatenate([stack, np.repeat(stack[-(self.copies - missing)][None], missing, axis=0)])
        return stack.reshape(passes, -1)

    def _each_pass(self, *stacks: np.ndarray):
        """For every forest pass the rows of the (S, ...) ``stacks`` take: the pass and each stack's forest vector."""
        used = self._passes(stacks[0].shape[0])
        return zip(used, *(self._forest_vectors(stack, len(used)) for stack in stacks))

    def terms(self, q: np.ndarray, v: np.ndarray):
        r"""The task terms of every row: ``(H, b, J, J̇q̇, p)`` as (S, n, n), (S, n), (S, 6, n), (S, 6), (S, 3).

        :math:`H` and :math:`b = C\dot q + g` of Eq. (20) (plus the joints' damping and friction when the robot
        models them, :meth:`torqueopt.Robot.joint_resistance`); the task frame's
        Jacobian :math:`J` and classical-acceleration drift :math:`\dot J\dot q`
        (Eq. (18)) in LOCAL_WORLD_ALIGNED, linear rows first; its position p.
        """
        count, model = q.shape[0], self.model
        for forest_pass, q_forest, v_forest in self._each_pass(q, v):
            data = forest_pass.data
            pin.crba(model, data, q_forest, pin.Convention.LOCAL)  # WORLD, the default, costs the same here
            pin.nonLinearEffects(model, data, q_forest, v_forest)
            pin.computeJointJacobiansTimeVariation(model, data, q_forest, v_forest)
            pin.updateFramePlacements(model, data)
        used = self._passes(count)
        inertia, bias = _gathered(used, "inertia", count), _gathered(used, "bias", count)
        if self.robot.models_joint_dynamics:
            bias += self.robot.joint_resistance(v)  # the motor's bias, as Robot.terms gives it
        # J_O and J̇_O of every row batch-last, (12, n, rows), so that numpy's inner loops run over the rows
        world = np.empty((12, self.n, len(used) * self.copies))
        np.concatenate([forest_pass.jacobian_columns for forest_pass in used], axis=2, out=world[:6])
        np.concatenate([forest_pass.jacobian_rate_columns for forest_pass in used], axis=2, out=world[6:])
        world = world[:, :, :count]
        if self._mask is not None:
            world *= self._mask[:, None]
        tip = np.concatenate([forest_pass.tip_columns for forest_pass in used], axis=1)[:, :count]
        jacobian, drift = _at_point_batch_last(world, tip, v)
        return inertia, bias, jacobian.transpose(2, 0, 1), drift.T, tip.T

    def kinematics(
        self, q: np.ndarray, v: np.ndarray | None = None, tip: np.ndarray | None = None, *,
        inverse_inertia: bool = False, inertia_rate: bool = False, joints: bool = False, inertia: bool = False,
    ) -> TaskKinematics:  # fmt: skip
        r"""The task frame's Jacobian :math:`J` (S, 6, n) in LOCAL_WORLD_ALIGNED, linear rows first, and its position (S, 3);
        with joint velocities v, also :math:`\dot J` (S, 6, n), the Jacobian's rate along v (else None).
        ``tip``: the positions at q when the caller has them (from a call at the same q): not read again.

        One joint-Jacobian pass per forest pass (with its time variation when v
        is given), no dynamics: what a velocity-level method needs at a state.
        The point's :math:`\dot J` is the rate of its :math:`J = J_v + J_\omega\times p`:
        :math:`\dot J_v + \dot J_\omega\times p + J_\omega\times\dot p`, :math:`\dot p = J\dot q`.

        ``inverse_inertia`` (without v): each pass is Pinocchio's ``computeMinverse`` instead, which computes the
        same joint Jacobians on its way (bit for bit, tests/test_robot_copies.py), and :math:`H^{-1}` (S, n, n),
        the inverse of the block-diagonal H being its blocks' inverses, is returned too: the C++ function fills
        the upper triangle, and the Python binding copies it into the lower one of the data's own matrix before
        it returns, so the blocks read are whole. ``inertia_rate`` (with v): each pass is
        ``computeCoriolisMatrix``, which computes the same J and :math:`\dot J` on its way, and
        :math:`\dot H v = (C + C^\top)v` (S, n) is returned too (:math:`\dot H - 2C` is skew). One forest pass
        where the kinetic-energy stack made two. ``inertia`` (without v, instead of ``inverse_inertia``): each pass
        is CRBA in the WORLD convention, which computes the same joint Jacobians and placements on its way (bit for
        bit, tests/test_robot_copies_inertia.py), and :math:`H` (S, n, n) is returned too. ``joints``: every joint's kinematics from the same pass
        (:class:`JointKinematics`; with v, their rates too), for tasks on other points (:func:`point_kinematics`).
        """
        count, model = q.shape[0], self.model
        if (inverse_inertia and v is not None) or (inertia_rate and v is None):
            raise ValueError("inverse_inertia is taken without joint velocities, inertia_rate with them")
        if inertia and (v is not None or inverse_inertia):
            raise ValueError("inertia is taken without joint velocities, and not with inverse_inertia")
        stacks = (q,) if v is None else (q, v)
        for forest_pass, q_forest, *v_forest in self._each_pass(*stacks):
            if inverse_inertia:
                pin.computeMinverse(model, forest_pass.data, q_forest)
            elif inertia:
                pin.crba(model, forest_pass.data, q_forest, pin.Convention.WORLD)
            elif v is None:
                pin.computeJointJacobians(model, forest_pass.data, q_forest)
            elif inertia_rate:
                pin.computeCoriolisMatrix(model, forest_pass.data, q_forest, v_forest[0])
            else:
                pin.computeJointJacobiansTimeVariation(model, forest_pass.data, q_forest, v_forest[0])
            if tip is None:
                pin.updateFramePlacements(model, forest_pass.data)
        used = self._passes(count)
        # J_O, and with v J̇_O below it, of every row batch-last, (6 or 12, n, rows), as the passes computed them
        world = np.empty((6 if v is None else 12, self.n, len(used) * self.copies))
        np.concatenate([forest_pass.jacobian_columns for forest_pass in used], axis=2, out=world[:6])
        if v is not None:
            np.concatenate([forest_pass.jacobian_rate_columns for forest_pass in used], axis=2, out=world[6:])
        world = world[:, :, :count]
        every_joint = self._joints(used, count, world) if joints else None
        if self._mask is not None:
            world *= self._mask[:, None]
        if tip is None:
            tip = np.concatenate([forest_pass.tip_columns for forest_pass in used], axis=1)[:, :count].T
        jacobian, rate = _shifted_batch_last(world, tip.T, v)
        jacobian = jacobian.transpose(2, 0, 1)
        rate = None if rate is None else rate.transpose(2, 0, 1)
        if v is None:
            inverse = _gathered(used, "inverse_inertia", count) if inverse_inertia else None
            mass = _gathered(used, "inertia", count) if inertia else None
            return TaskKinematics(jacobian, None, tip, inverse_inertia=inverse, joints=every_joint, inertia=mass)
        if not inertia_rate:
            return TaskKinematics(jacobian, rate, tip, joints=every_joint)
        coriolis = _gathered(used, "coriolis", count)
        # Ḣv = (C + Cᵀ)v
        rate_times = np.einsum("bij,bj->bi", coriolis, v) + np.einsum("bji,bj->bi", coriolis, v)
        return TaskKinematics(jacobian, rate, tip, inertia_rate_velocity=rate_times, joints=every_joint)

    def _joints(self, used: list[_Pass], count: int, world: np.ndarray) -> JointKinematics:
        """Every joint's kinematics of the ``used`` passes' rows, copies of what the pass computed; ``world`` the
        rows' J_O (and J̇_O below it) batch-last, (6 or 12, n, count), read before the task's columns are masked."""
        joints = (self.model.njoints - 1) // self.copies + 1  # the robot's own, the universe counted
        rows = len(used) * self.copies  # the passes' rows, the last pass's unused trees too: read straight into place
        origins = np.zeros((rows, joints, 3))
        np.concatenate([forest_pass.origins for forest_pass in used], out=origins[:, 1:])
        rotations = np.empty((rows, joints, 3, 3))
        rotations[:, 0] = identity(3)
        np.concatenate([forest_pass.rotations for forest_pass in used], out=rotations[:, 1:])
        # (S, 6, n) views of one batch-last copy: a stack that works batch-last reads it back without a copy
        own = world.copy().transpose(2, 0, 1)
        rate = own[:, 6:] if own.shape[1] == 12 else None
        return JointKinematics(own[:, :6], rate, origins[:count], rotations[:count])

    def support_columns(self, joint: int) -> np.ndarray:
        """(n,) ones at the velocity indices of the joints that move the robot's joint ``joint`` (its support, the
        joint itself included), zeros elsewhere: the columns of :class:`JointKinematics` a point on its body reads."""
        model = self.robot.model
        columns = np.zeros(self.n)
        for ancestor in model.supports[joint]:
            if ancestor > 0:
                columns[model.idx_vs[ancestor] : model.idx_vs[ancestor] + model.nvs[ancestor]] = 1.0
        columns.setflags(write=False)
        return columns

    def frame_points(self, joints: JointKinematics, frame_id: int) -> np.ndarray:
        r"""The world position (S, 3) [m] of the robot's frame ``frame_id`` in every row: its parent joint's placement
        applied to the frame's own, :math:`p = p_j + R_j\,p_{j,f}` (as ``pin.updateFramePlacements``)."""
        frame = self.robot.model.frames[frame_id]
        parent, offset = frame.parentJoint, frame.placement.translation
        if not offset.any():  # a frame at its joint's origin: p = p_j, the product of stacks skipped
            return joints.origins[:, parent].copy()
        return joints.origins[:, parent] + joints.rotations[:, parent] @ offset

    def _passes(self, count: int) -> list[_Pass]:
        """The forest passes that ``count`` rows take, the pool grown to them (each pass keeps its own data)."""
        passes = -(-count // self.copies)
        while len(self._pool) < passes:
            self._pool.append(_Pass(self.model, self.copies, self.n))
        return self._pool[:passes]

    def inertia(self, q: np.ndarray) -> np.ndarray:
        r""":math:`H` of every row, (S, n, n) [kg·m²]: CRBA once per forest pass, nothing else (what the kinetic and
        self-motion energies of a velocity-level stack need beside the J it has)."""
        for forest_pass, q_forest in self._each_pass(q):
            pin.crba(self.model, forest_pass.data, q_forest, pin.Convention.LOCAL)
        return _gathered(self._passes(q.shape[0]), "inertia", q.shape[0])

    def inverse_dynamics(self, q: np.ndarray, v: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """RNEA of every row, τ = H q̈ + b (Eq. (20)), (S, n) [N·m]: one Pinocchio call per forest pass (plus the
        joints' damping and friction when the robot models them)."""
        torques = [
            pin.rnea(self.model, forest_pass.data, q_forest, v_forest, acceleration_forest).reshape(self.copies, self.n)
            for forest_pass, q_forest, v_forest, acceleration_forest in self._each_pass(q, v, acceleration)
        ]
        torque = np.concatenate(torques)[: q.shape[0]]
        if self.robot.models_joint_dynamics:
            torque += self.robot.joint_resistance(v)  # the motor's torque, as VelocityRates.torque gives it
        return torque


def _gathered(used: list[_Pass], name: str, count: int) -> np.ndarray:
    """The passes' views ``name`` (a _Pass field) joined into one (count, ...) stack, a fresh array."""
    return np.concatenate([getattr(forest_pass, name) for forest_pass in used])[:count]


def stacked_cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b along axis 1 of (B, 3, ...) stacks (broadcast), by components: numpy's cross and matmul on stacks of
    3-vectors cost several times more per row (BENCHMARKS.md)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    first = a1 * b2 - a2 * b1
    out = np.empty((first.shape[0], 3, *first.shape[1:]))
    out[:, 0] = first
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


def _shifted(world: np.ndarray, world_rate: np.ndarray | None, point: np.ndarray, v: np.ndarray | None):
    r"""A point's Jacobian (S, 6, n) and, with ``world_rate`` and v, its rate (LOCAL_WORLD_ALIGNED) from the
    world-frame :math:`J_O`, :math:`\dot J_O` of the columns that move it; both overwritten (the caller's own).

    :math:`J = J_v + J_\omega\times p`; its rate along v is
    :math:`\dot J_v + \dot J_\omega\times p + J_\omega\times\dot p`, :math:`\dot p = J_{lin} v`.
    """
    jacobian = world
    angular = world[:, 3:].copy()
    jacobian[:, :3] += stacked_cross(angular, point[:, :, None])
    if world_rate is None:
        return jacobian, None
    rate = world_rate
    point_velocity = (jacobian[:, :3] * v[:, None, :]).sum(axis=2)
    rate[:, :3] += stacked_cross(rate[:, 3:], point[:, :, None]) + stacked_cross(angular, point_velocity[:, :, None])
    return jacobian, rate


def point_kinematics(joints: JointKinematics, columns: np.ndarray, point: np.ndarray, v: np.ndarray | None = None):
    r"""The Jacobian (S, 6, n) of points moving with one body, and with v its rate :math:`\dot J` (S, 6, n) along
    v, in LOCAL_WORLD_ALIGNED (linear rows first), from every joint's kinematics.

    ``columns``: (n,) ones at the velocity indices of the joints that move the body (its parent joint's support,
    :meth:`RobotForest.support_columns`), zeros elsewhere; ``point``: (S, 3) the points [m]. What
    ``pin.getFrameJacobian`` and ``getFrameJacobianTimeVariation`` give for a frame at the point, row by row
    (tests/test_robot_copies.py holds them to it); new arrays.
    """
    world = joints.jacobian * columns
    world_rate = None if v is None or joints.rate is None else joints.rate * columns
    if v is not None and world_rate is None:
        raise ValueError("a point's Jacobian rate needs joint kinematics taken with the joint velocities")
    return _shifted(world, world_rate, point, v)


def point_products(
    joints: JointKinematics, columns: np.ndarray, point: np.ndarray, vectors: np.ndarray,
    rate_vectors: np.ndarray | None = None, point_velocity: np.ndarray | None = None,
):  # fmt: skip
    r""":func:`point_kinematics`' J and :math:`\dot J` applied to vectors, without forming them: (S, 6, k) each.

    :math:`JX = J_OX + (J_{O,\omega}X)\times p` (linear rows) for ``vectors`` X (S, n, k); with ``rate_vectors``
    Y (S, n, k') and the point's velocity :math:`\dot p = J_{lin}v` (S, 3) along the joint velocities v the
    joints were taken with, :math:`\dot JY = \dot J_OY + (\dot J_{O,\omega}Y)\times p + (J_{O,\omega}Y)\times\dot p`
    (else None): the same shift as :func:`point_kinematics`, on k vectors instead of n columns (the tests hold the
    two to each other), each cross product with p as the product :math:`a\times p = -[p]_\times a` (one product of
    stacks where ``stacked_cross`` takes a dozen broadcast operations on these shapes)."""
    world = joints.jacobian @ (columns[:, None] * vectors)
    point_cross = _cross_matrices(point)
    world[:, :3] -= point_cross @ world[:, 3:]
    if rate_vectors is None:
        return world, None
    if joints.rate is None:
        raise ValueError("a point's Jacobian rate needs joint kinematics taken with the joint velocities")
    moving = columns[:, None] * rate_vectors
    rate = joints.rate @ moving
    angular = joints.jacobian[:, 3:] @ moving
    rate[:, :3] -= point_cross @ rate[:, 3:] + _cross_matrices(point_velocity) @ angular
    return world, rate


def _cross_matrices(vectors: np.ndarray) -> np.ndarray:
    r"""The cross-product matrices :math:`[p]_\times` (S, 3, 3) of (S, 3) vectors: :math:`[p]_\times a = p\times a`."""
    matrices = np.zeros((vectors.shape[0], 3, 3))
    matrices[:, 0, 1], matrices[:, 0, 2], matrices[:, 1, 2] = -vectors[:, 2], vectors[:, 1], -vectors[:, 0]
    matrices[:, 1, 0], matrices[:, 2, 0], matrices[:, 2, 1] = vectors[:, 2], -vectors[:, 1], vectors[:, 0]
    return matrices


def _shifted_batch_last(world: np.ndarray, point: np.ndarray, v: np.ndarray | None):
    r""":func:`_shifted` batch-last: a point's Jacobian (6, n, S) and, with v, its rate (6, n, S) from ``world``
    (6 or 12, n, S), :math:`J_O` above :math:`\dot J_O` (overwritten, the caller's own); ``point`` (3, S) [m].
    The same products in the same order as :func:`_shifted` (bit for bit), with the rows in numpy's inner loops."""
    jacobian = world[:6]
    angular = jacobian[3:]
    jacobian[:3] += cross_along(angular, point[:, None], 0)  # J = J_v + J_ω × p
    if v is None:
        return jacobian, None
    rate = world[6:]
    point_velocity = np.einsum("rjb,jb->rb", jacobian[:3], np.ascontiguousarray(v.T))  # ṗ = J_lin v, (3, S)
    # J̇ = J̇_v + J̇_ω × p + J_ω × ṗ
    rate[:3] += cross_along(rate[3:], point[:, None], 0) + cross_along(angular, point_velocity[:, None], 0)
    return jacobian, rate


def _at_point_batch_last(world: np.ndarray, point: np.ndarray, v: np.ndarray):
    r"""A point's Jacobian (6, n, S) and classical drift :math:`\dot J\dot q` (6, S) in LOCAL_WORLD_ALIGNED, linear
    rows first, batch-last, from the world-frame quantities of the body that carries it.

    ``world`` (12, n, S): :math:`J_O` (rows 0-5), which maps :math:`\dot q` to the body's spatial velocity
    :math:`(v_O, \omega)` at the world origin, above :math:`\dot J_O` (rows 6-11); overwritten, its first six rows
    become the point's Jacobian. ``point`` (3, S) [m], ``v`` (S, n) the joint velocities. One product of the twelve
    rows with :math:`\dot q` gives :math:`(v_O, \omega)` and the acceleration at zero :math:`\ddot q`,
    :math:`(\dot v_O, \dot\omega)`. The point p moves at :math:`v_p = v_O + \omega\times p`, so its Jacobian's
    linear rows are :math:`J_v + J_\omega\times p`, and at zero :math:`\ddot q` it accelerates at
    :math:`\dot v_O + \dot\omega\times p + \omega\times v_p`.
    """
    velocities = np.einsum("rjb,jb->rb", world, np.ascontiguousarray(v.T))  # (v_O, ω, v̇_O, ω̇), (12, S)
    jacobian = world[:6]
    jacobian[:3] += cross_along(jacobian[3:], point[:, None], 0)
    angular_velocity, angular_acceleration = velocities[3:6], velocities[9:]
    point_velocity = velocities[:3] + cross_along(angular_velocity, point, 0)
    drift = velocities[6:]
    drift[:3] += cross_along(angular_acceleration, point, 0)
    drift[:3] += cross_along(angular_velocity, point_velocity, 0)
    return jacobian, drift
