r"""The atlas's population of movements: seeded, documented, reproducible.

A movement starts at rest at a start configuration :math:`q_0` and follows
one of three kinds of tip path (``path``), each one of torqueopt's
trajectory classes:

``line`` (the default)
    the paper's rest-to-rest straight line (Section 3: constant tangential
    acceleration :math:`a` over the first half of the duration :math:`T`,
    deceleration over the second, length :math:`aT^2/4`) along a unit
    direction :math:`u` (:class:`~torqueopt.StraightLine`);
``min-jerk``
    a straight line along :math:`u` with the minimum-jerk profile
    (:class:`~torqueopt.MinimumJerkLine`) of random length
    :math:`L = f\,aT^2/4`, :math:`f` uniform in ``length_range`` (default
    0.25 to 1: at most the line's length, so its peak acceleration
    :math:`5.77 L/T^2` is at most 1.44 a);
``circle``
    a rest-to-rest circle through the start, one turn with the minimum-jerk
    phase (:class:`~torqueopt.Circle`), in a random plane (normal
    :math:`n` uniform on the sphere; the xy plane for the planar task) about
    a random centre :math:`c = x_0 - r e_1` (:math:`e_1` uniform on the unit
    circle of that plane), of circumference :math:`2\pi r = f\,aT^2/4`,
    :math:`f` uniform in ``length_range``.

The acceleration :math:`a`
    given (``accel``), or by default sized to the arm: the paper's
    :math:`\sqrt2` m/s² on its 3 m arm scaled by the arm's reach,
    :math:`a = \sqrt2\,\mathrm{m/s^2} \times \mathrm{reach}/3\,\mathrm{m}`
    (:func:`default_accel`): the same movements in units of the arm's size,
    so the 2 s line spans 0.47 of the reach on every arm (planar3 keeps
    exactly √2 m/s²; panda 0.404, xarm7 0.364, tiago 0.377, baxter 0.664).

Random mode (the default)
    For each duration, draw :math:`q_0` uniformly in the joint ranges (each
    clipped to :math:`[-\pi, \pi]`) and :math:`u` uniformly on the circle
    (``xy``) or sphere (``position``) as a normalised Gaussian vector (for
    a circle, then :math:`n`, :math:`e_1` and :math:`f`; for a min-jerk
    line, :math:`f`); keep the draw only when the acceptance rules hold,
    until ``paths`` are kept:

    * ``reach_fraction`` (default 0.9): the whole path lies within that
      fraction of the arm's reach from its base: for a line both end points
      (hence, by convexity of the distance, the whole line); for a circle its
      farthest point, at :math:`\sqrt{|d|^2 + r^2 + 2r|d_\parallel|}` from
      the base, :math:`d = c - b` and :math:`d_\parallel` its part in the
      circle's plane;
    * ``min_condition`` (default 0.05): the start is not near-singular,
      :math:`\sigma_{min}/\sigma_{max}(J(q_0))` at least this.

    The stream of draws for one duration depends only on the seed, that
    duration and the path kind (a NumPy ``SeedSequence`` keyed by them; the
    line's key is the seed and duration alone, as before paths had kinds),
    so adding a duration leaves the others' movements unchanged.

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
    times directions) is refused before any inverse kinematics. The grid
    draws lines only (``path="line"``).

The reach is the largest distance from the base (the origin of the first
moving joint) to the task frame over 4096 seeded random configurations
(exact for planar3: 3 m, which the tests check).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import pinocchio as pin

from ..checks import joint_vector, number_in_range, positive_number, whole_number
from ..errors import InvalidInput
from ..linalg import inverse_condition_number
from ..progress import command_name, progress_bar
from ..robot import Robot
from ..trajectory import Circle, MinimumJerkLine, StraightLine

__all__ = [
    "MAX_PATHS",
    "PATH_KINDS",
    "Movement",
    "PopulationSpec",
    "arm_reach",
    "default_accel",
    "draw_population",
    "grid_start_points",
    "movement_trajectory",
    "path_length",
]

#: Largest number of movements per duration the atlas accepts.
MAX_PATHS = 1_000_000
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_MODES = ("random", "grid")
#: The kinds of tip path a population draws (``--path``).
PATH_KINDS = ("line", "min-jerk", "circle")
#: Each kind's key in the seed of its stream of draws (the line has none: its stream predates the kinds).
_KIND_KEYS = {"line": (), "min-jerk": (1,), "circle": (2,)}
#: The paper's acceleration [m/s²] and its arm's reach [m]: the default acceleration scales the one by the other.
PAPER_ACCEL, PAPER_REACH = math.sqrt(2.0), 3.0


@dataclass(frozen=True)
class PopulationSpec:
    """How the movements are drawn (see the module docstring). All lengths in [m], times in [s]."""

    mode: str = "random"
    paths: int = 100
    durations: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0)
    seed: int = 0
    #: The acceleration a in m/s², or None to size it to the arm (``default_accel``; ``sized`` fills it in).
    accel: float | None = None
    path: str = "line"
    length_range: tuple[float, float] = (0.25, 1.0)
    reach_fraction: float = 0.9
    min_condition: float = 0.05
    grid_spacing: float = 0.25
    grid_directions: int = 8
    grid_posture: tuple[float, ...] | None = None
    max_draws_per_path: int = 1000

    def __post_init__(self):
        if self.mode not in _MODES:
            raise InvalidInput(f"unknown population mode '{self.mode}': choose one of {', '.join(_MODES)}")
        if self.path not in PATH_KINDS:
            raise InvalidInput(f"path '{self.path}' is not a kind of path: choose one of {', '.join(PATH_KINDS)}")
        if self.mode == "grid" and self.path != "line":
            raise InvalidInput(f"the grid draws lines only: path '{self.path}' needs mode 'random'")
        try:
            low, high = (float(x) for x in self.length_range)
        except (TypeError, ValueError):
            raise InvalidInput(f"length_range {self.length_range!r} must be two numbers LOW,HIGH") from None
        if not (math.isfinite(low) and math.isfinite(high) and 0 < low <= high <= 1):
            raise InvalidInput(
                f"length_range {[low, high]} must be two fractions 0 < LOW <= HIGH <= 1 of the line's length a·T²/4"
            )
        object.__setattr__(self, "length_range", (low, high))
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
        if self.accel is not None:
            object.__setattr__(self, "accel", positive_number(self.accel, "accel", "m/s²"))
        object.__setattr__(self, "grid_spacing", positive_number(self.grid_spacing, "grid_spacing"))
        object.__setattr__(self, "grid_directions", whole_number(self.grid_directions, "grid_directions", 1, 360))
        if self.grid_posture is not None:
            object.__setattr__(self, "grid_posture", tuple(float(x) for x in self.grid_posture))

    def as_dict(self) -> dict:
        return asdict(self)

    def sized(self, reach: float) -> PopulationSpec:
        """This spec with its acceleration given: its own, or :func:`default_accel` of ``reach`` [m]."""
        return self if self.accel is not None else replace(self, accel=default_accel(reach))


def default_accel(reach: float) -> float:
    """The atlas's default acceleration [m/s²] for an arm of ``reach`` [m]: √2 m/s² × reach / 3 m.

    The paper's √2 m/s² on its arm of 3 m reach, scaled by the arm's size:
    movements of the same durations then span the same fraction of the reach
    (the 2 s line 0.47 of it) on every arm; planar3 keeps exactly √2 m/s².
    """
    return PAPER_ACCEL * (float(reach) / PAPER_REACH)


@dataclass(frozen=True)
class Movement:
    """One movement of the population.

    Attributes:
        path: its number in the atlas (unique over all durations).
        duration: T [s].
        q0: start joint angles [rad], one per joint.
        direction: unit direction of the line (2 or 3 values); for a circle, the
            direction of travel at the start, :math:`e_2`.
        start: tip position at q0 [m].
        kind: ``line``, ``min-jerk`` or ``circle``.
        length: path length [m]: a·T²/4 for a line, L for a min-jerk line, 2πr for a circle.
        accel: the line's acceleration a [m/s²] (the population's).
        radius: the circle's radius r [m] (NaN for a line).
        centre: the circle's centre [m] (None for a line).
        normal: the circle's plane normal (3 values; None for a line and for a planar circle).
    """

    path: int
    duration: float
    q0: np.ndarray = field(repr=False)
    direction: np.ndarray = field(repr=False)
    start: np.ndarray = field(repr=False)
    kind: str = "line"
    length: float = math.nan
    accel: float = PAPER_ACCEL
    radius: float = math.nan
    centre: np.ndarray | None = field(default=None, repr=False)
    normal: np.ndarray | None = field(default=None, repr=False)


def movement_trajectory(movement: Movement):
    """The movement's tip path as a trajectory object (StraightLine, MinimumJerkLine, Circle) anchored at its start."""
    if movement.kind == "line":
        return StraightLine(movement.direction, accel=movement.accel, duration=movement.duration, start=movement.start)
    if movement.kind == "min-jerk":
        return MinimumJerkLine(
            movement.direction, length=movement.length, duration=movement.duration, start=movement.start
        )
    return Circle(
        movement.radius,
        movement.duration,
        normal=movement.normal,
        centre_direction=np.asarray(movement.centre) - np.asarray(movement.start),
        start=movement.start,
    )


def path_length(accel: float, duration: float) -> float:
    """Length a·T²/4 [m] of the paper's line."""
    return accel * duration**2 / 4.0


def arm_reach(robot: Robot, samples: int = 4096) -> tuple[np.ndarray, float]:
    """(base point, reach) [m]: the first moving joint's origin and the farthest the task frame gets from it.

    Computed once per robot and sample count (a Robot is immutable): 4,096 forward kinematics.
    """
    cached = _REACHES.setdefault(robot, {})
    if samples not in cached:
        cached[samples] = _sampled_reach(robot, samples)
    base, reach = cached[samples]
    return base.copy(), reach


# (base point, reach) per robot and sample count.
_REACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _sampled_reach(robot: Robot, samples: int) -> tuple[np.ndarray, float]:
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(12345)
    base_joint = next(j for j in range(1, model.njoints) if model.joints[j].nv > 0)
    low, high = _joint_ranges(robot)
    dimension = min(robot.m, 3)
    pin.framesForwardKinematics(model, data, robot.configuration(np.zeros(robot.nv)))
    base = data.oMi[base_joint].translation[:dimension].copy()
    if robot.name == "planar3" and robot.task == "xy":
        return base, 3.0  # three 1 m links: a sampled value would approach it from below
    reach = 0.0
    for _ in range(samples):
        q = robot.configuration(rng.uniform(low, high))
        pin.framesForwardKinematics(model, data, q)
        reach = max(reach, float(np.linalg.norm(data.oMf[robot.frame_id].translation[:dimension] - base)))
    return base.copy(), reach


#: Populations of this many movements and more show a bar while they are drawn (about 25 s at 4,000 a second).
DRAW_PROGRESS_FROM = 100_000


def draw_population(robot: Robot, spec: PopulationSpec, progress: bool = False) -> list[Movement]:
    """Every movement of the atlas, durations in the given order, paths numbered from 0.

    ``progress``: the grid's inverse kinematics says what it does on stderr (a bar, or one line in a log).

    A spec without an acceleration is sized to the arm first (:meth:`PopulationSpec.sized`).

    Raises:
        InvalidInput: the acceptance rules reject too many draws (loosen them),
            or the grid keeps no start point.
    """
    base, reach = arm_reach(robot)
    spec = spec.sized(reach)
    if spec.mode == "grid":
        return _grid(robot, spec, base, reach, progress)
    movements: list[Movement] = []
    low, high = _joint_ranges(robot)
    dimension = min(robot.m, 3)
    data = robot.model.createData()
    total = spec.paths * len(spec.durations)
    # Drawing a million movements takes minutes (about 4,000 a second): a large population says how far it is.
    bar = progress_bar(f"{command_name('torqueopt atlas')}: drawing {total:,} movements", total=total, unit="movement",
                       enabled=progress and total >= DRAW_PROGRESS_FROM)  # fmt: skip
    with bar:
        for duration in spec.durations:
            _draw_duration(robot, spec, data, duration, movements, low, high, dimension, base, reach, bar)
    return movements


def _draw_duration(robot, spec, data, duration, movements, low, high, dimension, base, reach, bar) -> None:
    """Append the movements of one duration, drawn from its own seeded stream, to ``movements``."""
    # One stream per (seed, duration in µs, kind): other durations do not shift it.
    key = [spec.seed, round(duration * 1e6), *_KIND_KEYS[spec.path]]
    rng = np.random.default_rng(np.random.SeedSequence(key))
    line_length = path_length(spec.accel, duration)
    kept, draws = 0, 0
    while kept < spec.paths:
        draws += 1
        if draws > spec.max_draws_per_path * spec.paths:
            raise InvalidInput(
                f"the acceptance rules kept only {kept} of {draws - 1} draws for duration {duration:g} s "
                f"({spec.path} paths, line length {line_length:.3g} m, reach {reach:.3g} m): lower min_condition "
                f"({spec.min_condition:g}) or raise reach_fraction ({spec.reach_fraction:g}), or shorten the duration"
            )
        angles = rng.uniform(low, high)
        direction = rng.normal(size=dimension)
        direction /= np.linalg.norm(direction)
        shape = _draw_shape(rng, spec, direction, line_length)
        start = _accept(robot, data, angles, shape, base, reach, spec)
        if start is None:
            continue
        movements.append(_movement(len(movements), duration, angles, start, shape, spec.accel))
        kept += 1
        bar.update(1)


def _draw_shape(rng, spec: PopulationSpec, direction: np.ndarray, line_length: float) -> dict:
    """The path's shape relative to its start: kind, length and, for a circle, normal, e₁ and radius."""
    if spec.path == "line":
        return {"kind": "line", "direction": direction, "length": line_length}
    fraction = rng.uniform(*spec.length_range)
    if spec.path == "min-jerk":
        return {"kind": "min-jerk", "direction": direction, "length": fraction * line_length}
    # The circle: the normal is the direction drawn (uniform on the sphere), e₁ uniform in its plane.
    dimension = direction.size
    if dimension == 3:
        normal = direction
        towards_start = rng.normal(size=3)
        towards_start -= towards_start.dot(normal) * normal
    else:
        normal = None
        towards_start = rng.normal(size=2)
    towards_start /= np.linalg.norm(towards_start)
    travel = np.array([-towards_start[1], towards_start[0]]) if dimension == 2 else np.cross(normal, towards_start)
    radius = fraction * line_length / (2.0 * math.pi)
    return {
        "kind": "circle", "direction": travel, "length": 2.0 * math.pi * radius, "radius": radius,
        "normal": normal, "towards_start": towards_start,
    }  # fmt: skip


def _movement(path: int, duration: float, angles, start, shape: dict, accel: float) -> Movement:
    circle = shape["kind"] == "circle"
    return Movement(
        path, duration, angles, shape["direction"], start,
        kind=shape["kind"], length=float(shape["length"]), accel=float(accel),
        radius=float(shape["radius"]) if circle else math.nan,
        centre=start - shape["radius"] * shape["towards_start"] if circle else None,
        normal=shape["normal"] if circle else None,
    )  # fmt: skip


def farthest_distance(shape: dict, start: np.ndarray, base: np.ndarray) -> float:
    """The largest distance [m] from ``base`` of the path of ``shape`` starting at ``start``."""
    if shape["kind"] != "circle":
        return max(
            float(np.linalg.norm(start - base)),
            float(np.linalg.norm(start + shape["length"] * shape["direction"] - base)),
        )
    radius = shape["radius"]
    offset = start - radius * shape["towards_start"] - base  # d = c − b
    in_plane = offset if shape["normal"] is None else offset - offset.dot(shape["normal"]) * shape["normal"]
    # |c + r u − b|² = |d|² + r² + 2r d·u, largest for u along d's part in the plane.
    return math.sqrt(float(offset.dot(offset)) + radius**2 + 2.0 * radius * float(np.linalg.norm(in_plane)))


def _accept(robot, data, angles, shape, base, reach, spec):
    """The tip start point when (angles, shape) passes the acceptance rules, else None."""
    q = robot.configuration(angles)
    dimension = shape["direction"].size
    jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, _LWA)[robot.task_rows]
    if not inverse_condition_number(jacobian) >= spec.min_condition:
        return None
    pin.updateFramePlacements(robot.model, data)
    start = data.oMf[robot.frame_id].translation[:dimension].copy()
    if farthest_distance(shape, start, base) > spec.reach_fraction * reach:
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


def _grid(robot: Robot, spec: PopulationSpec, base, reach, progress: bool = False) -> list[Movement]:
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
    description = f"{command_name('torqueopt atlas')}: inverse kinematics of {len(points):,} grid points"
    with progress_bar(description, total=len(points), unit="point", enabled=progress) as bar:
        for point in points:
            angles = _inverse_kinematics(robot, data, point, posture)
            bar.update()
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
                    movements.append(
                        Movement(
                            len(movements), duration, angles, direction.copy(), point.copy(),
                            length=length, accel=float(spec.accel),
                        )
                    )  # fmt: skip
    if not movements:
        raise InvalidInput(
            f"the grid of spacing {spec.grid_spacing:g} m keeps no movement inside {spec.reach_fraction:g} of the "
            f"reach {reach:.3g} m: use a finer spacing or shorter durations"
        )
    return movements
