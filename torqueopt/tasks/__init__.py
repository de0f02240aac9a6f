"""Task objects: a frame task, a stack of prioritised tasks, the arm's closest point to an obstacle.

As pink's ``pink.tasks``: one concept per module behind the small base
class :class:`Task`, all reading one :class:`Kinematics` per configuration.
"""

from .frame_task import FRAME_TASK_KINDS, FrameTask
from .obstacle import ClosestPoint, ObstacleTask
from .posture_task import PostureTask
from .stack import (
    PriorityLevel,
    TaskStack,
    prioritised_accelerations,
    prioritised_rates,
    priority_levels,
    pseudoinverse,
    pseudoinverse_rate,
    pseudoinverse_workspace,
    rates_through,
    stacked_undamped_pseudoinverse,
    undamped_pseudoinverse,
)
from .task import Kinematics, PerConfiguration, Task

__all__ = [
    "Task",
    "Kinematics",
    "PerConfiguration",
    "FrameTask",
    "FRAME_TASK_KINDS",
    "PostureTask",
    "TaskStack",
    "prioritised_rates",
    "PriorityLevel",
    "priority_levels",
    "rates_through",
    "prioritised_accelerations",
    "pseudoinverse",
    "undamped_pseudoinverse",
    "stacked_undamped_pseudoinverse",
    "pseudoinverse_workspace",
    "pseudoinverse_rate",
    "ObstacleTask",
    "ClosestPoint",
]
