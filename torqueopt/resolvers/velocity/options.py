"""Converters for the options of the velocity-level resolvers (API values or the CLI's text), on the rules of
:mod:`torqueopt.checks`."""

from __future__ import annotations

import numpy as np

from ...checks import Refused, finite_array
from ...tasks import FrameTask, ObstacleTask, PostureTask, Task, TaskStack
from ..options import label_value

__all__ = ["vector_or_callable", "task_stack", "obstacle", "criterion_spec"]


def _vector(value) -> np.ndarray:
    return finite_array(value, "a vector", example="0,0.1,0").reshape(-1)


def vector_or_callable(value):
    """A callable as it is, else a vector of finite numbers (comma-separated on the CLI)."""
    if callable(value):
        return value
    if not isinstance(value, str):
        try:
            np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise Refused("is neither a vector of numbers nor a callable") from None
    return _vector(value)


def task_stack(value) -> TaskStack:
    """A TaskStack from a Task, a sequence of Tasks, or the CLI's ``FRAME:x,y[,z]`` (an xy or position target)."""
    if isinstance(value, str) and value.strip() == "posture":
        return TaskStack([PostureTask()])
    if isinstance(value, str):
        items = []
        for spec in value.split(";"):
            frame, separator, numbers = spec.partition(":")
            if not separator or not frame.strip():
                raise Refused("must be FRAME:x,y (xy target) or FRAME:x,y,z (position target), ';' between tasks")
            target = _vector(numbers)
            if target.size not in (2, 3):
                raise Refused(f"target of frame '{frame.strip()}' must have 2 (xy) or 3 (position) values")
            items.append(FrameTask(frame.strip(), "xy" if target.size == 2 else "position", target=target))
        return TaskStack(items)
    if isinstance(value, (Task, TaskStack)) or (
        isinstance(value, (list, tuple)) and value and all(isinstance(item, Task) for item in value)
    ):
        return TaskStack.of(value)
    raise Refused("must be a Task with a target, a TaskStack, a list of Tasks, or FRAME:x,y")


def obstacle(value) -> ObstacleTask:
    """An ObstacleTask, or numbers x,y | x,y,z | x,y,z,radius [m]."""
    if isinstance(value, ObstacleTask):
        return value
    numbers = _vector(value)
    if numbers.size not in (2, 3, 4):
        raise Refused("must be an ObstacleTask or 2-4 numbers: x,y[,z[,radius]] [m]")
    return ObstacleTask.from_spec(numbers)


def obstacle_text(value: ObstacleTask) -> str:
    """The obstacle as :func:`obstacle` reads it back, x,y,z,radius [m]; its repr where the numbers cannot say it
    (a speed or an end frame of its own, set on the object)."""
    text = label_value([*value.center, value.radius])
    fresh = ObstacleTask.from_spec(_vector(text))
    return text if (fresh.speed, fresh.frame) == (value.speed, value.frame) else repr(value)


def criterion_spec(value):
    """A criterion name, a Criterion object, or a callable p(joint_angles)."""
    from .criteria import CRITERIA, Criterion

    if isinstance(value, str):
        if value.strip() not in CRITERIA:
            raise Refused(f"must be one of {', '.join(CRITERIA)}, a Criterion or a callable p(joint_angles)")
        return value.strip()
    if isinstance(value, Criterion) or callable(value):
        return value
    raise Refused(f"must be one of {', '.join(CRITERIA)}, a Criterion or a callable p(joint_angles)")
