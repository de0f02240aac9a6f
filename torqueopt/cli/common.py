"""Options shared by the subcommands; the parsers of option text are those of :mod:`torqueopt.checks`."""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from ..checks import parse_count, parse_number, parse_positive, parse_vector, parse_whole
from ..errors import InvalidInput
from ..loading import load_robot
from ..payload import Payload
from ..progress import said_if_slow
from ..robot import DEFAULT_JOINT_DYNAMICS, JOINT_DYNAMICS, TASK_DIMENSIONS, Robot

__all__ = [
    "add_gravity_and_payload_options",
    "add_joint_dynamics_option",
    "add_robot_options",
    "add_start_options",
    "robot_from_args",
    "start_from_args",
    "start_velocity_from_args",
    "gravity_from_args",
    "payload_from_args",
    "parse_vector",
    "parse_number",
    "parse_positive",
    "parse_count",
    "parse_whole",
    "importable_from_here",
    "in_radians",
    "torque_table",
]


def add_start_options(group: argparse._ArgumentGroup, velocity: bool = False) -> None:
    """``--q0`` and ``--degrees`` (and with ``velocity``, ``--v0``): the start of the movement the command runs."""
    group.add_argument(
        "--q0",
        metavar="ANGLES",
        help="start configuration, one value per joint [rad; m for a prismatic joint] (default: the robot's SRDF or neutral "
        "configuration)",
    )
    if velocity:
        group.add_argument(
            "--v0",
            metavar="RATES",
            help="start joint velocities, one value per joint [rad/s; m/s for a prismatic joint] (default: at rest)",
        )
    group.add_argument(
        "--degrees",
        action="store_true",
        help="read --q0 in degrees"
        + (" and --v0 in degrees per second" if velocity else "")
        + " (its revolute joints; prismatic ones stay in m"
        + (", m/s" if velocity else "")
        + ")",
    )


def start_from_args(args: argparse.Namespace, robot: Robot) -> np.ndarray:
    """The start configuration ``--q0`` and ``--degrees`` give (one value per joint), else the robot's default."""
    if args.q0 is None:
        return robot.default_configuration
    angles = parse_vector(args.q0, "q0", robot.nv)
    return robot.configuration(in_radians(angles, robot) if args.degrees else angles)


def in_radians(values: np.ndarray, robot: Robot) -> np.ndarray:
    """``--degrees``: the revolute and continuous joints' values from degrees to radians; a prismatic joint's value
    is a length [m] (or m/s) and stays as given."""
    rotational = np.array([kind != "prismatic" for kind in robot.joint_kinds])
    return np.where(rotational, np.radians(values), values)


def start_velocity_from_args(args: argparse.Namespace, robot: Robot) -> np.ndarray | None:
    """The start joint velocities ``--v0`` and ``--degrees`` give (one value per joint), read as ``--q0`` is; else None (at rest)."""
    if args.v0 is None:
        return None
    rates = parse_vector(args.v0, "v0", robot.nv)
    return in_radians(rates, robot) if args.degrees else rates


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


def add_gravity_and_payload_options(group) -> None:
    """``--gravity [X,Y,Z]``, ``--no-gravity`` and ``--payload``: what :func:`gravity_from_args` and
    :func:`payload_from_args` read."""
    group.add_argument(
        "--gravity",
        nargs="?",
        const=True,
        default=None,
        metavar="X,Y,Z",
        help="gravity: alone, along −z at 9.81 m/s²; with a vector, that vector in world axes [m/s²], e.g. "
        "--gravity=-9.81,0,0 for an arm on a wall (default: off for planar3, as in the paper; on otherwise)",
    )
    group.add_argument("--no-gravity", dest="gravity", action="store_const", const=False, help="no gravity")
    group.add_argument(
        "--payload",
        metavar="MASS[,X,Y,Z[,IXX,IYY,IZZ]]",
        help="a load fixed to the task frame: its mass [kg], its centre of mass in the task frame [m] (default at "
        "the frame's origin) and its principal moments of inertia about it along the frame's axes [kg·m²] "
        "(default 0: a point mass)",
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
    add_gravity_and_payload_options(group)
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
            gravity=gravity_from_args(args),
            lock=lock,
            payload=payload_from_args(args),
            joint_dynamics=getattr(args, "joint_dynamics", None),
        )


def gravity_from_args(args: argparse.Namespace):
    """``--gravity`` alone (True), ``--no-gravity`` (False), ``--gravity X,Y,Z`` (the vector [m/s²]) or None (the robot's default)."""
    if args.gravity is None or isinstance(args.gravity, bool):
        return args.gravity
    text = args.gravity
    if len(text.split(",")) != 3:
        raise InvalidInput(
            f"--gravity {text}: give three numbers X,Y,Z [m/s²] in world axes (e.g. --gravity=0,0,-9.81), or "
            "--gravity alone for 9.81 m/s² along −z"
        )
    return parse_vector(text, "gravity", 3)


#: How many numbers ``--payload`` takes, and what they are.
_PAYLOAD_FORMS = {1: "MASS", 4: "MASS,X,Y,Z", 7: "MASS,X,Y,Z,IXX,IYY,IZZ"}


def payload_from_args(args: argparse.Namespace) -> Payload | None:
    """The :class:`~torqueopt.Payload` ``--payload MASS[,X,Y,Z[,IXX,IYY,IZZ]]`` gives, else None."""
    if args.payload is None:
        return None
    values = parse_vector(args.payload, "payload")
    if len(values) not in _PAYLOAD_FORMS:
        raise InvalidInput(
            f"--payload {args.payload} has {len(values)} values; give {', '.join(_PAYLOAD_FORMS.values())} "
            "(kg, m in the task frame, kg·m²)"
        )
    mass, position, inertia = values[0], values[1:4], values[4:7]
    return Payload(mass, position if position.size else (0.0, 0.0, 0.0), inertia if inertia.size else (0.0, 0.0, 0.0))


def importable_from_here(spec: str) -> None:
    """Let a ``module:Class`` spec import from the working directory, as ``python -m`` would.

    The ``torqueopt`` script's own directory, not the working directory, heads ``sys.path``; a user who gives
    ``--resolver mymodule:MyResolver`` beside ``mymodule.py`` means the file in front of them (uvicorn and
    gunicorn read an ``app:module`` the same way). Added before any Dask worker starts, so the workers, forked
    with this ``sys.path``, import it too.
    """
    if ":" in str(spec).split("[", 1)[0] and os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())


def torque_table(names, peaks, limits, ratios, units) -> list[str]:
    """The peak-torque table, its columns as wide as their widest cell (at least the usual 24, 18, 14, 12
    characters) and two spaces apart, so a runaway torque of 1e9 N·m never runs into its limit. ``units``: per
    joint, N·m or N; one unit goes in the titles, a mixed arm (a prismatic joint among revolute ones) has it in
    every cell."""
    shared = units[0] if len(set(units)) == 1 else None
    suffix = [("" if shared else f" {unit}") for unit in units]
    cells = [
        (
            str(name),
            f"{peak:.3f}{unit}",
            f"{limit:.3f}{unit}" if np.isfinite(limit) else "none",
            f"{ratio:.3f}" if np.isfinite(limit) else "-",
            "  OVER" if ratio > 1.0 else "",
        )
        for name, peak, limit, ratio, unit in zip(names, peaks, limits, ratios, suffix)
    ]
    brackets = f" [{shared}]" if shared else ""
    titles = ("joint", f"peak |tau|{brackets}", f"limit{brackets}", "peak/limit")
    widths = [max([24, *(len(row[0]) + 2 for row in cells)])]
    for column, usual in zip((1, 2, 3), (18, 14, 12)):
        widths.append(max([usual, *(len(row[column]) + 2 for row in cells)]))
    lines = [f"{titles[0]:<{widths[0]}}" + "".join(f"{title:>{width}}" for title, width in zip(titles[1:], widths[1:]))]
    for row in cells:
        lines.append(
            f"{row[0]:<{widths[0]}}" + "".join(f"{cell:>{width}}" for cell, width in zip(row[1:4], widths[1:])) + row[4]
        )
    return lines
