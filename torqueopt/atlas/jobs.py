"""The work the atlas sends to its Dask workers: typed, frozen, and the same rows for the same job.

A job names the robot by a :class:`RobotSpec` (each worker thread loads the robot once, :func:`worker_robot`),
and carries its movements, the step, the verdict thresholds and the atlas's fingerprint (``digest``, which the
chunk's file records). A job sent twice gives the same rows: Dask may run a chunk twice.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

from ..loading import load_robot
from ..payload import Payload
from ..resolvers import Resolver
from ..robot import Robot
from .population import Movement
from .verdicts import Thresholds

__all__ = ["GlobalChunk", "ResolverChunk", "RobotSpec", "worker_robot"]


@dataclass(frozen=True)
class RobotSpec:
    """What a worker needs to load the robot (a Robot object is not sent: each worker loads its own)."""

    source: str
    frame: str | None = None
    task: str | None = None
    torque_limit: tuple[float, ...] | None = None
    gravity: bool | tuple[float, ...] | None = None
    payload: Payload | None = None
    #: ``urdf`` or ``off`` (:func:`torqueopt.load_robot`'s ``joint_dynamics``); None: the default.
    joint_dynamics: str | None = None

    def __post_init__(self):
        # As atlas-config.json records them (lists, the payload's fields), read back into hashable values.
        if isinstance(self.gravity, list):
            object.__setattr__(self, "gravity", tuple(self.gravity))
        if isinstance(self.torque_limit, list):
            object.__setattr__(self, "torque_limit", tuple(self.torque_limit))
        if isinstance(self.payload, dict):
            object.__setattr__(self, "payload", Payload(**self.payload))

    def load(self, lock: tuple[str, ...] = ()) -> Robot:
        """The robot, with the joints of ``lock`` locked as well (``torqueopt run``'s ``--lock``)."""
        return load_robot(
            self.source,
            frame=self.frame,
            task=self.task,
            torque_limit=self.torque_limit,
            gravity=self.gravity,
            lock=lock,
            payload=self.payload,
            joint_dynamics=self.joint_dynamics,
        )

    def as_dict(self) -> dict:
        # The payload and joint_dynamics only when given, so that an atlas without them keeps its fingerprint
        # (and resumes).
        return {
            "source": self.source,
            "frame": self.frame,
            "task": self.task,
            "torque_limit": None if self.torque_limit is None else list(self.torque_limit),
            "gravity": list(self.gravity) if isinstance(self.gravity, tuple) else self.gravity,
            **({} if self.payload is None else {"payload": self.payload.record()}),
            **({} if self.joint_dynamics is None else {"joint_dynamics": self.joint_dynamics}),
        }


@dataclass(frozen=True)
class ResolverChunk:
    """Every resolver on the movements of one chunk (of one duration), ``pinv`` first: the baseline.

    Attributes:
        robot: the robot to load.
        resolvers: the resolvers, ``pinv`` (its defaults) first.
        movements: the chunk's movements.
        dt: the step [s].
        thresholds: the verdicts' thresholds.
        batch: simulate the movements as one batch where the resolver allows it.
        digest: the atlas's fingerprint, recorded in the chunk's file.
        margin_every: the time between the states whose stability margin is evaluated [s]; None: no margin.
        plant: what the torques act on, a name :func:`torqueopt.plants.make_plant` takes.
        plant_options: the plant's options, as sorted (key, value) pairs.
        keep_traces: the explorer's ``keep``: hand back the traces of the runs of the paths it may keep
            (:func:`torqueopt.atlas.sweep.chunk_output`); 0: none.
        parts_per_path: the chunks each path's rows come in (2 with the global optimum's chunks): until its
            other part is known, a path whose resolvers are all calm may still whip.
    """

    robot: RobotSpec
    resolvers: tuple[Resolver, ...]
    movements: tuple[Movement, ...]
    dt: float
    thresholds: Thresholds
    batch: bool
    digest: str
    margin_every: float | None = None
    plant: str = "pinocchio"
    plant_options: tuple[tuple[str, str], ...] = ()
    keep_traces: int = 0
    parts_per_path: int = 1


@dataclass(frozen=True)
class GlobalChunk:
    """The ``global-optimum`` rows of the movements of one chunk (:mod:`torqueopt.atlas.global_optimum`).

    ``settings`` is the optimiser's, as atlas-config.json records them (``global``); the other attributes are
    those of :class:`ResolverChunk`.
    """

    robot: RobotSpec
    movements: tuple[Movement, ...]
    dt: float
    thresholds: Thresholds
    digest: str
    settings: dict


_LOCAL = threading.local()


def worker_robot(spec: RobotSpec) -> Robot:
    """The robot for ``spec``, loaded once per worker thread."""
    robots = getattr(_LOCAL, "robots", None)
    if robots is None:
        robots = _LOCAL.robots = {}
    if spec not in robots:
        robots[spec] = spec.load()
    return robots[spec]
