"""Options shared by the subcommands; the parsers of option text are those of :mod:`torqueopt.checks`."""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from ..checks import parse_count, parse_number, parse_positive, parse_vector, parse_whole
from ..loading import load_robot
from ..progress import said_if_slow
from ..robot import DEFAULT_JOINT_DYNAMICS, JOINT_DYNAMICS, TASK_DIMENSIONS, Robot

__all__ = [
    "add_joint_dynamics_option",
    "add_robot_options",
    "add_start_options",
    "robot_from_args",
    "start_from_args",
    "parse_vector",
    "parse_number",
    "parse_positive",
    "parse_count",
    "parse_whole",
    "importable_from_here",
]


def add_start_options(group: argparse._ArgumentGroup) -> None:
    """``--q0`` and ``--degrees``: the start configuration of a movement, the start of the movement the command runs."""
    group.add_argument(
        "--q0",
        metavar="ANGLES",
        help="start configuration, one value per joint [rad] (default: the robot's SRDF or neutral configuration)",
    )
    group.add_argument("--degrees", action="store_true", help="read --q0 in degrees")


def start_from_args(args: argparse.Namespace, robot: Robot) -> np.ndarray:
    """The start configuration ``--q0`` and ``--degrees`` give (one value per joint), else the robot's default."""
    if args.q0 is None:
        return robot.default_configuration
    angles = parse_vector(args.q0, "q0", robot.nv)
    return robot.configuration(np.radians(angles) if args.degrees else angles)


def add_joint_dynamics_option(group) -> None:
    """``--joint-dynamics urdf|off``: model the URDF's joint damping and friction (controller and plant), or not."""
    group.add_argument(
        "--joint-dynamics",
        choices=JOINT_DYNAMICS,
        default=None,
        help="urdf: model the URDF's joint damping and friction (<dynamics damping friction>) in the controller's "
        "bias torque and in the plant (Pinocchio or MuJoCo); off: in neither "
        f"(default {DEFAULT_JOINT_DYNAMICS})",
    )


def add_robot_options(parser: argparse.ArgumentParser, required: bool = True, joint_dynamics: bool = False) -> None:
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
    if joint_dynamics:
        add_joint_dynamics_option(group)
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
    with said_if_slow(f"torqueopt {args.command}: loading robot '{args.robot}'"):
        return load_robot(
            args.robot,
            frame=args.frame,
            task=args.task,
            torque_limit=torque_limit,
            gravity=args.gravity,
            lock=lock,
            joint_dynamics=getattr(args, "joint_dynamics", None),
        )


def importable_from_here(spec: str) -> None:
    """Let a ``module:Class`` spec import from the working directory, as ``python -m`` would.

    The ``torqueopt`` script's own directory, not the working directory, heads ``sys.path``; a user who gives
    ``--resolver mymodule:MyResolver`` beside ``mymodule.py`` means the file in front of them (uvicorn and
    gunicorn read an ``app:module`` the same way). Added before any Dask worker starts, so the workers, forked
    with this ``sys.path``, import it too.
    """
    if ":" in str(spec).split("[", 1)[0] and os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())
