r"""The paper's experiment as a named scenario: ``paper``.

Hollerbach & Suh (Section 3) simulate a planar arm of three 1 m, 10 kg thin
rods, without gravity, with torque limits of 54, 24 and 6 N·m, tracking
rest-to-rest straight lines with a tangential acceleration of √2 m/s² (RK4,
1 ms, torque held over each step). The paper does not give the start
configuration; torqueopt uses q0 = (−45°, 135°, −135°), where the tip is at
(√2, 1 − √2) m, and the direction (1, 1)/√2. Movements last 0.5 s (short,
Fig. 2), 1.25 s (medium, 2.5 times longer, Fig. 3) and 2 s (long, 4 times,
Fig. 4); the weighted null-space method uses W = diag(1/limit²).

Fig. 7 of the paper is the same arm swinging freely: zero torque, gravity
along the former straight-line direction with the magnitude that gives the
tip an initial acceleration of √2 m/s², over the long movement's duration.

:data:`PAPER` is that scenario; :func:`dataclasses.replace` (or
:meth:`PaperScenario.replace`) gives one with another start, direction or
durations. :func:`run_paper` simulates every (movement, resolver) pair and
the free swing, judges each run with :func:`torqueopt.whiplash.detect_whiplash`
and checks the paper's six claims; :func:`write_paper` writes Figures 2-7,
a stick-figure strip per resolver for the long movement, ``summary.json``
and ``summary.md``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InvalidInput, SingularJacobian
from .linalg import JacobianSolver
from .resolvers import get_resolver, resolver_names
from .result import SimResult, atomic_write
from .robot import Robot, load_robot
from .simulate import rk4_step, simulate
from .trajectory import StraightLine
from .whiplash import DEFAULT_GROWTH_FACTOR, DEFAULT_LIMIT_FACTOR, WhiplashReport, detect_whiplash

__all__ = [
    "MOVEMENTS",
    "PaperScenario",
    "PAPER",
    "PaperResults",
    "Claim",
    "run_paper",
    "run_movement",
    "free_swing",
    "free_swing_gravity",
    "alignment_times",
    "check_claims",
    "format_summary_markdown",
    "summary_entries",
    "write_paper",
]

#: Movement names, shortest first.
MOVEMENTS = ("short", "medium", "long")
_FREE_SWING = "free swing"


def _finite_tuple(values, name: str) -> tuple[float, ...]:
    try:
        array = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a list of numbers") from None
    if not array.size or not np.isfinite(array).all():
        raise InvalidInput(f"{name} {array.tolist()} must be finite numbers")
    return tuple(array.tolist())


@dataclass(frozen=True)
class PaperScenario:
    """The paper's experiment (Section 3); every field can be replaced.

    Attributes:
        q0: start joint angles [rad], one per joint.
        direction: direction of the straight line in the xy plane (normalised on use).
        accel: tangential acceleration and deceleration [m/s²].
        durations: (short, medium, long) movement durations [s].
        torque_limit: symmetric torque limits τ⁺ = −τ⁻ [N·m].
        dt: integration step [s]; the torque is held over each step.
        robot: the arm, ``planar3`` (gravity off).
    """

    q0: tuple[float, ...] = tuple(np.radians([-45.0, 135.0, -135.0]).tolist())
    direction: tuple[float, ...] = (1.0, 1.0)
    accel: float = math.sqrt(2.0)
    durations: tuple[float, float, float] = (0.5, 1.25, 2.0)
    torque_limit: tuple[float, ...] = (54.0, 24.0, 6.0)
    dt: float = 1e-3
    robot: str = "planar3"

    def __post_init__(self):
        object.__setattr__(self, "q0", _finite_tuple(self.q0, "q0"))
        object.__setattr__(self, "direction", _finite_tuple(self.direction, "direction"))
        durations = _finite_tuple(self.durations, "durations")
        if len(durations) != len(MOVEMENTS) or min(durations) <= 0:
            raise InvalidInput(
                f"durations {list(durations)} must be {len(MOVEMENTS)} positive numbers of seconds "
                f"({', '.join(MOVEMENTS)})"
            )
        object.__setattr__(self, "durations", durations)
        limits = _finite_tuple(self.torque_limit, "torque_limit")
        if min(limits) <= 0:
            raise InvalidInput(f"torque_limit {list(limits)} must be positive numbers [N·m]")
        object.__setattr__(self, "torque_limit", limits)
        for name in ("accel", "dt"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInput(f"{name}={value!r} must be a positive finite number")
        if self.dt > min(durations):
            raise InvalidInput(f"dt={self.dt} s is longer than the shortest movement, {min(durations)} s")

    def replace(self, **changes) -> PaperScenario:
        """The same scenario with some fields changed, e.g. ``PAPER.replace(durations=(0.4, 1.0, 1.6))``."""
        return dataclasses.replace(self, **changes)

    def duration(self, movement: str) -> float:
        """Duration of ``short``, ``medium`` or ``long`` [s]."""
        try:
            return self.durations[MOVEMENTS.index(movement)]
        except ValueError:
            raise InvalidInput(f"unknown movement '{movement}': choose one of {', '.join(MOVEMENTS)}") from None

    @property
    def weight(self) -> np.ndarray:
        """Diagonal of W = diag(1/limit²) for ``weighted-null-space``, as in the paper."""
        return 1.0 / np.square(self.torque_limit)

    def line(self, movement: str) -> StraightLine:
        """The straight line of a movement, anchored by :func:`~torqueopt.simulate` at the tip's start."""
        return StraightLine(self.direction, accel=self.accel, duration=self.duration(movement))

    def load_robot(self) -> Robot:
        """The arm with the scenario's limits and gravity off."""
        robot = load_robot(self.robot, torque_limit=np.array(self.torque_limit), gravity=False)
        if len(self.q0) != robot.nv:
            raise InvalidInput(f"q0 has {len(self.q0)} angles but robot '{robot.name}' has {robot.nv} joints")
        return robot

    def as_dict(self) -> dict:
        """JSON-ready description, angles in degrees as well."""
        return {
            "robot": self.robot,
            "q0_rad": list(self.q0),
            "q0_deg": np.degrees(self.q0).round(9).tolist(),
            "direction": (np.asarray(self.direction) / np.linalg.norm(self.direction)).tolist(),
            "accel": self.accel,
            "durations": dict(zip(MOVEMENTS, self.durations)),
            "torque_limit": list(self.torque_limit),
            "weight": self.weight.tolist(),
            "dt": self.dt,
            "gravity": False,
        }


#: The paper's scenario as torqueopt reproduces it.
PAPER = PaperScenario()


@dataclass(frozen=True)
class Claim:
    """One of the paper's claims, checked on the runs.

    Attributes:
        number: 1 to 6, as in issue 3.
        statement: the claim in words.
        holds: whether the numbers bear it out.
        evidence: the numbers, in one or two sentences.
    """

    number: int
    statement: str
    holds: bool
    evidence: str


@dataclass
class PaperResults:
    """Everything :func:`run_paper` computed.

    Attributes:
        scenario: the scenario that was run.
        robot: the arm it was run on (gravity off).
        runs: SimResult per (movement, resolver).
        whiplash: WhiplashReport per (movement, resolver).
        free_swing: the zero-torque swing of Fig. 7 (resolver name ``free swing``).
        free_swing_gravity: the gravity vector used for it [m/s²].
        claims: the six claims of issue 3, checked.
        limit_factor, growth_factor: the whiplash thresholds used.
    """

    scenario: PaperScenario
    robot: Robot
    runs: dict[tuple[str, str], SimResult]
    whiplash: dict[tuple[str, str], WhiplashReport]
    free_swing: SimResult
    free_swing_gravity: np.ndarray
    limit_factor: float
    growth_factor: float
    claims: list[Claim] = field(default_factory=list)

    @property
    def stopped_early(self) -> list[tuple[str, str]]:
        """(movement, resolver) of the runs that stopped before their duration."""
        return [key for key, result in self.runs.items() if not result.completed]


def run_movement(scenario: PaperScenario, movement: str, resolver: str, robot: Robot | None = None) -> SimResult:
    """Simulate one resolver on one of the scenario's movements."""
    robot = robot or scenario.load_robot()
    options = {"weight": scenario.weight} if resolver == "weighted-null-space" else {}
    return simulate(robot, get_resolver(resolver, **options), scenario.line(movement), scenario.q0, dt=scenario.dt)


def free_swing_gravity(robot: Robot, scenario: PaperScenario) -> np.ndarray:
    r"""Gravity [m/s²] along the line direction that gives the tip an initial acceleration of ``accel``.

    From rest the tip's acceleration is :math:`J\ddot q` with
    :math:`\ddot q` = ABA(q0, 0, 0), linear in the gravity vector; Pinocchio
    computes it for unit gravity along the direction, then it is scaled.
    """
    direction = np.zeros(3)
    planar = np.asarray(scenario.direction, float)
    direction[: planar.size] = planar / np.linalg.norm(planar)
    q = robot.configuration(scenario.q0)
    zero = np.zeros(robot.nv)
    saved = robot.gravity
    try:
        robot.set_gravity(direction)
        tip_acceleration = robot.terms(q, zero).jacobian.dot(robot.forward_dynamics(q, zero, zero))
    finally:
        robot.set_gravity(saved)
    size = float(np.linalg.norm(tip_acceleration))
    if size == 0.0:
        raise InvalidInput(f"gravity along {planar.tolist()} does not move the tip from q0; choose another direction")
    return direction * scenario.accel / size


def free_swing(scenario: PaperScenario, robot: Robot | None = None, duration: float | None = None) -> SimResult:
    """Fig. 7: the arm released at q0 with zero torque under :func:`free_swing_gravity`.

    Integrated by the same RK4 step as the resolvers. ``x_ref`` holds the
    long movement's straight line, the path the swing replaces; torques are
    zero, so no torque limit is ever reached.
    """
    robot = robot or scenario.load_robot()
    duration = scenario.durations[-1] if duration is None else duration
    gravity = free_swing_gravity(robot, scenario)
    steps = round(duration / scenario.dt)
    times = scenario.dt * np.arange(steps + 1)
    n = robot.nv
    q = robot.configuration(scenario.q0)
    v = np.zeros(n)
    zero = np.zeros(n)
    configurations, velocities, accelerations, tips = [], [], [], []
    saved = robot.gravity
    try:
        robot.set_gravity(gravity)
        for _ in times:
            acceleration = robot.forward_dynamics(q, v, zero)
            configurations.append(q)
            velocities.append(v)
            accelerations.append(acceleration)
            tips.append(robot.task_position(q))
            q, v = rk4_step(robot, q, v, zero, scenario.dt, acceleration)
    finally:
        robot.set_gravity(saved)
    tips = np.array(tips)
    line = StraightLine(scenario.direction, accel=scenario.accel, duration=duration).anchored(tips[0])
    return SimResult(
        robot=robot.name,
        frame=robot.frame,
        task=robot.task,
        resolver=_FREE_SWING,
        joint_names=list(robot.joint_names),
        dt=scenario.dt,
        t=times,
        q=np.array(configurations),
        joint_angles=np.array([robot.joint_angles(c) for c in configurations]),
        v=np.array(velocities),
        acceleration=np.array(accelerations),
        tau=np.zeros((len(times), n)),
        x=tips,
        x_ref=line.sample(times).position,
        jacobian_condition=np.full(len(times), np.nan),
        torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(),
        duration=duration,
    )


def alignment_times(result: SimResult, joint: int = 2) -> list[float]:
    """Times [s] at which ``joint`` (0-based; 2 is joint 3) passes through 0 mod 2π: its two links in line.

    Found as sign changes of the angle wrapped to (−π, π], interpolated
    linearly; wraps through ±π (links folded back) are not counted.
    """
    angle = np.angle(np.exp(1j * result.joint_angles[:, joint]))
    times = []
    for k in range(len(angle) - 1):
        a, b = angle[k], angle[k + 1]
        if (a == 0.0 or a * b < 0.0) and abs(a - b) < math.pi:
            fraction = 0.0 if a == b else a / (a - b)
            times.append(float(result.t[k] + fraction * (result.t[k + 1] - result.t[k])))
    return times


def run_paper(
    scenario: PaperScenario = PAPER,
    *,
    limit_factor: float = DEFAULT_LIMIT_FACTOR,
    growth_factor: float = DEFAULT_GROWTH_FACTOR,
) -> PaperResults:
    """Simulate every resolver on every movement, and the free swing; judge and check the claims.

    Raises:
        InvalidInput: q0 is a singular configuration, where no resolver can start.
    """
    robot = scenario.load_robot()
    _check_start(robot, scenario)
    runs = {
        (movement, name): run_movement(scenario, movement, name, robot)
        for movement in MOVEMENTS
        for name in resolver_names()
    }
    whiplash = {key: detect_whiplash(result, limit_factor, growth_factor) for key, result in runs.items()}
    swing = free_swing(scenario, robot)
    results = PaperResults(
        scenario=scenario,
        robot=robot,
        runs=runs,
        whiplash=whiplash,
        free_swing=swing,
        free_swing_gravity=free_swing_gravity(robot, scenario),
        limit_factor=float(limit_factor),
        growth_factor=float(growth_factor),
    )
    results.claims = check_claims(results)
    return results


def _check_start(robot: Robot, scenario: PaperScenario) -> None:
    q = robot.configuration(scenario.q0)
    jacobian = robot.terms(q, np.zeros(robot.nv)).jacobian
    try:
        # Only its singularity check is wanted here.
        JacobianSolver(robot.m, robot.nv, null_space=False)(jacobian, np.zeros(robot.m))
    except SingularJacobian as error:
        degrees = ", ".join(f"{a:g}°" for a in np.degrees(scenario.q0).round(4))
        raise InvalidInput(f"q0 = ({degrees}) is a singular configuration ({error}); choose another start") from None


# -- the claims ----------------------------------------------------------------
#: What the words of the claims are taken to mean, in numbers.
SMALL_FRACTION = 0.25  # claim 1: "a small fraction": at most a quarter
PULLED_AWAY = 0.10  # claim 1: joint 3's peak drops by at least 10 % of its limit
MUCH_SMALLER = 0.75  # claim 4: "much smaller": at most three quarters
HIGH_SPEED = 3.0  # claims 3, 6: "high joint speed": 3 times pinv's fastest joint on the long movement
NEAR_ALIGNMENT = 0.1  # claims 3, 6: a speed peak "as links 2 and 3 straighten": within 0.1 s [s]


def check_claims(results: PaperResults) -> list[Claim]:
    """The six claims of the paper (issue 3), each with its verdict and numbers.

    The thresholds that turn the paper's words into numbers are the module
    constants ``SMALL_FRACTION``, ``PULLED_AWAY``, ``MUCH_SMALLER``,
    ``HIGH_SPEED`` and ``NEAR_ALIGNMENT``.
    """
    # A run that stopped at its first step has no rows: its peaks are 0 and
    # ratios of them nan, which every comparison below counts as "does not hold".
    with np.errstate(divide="ignore", invalid="ignore"):
        return _check_claims(results)


def _check_claims(results: PaperResults) -> list[Claim]:
    runs, judged = results.runs, results.whiplash
    limit = np.asarray(results.scenario.torque_limit)

    def peak(movement, name):
        return runs[movement, name].peak_torque

    def within(movement, name):
        return runs[movement, name].first_limit_violation is None and runs[movement, name].completed

    def fmt(values):
        return "[" + ", ".join(f"{v:.3g}" for v in values) + "]"

    claims = []
    pinv, null = peak("short", "pinv"), peak("short", "null-space")
    fraction = null[0] / pinv[0]
    pulled = (pinv[2] - null[2]) / limit[2]
    claims.append(Claim(
        1,
        "short: null-space cuts the peak joint-1 torque to a small fraction of pinv's and pulls joint 3 "
        "away from its 6 N·m limit",
        bool(fraction <= SMALL_FRACTION and pulled >= PULLED_AWAY),
        f"peak |τ| pinv {fmt(pinv)}, null-space {fmt(null)} N·m: joint 1 at {fraction:.1%} of pinv's "
        f"(small: <= {SMALL_FRACTION:.0%}); joint 3 at {pinv[2] / limit[2]:.0%} of its limit with pinv, "
        f"{null[2] / limit[2]:.0%} with null-space (pulled away: by >= {PULLED_AWAY:.0%} of the limit)",
    ))

    pinv, null = peak("medium", "pinv"), peak("medium", "null-space")
    claims.append(Claim(
        2,
        "medium: null-space still needs less peak torque than pinv at joints 1 and 3 and stays within all "
        "limits, though joint 2 is larger",
        bool(null[0] < pinv[0] and null[2] < pinv[2] and within("medium", "null-space") and null[1] > pinv[1]),
        f"peak |τ| pinv {fmt(pinv)}, null-space {fmt(null)} N·m, limits {fmt(limit)}; null-space first limit "
        f"violation: {_when(runs['medium', 'null-space'].first_limit_violation)}",
    ))

    long_pinv, long_null = runs["long", "pinv"], runs["long", "null-space"]
    verdict = judged["long", "null-space"]
    pinv_speed = float(np.abs(long_pinv.v).max(initial=0.0))
    aligned = [t for t in alignment_times(long_null) if verdict.time is not None and t >= verdict.time - NEAR_ALIGNMENT]
    speed_at = [_speed_at(long_null, t) for t in aligned]
    fast = [pinv_speed > 0 and s >= HIGH_SPEED * pinv_speed for s in speed_at]
    late = bool(verdict.unstable and verdict.time > 0.5 * long_null.duration)
    claims.append(Claim(
        3,
        "long: pinv stays within all limits; null-space goes unstable late in the movement, with links 2 and 3 "
        "passing through alignment at high joint speeds",
        bool(within("long", "pinv") and not judged["long", "pinv"].unstable and late and any(fast)),
        f"pinv peak |τ| {fmt(long_pinv.peak_torque)} N·m, fastest joint {pinv_speed:.3g} rad/s; null-space "
        f"{_verdict_text(verdict)} of {long_null.duration:g} s, peak |τ| {fmt(long_null.peak_torque)} N·m; "
        f"links 2 and 3 in line at t = {fmt(aligned)} s with the fastest joint at {fmt(speed_at)} rad/s "
        f"(high: >= {HIGH_SPEED:g} x pinv's {pinv_speed:.3g} rad/s)",
    ))

    weighted, null = peak("short", "weighted-null-space"), peak("short", "null-space")
    ratio = weighted[2] / null[2]
    claims.append(Claim(
        4,
        "short: weighted-null-space makes joint 3's torque much smaller than null-space's at the expense of "
        "joints 1 and 2, all within limits",
        bool(ratio <= MUCH_SMALLER and weighted[0] > null[0] and weighted[1] > null[1]
             and within("short", "weighted-null-space")),
        f"peak |τ| weighted {fmt(weighted)}, null-space {fmt(null)} N·m: joint 3 at {ratio:.0%} of null-space's "
        f"(much smaller: <= {MUCH_SMALLER:.0%}); weighted peak/limit {fmt(weighted / limit)}",
    ))

    inertia, pinv, null = peak("short", "inertia-pinv"), peak("short", "pinv"), peak("short", "null-space")
    between = [min(p, z) <= i <= max(p, z) for i, p, z in zip(inertia, pinv, null)]
    unstable_long = {name: judged["long", name] for name in ("weighted-null-space", "inertia-pinv")}
    claims.append(Claim(
        5,
        "long: weighted-null-space and inertia-pinv go unstable too; inertia-pinv's torques in the short "
        "movement lie between those of pinv and null-space for most joints",
        bool(all(v.unstable for v in unstable_long.values()) and sum(between) > len(between) / 2),
        "; ".join(f"{name} {_verdict_text(v)}" for name, v in unstable_long.items())
        + f"; short peak |τ| inertia-pinv {fmt(inertia)}, pinv {fmt(pinv)}, null-space {fmt(null)} N·m: between "
        f"for joints {[i + 1 for i, b in enumerate(between) if b]} of {len(between)}",
    ))

    swing = results.free_swing
    speed = np.abs(swing.v).max(axis=1, initial=0.0)
    peak_row = int(np.argmax(speed))
    peak_time, peak_speed = float(swing.t[peak_row]), float(speed[peak_row])
    peak_joint = swing.joint_names[int(np.argmax(np.abs(swing.v[peak_row])))]
    swing_aligned = alignment_times(swing)
    nearest = min(swing_aligned, key=lambda t: abs(t - peak_time)) if swing_aligned else None
    claims.append(Claim(
        6,
        "the free-swinging arm shows the same whip: a joint-speed peak as links 2 and 3 straighten",
        bool(nearest is not None and abs(nearest - peak_time) <= NEAR_ALIGNMENT and pinv_speed > 0
             and peak_speed >= HIGH_SPEED * pinv_speed),
        f"zero torque, gravity {fmt(results.free_swing_gravity)} m/s²: fastest joint {peak_joint} at "
        f"{peak_speed:.3g} rad/s at t = {peak_time:.3f} s; links 2 and 3 in line at t = {fmt(swing_aligned)} s "
        f"(near: within {NEAR_ALIGNMENT:g} s; high: >= {HIGH_SPEED:g} x pinv's {pinv_speed:.3g} rad/s)",
    ))
    return claims


def _speed_at(result: SimResult, time: float) -> float:
    row = int(np.clip(np.searchsorted(result.t, time), 0, len(result.t) - 1))
    return float(np.abs(result.v[row]).max())


def _when(time: float | None) -> str:
    return "none" if time is None else f"t = {time:.3f} s"


def _verdict_text(report: WhiplashReport) -> str:
    return f"unstable from t = {report.time:.3f} s" if report.unstable else "stable"


# -- files ---------------------------------------------------------------------
def summary_entries(results: PaperResults) -> list[dict]:
    """One JSON-ready entry per (movement, resolver) run, with exactly the fields of issue 3."""
    entries = []
    for (movement, name), result in results.runs.items():
        report = results.whiplash[movement, name]
        entries.append({
            "movement": movement,
            "resolver": name,
            "duration": result.duration,
            "peak_torque": result.peak_torque.tolist(),
            "torque_limit": [float(x) if np.isfinite(x) else None for x in result.torque_upper],
            "first_limit_violation": result.first_limit_violation,
            "unstable": report.unstable,
            "instability_time": report.time,
            "max_tip_error": result.max_tip_error,
        })
    return entries


def write_paper(results: PaperResults, out_dir: str | os.PathLike) -> list[Path]:
    """Write Figures 2-7, the long-movement stick-figure strips, summary.json and summary.md into ``out_dir``."""
    from . import plots

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInput(f"output '{out}' exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    scenario, runs, judged = results.scenario, results.runs, results.whiplash

    def unstable(movement, *names):
        return {name: judged[movement, name].time for name in names}

    def movement_text(movement):
        line = scenario.line(movement)
        return f"{movement} movement ({line.duration:g} s, {line.length:.3g} m straight line, peak tip speed {line.peak_speed:.3g} m/s)"

    written = []
    comparisons = (
        ("fig2.png", "short", ("pinv", "null-space"), "Fig. 2"),
        ("fig3.png", "medium", ("pinv", "null-space"), "Fig. 3"),
        ("fig4.png", "long", ("pinv", "null-space"), "Fig. 4"),
        ("fig6.png", "short", ("weighted-null-space", "inertia-pinv"), "Fig. 6"),
    )
    for filename, movement, names, label in comparisons:
        title = f"{label}: joint torques, {' vs '.join(names)}, {movement_text(movement)}"
        written.append(plots.plot_torques([runs[movement, n] for n in names], out / filename, title=title,
                                          instability_times=unstable(movement, *names)))

    long_null = runs["long", "null-space"]
    events = _events(long_null, judged["long", "null-space"])
    written.append(plots.plot_motion(
        long_null, out / "fig5.png",
        title=f"Fig. 5: joint velocities and accelerations of the null-space method, {movement_text('long')}",
        events=events,
    ))
    swing = results.free_swing
    gravity = np.linalg.norm(results.free_swing_gravity)
    written.append(plots.plot_stick_strip(
        results.robot, swing, out / "fig7.png",
        title=(
            f"Fig. 7: free-swinging arm: zero torque, gravity {gravity:.3g} m/s² along the line direction "
            f"(initial tip acceleration {scenario.accel:.3g} m/s²), {swing.duration:g} s; dashed: the long "
            "movement's straight line, which the swing replaces"
        ),
        snapshots=10,
        events=dict(zip(["links 2 and 3 in line"], alignment_times(swing))),
    ))
    for name in resolver_names():
        result = runs["long", name]
        verdict = judged["long", name]
        state = _verdict_text(verdict)
        written.append(plots.plot_stick_strip(
            results.robot, result, out / f"arm_long_{name}.png",
            title=f"{name}: the arm during the {movement_text('long')}: {state}",
            snapshots=10,
            events=_events(result, verdict),
        ))
    written.append(plots.plot_tip_path(
        [runs["long", name] for name in resolver_names()], out / "tip_long.png",
        title=f"Tip paths of the four resolvers, {movement_text('long')} (open loop)",
    ))

    summary = {
        "scenario": scenario.as_dict(),
        "whiplash": {
            "definition": (
                "unstable from the first sample at which some joint needs more than limit_factor times its "
                "torque limit (joints without a limit: more than growth_factor times the largest starting "
                "torque of such joints); see torqueopt.whiplash"
            ),
            "limit_factor": results.limit_factor,
            "growth_factor": results.growth_factor,
        },
        "runs": summary_entries(results),
        "free_swing": {
            "gravity": results.free_swing_gravity.tolist(),
            "duration": swing.duration,
            "peak_joint_speed": np.abs(swing.v).max(axis=0).tolist(),
            "peak_joint_speed_time": [float(swing.t[i]) for i in np.abs(swing.v).argmax(axis=0)],
            "links_2_3_aligned": alignment_times(swing),
        },
        "claims": [dataclasses.asdict(claim) for claim in results.claims],
        "figures": [path.name for path in written],
    }
    summary_json = (json.dumps(summary, indent=2) + "\n").encode()
    atomic_write(out / "summary.json", lambda handle: handle.write(summary_json))
    markdown = format_summary_markdown(results, [path.name for path in written]).encode()
    atomic_write(out / "summary.md", lambda handle: handle.write(markdown))
    return [*written, out / "summary.json", out / "summary.md"]


def _events(result: SimResult, report: WhiplashReport) -> dict[str, float]:
    events = {}
    if report.unstable:
        events[f"{result.resolver} unstable"] = report.time
    aligned = alignment_times(result)
    if aligned:
        events["links 2 and 3 first in line"] = aligned[0]
    return events


def format_summary_markdown(results: PaperResults, figures: list[str]) -> str:
    """The readable summary: scenario, instability definition, one row per run, the claims."""
    scenario = results.scenario
    q0 = ", ".join(f"{a:g}°" for a in np.degrees(scenario.q0).round(6))
    direction = np.asarray(scenario.direction) / np.linalg.norm(scenario.direction)
    lines = [
        "# Hollerbach & Suh 1987, reproduced by torqueopt",
        "",
        f"Scenario `paper`: arm `{scenario.robot}` (three 1 m, 10 kg thin rods, no gravity), q0 = ({q0}), "
        f"line direction ({direction[0]:.4g}, {direction[1]:.4g}), tangential acceleration {scenario.accel:.4g} m/s², "
        f"torque limits {', '.join(f'{x:g}' for x in scenario.torque_limit)} N·m, "
        f"W = diag(1/limit²), RK4 with dt = {scenario.dt * 1e3:g} ms and the torque held over each step, open loop. "
        "Movements: " + ", ".join(f"{m} {d:g} s" for m, d in zip(MOVEMENTS, scenario.durations)) + ".",
        "",
        (
            f"**Unstable** (whiplash): from the first sample at which some joint needs more than "
            f"{results.limit_factor:g} times its torque limit (a joint without a limit: more than "
            f"{results.growth_factor:g} times the torque the movement started with). Tip error is the distance "
            "from the reference path; the simulation tracks open loop, as the paper did."
        ),
        "",
        (
            "| movement | resolver | duration [s] | peak torque [N·m] | limit [N·m] | first limit violation [s] "
            "| unstable | instability time [s] | max tip error [mm] |"
        ),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for entry in summary_entries(results):
        peaks = ", ".join(f"{x:.3g}" for x in entry["peak_torque"])
        limits = ", ".join("none" if x is None else f"{x:g}" for x in entry["torque_limit"])
        violation = "-" if entry["first_limit_violation"] is None else f"{entry['first_limit_violation']:.3f}"
        when = "-" if entry["instability_time"] is None else f"{entry['instability_time']:.3f}"
        lines.append(
            f"| {entry['movement']} | {entry['resolver']} | {entry['duration']:g} | {peaks} | {limits} | {violation} "
            f"| {'**yes**' if entry['unstable'] else 'no'} | {when} | {entry['max_tip_error'] * 1e3:.3g} |"
        )
    stopped = [f"- {m} {n}: {results.runs[m, n].stop_reason}" for m, n in results.stopped_early]
    if stopped:
        lines += ["", "Runs that stopped early (their rows up to then are summarised):", "", *stopped]
    lines += ["", "## Why each unstable run tripped", ""]
    tripped = [(key, report) for key, report in results.whiplash.items() if report.unstable]
    lines += [f"- {m} {n}: {report.reason}" for (m, n), report in tripped] or ["- none"]
    swing = results.free_swing
    gravity = results.free_swing_gravity
    lines += [
        "",
        "## Free swing (Fig. 7)",
        "",
        f"Zero torque from q0 at rest, gravity ({gravity[0]:.4g}, {gravity[1]:.4g}, {gravity[2]:.4g}) m/s² "
        f"({np.linalg.norm(gravity):.4g} m/s² along the line direction, so that the tip starts with "
        f"{scenario.accel:.4g} m/s²), {swing.duration:g} s. Peak joint speeds "
        + ", ".join(f"{name} {s:.3g} rad/s" for name, s in zip(swing.joint_names, np.abs(swing.v).max(axis=0)))
        + "; links 2 and 3 in line at t = "
        + (", ".join(f"{t:.3f}" for t in alignment_times(swing)) or "never")
        + " s.",
        "",
        "## The paper's claims",
        "",
    ]
    for claim in results.claims:
        lines.append(f"{claim.number}. **{'holds' if claim.holds else 'DOES NOT HOLD'}**: {claim.statement}.  ")
        lines.append(f"   {claim.evidence}.")
    lines += ["", "## Figures", ""]
    descriptions = {
        "fig2.png": "short movement, torques of pinv and null-space with the ± limits",
        "fig3.png": "medium movement, the same",
        "fig4.png": "long movement, the same: null-space goes unstable",
        "fig5.png": "joint velocities and accelerations of the long null-space movement",
        "fig6.png": "short movement, weighted-null-space and inertia-pinv",
        "fig7.png": "the free-swinging arm as stick figures, with its joint speeds",
        "tip_long.png": "tip paths of the long movement against the straight line",
    }
    for name in figures:
        text = descriptions.get(name)
        if text is None and name.startswith("arm_long_"):
            text = f"stick figures of the arm during the long movement, {name[len('arm_long_'):-len('.png')]}"
        lines.append(f"- `{name}`: {text}")
    return "\n".join(lines) + "\n"

