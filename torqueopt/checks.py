"""Checks of values that enter torqueopt, with messages that name the value and what would be valid.

The one set of validators: the Python API, the CLI and every module use
these. Values from the API (:func:`positive_number`, :func:`finite_vector`,
...) are named ``name=value``; text from the command line
(:func:`parse_vector`, :func:`parse_positive`, :func:`parse_count`) is named
by its option, ``--name: text``. Each rule (positive and finite, finite,
whole) is written once and shared by both forms.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidInput

__all__ = [
    "configuration_vector",
    "finite_values",
    "finite_vector",
    "non_negative_number",
    "parse_count",
    "parse_positive",
    "parse_vector",
    "positive_number",
    "bounded_count",
    "step_count",
    "show_number",
    "count_values",
    "task_ranks",
    "check_task_rank",
]

#: Random configurations at which :func:`check_task_rank` looks for a full-rank task Jacobian.
RANK_SAMPLES = 8


def _positive_finite(number: float) -> bool:
    return math.isfinite(number) and number > 0


def _whole_count(number: float) -> bool:
    return math.isfinite(number) and number >= 1 and number == int(number)


def positive_number(value, name: str, unit: str | None = None, hint: str | None = None) -> float:
    """``value`` as a float, or InvalidInput unless it is a finite number > 0.

    Args:
        name: how the message names the value (``dt``, ``limit_factor``).
        unit: appended as `` [unit]``.
        hint: appended as `` (hint)``, e.g. "a multiple, such as 2".
    """
    suffix = (f" [{unit}]" if unit else "") + (f" ({hint})" if hint else "")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}={show_number(value)} is not a number{suffix}") from None
    if not _positive_finite(number):
        raise InvalidInput(f"{name}={show_number(value)} must be a positive finite number{suffix}")
    return number


def non_negative_number(value, name: str, unit: str | None = None) -> float:
    """``value`` as a float, or InvalidInput unless it is a finite number >= 0 (a gain, a clearance)."""
    suffix = f" [{unit}]" if unit else ""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}={show_number(value)} is not a number{suffix}") from None
    if not (math.isfinite(number) and number >= 0):
        raise InvalidInput(f"{name}={show_number(value)} must be a finite number >= 0{suffix}")
    return number


def finite_values(values, name: str) -> tuple[float, ...]:
    """One or more finite numbers as a tuple of floats (any count), or InvalidInput naming ``name``."""
    try:
        array = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a list of numbers") from None
    if not array.size or not np.isfinite(array).all():
        raise InvalidInput(f"{name} {array.tolist()} must be finite numbers")
    return tuple(array.tolist())


def finite_vector(values, size: int, name: str, names=None) -> np.ndarray:
    """A float vector of ``size`` finite entries, or InvalidInput naming ``name`` (and the joints ``names``)."""
    try:
        vector = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a vector of numbers") from None
    if vector.size != size:
        joints = f" (joints {', '.join(names)})" if names else ""
        raise InvalidInput(f"{name} has {count_values(vector.size)} but needs {size}{joints}")
    if not np.isfinite(vector).all():
        raise InvalidInput(f"{name} {vector.tolist()} has a non-finite value; all {size} values must be finite")
    return vector


def configuration_vector(robot, values, name: str = "q0") -> np.ndarray:
    """A configuration vector of ``robot`` from either its nq configuration values or one angle per joint [rad]."""
    try:
        array = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a vector of numbers") from None
    if robot.nq != robot.nv and array.size == robot.nq:
        return finite_vector(array, robot.nq, name)
    return robot.configuration(finite_vector(array, robot.nv, name, names=robot.joint_names))


def parse_vector(text: str, name: str, size: int | None = None, allow_infinite: bool = False) -> np.ndarray:
    """The numbers of option ``--name``, comma-separated (``-0.785,2.356,-2.356``); rejects text, NaN,
    wrong sizes and (unless ``allow_infinite``) inf."""
    values = []
    for part in (part.strip() for part in str(text).split(",")):
        try:
            value = float(part)
        except ValueError:
            raise InvalidInput(f"--{name}: '{part}' is not a number (give comma-separated numbers, e.g. 1,1)") from None
        if math.isnan(value) or (math.isinf(value) and not allow_infinite):
            raise InvalidInput(f"--{name}: '{part}' is not finite; give finite numbers")
        values.append(value)
    if size is not None and len(values) != size:
        raise InvalidInput(f"--{name} has {count_values(len(values))} but needs {size}")
    return np.array(values)


def _parse_number(text: str, name: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InvalidInput(f"--{name}: '{text}' is not a number") from None


def parse_positive(text: str, name: str) -> float:
    """The positive finite number of option ``--name``."""
    value = _parse_number(text, name)
    if not _positive_finite(value):
        raise InvalidInput(f"--{name}: {text} must be a positive finite number")
    return value


def parse_count(text: str, name: str) -> int:
    """The positive whole number of option ``--name``, e.g. ``--max-steps 2000000`` (``2e6`` is accepted too)."""
    value = _parse_number(text, name)
    if not _whole_count(value):
        raise InvalidInput(f"--{name}: {text} must be a positive whole number")
    return int(value)


def show_number(value) -> str:
    """A number as the user gave it: ``-1``, ``-100.0``, ``inf`` (numpy scalars as plain numbers, never ``np.float64(-100.0)``)."""
    if isinstance(value, np.generic):
        value = value.item()
    return repr(value)


def count_values(count: int, noun: str = "value") -> str:
    """``1 value``, ``3 values``."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def bounded_count(
    count: float, limit: int, what: str, noun: str, option: str, remedy: str = "", item_bytes: int | None = None
) -> int:
    """``count`` as an int when it is at most ``limit``, else InvalidInput naming both and how to raise the limit.

    Every piece of work whose size the user controls (simulation steps,
    playback frames, sweep cells) is checked here before it starts, so a
    mistyped ``1e9`` fails at once with one line instead of exhausting memory.

    Args:
        count: the number of items the request needs (a float is fine: huge
            or infinite requests are refused before any int conversion).
        limit: the largest count accepted.
        what: the request, e.g. ``"duration 1e+09 s at dt 0.001 s"``.
        noun: the items, plural, e.g. ``"steps"``.
        option: the option that raises the limit, e.g. ``"--max-steps"`` or ``"max_steps"``.
        remedy: appended as ``"; remedy"``, e.g. "or give a larger dt".
        item_bytes: memory one item takes [bytes]; when given, the message
            says how much memory the request would need.

    Example message: ``duration 1e+09 s at dt 0.001 s needs 1e+12 steps, more
    than the limit of 1,000,000 steps (raise it with --max-steps)``.
    """
    try:
        limit = int(limit)
    except (TypeError, ValueError):
        raise InvalidInput(f"{option}={limit!r} is not a whole number") from None
    if limit < 1:
        raise InvalidInput(f"{option}={limit} must be a positive whole number")
    if not (math.isfinite(count) and count <= limit):
        shown = f"{count:.4g}" if math.isfinite(count) else "infinitely many"
        extra = f"; {remedy}" if remedy else ""
        memory = f" (about {_bytes_text(count * item_bytes)} of memory)" if item_bytes and math.isfinite(count) else ""
        raise InvalidInput(
            f"{what} needs {shown} {noun}{memory}, more than the limit of {limit:,} {noun} "
            f"(raise it with {option}){extra}"
        )
    return int(count)


def step_count(duration: float, dt: float) -> int:
    """The number of steps of length ``dt`` that make up ``duration``, or InvalidInput when dt does not divide it.

    A step that stopped short of the duration, or overshot it, would
    simulate a different movement than the one asked for (the reference
    would be sampled past its end), so a dt that does not divide the
    duration is refused, and the message offers the nearest steps that do.
    Within a relative 1e-9 (the rounding of decimal inputs such as 0.1 or
    0.001) the quotient counts as whole.
    """
    ratio = duration / dt
    if not math.isfinite(ratio):
        raise InvalidInput(f"duration {show_number(duration)} s at dt {show_number(dt)} s needs infinitely many steps")
    steps = round(ratio)
    if steps >= 1 and abs(ratio - steps) <= 1e-9 * max(ratio, 1.0):
        return int(steps)
    lower, upper = max(math.floor(ratio), 1), math.floor(ratio) + 1
    choices = " or ".join(f"{duration / count:.6g} s ({count} steps)" for count in sorted({lower, upper}))
    raise InvalidInput(
        f"dt={dt:g} s does not divide the duration {duration:g} s ({ratio:.4g} steps); "
        f"give a dt that does, such as {choices}"
    )


def _bytes_text(size: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if size < 1000 or unit == "PB":
            return f"{size:.3g} {unit}"
        size /= 1000


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

    from .robot import TASK_DIMENSIONS

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
    from .robot import TASK_DIMENSIONS

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
