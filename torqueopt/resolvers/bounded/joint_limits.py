r"""Joint position, velocity and acceleration limits as bounds on :math:`\ddot q`, for any bounded resolver.

The formulation is A. Del Prete, "Joint position and velocity bounds in
discrete-time acceleration/torque control of robot manipulators", IEEE
Robotics and Automation Letters 3(1), 2018 (as tsid implements it in
``TaskJointPosVelAccBounds``). With the joint acceleration :math:`a = \ddot q_i`
held over the step :math:`\delta` [s] from the state :math:`(q_i, \dot q_i)`,

.. math::

    q_i^+ = q_i + \delta\dot q_i + \tfrac12\delta^2 a, \qquad \dot q_i^+ = \dot q_i + \delta a,

and per joint, with position limits :math:`[q^-_i, q^+_i]` [rad], velocity
limit :math:`\dot q^{max}_i` [rad/s] and maximum deceleration
:math:`\bar a_i > 0` [rad/s²], the bounds on :math:`a` are the tightest of

position
    :math:`q_i^+ \le q^+_i`: :math:`a \le 2(q^+_i - q_i - \delta\dot q_i)/\delta^2`;
    when that bound would reverse the velocity inside the step
    (:math:`a < -\dot q_i/\delta`, :math:`\dot q_i > 0`), the joint's turning
    point :math:`q_i - \dot q_i^2/(2a)` must stay within the limit too:
    :math:`a \le \min(-\dot q_i^2/(2(q^+_i - q_i)), -\dot q_i/\delta)`.
    The same, mirrored, at :math:`q^-_i`.
viability
    the next state can still stop before the limit decelerating at
    :math:`\bar a_i`. Del Prete's condition is :math:`q_i^+ + (\dot q_i^+)^2/(2\bar a_i) \le q^+_i`,
    the braking parabola :math:`\dot q \le \sqrt{2\bar a_i d}` at the distance
    :math:`d = q^+_i - q` from the limit. Its slope is infinite at the limit: a
    joint pushed into the limit arrives there with speed, and a held torque
    whose acceleration drifts inside the step by a few percent then rebounds
    from it step after step (the torque chatters by tens of N·m on panda). Here
    the parabola is offset so that it meets the limit with the finite slope
    :math:`k = 1/(N\delta)` (:data:`APPROACH_STEPS` N = 10),

    .. math::

        \dot q \le \sqrt{2\bar a_i (d + d_0)} - w,\qquad w = \bar a_i/k,\quad d_0 = w^2/(2\bar a_i),

    a curve inside Del Prete's (every state under it can stop at
    :math:`\bar a_i`), that needs no more than :math:`\bar a_i` to ride
    (:math:`f f' \le \bar a_i`) and that brings a joint to rest on its limit
    along :math:`\dot q \approx k d` without rebounding. The bound is its
    condition on the next state, :math:`(\dot q_i^+ + w)^2 \le 2\bar a_i(q^+_i + d_0 - q_i^+)`,
    a quadratic in a whose larger root is

    .. math::

        a \le \frac{-2c}{b + \sqrt{b^2 - 4\delta^2 c}},\quad
        b = 2\delta(\dot q_i + w) + \bar a_i\delta^2,\quad
        c = (\dot q_i + w)^2 - 2\bar a_i(q^+_i + d_0 - q_i - \delta\dot q_i),

    (Del Prete's root, written without cancellation; w = 0 gives his bound
    exactly), and never below :math:`-\dot q_i/\delta` (stopping within the
    step is always allowed); mirrored at :math:`q^-_i`.

    A state above the curve of :math:`\bar a_i` (:math:`\bar a_i` is derived at
    each state, and falls when the bias torque grows) is asked back under it
    within one step where the torque box gives the joint that braking (its
    lowest acceleration at the state, :func:`acceleration_range`, is below the
    bound). Where it does not (hundreds of rad/s² far from the limit, which no
    torque gives), the curve of the deceleration that passes through the state,

    .. math::

        \bar a^*_i = \frac{\dot q_i^2}{2(d - N\delta\dot q_i)}\quad(d > N\delta\dot q_i),

    takes the place of :math:`\bar a_i` in the bound: the joint brakes at
    about :math:`\bar a^*_i`, what still brings it to rest on the limit, and
    the step asks for more only where that is more than the torque gives.
    Next to the limit (:math:`d \le N\delta\dot q_i`) no curve passes through
    the state, and the bound asks it back under the curve of :math:`\bar a_i`
    (every curve there is :math:`\dot q \approx k d`). Riding through where
    the box could bring the joint back let baxter's joints ride above their
    curves and meet their torque limits later (docs/guide/joint-limits.md).
velocity
    :math:`|\dot q_i^+| \le \dot q^{max}_i`:
    :math:`(-\dot q^{max}_i - \dot q_i)/\delta \le a \le (\dot q^{max}_i - \dot q_i)/\delta`.
acceleration
    :math:`|a| \le \ddot q^{max}_i` where an acceleration limit is given.

The maximum deceleration :math:`\bar a_i` is the acceleration limit where
one is given (option ``joint_acceleration_limit``). Otherwise it is derived
at each state from the torque limit, the mass matrix, the bias torque
:math:`b = C(q, \dot q)\dot q + g(q)` and the gravity torque :math:`g(q)`
(Pinocchio's ``computeGeneralizedGravity``),

.. math::

    \bar a_i = \tfrac12\,\frac{\max(\tau^{max}_i - |b_i|,\ 0.1\,\tau^{max}_i)}{H_{ii}},

half the acceleration joint i's own torque gives it beyond the bias, with the
other joints at rest (a tenth of the limit where the bias takes more than
nine tenths). The half leaves torque for the task and for the other joints,
which the real stop also moves. The velocity terms of the bias, :math:`b - g`
(Coriolis, centrifugal, the joints' damping and friction), are counted at
their value at the state: the task keeps the other joints moving while one
brakes, and counting less lets a joint reach its limit faster than the
torque the task leaves can stop it (tiago's atlases give up the task on more
runs with gravity alone: docs/guide/joint-limits.md). Where they alone take
more than nine tenths of the limit, :math:`|b_i - g_i| > 0.9\,\tau^{max}_i`,
counting them as if they lasted the whole stop made states far from every
limit look unable to stop (on planar3, whose Coriolis torque can exceed a
joint's whole limit, the step gave up the task 8.5 rad from any limit). Velocity terms that large fall as the joints
slow, and there ā is at least that of gravity alone,
:math:`\tfrac12\max(\tau^{max}_i - |g_i|, 0.1\,\tau^{max}_i)/H_{ii}`. ā
jumps where the velocity terms cross that share; a state that a smaller ā
leaves above its curve is handled as above. A joint without a torque limit
and without an acceleration limit can stop at once: it has no viability
bound. :math:`\bar a_i` is the same in both directions, and it is not a
proven bound.

What the torque box really gives joint i at the state, each way, is the box
LP of :math:`\ddot q_i = [H^{-1}(\tau - b)]_i` over :math:`\tau^- \le \tau \le \tau^+`.
Each :math:`\tau_j` sits at the end of its range that the sign of
:math:`(H^{-1})_{ij}` picks, so the LP has the closed form
:math:`c_i \mp \sum_j |(H^{-1})_{ij}|\rho_j`, with :math:`c = H^{-1}(\tau_{mid} - b)`
and :math:`\rho` the half-ranges (:func:`acceleration_range`, held to HiGHS in
the tests). It is exact for one joint alone, but several joints that must stop at
once cannot each have their own extreme, and no share of it measured on the
arms' atlases kept them as they were (docs/guide/joint-limits.md).

A run holds the torque over the step, not the acceleration: the
acceleration drifts inside the step with the state, and the state at the
end of it differs from the constant-acceleration prediction above (measured
on panda, xarm7, tiago and baxter, 1 s lines in six directions at δ = 1 ms,
without margins: up to 0.35 % of a velocity limit and 2.1e-6 rad beyond a
position limit, at steps that ride a bound). The bounds are therefore computed
for limits pulled in by :data:`VELOCITY_MARGIN` of each velocity limit and
:data:`POSITION_MARGIN` at each position limit, so that the run stays
inside the URDF's own limits.

A joint beyond a pulled-in limit, such as a start on the URDF's limit, is not
asked back inside the margin in one step: that would take
:math:`2\cdot 10^{-4}/\delta^2` = 200 rad/s² at 1 ms, far more than the torque
gives. Its position bound asks it to stop within the step and come back
at :math:`\bar a` at most:
:math:`a \le \max(2(q^+_i - q_i - \delta\dot q_i)/\delta^2,\ -\dot q_i/\delta - \bar a_i)`.
A drift-size excess is still taken back in one step (1e-7 rad asks
0.2 rad/s²). A bound that only held such a joint where it stands would not
return it, and the drift could carry it through the margin step by step.
Measured on tiago's path 120 of its atlas, ``energy-bounded-torque``: arm_7
crossed the 1e-4 rad margin in 40 ms and left its URDF limit by 8.3e-7 rad,
with no infeasible step.

When a joint's bounds cross (a state outside its limits, or not viable with
:math:`\bar a_i`), the bound of the higher kind wins (position, then
viability, then velocity, then acceleration) and the joint's acceleration is
pinned to it. Joints without any finite limit have no rows.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ...checks import Refused, finite_array
from ...robot import Robot, TaskTerms
from ..options import Option

__all__ = [
    "APPROACH_STEPS",
    "BOUND_KINDS",
    "DEFAULT_STEP",
    "JOINT_ACCELERATION_LIMIT_OPTION",
    "JOINT_LIMITS_OPTION",
    "AccelerationBounds",
    "JointLimits",
    "POSITION_MARGIN",
    "VELOCITY_MARGIN",
    "acceleration_bounds",
    "acceleration_range",
    "stopping_deceleration",
]

#: The kinds of a joint-acceleration bound, in the order in which they win when two cross.
BOUND_KINDS = ("position", "viability", "velocity", "acceleration")
_NONE = len(BOUND_KINDS)
#: The step δ [s] the bounds assume when the resolver is not told the run's (simulate's default dt).
DEFAULT_STEP = 1e-3
#: Fraction of each velocity limit by which the bounds pull it in (the held torque's drift inside a step).
VELOCITY_MARGIN = 0.01
#: How far inside each position limit [rad or m] the bounds keep the joint (the same drift).
POSITION_MARGIN = 1e-4
#: The viability bound's approach to a limit: within about ā·(APPROACH_STEPS·δ)²/2 of it, a joint's speed towards it
#: is at most its distance over APPROACH_STEPS steps, so that it comes to rest on the limit without rebounding.
APPROACH_STEPS = 10
#: Fraction of a joint's own torque-limited acceleration taken as its maximum deceleration.
STOPPING_FRACTION = 0.5
#: The least share of the torque limit counted as available to stop, when the bias torque takes more; where the
#: velocity terms alone take more than 1 − this of the limit, ā counts at least what gravity alone leaves.
LEAST_STOPPING_SHARE = 0.1


def _on_off(value) -> str:
    if value is True or value is False:
        return "on" if value else "off"
    text = str(value).strip().lower() if isinstance(value, str) else value
    if text not in ("on", "off"):
        raise Refused("must be 'on' or 'off'")
    return text


def _acceleration_limit(value):
    if isinstance(value, str) and value.strip() == "torque":
        return "torque"
    if isinstance(value, str) and not any(ch.isdigit() for ch in value):
        raise Refused("must be 'torque' or a positive number or vector")
    array = finite_array(value, "'torque' or a number or vector")
    if array.ndim > 1 or not (array > 0).all():
        raise Refused("must be 'torque' or a positive number or vector")
    return float(array) if array.ndim == 0 else array


JOINT_LIMITS_OPTION = Option(
    name="joint_limits",
    kind="'on' | 'off'",
    unit="",
    default="on",
    meaning=(
        "the URDF's joint position and velocity limits (and joint_acceleration_limit) as bounds on q̈ that keep "
        "the next state inside them and able to stop (Del Prete, RA-L 2018); 'off': torque bounds only"
    ),
    convert=_on_off,
)

JOINT_ACCELERATION_LIMIT_OPTION = Option(
    name="joint_acceleration_limit",
    kind="'torque' | number > 0 | vector (n)",
    unit="rad/s²",
    default="torque",
    meaning=(
        "joint acceleration limits |q̈| <= value, also the deceleration the joint-limit bounds count on to stop; "
        "'torque': none, the deceleration derived at each state from the torque limits and H"
    ),
    convert=_acceleration_limit,
)


class AccelerationBounds(NamedTuple):
    r"""Bounds on the joint accelerations of the limited joints at one state.

    Attributes:
        lower, upper: the bounds [rad/s²], one per limited joint.
        lower_kind, upper_kind: which bound each is, an index into :data:`BOUND_KINDS`
            (``len(BOUND_KINDS)`` for an infinite bound).
        deceleration: the larger of the decelerations :math:`\bar a^\pm_i` [rad/s²] assumed before the two limits
            (inf when the joint can stop at once), the scale of the joint's row.
    """

    lower: np.ndarray
    upper: np.ndarray
    lower_kind: np.ndarray
    upper_kind: np.ndarray
    deceleration: np.ndarray


def acceleration_range(terms: TaskTerms, torque_upper: np.ndarray, torque_lower: np.ndarray):
    r"""(lowest, highest) [rad/s²]: each joint's acceleration :math:`[H^{-1}(\tau - b)]_i` over the torque box.

    The box LP in closed form (module docstring): :math:`c_i \mp \sum_j |(H^{-1})_{ij}|\rho_j`,
    :math:`c = H^{-1}(\tau_{mid} - b)`. ``torque_upper``/``torque_lower`` [N·m]
    are per joint. A joint without a torque limit counts at 0 N·m in the others' ranges, and its own is
    (−inf, inf). One state (n values) or, from :class:`~torqueopt.resolvers.stacks.StackTerms`, one row per
    state (B × n).
    """
    bounded = np.isfinite(torque_upper) & np.isfinite(torque_lower)
    upper, lower = np.where(bounded, torque_upper, 0.0), np.where(bounded, torque_lower, 0.0)
    middle, half_range = 0.5 * (upper + lower), 0.5 * (upper - lower)
    inverse = np.linalg.inv(terms.inertia)  # H⁻¹
    centre = np.einsum("...ij,...j->...i", inverse, middle - terms.bias_torque)
    reach = np.where(bounded, np.abs(inverse) @ half_range, np.inf)
    return centre - reach, centre + reach


def stopping_deceleration(
    terms: TaskTerms, torque_upper: np.ndarray, torque_lower: np.ndarray, gravity_torque: np.ndarray
):
    r"""(:math:`\bar a^+`, :math:`\bar a^-`) [rad/s²]: the deceleration counted on before each joint's upper limit and
    before its lower one, from the torque limits [N·m], H and the bias torque b at the state of ``terms`` and the
    gravity torque :math:`g(q)` [N·m] there (module docstring).

    :math:`\bar a_i = \tfrac12\max(\tau^{max}_i - |b_i|, 0.1\tau^{max}_i)/H_{ii}`, and at least
    :math:`\tfrac12\max(\tau^{max}_i - |g_i|, 0.1\tau^{max}_i)/H_{ii}` where the velocity terms :math:`|b_i - g_i|` alone
    take more than nine tenths of :math:`\tau^{max}_i`; the same both ways, inf where the torque is unbounded. One
    state (n values each) or a stack (B × n).
    """
    limit = np.minimum(torque_upper, -torque_lower)
    least = LEAST_STOPPING_SHARE * limit
    beyond_bias = np.maximum(limit - np.abs(terms.bias_torque), least)
    # Velocity terms that alone take more than nine tenths of the limit are not counted: they fall as the joints slow.
    taken = np.abs(terms.bias_torque - gravity_torque) > (1.0 - LEAST_STOPPING_SHARE) * limit
    available = np.where(taken, np.maximum(beyond_bias, np.maximum(limit - np.abs(gravity_torque), least)), beyond_bias)
    deceleration = STOPPING_FRACTION * available / np.diagonal(terms.inertia, axis1=-2, axis2=-1)
    return deceleration, deceleration


def _through(distance, speed, scale, deceleration):
    r"""The larger of ``deceleration`` and the one whose approach curve passes through the state.

    Towards a limit at ``distance`` d [rad] with ``speed`` q̇ > 0 [rad/s], the approach curve of the deceleration a
    (scale Nδ [s], module docstring) passes through the state where q̇² = 2a(d − Nδq̇): a = q̇²/(2(d − Nδq̇)). Where
    no curve does (d <= Nδq̇, next to the limit) or the state is under the curve of ``deceleration``, that one.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        room = distance - scale * speed
        through = speed**2 / (2.0 * room)
    return np.where((speed > 0.0) & (room > 0.0) & (through > deceleration), through, deceleration)


def _viability_roots(dt, q, v, lower, upper, upper_brake, lower_brake, scale):
    r"""(upper, lower) bound on a that keeps the next state under the approach curves of ``upper_brake`` ā⁺ before the
    upper limit and ``lower_brake`` ā⁻ before the lower one (module docstring; ``scale`` Nδ [s], 0: Del Prete's
    parabola). NaN where no a does.
    """
    offset, lower_offset = upper_brake * scale, lower_brake * scale
    reach, lower_reach = 0.5 * offset**2 / upper_brake, 0.5 * lower_offset**2 / lower_brake
    root_up = _larger_root(
        dt,
        2.0 * dt * (v + offset) + upper_brake * dt**2,
        (v + offset) ** 2 - 2.0 * upper_brake * (upper + reach - q - dt * v),
    )
    root_down = -_larger_root(
        dt,
        2.0 * dt * (lower_offset - v) + lower_brake * dt**2,
        (lower_offset - v) ** 2 - 2.0 * lower_brake * (q + dt * v - lower + lower_reach),
    )
    return root_up, root_down


def _pick(candidates, choose):
    """Per joint, the tightest of the stacked ``candidates`` (kinds × joints) and which kind it is."""
    kind = choose(candidates, axis=0)
    value = np.take_along_axis(candidates, kind[None, :], axis=0)[0]
    return value, np.where(np.isfinite(value), kind, _NONE)


def _larger_root(dt, b, c):
    """The larger root of δ²a² + b a + c = 0 (NaN where there is none), as −2c/(b + √(b² − 4δ²c)) where b > 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        discriminant = np.sqrt(b**2 - 4.0 * dt**2 * c)
        return np.where(b > 0.0, -2.0 * c / (b + discriminant), (discriminant - b) / (2.0 * dt**2))


def acceleration_bounds(
    angle,
    velocity,
    step,
    position_lower,
    position_upper,
    velocity_limit,
    deceleration,
    acceleration_limit,
    approach: bool = True,
    lower_deceleration=None,
    box_range=None,
) -> AccelerationBounds:
    r"""Del Prete's bounds on :math:`\ddot q` (module docstring) for joints at ``angle`` [rad], ``velocity`` [rad/s].

    All arguments are arrays of one value per joint (±inf where a joint has
    no such limit), but ``step``, δ [s]; ``angle``, ``velocity`` and
    ``deceleration`` (and ``lower_deceleration``) may be stacks of states (B × joints), the limits broadcast along them.
    ``deceleration`` is :math:`\bar a^+` [rad/s²], the deceleration that stops the joint before its upper limit
    (inf: at once), ``lower_deceleration`` :math:`\bar a^-`, before its lower limit (None: ``deceleration``),
    ``acceleration_limit``
    :math:`\ddot q^{max}` [rad/s²] (inf: none). ``approach=False`` is Del Prete's braking parabola
    without the offset (w = 0), kept for comparison: it rebounds from a limit it is pushed into. ``box_range`` is
    (lowest, highest) [rad/s²], what the torque box gives each joint at the state (:func:`acceleration_range`): a state
    above its curve is asked back under it within one step where that lies within them, and rides the curve through it
    where it does not (None: wherever it is above).
    """
    q, v, dt = np.asarray(angle, float), np.asarray(velocity, float), float(step)
    lower, upper = np.asarray(position_lower, float), np.asarray(position_upper, float)
    upper_brake = np.asarray(deceleration, float)
    lower_brake = upper_brake if lower_deceleration is None else np.asarray(lower_deceleration, float)
    stop_in_step = -v / dt
    with np.errstate(divide="ignore", invalid="ignore"):
        # Position: q⁺ = q + δq̇ + ½δ²a within [q⁻, q⁺], and the turning point inside the step too.
        upper_next = 2.0 * (upper - q - dt * v) / dt**2
        lower_next = 2.0 * (lower - q - dt * v) / dt**2
        upper_turn = np.minimum(-(v**2) / (2.0 * (upper - q)), stop_in_step)
        lower_turn = np.maximum(v**2 / (2.0 * (q - lower)), stop_in_step)
        turns_up = (v > 0) & (upper_next <= stop_in_step) & (q < upper)
        turns_down = (v < 0) & (lower_next >= stop_in_step) & (q > lower)
        upper_position = np.where(turns_up, upper_turn, upper_next)
        lower_position = np.where(turns_down, lower_turn, lower_next)
        # Beyond the limit (a start on the URDF's, inside the margin): stop within the step, then back at ā at most.
        upper_position = np.where(q > upper, np.maximum(upper_position, stop_in_step - upper_brake), upper_position)
        lower_position = np.where(q < lower, np.minimum(lower_position, stop_in_step + lower_brake), lower_position)
        # Viability: (q̇⁺ + w)² <= 2ā(q⁺_max + d − q⁺), Del Prete's braking parabola offset so that it meets the
        # limit with the finite slope 1/(APPROACH_STEPS·δ) (w = ā·APPROACH_STEPS·δ, d = w²/(2ā)); w = 0 is the
        # parabola itself. The larger root of δ²a² + B a + C = 0, in the form without cancellation where B > 0.
        # upper_brake stops the joint before its upper limit (a negative acceleration), lower_brake before its lower.
        scale = APPROACH_STEPS * dt if approach else 0.0
        root_up, root_down = _viability_roots(dt, q, v, lower, upper, upper_brake, lower_brake, scale)
        # A state above ā's curve is asked back under it within one step where the torque box gives that braking, and
        # rides the curve through it where it does not (more than ā, and more than the torque gives).
        lowest, highest = (np.inf, -np.inf) if box_range is None else box_range
        ride_up = np.nan_to_num(root_up, nan=-np.inf) < lowest
        ride_down = np.nan_to_num(root_down, nan=np.inf) > highest
        if ride_up.any() or ride_down.any():
            upper_ride = _through(upper - q, v, scale, upper_brake)
            lower_ride = _through(q - lower, -v, scale, lower_brake)
            ride_root_up, ride_root_down = _viability_roots(dt, q, v, lower, upper, upper_ride, lower_ride, scale)
            root_up = np.where(ride_up, ride_root_up, root_up)
            root_down = np.where(ride_down, ride_root_down, root_down)
    upper_viability = np.where(
        np.isfinite(upper_brake), np.fmax(np.nan_to_num(root_up, nan=-np.inf), stop_in_step), np.inf
    )
    lower_viability = np.where(
        np.isfinite(lower_brake), np.fmin(np.nan_to_num(root_down, nan=np.inf), stop_in_step), -np.inf
    )
    upper_viability = np.where(np.isfinite(upper), upper_viability, np.inf)
    lower_viability = np.where(np.isfinite(lower), lower_viability, -np.inf)
    # Velocity: |q̇ + δa| <= q̇_max.
    speed = np.asarray(velocity_limit, float)
    upper_velocity, lower_velocity = (speed - v) / dt, (-speed - v) / dt
    limit = np.asarray(acceleration_limit, float) * np.ones_like(q)
    high, high_kind = _pick(np.array([upper_position, upper_viability, upper_velocity, limit]), np.argmin)
    low, low_kind = _pick(np.array([lower_position, lower_viability, lower_velocity, -limit]), np.argmax)
    crossed = low > high
    if crossed.any():
        # The bound of the higher kind wins (position first), and pins the acceleration.
        upper_wins = crossed & (high_kind <= low_kind)
        lower_wins = crossed & ~upper_wins
        low = np.where(upper_wins, high, low)
        high = np.where(lower_wins, low, high)
    return AccelerationBounds(low, high, low_kind, high_kind, np.maximum(upper_brake, lower_brake) * np.ones_like(q))


class JointLimits:
    """A robot's joint limits as bounds on q̈ at each state, for a resolver's program (built once per run).

    ``joints`` are the indices of the joints with a finite position,
    velocity or acceleration limit: one row each. ``step`` is the run's dt
    [s] (:data:`DEFAULT_STEP` when not known), ``acceleration_limit`` the
    ``joint_acceleration_limit`` option ('torque', a number or n values [rad/s²]).
    """

    def __init__(self, robot: Robot, step: float | None = None, acceleration_limit="torque"):
        lower, upper, velocity = robot.joint_limits
        if isinstance(acceleration_limit, str):
            limit = np.full(robot.nv, np.inf)
        else:
            limit = np.asarray(acceleration_limit, float) * np.ones(robot.nv)
        limited = np.isfinite(lower) | np.isfinite(upper) | np.isfinite(velocity) | np.isfinite(limit)
        self.robot = robot
        self.joints = np.flatnonzero(limited)
        self.step = DEFAULT_STEP if step is None else float(step)
        self.derived = isinstance(acceleration_limit, str)
        joints = self.joints
        # The margins, but never past the middle of a joint's range.
        position_margin = np.minimum(POSITION_MARGIN, 0.25 * (upper - lower))[joints]
        self._lower, self._upper = lower[joints] + position_margin, upper[joints] - position_margin
        self._velocity, self._limit = (1.0 - VELOCITY_MARGIN) * velocity[joints], limit[joints]
        self._euclidean = robot.euclidean
        self._neutral = robot.configuration(np.zeros(robot.nv))
        self._data = robot.model.createData()

    @property
    def count(self) -> int:
        """The number of limited joints (rows)."""
        return self.joints.size

    def __call__(self, terms: TaskTerms) -> AccelerationBounds:
        """The bounds on q̈ of the limited joints at the state of ``terms``.

        One state (:class:`~torqueopt.robot.TaskTerms`: arrays of one value per
        limited joint) or a stack (:class:`~torqueopt.resolvers.stacks.StackTerms`:
        B × limited joints), by the same element-wise formulas.
        """
        joints = self.joints
        configuration = terms.configuration
        angles = configuration - self._neutral if self._euclidean else self.robot.joint_angles(configuration)
        angles = angles[..., joints]
        if self.derived:
            gravity = self.gravity_torque(configuration)
            before_upper, before_lower = stopping_deceleration(
                terms, self.robot.torque_upper, self.robot.torque_lower, gravity
            )
            before_upper, before_lower = before_upper[..., joints], before_lower[..., joints]
        else:
            before_upper = before_lower = self._limit
        lowest, highest = acceleration_range(terms, self.robot.torque_upper, self.robot.torque_lower)
        return acceleration_bounds(
            angles,
            terms.joint_velocity[..., joints],
            self.step,
            self._lower,
            self._upper,
            self._velocity,
            before_upper,
            self._limit,
            lower_deceleration=before_lower,
            box_range=(lowest[..., joints], highest[..., joints]),
        )

    def gravity_torque(self, configuration: np.ndarray) -> np.ndarray:
        """g(q) [N·m] by Pinocchio at one configuration (nq) or a stack (B × nq): n values or B × n."""
        model, data = self.robot.model, self._data
        if configuration.ndim == 1:
            return pin.computeGeneralizedGravity(model, data, configuration).copy()
        return np.array([pin.computeGeneralizedGravity(model, data, row).copy() for row in configuration])

    def scale(self, bounds: AccelerationBounds) -> np.ndarray:
        """Per row, the acceleration [rad/s²] it is divided by, so that the solver's tolerance is relative."""
        return np.where(np.isfinite(bounds.deceleration), bounds.deceleration, 1.0)

    def active(self, bounds: AccelerationBounds, acceleration: np.ndarray, tolerance: float = 1e-6) -> list[str]:
        """The joint bounds ``acceleration`` (n) [rad/s²] lies on, as "position limit (upper) of joint J" texts."""
        found = []
        joint_acceleration = acceleration[self.joints]
        scale = self.scale(bounds)
        names = self.robot.joint_names
        for side, bound, kinds in (
            ("upper", bounds.upper, bounds.upper_kind),
            ("lower", bounds.lower, bounds.lower_kind),
        ):
            on = np.isfinite(bound) & (np.abs(joint_acceleration - bound) <= tolerance * scale)
            for row in np.flatnonzero(on):
                found.append(f"{describe_kind(kinds[row])} ({side}) of joint {names[self.joints[row]]}")
        return found

    def exceeded(self, bounds: AccelerationBounds, acceleration: np.ndarray, tolerance: float = 1e-6) -> list[str]:
        """The joint bounds ``acceleration`` (n) [rad/s²] exceeds, as "position limit (upper) of joint J by X rad/s²" (m/s² for a prismatic joint)."""
        found = []
        joint_acceleration = acceleration[self.joints]
        scale = self.scale(bounds)
        names = self.robot.joint_names
        for side, beyond, kinds in (
            ("upper", joint_acceleration - bounds.upper, bounds.upper_kind),
            ("lower", bounds.lower - joint_acceleration, bounds.lower_kind),
        ):
            for row in np.flatnonzero(beyond > tolerance * scale):
                joint = self.joints[row]
                found.append(
                    f"{describe_kind(kinds[row])} ({side}) of joint {names[joint]} by {beyond[row]:.3g} "
                    f"{self.robot.joint_unit(joint, 'acceleration')}"
                )
        return found


def describe_kind(kind: int) -> str:
    """'position limit', 'position limit (stopping distance)', 'velocity limit', 'acceleration limit'."""
    return {0: "position limit", 1: "position limit (stopping distance)", 2: "velocity limit"}.get(
        int(kind), "acceleration limit"
    )
