"""``torqueopt robots``: the robot names ``--robot`` accepts."""

from __future__ import annotations

import argparse

from ..catalog import available_robots, example_robot_data_dir, find_robot
from . import EXIT_OK

__all__ = ["add_parser"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "robots",
        help="list the robot names --robot accepts",
        description=(
            "List the robots known by name: the URDFs in torqueopt's robots/ folder and those installed by "
            "example-robot-data, with the task frame and task used when none is given. Any URDF path works too."
        ),
    )
    parser.set_defaults(handler=robots_command)


def robots_command(args: argparse.Namespace) -> int:
    print(f"{'name':<28}{'default frame':<28}{'task':<10}urdf")
    for name in available_robots():
        source = find_robot(name)
        frame = source.frame or "(give --frame)"
        print(f"{name:<28}{frame:<28}{source.task or 'position':<10}{source.urdf}")
    if example_robot_data_dir() is None:
        print("example-robot-data is not installed: pip install example-robot-data")
    return EXIT_OK
