"""The robot a run was made with: what the run's files record of it, and that robot rebuilt for playback.

A URDF of the user's own is not in the catalogue, so a run's robot name alone cannot find it again:
:func:`robot_record` adds the URDF's absolute path and SHA-256, the joints locked and the configuration they are
held at, and :func:`robot_of_run` loads that robot back (``torqueopt play``; the rules: docs/playback.md).
"""

from __future__ import annotations

import hashlib
import warnings
from functools import lru_cache
from pathlib import Path

from .catalog import RobotSource, find_robot
from .errors import RobotNotFound, TorqueoptWarning
from .loading import load_robot
from .robot import Robot

__all__ = ["file_sha256", "robot_of_run", "robot_record"]


def file_sha256(path: str | Path) -> str | None:
    """SHA-256 of the file's bytes, as hexadecimal; None when it cannot be read."""
    path = Path(path)
    try:
        status = path.stat()
    except OSError:
        return None
    return _sha256(str(path), status.st_mtime_ns, status.st_size)


@lru_cache(maxsize=64)
def _sha256(path: str, modified_ns: int, size: int) -> str | None:
    # Keyed by the file's modification time and size: a batch of runs of one robot reads the file once.
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def robot_record(robot: Robot) -> dict | None:
    """What rebuilds ``robot``: its URDF and how it was reduced, JSON-ready; None for a robot built without a URDF.

    Keys: ``urdf`` (absolute path), ``sha256`` (of the file's bytes),
    ``locked_joints`` (every joint locked, in the chain or outside it) and
    ``locked_configuration`` (the full model's configuration they are held at).
    """
    source = robot.source
    if source is None:
        return None
    urdf = Path(source.urdf).resolve()
    locked = robot.locked_configuration
    return {
        "urdf": str(urdf),
        "sha256": file_sha256(urdf),
        "locked_joints": list(robot.locked_joints),
        "locked_configuration": None if locked is None else [float(value) for value in locked],
    }


def robot_of_run(
    result,
    robot: str | Path | None = None,
    *,
    frame: str | None = None,
    task: str | None = None,
    lock: list[str] | None = None,
    **load_options,
) -> Robot:
    """The robot ``result`` was made with, loaded again; ``robot``, ``frame``, ``task`` and ``lock`` override.

    Args:
        result: a :class:`~torqueopt.result.SimResult`, e.g. from :func:`torqueopt.load_result`.
        robot: URDF path or robot name to load instead of the recorded one. When it
            is the run's robot (the same file, or the same name), the run's frame,
            task and locked joints still apply; else the robot's own defaults do.
        frame, task: override the run's.
        lock: joints to lock instead of the run's (None: the run's).
        load_options: further keywords of :func:`torqueopt.load_robot` (``torque_limit``, ``gravity``, ``payload``).

    Raises:
        RobotNotFound: the run's URDF is gone and no ``robot`` is given.

    Warns:
        TorqueoptWarning: the URDF's SHA-256 is not the one recorded (the file changed since the run).
    """
    record = getattr(result, "robot_source", None)
    if robot is not None:
        source = find_robot(robot)
        same_robot = source.name == result.robot or (
            record is not None and str(Path(source.urdf).resolve()) == record["urdf"]
        )
        name = robot
    elif record is None:
        source, same_robot, name = None, True, result.robot
    else:
        source, same_robot = _recorded_source(result, record), True
        # A catalogue robot loads by its name, as it always did (its SRDF, its defaults); any other from its file.
        name = result.robot if _is_catalogue(result.robot, source) else str(source.urdf)
    same_file = False
    if record is not None and same_robot and source is not None:
        now = file_sha256(source.urdf)
        same_file = now is not None and now == record.get("sha256")
        if not same_file and record.get("sha256"):
            warnings.warn(
                f"URDF '{source.urdf}' has changed since the run was made (SHA-256 {record['sha256'][:12]}… then, "
                f"{(now or 'unreadable')[:12]}… now): loading the file as it is now",
                TorqueoptWarning,
                stacklevel=2,
            )
    own_frame = frame is None or frame == result.frame
    if lock is None:
        lock = list(record.get("locked_joints") or []) if record and same_robot and own_frame else []
    return load_robot(
        name,
        frame=frame or (result.frame if same_robot else None),
        task=task or (result.task if same_robot else None),
        lock=lock,
        # Held where the run held them; for the same file's model only (another frame may rebuild it with mimic joints).
        reference_configuration=record.get("locked_configuration") if same_file and own_frame else None,
        **load_options,
    )


def _recorded_source(result, record: dict) -> RobotSource:
    """The URDF the run records, or the catalogue's file of its name when that holds the same bytes."""
    recorded = Path(record["urdf"])
    if recorded.is_file():
        return find_robot(recorded)
    catalogue = _catalogue_source(result.robot)
    if catalogue is not None and file_sha256(catalogue.urdf) == record.get("sha256"):
        return catalogue  # the same file, installed elsewhere since (a new environment)
    raise RobotNotFound(f"the run's URDF '{recorded}' does not exist any more; give the robot's URDF with --robot FILE")


def _catalogue_source(name: str) -> RobotSource | None:
    """The catalogue's robot of that name, or None (a URDF of the user's own is named after its file)."""
    if "/" in name or "\\" in name or name.lower().endswith(".urdf"):
        return None
    try:
        return find_robot(name)
    except RobotNotFound:
        return None


def _is_catalogue(name: str, source: RobotSource) -> bool:
    """True when the catalogue gives ``name`` the file ``source`` holds, so that loading by name is the same robot."""
    catalogue = _catalogue_source(name)
    return catalogue is not None and Path(catalogue.urdf).resolve() == Path(source.urdf).resolve()
