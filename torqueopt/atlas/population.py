r"""The atlas's population of movements: seeded, documented, reproducible.

A movement is the paper's rest-to-rest straight line (Section 3: constant
tangential acceleration :math:`a` over the first half of the duration
:math:`T`, deceleration over the second, length :math:`aT^2/4`) from a start
configuration :math:`q_0` along a unit direction :math:`u`.

Random mode (the default)
    For each duration, draw :math:`q_0` uniformly in the joint ranges (each
    clipped to :math:`[-\pi, \pi]`) and :math:`u` uniformly on the circle
    (``xy``) or sphere (``position``) as a normalised Gaussian vector; keep
    the pair only when the acceptance rules hold, until ``paths`` are kept:

    * ``reach_fraction`` (default 0.9): both end points of the line, hence
      (by convexity of the distance) the whole line, lie within that
      fraction of the arm's reach from its base;
    * ``min_condition`` (default 0.05): the start is not near-singular,
      :math:`\sigma_{min}/\sigma_{max}(J(q_0))` at least this.

    The stream of draws for one duration depends only on the seed and that
    duration (a NumPy ``SeedSequence`` keyed by both), so adding a duration
    leaves the others' movements unchanged.

Grid mode (for maps)
    Start points on a square grid of ``grid_spacing`` [m] in the task space,
    centred on the base, kept when inside ``reach_fraction`` of the reach;
    at each, :math:`q_0` is found by inverse kinematics (Newton steps on the
    tip position with a null-space pull towards ``grid_posture``, the same
    start for every point so the map does not depend on the order), kept when
    it converges and meets ``min_condition``; each point is paired with
    ``grid_directions`` directions evenly spread on the circle (or a
    Fibonacci set on the sphere), and the line must stay inside the reach.
    The grid is counted before it is built (:func:`grid_start_points`, one
    slab of the grid at a time, after a bound by the ball's volume), and a
    grid of more than :data:`MAX_PATHS` movements per duration (start points
    times directions) is refused before any inverse kinematics.

The reach is the largest distance from the base (the origin of the first
moving joint) to the task frame over 4096 seeded random configurations
(exact for planar3: 3 m, which the tests check).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
import pinocchio as pin

from ..checks import joint_vector, number_in_range, positive_number, whole_number
from ..errors import InvalidInput
from ..linalg import inverse_condition_number
from ..robot import Robot

__all__ = [
    "MAX_PATHS",
    "Movement",
    "PopulationSpec",
    "arm_reach",
    "draw_population",
    "grid_start_points",
    "path_length",
]

#: Largest number of movements per duration the atlas accepts.
MAX_PATHS = 1_000_000
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_MODES = ("random", "grid")


@dataclass(frozen=True)
class PopulationSpec:
    """How the movements are drawn (see the module docstring). All lengths in [m], times in [s]."""

    mode: str = "random"
    paths: int = 100
    durations: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0)
    seed: int = 0
    accel: float = math.sqrt(2.0)
    reach_fraction: float = 0.9
    min_condition: float = 0.05
    grid_spacing: float = 0.25
    grid_directions: int = 8
    grid_posture: tuple[float, ...] | None = None
    max_draws_per_path: int = 1000

    def __post_init__(self):
        if self.mode not in _MODES:
            raise InvalidInput(f"unknown population mode '{self.mode}': choose one of {', '.join(_MODES)}")
        object.__setattr__(self, "paths", whole_number(self.paths, "paths", 1, MAX_PATHS))
        durations = tuple(float(d) for d in np.atleast_1d(np.asarray(self.durations, dtype=float)))
        if not durations or len(durations) > 100 or not all(math.isfinite(d) and 0 < d <= 600 for d in durations):
            raise InvalidInput(f"durations {list(durations)} must be 1 to 100 numbers of seconds in (0, 600]")
        if len(set(durations)) != len(durations):
            raise InvalidInput(f"durations {list(durations)} repeat a value; give each once")
        object.__setattr__(self, "durations", durations)
        object.__setattr__(self, "seed", whole_number(self.seed, "seed"))
        object.__setattr__(
            self, "reach_fraction", number_in_range(self.reach_fraction, "reach_fraction", 0.0, 1.0, low_open=True)
        )
        object.__setattr__(self, "min_condition", number_in_range(self.min_condition, "min_condition", 0.0, 1.0))
        for name in ("accel", "grid_spacing"):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        object.__setattr__(self, "grid_directions", whole_number(self.grid_directions, "grid_directions", 1, 360))
        if self.grid_posture is not None:
            object.__setattr__(self, "grid_posture", tuple(float(x) for x in self.grid_posture))

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Movement:
    """One movement of the population.

    Attributes:
        path: its number in the atlas (unique over all durations).
        duration: T [s].
        q0: start joint angles [rad], one per joint.
        direction: unit direction of the line (2 or 3 values).
        start: tip position at q0 [m].
    """

    path: int
    duration: float
    q0: np.ndarray = field(repr=False)
    direction: np.ndarray = field(repr=False)
    start: np.ndarray = field(repr=False)


def path_length(accel: float, duration: float) -> float:
    """Length a·T²/4 [m] of the paper's line."""
    return accel * duration**2 / 4.0


def arm_reach(robot: Robot, samples: int = 4096) -> tuple[np.ndarray, float]:
    """(base point, reach) [m]: the first moving joint's origin and the farthest the task frame gets from it."""
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(12345)
    base_joint = next(j for j in range(1, model.njoints) if model.joints[j].nv > 0)
    low, high = _joint_ranges(robot)
    dimension = min(robot.m, 3)
    pin.framesForwardKinematics(model, data, robot.configuration(np.zeros(robot.nv)))
    base = data.oMi[base_joint].translation[:dimension].copy()
    reach = 0.0
    for _ in range(samples):
        q = robot.configuration(rng.uniform(low, high))
        pin.framesForwardKinematics(model, data, q)
        reach = max(reach, float(np.linalg.norm(data.oMf[robot.frame_id].translation[:dimension] - base)))
    if robot.name == "planar3" and robot.task == "xy":
        reach = 3.0  # three 1 m links: the sampled value approaches it from below
    return base, reach


def draw_population(robot: Robot, spec: PopulationSpec) -> list[Movement]:
    """Every movement of the atlas, durations in the given order, paths numbered from 0.

    Raises:
        InvalidInput: the acceptance rules reject too many draws (loosen them),
            or the grid keeps no start point.
    """
    base, reach = arm_reach(robot)
    if spec.mode == "grid":
        return _grid(robot, spec, base, reach)
    movements: list[Movement] = []
    low, high = _joint_ranges(robot)
    dimension = min(robot.m, 3)
    data = robot.model.createData()
    for duration in spec.durations:
        # One stream per (seed, duration in µs): other durations do not shift it.
        rng = np.random.default_rng(np.random.SeedSequence([spec.seed, round(duration * 1e6)]))
        length = path_length(spec.accel, duration)
        kept, draws = 0, 0
        while kept < spec.paths:
            draws += 1
            if draws > spec.max_draws_per_path * spec.paths:
                raise InvalidInput(
                    f"the acceptance rules kept only {kept} of {draws - 1} draws for duration {duration:g} s "
                    f"(line length {length:.3g} m, reach {reach:.3g} m): lower min_condition ({spec.min_condition:g}) "
                    f"or raise reach_fraction ({spec.reach_fraction:g}), or shorten the duration"
                )
            angles = rng.uniform(low, high)
            direction = rng.normal(size=dimension)
            direction /= np.linalg.norm(direction)
            start = _accept(robot, data, angles, direction, length, base, reach, spec)
            if start is None:
                continue
            movements.append(Movement(len(movements), duration, angles, direction, start))
            kept += 1
    return movements


def _accept(robot, data, angles, direction, length, base, reach, spec):
    """The tip start point when (angles, direction) passes the acceptance rules, else None."""
    q = robot.configuration(angles)
    dimension = direction.size
    jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, _LWA)[robot.task_rows]
    if not inverse_condition_number(jacobian) >= spec.min_condition:
        return None
    pin.updateFramePlacements(robot.model, data)
    start = data.oMf[robot.frame_id].translation[:dimension].copy()
    limit = spec.reach_fraction * reach
    if np.linalg.norm(start - base) > limit or np.linalg.norm(start + length * direction - base) > limit:
        return None
    return start


def _joint_ranges(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the sampling range: the model's position limits clipped to [-π, π]."""
    model = robot.model
    low, high = np.full(robot.nv, -math.pi), np.full(robot.nv, math.pi)
    if robot.euclidean:
        lower, upper = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
        finite = np.isfinite(lower) & np.isfinite(upper) & (upper > lower)
        low = np.where(finite, np.maximum(lower, -math.pi), low)
        high = np.where(finite, np.minimum(upper, math.pi), high)
    return low, high


def _grid_directions(count: int, dimension: int) -> np.ndarray:
    if dimension == 2:
        angles = 2 * math.pi * np.arange(count) / count
        return np.column_stack([np.cos(angles), np.sin(angles)])
    index = np.arange(count) + 0.5
    polar = np.arccos(1 - 2 * index / count)
    azimuth = math.pi * (1 + 5**0.5) * index
    return np.column_stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)])


def _inverse_kinematics(robot: Robot, data, target, posture, iterations: int = 200):
    """Joint angles putting the task frame at ``target`` [m], near ``posture``; None when it does not converge."""
    angles = posture.copy()
    dimension = target.size
    for _ in range(iterations):
        q = robot.configuration(angles)
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, _LWA)[:dimension]
        pin.updateFramePlacements(robot.model, data)
        error = target - data.oMf[robot.frame_id].translation[:dimension]
        if np.linalg.norm(error) < 1e-11:
            return angles
        pseudo_inverse = np.linalg.pinv(jacobian, rcond=1e-8)
        projector = np.eye(robot.nv) - pseudo_inverse @ jacobian
        step = pseudo_inverse @ error + 0.2 * projector @ (posture - angles)
        scale = min(1.0, 0.5 / max(np.linalg.norm(step), 1e-300))
        angles = angles + scale * step
    return None


def grid_start_points(robot: Robot, spec: PopulationSpec, base=None, reach=None) -> int:
    """The number of grid points inside ``reach_fraction`` of the reach: the starts the grid tries, counted, not built.

    Raises:
        InvalidInput: the grid has more than :data:`MAX_PATHS` movements per
            duration (start points x directions); when even the ball's volume
            says so, without counting.
    """
    if base is None or reach is None:
        base, reach = arm_reach(robot)
    dimension = min(robot.m, 3)
    limit = spec.reach_fraction * reach
    radius = limit / spec.grid_spacing  # in grid steps
    # The cubes of side one step centred on the points inside the ball cover the ball shrunk by half a diagonal.
    inner = max(radius - math.sqrt(dimension) / 2, 0.0)
    at_least = math.pi ** (dimension / 2) / math.gamma(dimension / 2 + 1) * inner**dimension
    if at_least * spec.grid_directions > MAX_PATHS:
        _refuse_grid(spec, f"at least {at_least:.3g}", at_least, limit)
    count = sum(len(slab) for slab in _grid_slabs(spec, dimension, limit))
    if count * spec.grid_directions > MAX_PATHS:
        _refuse_grid(spec, f"{count:,}", count, limit)
    return count


def _refuse_grid(spec: PopulationSpec, count_text: str, count: float, limit: float):
    raise InvalidInput(
        f"the grid of spacing {spec.grid_spacing:g} m has {count_text} start points within {limit:.3g} m of the base "
        f"(x {spec.grid_directions} direction{'s' if spec.grid_directions != 1 else ''}: "
        f"{count * spec.grid_directions:.3g} movements per duration), more "
        f"than the {MAX_PATHS:,} movements per duration an atlas takes: give a coarser --grid-spacing or fewer "
        "--grid-directions"
    )


def _grid_slabs(spec: PopulationSpec, dimension: int, limit: float):
    """The grid points (relative to the base) within ``limit``, one slab (first coordinate fixed) at a time."""
    count = math.floor(limit / spec.grid_spacing)
    axis = spec.grid_spacing * np.arange(-count, count + 1)
    rest = np.stack(np.meshgrid(*([axis] * (dimension - 1)), indexing="ij"), axis=-1).reshape(-1, dimension - 1)
    for first in axis:
        slab = np.column_stack([np.full(len(rest), first), rest])
        yield slab[np.linalg.norm(slab, axis=1) <= limit]


def _grid(robot: Robot, spec: PopulationSpec, base, reach) -> list[Movement]:
    dimension = min(robot.m, 3)
    limit = spec.reach_fraction * reach
    grid_start_points(robot, spec, base, reach)  # refuses a grid too large before it is built
    points = base + np.concatenate(list(_grid_slabs(spec, dimension, limit)))
    if spec.grid_posture is not None:
        posture = joint_vector(robot, spec.grid_posture, "grid_posture")
    elif robot.name == "planar3":
        posture = np.radians([-45.0, 135.0, -135.0])  # the paper's start posture: elbow and wrist bent
    else:
        posture = robot.joint_angles(robot.default_configuration)
    data = robot.model.createData()
    directions = _grid_directions(spec.grid_directions, dimension)
    starts = []
    for point in points:
        angles = _inverse_kinematics(robot, data, point, posture)
        if angles is None:
            continue
        q = robot.configuration(angles)
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, _LWA)[robot.task_rows]
        if inverse_condition_number(jacobian) >= spec.min_condition:
            starts.append((angles, point))
    movements: list[Movement] = []
    for duration in spec.durations:
        length = path_length(spec.accel, duration)
        for angles, point in starts:
            for direction in directions:
                if np.linalg.norm(point + length * direction - base) <= limit:
                    movements.append(Movement(len(movements), duration, angles, direction.copy(), point.copy()))
    if not movements:
        raise InvalidInput(
            f"the grid of spacing {spec.grid_spacing:g} m keeps no movement inside {spec.reach_fraction:g} of the "
            f"reach {reach:.3g} m: use a finer spacing or shorter durations"
        )
    return movements
