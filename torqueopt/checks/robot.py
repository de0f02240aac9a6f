"""Checks that need the robot: one value per joint, a configuration, torque limits, a joint-space weight, a task
and a frame it has, a task its joints can realise.

They read a robot through its attributes (``nv``, ``nq``, ``joint_names``, ``configuration``, ``model``, ...)
and never import :mod:`torqueopt.robot`, which imports them: the task kinds and their dimensions,
:data:`TASK_DIMENSIONS`, are defined here and re-exported there.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import FrameNotFound, InvalidInput, TaskNotFound
from .numbers import count_values, finite_vector

__all__ = [
    "TASK_DIMENSIONS",
    "configuration_vector",
    "joint_vector",
    "velocity_vector",
    "torque_limit_vector",
    "weight_matrix_root",
    "trajectory_dimension",
    "check_task_and_frame",
    "check_task",
    "check_frame",
    "task_ranks",
    "check_task_rank",
    "RANK_SAMPLES",
    "check_rigid_joints",
]

#: The task kinds and their dimension m: planar tip position, 3-D position, position and orientation.
TASK_DIMENSIONS = {"xy": 2, "position": 3, "pose": 6}
#: Random configurations at which :func:`check_task_rank` looks for a full-rank task Jacobian.
RANK_SAMPLES = 8


def configuration_vector(robot, values, name: str = "q0") -> np.ndarray:
    """A configuration vector of ``robot`` from either its nq configuration values or one angle per joint [rad]."""
    try:
        array = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a vector of numbers") from None
    if robot.nq != robot.nv and array.size == robot.nq:
        return finite_vector(array, robot.nq, name)
    return robot.configuration(joint_vector(robot, array, name))


def joint_vector(robot, values, name: str) -> np.ndarray:
    """One finite value per joint of ``robot`` (n values), or InvalidInput naming the joints.

    Example message: ``q0 has 2 values but needs 3 (joints joint1, joint2, joint3)``.
    """
    return finite_vector(values, robot.nv, name, names=robot.joint_names)


def velocity_vector(robot, values, name: str = "v0") -> np.ndarray:
    """A joint velocity vector of ``robot``: n finite values [rad/s] (:func:`~torqueopt.checks.joint_vector`)."""
    return joint_vector(robot, values, name)


def torque_limit_vector(robot, values) -> np.ndarray:
    """Symmetric torque limits of ``robot`` [N·m]: one positive number for every joint or one per joint, ``inf``
    for a joint without a limit; else InvalidInput naming the joints."""
    try:
        limits = np.atleast_1d(np.asarray(values, dtype=float)).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"torque limit {values!r} is not a vector of numbers") from None
    if limits.size == 1:
        limits = np.full(robot.nv, limits.item())
    if limits.size != robot.nv:
        raise InvalidInput(
            f"torque limit has {count_values(limits.size)}; robot '{robot.name}' needs 1 or {robot.nv} "
            f"(joints {', '.join(robot.joint_names)})"
        )
    if np.isnan(limits).any() or (limits <= 0).any():
        raise InvalidInput(f"torque limit {limits.tolist()} must be positive numbers (inf for unbounded)")
    return limits


def trajectory_dimension(robot, trajectory) -> int:
    """The number of position coordinates the robot's task moves the tip in, min(m, 3), or InvalidInput when
    ``trajectory`` moves in another number (a planar path for a 3-D task, say) or carries rotations for a task
    other than ``pose``; a trajectory without a dimension of its own takes this one."""
    linear_dimension = min(robot.m, 3)
    if getattr(trajectory, "oriented", False) and robot.task != "pose":
        raise InvalidInput(
            f"trajectory {type(trajectory).__name__} carries rotations but task '{robot.task}' has no orientation; "
            "give the task pose (--task pose), or a path without orientation columns"
        )
    if trajectory.dimension is not None and trajectory.dimension != linear_dimension:
        raise InvalidInput(
            f"trajectory {type(trajectory).__name__} moves in {trajectory.dimension} dimensions but task "
            f"'{robot.task}' moves the tip in {linear_dimension}"
        )
    return linear_dimension


def task_ranks(robot, samples: int = RANK_SAMPLES, seed: int = 0) -> dict[str, int]:
    """Per task kind, the largest rank of its task Jacobian over ``samples`` seeded random configurations.

    A chain's Jacobian has its generic (structural) rank at almost every
    configuration, so a rank below the task dimension at every one of a few
    random configurations means the task can never be realised: a planar arm
    asked for a 3-D position, or a frame with too few joints above it.
    Angles are drawn uniformly within the joint limits (within ±π where a
    limit is wider or missing), with a numpy generator of fixed seed, so the
    answer never depends on global random state.
    """
    import pinocchio as pin

    generator = np.random.default_rng(seed)
    model = robot.model
    data = model.createData()
    low, high = np.full(robot.nv, -math.pi), np.full(robot.nv, math.pi)
    if robot.nq == robot.nv:
        low = np.maximum(low, np.nan_to_num(np.asarray(model.lowerPositionLimit, float), nan=-math.pi))
        high = np.maximum(
            np.minimum(high, np.nan_to_num(np.asarray(model.upperPositionLimit, float), nan=math.pi)), low
        )
    # Each task's rows are the first m of the world-aligned 6-row Jacobian (linear, then angular).
    ranks = dict.fromkeys(TASK_DIMENSIONS, 0)
    for _ in range(samples):
        q = robot.configuration(generator.uniform(low, high))
        jacobian = pin.computeFrameJacobian(model, data, q, robot.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        for task, size in TASK_DIMENSIONS.items():
            singular_values = np.linalg.svd(jacobian[:size], compute_uv=False)
            if singular_values[0] > 0:
                rank = int((singular_values > 1e-9 * singular_values[0]).sum())
                ranks[task] = max(ranks[task], rank)
    return ranks


def check_task_rank(robot) -> None:
    """InvalidInput when the robot's task Jacobian is rank-deficient everywhere (see :func:`task_ranks`).

    The message names the rank the joints reach and the tasks this frame can
    do; it is an input mistake, found before any simulation.
    """
    if robot.m > robot.nv:
        return  # fewer joints than task coordinates: the resolvers' own check says so
    ranks = task_ranks(robot)
    rank, m = ranks[robot.task], robot.m
    if rank >= m:
        return
    feasible = [task for task, size in TASK_DIMENSIONS.items() if ranks[task] >= size]
    tasks = f"task {' or '.join(feasible)} at this frame" if feasible else "no task at this frame"
    joints = count_values(robot.nv, "joint")
    default = getattr(getattr(robot, "source", None), "frame", None)
    example = f" such as '{default}'" if default and default != robot.frame else ""
    raise InvalidInput(
        f"task '{robot.task}' (m={m}) at frame '{robot.frame}' of robot '{robot.name}' can never be realised: "
        f"its {joints} move the frame in only {rank} independent directions of the task at every one of "
        f"{RANK_SAMPLES} random configurations; valid: {tasks}, or a frame further along the chain{example}"
    )


def weight_matrix_root(weight, n: int, choices: tuple[str, ...] = ()) -> np.ndarray:
    r"""A square root :math:`S` with :math:`S^\top S = W` of a joint-space weight, or InvalidInput.

    ``weight`` is a vector of ``n`` finite non-negative numbers, the
    diagonal of W (the root is then the vector of their square roots), or a
    symmetric positive semi-definite n×n matrix (the root is an n×n matrix).

    Args:
        choices: the names the caller also accepts, listed in the message
            when the shape fits neither form.
    """
    try:
        values = np.asarray(weight, dtype=float)
    except (TypeError, ValueError):
        named = "a name, " if choices else ""
        raise InvalidInput(f"weight {weight!r} is not {named}a vector or a matrix of numbers") from None
    if values.shape == (n,):
        if not np.isfinite(values).all() or (values < 0).any():
            raise InvalidInput(f"weight {values.tolist()} must be {n} finite non-negative numbers")
        return np.sqrt(values)
    if values.shape != (n, n) or not np.isfinite(values).all() or not np.allclose(values, values.T):
        forms = f"{', '.join(choices)}, {n} values" if choices else f"a vector of {n} values"
        raise InvalidInput(f"weight must be {forms} or a symmetric {n}x{n} matrix, got shape {values.shape}")
    eigenvalues, eigenvectors = np.linalg.eigh(values)
    if eigenvalues.min() < -1e-12 * max(1.0, eigenvalues.max()):
        raise InvalidInput(
            f"weight matrix must be positive semi-definite; its smallest eigenvalue is {eigenvalues.min():.3g}"
        )
    return (eigenvectors * np.sqrt(np.clip(eigenvalues, 0.0, None))).T


def check_task_and_frame(model, frame: str, task: str, robot_name: str) -> None:
    """TaskNotFound or FrameNotFound, naming the valid choices, unless ``task`` is known and ``model`` has ``frame``."""
    check_task(task)
    check_frame(model, frame, robot_name)


def check_task(task: str, what: str = "task") -> None:
    """TaskNotFound naming the task kinds (``xy``, ``position``, ``pose``) unless ``task`` is one of them."""
    if task not in TASK_DIMENSIONS:
        raise TaskNotFound(f"unknown {what} '{task}': choose one of {', '.join(TASK_DIMENSIONS)}")


def check_frame(model, frame: str, robot_name: str) -> None:
    """FrameNotFound unless the Pinocchio ``model`` has ``frame``; the message lists (the last 12 of) its body frames."""
    if model.existFrame(frame):
        return
    import pinocchio as pin

    names = [f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
    shown = ("..., " if len(names) > 12 else "") + ", ".join(names[-12:])
    raise FrameNotFound(f"robot '{robot_name}' has no frame '{frame}': choose one of {shown}")


def check_rigid_joints(robot) -> None:
    """Refuse a robot that models its URDF's joint damping and friction: the whole-movement problem's dynamics
    (τ by RNEA) have neither, so its optimum would not be the motion the robot makes."""
    if robot.models_joint_dynamics:
        raise InvalidInput(
            f"robot '{robot.name}' models its URDF's joint damping and friction (joint_dynamics='urdf', "
            "--joint-dynamics urdf); the whole-movement optimum's dynamics have neither: load it with "
            "joint_dynamics='off' (--joint-dynamics off)"
        )
