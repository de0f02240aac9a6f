"""Options and parsing shared by the subcommands."""

from __future__ import annotations

import argparse
import math

import numpy as np

from ..checks import count_values
from ..errors import InvalidInput
from ..robot import TASK_DIMENSIONS, Robot, load_robot

__all__ = ["add_robot_options", "robot_from_args", "parse_vector", "parse_positive", "parse_count"]


def parse_vector(text: str, name: str, size: int | None = None, allow_infinite: bool = False) -> np.ndarray:
    """Comma-separated numbers, e.g. ``-0.785,2.356,-2.356``; rejects text, NaN, wrong sizes and (unless
    ``allow_infinite``) inf."""
    parts = [part.strip() for part in str(text).split(",")]
    values = []
    for part in parts:
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


def parse_positive(text: str, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InvalidInput(f"--{name}: '{text}' is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise InvalidInput(f"--{name}: {text} must be a positive finite number")
    return value


def parse_count(text: str, name: str) -> int:
    """A positive whole number, e.g. ``--max-steps 2000000`` (``2e6`` is accepted too)."""
    try:
        value = float(text)
    except ValueError:
        raise InvalidInput(f"--{name}: '{text}' is not a number") from None
    if not (math.isfinite(value) and value >= 1 and value == int(value)):
        raise InvalidInput(f"--{name}: {text} must be a positive whole number")
    return int(value)


def add_robot_options(parser: argparse.ArgumentParser, required: bool = True) -> None:
    group = parser.add_argument_group("robot")
    group.add_argument(
        "--robot",
        required=required,
        help="URDF path, 'planar3' (the paper's arm) or an example-robot-data arm: panda, xarm7, baxter, tiago, ...",
    )
    group.add_argument("--frame", help="task frame (default: the robot's end effector, 'tip' for planar3)")
    group.add_argument(
        "--task",
        help=f"task: {', '.join(f'{k} (m={v})' for k, v in TASK_DIMENSIONS.items())}; "
        "default xy for planar3, position otherwise",
    )
    group.add_argument(
        "--torque-limit",
        metavar="TAU",
        help="symmetric torque limits [N·m], one value for all joints or one per joint, inf for unbounded "
        "(default: URDF effort limits)",
    )
    group.add_argument(
        "--gravity",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="gravity along −z at 9.81 m/s² (default: off for planar3, as in the paper; on otherwise)",
    )
    group.add_argument(
        "--lock",
        metavar="JOINTS",
        help="comma-separated joints of the task chain to lock at their reference value "
        "(joints outside the chain are always locked)",
    )


def robot_from_args(args: argparse.Namespace) -> Robot:
    torque_limit = (
        None if args.torque_limit is None else parse_vector(args.torque_limit, "torque-limit", allow_infinite=True)
    )
    lock = [name.strip() for name in args.lock.split(",") if name.strip()] if args.lock else []
    return load_robot(
        args.robot,
        frame=args.frame,
        task=args.task,
        torque_limit=torque_limit,
        gravity=args.gravity,
        lock=lock,
    )
