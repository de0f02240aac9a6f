"""Settings shared by the subcommands (the arm, the start), declared once as :class:`~torqueopt.settings.Settings`
groups; the parsers of option text are those of :mod:`torqueopt.checks`."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass

import numpy as np

from ..checks import parse_vector
from ..checks.numbers import count_values
from ..errors import InvalidInput
from ..payload import Payload
from ..progress import said_if_slow
from ..robot import DEFAULT_JOINT_DYNAMICS, JOINT_DYNAMICS, TASK_DIMENSIONS, Robot
from ..settings import Settings, numbers, setting
from ..units import joint_unit

__all__ = [
    "RobotModelSettings",
    "RobotSettings",
    "OptionalRobotSettings",
    "StartSettings",
    "RestStartSettings",
    "parse_gravity",
    "parse_payload",
    "sized",
    "importable_from_here",
    "in_radians",
    "torque_table",
]


def parse_gravity(text: str, name: str = "gravity") -> tuple[float, float, float]:
    """``--gravity X,Y,Z``: the vector [m/s²] in world axes."""
    if len(text.split(",")) != 3:
        raise InvalidInput(
            f"--gravity {text}: give three numbers X,Y,Z [m/s²] in world axes (e.g. --gravity=0,0,-9.81), or "
            "--gravity alone for 9.81 m/s² along −z"
        )
    return tuple(parse_vector(text, name, 3).tolist())


#: How many numbers ``--payload`` takes, and what they are.
_PAYLOAD_FORMS = {1: "MASS", 4: "MASS,X,Y,Z", 7: "MASS,X,Y,Z,IXX,IYY,IZZ"}


def parse_payload(text: str, name: str = "payload") -> Payload:
    """``--payload MASS[,X,Y,Z[,IXX,IYY,IZZ]]``: the load (its centre and moments 0 when not given)."""
    values = parse_vector(text, name)
    if len(values) not in _PAYLOAD_FORMS:
        raise InvalidInput(
            f"--payload {text} has {len(values)} values; give {', '.join(_PAYLOAD_FORMS.values())} "
            "(kg, m in the task frame, kg·m²)"
        )
    mass, position, inertia = values[0], values[1:4], values[4:7]
    return Payload(mass, position if position.size else (0.0, 0.0, 0.0), inertia if inertia.size else (0.0, 0.0, 0.0))


def _joint_names(text: str, name: str) -> tuple[str, ...]:
    return tuple(joint.strip() for joint in text.split(",") if joint.strip())


_ROBOT_HELP = "URDF path, 'planar3' (the paper's arm) or an example-robot-data arm: panda, xarm7, baxter, tiago, ..."


@dataclass(frozen=True)
class RobotModelSettings(Settings):
    """The arm and its model, as :func:`torqueopt.load_robot` and the atlas's
    :class:`~torqueopt.atlas.jobs.RobotSpec` take them (:meth:`load`, :meth:`spec`)."""

    robot: str | None = setting(None, _ROBOT_HELP, cli_required=True)
    frame: str | None = setting(None, "task frame (default: the robot's end effector, 'tip' for planar3)")
    task: str | None = setting(
        None,
        lambda: (
            f"task: {', '.join(f'{k} (m={v})' for k, v in TASK_DIMENSIONS.items())}; "
            "default xy for planar3, position otherwise"
        ),
    )
    torque_limit: tuple[float, ...] | None = setting(
        None,
        "symmetric torque limits [N·m], one value for all joints or one per joint, inf for unbounded "
        "(default: URDF effort limits)",
        unit="N·m",
        metavar="TAU",
        parse=numbers(allow_infinite=True),
    )
    gravity: bool | tuple[float, float, float] | None = setting(
        None,
        "gravity: alone, along −z at 9.81 m/s²; with a vector, that vector in world axes [m/s²], e.g. "
        "--gravity=-9.81,0,0 for an arm on a wall (default: off for planar3, as in the paper; on otherwise)",
        unit="m/s²",
        metavar="X,Y,Z",
        parse=parse_gravity,
        const=True,
        negation=("--no-gravity", "no gravity"),
    )
    payload: Payload | None = setting(
        None,
        "a load fixed to the task frame: its mass [kg], its centre of mass in the task frame [m] (default at "
        "the frame's origin) and its principal moments of inertia about it along the frame's axes [kg·m²] "
        "(default 0: a point mass)",
        metavar="MASS[,X,Y,Z[,IXX,IYY,IZZ]]",
        parse=parse_payload,
    )
    joint_dynamics: str | None = setting(
        None,
        "urdf: model the URDF's joint damping and friction (<dynamics damping friction>) in the controller's "
        "bias torque and in the plant (Pinocchio or MuJoCo); off: in neither "
        f"(default {DEFAULT_JOINT_DYNAMICS})",
        choices=JOINT_DYNAMICS,
    )

    def spec(self):
        """The :class:`~torqueopt.atlas.jobs.RobotSpec` of these settings (the atlas's and tune's robot)."""
        from ..atlas.jobs import RobotSpec

        return RobotSpec(
            self.robot,
            frame=self.frame,
            task=self.task,
            torque_limit=self.torque_limit,
            gravity=self.gravity,
            payload=self.payload,
            joint_dynamics=self.joint_dynamics,
        )


@dataclass(frozen=True)
class RobotSettings(RobotModelSettings):
    """The arm of one movement: :class:`RobotModelSettings` and the joints to lock."""

    TITLE = "robot"

    lock: tuple[str, ...] = setting(
        (),
        "comma-separated joints of the task chain to lock at their reference value "
        "(joints outside the chain are always locked)",
        metavar="JOINTS",
        parse=_joint_names,
    )

    def load(self, command: str) -> Robot:
        """The robot, loaded (a slow load says so, as ``torqueopt COMMAND: loading robot ...``)."""
        with said_if_slow(f"torqueopt {command}: loading robot '{self.robot}'"):
            return self.spec().load(lock=self.lock)


@dataclass(frozen=True)
class OptionalRobotSettings(RobotSettings):
    """:class:`RobotSettings` for a command that may run without ``--robot`` and has no ``--joint-dynamics``."""

    robot: str | None = setting(None, _ROBOT_HELP)
    joint_dynamics: str | None = setting(None, cli=False)


def sized(values, name: str, size: int) -> np.ndarray:
    """``values`` of option ``--name`` as an array, refused unless there are ``size`` of them (one per joint)."""
    if len(values) != size:
        raise InvalidInput(f"--{name} has {count_values(len(values))} but needs {size}")
    return np.array(values, dtype=float)


@dataclass(frozen=True)
class StartSettings(Settings):
    """The state the movement starts from: ``--q0``, ``--v0`` and ``--degrees``."""

    TITLE = "movement"

    q0: tuple[float, ...] | None = setting(
        None,
        "start configuration, one value per joint [rad; m for a prismatic joint] (default: the robot's SRDF or "
        "neutral configuration)",
        metavar="ANGLES",
        parse=numbers(),
    )
    v0: tuple[float, ...] | None = setting(
        None,
        "start joint velocities, one value per joint [rad/s; m/s for a prismatic joint] (default: at rest)",
        metavar="RATES",
        parse=numbers(),
    )
    degrees: bool = setting(
        False,
        "read --q0 in degrees and --v0 in degrees per second (its revolute joints; prismatic ones stay in m, m/s)",
        switch="on",
    )

    def configuration(self, robot: Robot) -> np.ndarray:
        """The start configuration (one value per joint), else the robot's default."""
        return robot.default_configuration if self.q0 is None else robot.configuration(self._per_joint("q0", robot))

    def velocity(self, robot: Robot) -> np.ndarray | None:
        """The start joint velocities (one value per joint), else None (at rest)."""
        return None if self.v0 is None else self._per_joint("v0", robot)

    def _per_joint(self, name: str, robot: Robot) -> np.ndarray:
        values = sized(getattr(self, name), name, robot.nv)
        return in_radians(values, robot) if self.degrees else values


@dataclass(frozen=True)
class RestStartSettings(StartSettings):
    """:class:`StartSettings` of a movement that starts at rest (no ``--v0``)."""

    v0: tuple[float, ...] | None = setting(None, cli=False)
    degrees: bool = setting(False, "read --q0 in degrees (its revolute joints; prismatic ones stay in m)", switch="on")


def in_radians(values: np.ndarray, robot: Robot) -> np.ndarray:
    """``--degrees``: the revolute and continuous joints' values from degrees to radians; a prismatic joint's value
    is a length [m] (or m/s) and stays as given."""
    rotational = np.array([kind != "prismatic" for kind in robot.joint_kinds])
    return np.where(rotational, np.radians(values), values)


def importable_from_here(spec: str) -> None:
    """Let a ``module:Class`` spec import from the working directory, as ``python -m`` would.

    The ``torqueopt`` script's own directory, not the working directory, heads ``sys.path``; a user who gives
    ``--resolver mymodule:MyResolver`` beside ``mymodule.py`` means the file in front of them (uvicorn and
    gunicorn read an ``app:module`` the same way). Added before any Dask worker starts, so the workers, forked
    with this ``sys.path``, import it too.
    """
    if ":" in str(spec).split("[", 1)[0] and os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())


def torque_table(result) -> list[str]:
    """The peak-torque table of a run or an optimisation (its ``joint_names``, ``peak_torque``, ``torque_upper``,
    ``peak_torque_ratio`` and ``joint_kinds``), its columns as wide as their widest cell (at least the usual 24,
    18, 14, 12 characters) and two spaces apart, so a runaway torque of 1e9 N·m never runs into its limit. One
    unit (N·m or N) goes in the titles; a mixed arm (a prismatic joint among revolute ones) has it in every cell."""
    names, peaks, limits, ratios = result.joint_names, result.peak_torque, result.torque_upper, result.peak_torque_ratio
    units = [joint_unit(kind, "torque") for kind in (result.joint_kinds or [None] * len(names))]
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
    widths = [max([usual, *(len(row[column]) + 2 for row in cells)]) for column, usual in enumerate((24, 18, 14, 12))]
    lines = [f"{titles[0]:<{widths[0]}}" + "".join(f"{title:>{width}}" for title, width in zip(titles[1:], widths[1:]))]
    for row in cells:
        lines.append(
            f"{row[0]:<{widths[0]}}" + "".join(f"{cell:>{width}}" for cell, width in zip(row[1:4], widths[1:])) + row[4]
        )
    return lines
