r"""Many movements advanced together: the batched twin of :func:`torqueopt.simulate`.

:func:`simulate_batch` runs B movements of one robot and one resolver side
by side, one time step for the whole batch at a time. It computes what
:func:`~torqueopt.simulate` computes, in the same order, and the tests hold
each of its runs to the matching ``simulate`` run to 1e-9:

* the task terms :math:`H`, :math:`b = \dot q\cdot C\cdot\dot q + g`,
  :math:`J`, :math:`\dot J\dot q` and the tip placement come from Pinocchio
  through a :class:`~torqueopt.forest.RobotForest`: copies of the robot in one
  Pinocchio model, so four calls give the terms of a whole pass of movements
  (CRBA, RNEA, the joint Jacobians and their rate); the tests hold them to
  ``simulate``'s per-movement frame calls;
* the resolver's linear algebra runs on (B, ...) stacks at once: the complete
  QR of the task Jacobians (or, for two task rows on two or three joints, its
  closed form) gives :math:`J^\dagger r` and a null-space basis :math:`Z`,
  then each resolver's choice of the null-space coordinates :math:`y` is a
  batched solve (the formulas of :mod:`torqueopt.resolvers`, Eq. (31),
  Eq. (33), Eq. (34), Eq. (35), Eq. (36), Eq. (37));
* RK4 with the torque held (:func:`torqueopt.integrators.rk4_step`) takes the
  resolver's :math:`\ddot q` as its first stage and computes the other three
  stage accelerations of the whole batch with one ``pin.abaInParallel``
  call each, over a ``pin.ModelPool``.

A movement that stops early (singular Jacobian, runaway torque or speed,
non-finite values, for the reasons and with the messages of ``simulate``)
leaves the batch at once: the arrays are compacted, so the rest go on at
the cost of the movements still running.

Supported: the four paper resolvers (``pinv``, ``inertia-pinv``,
``null-space``, ``weighted-null-space``, with any weight) and the four
remedies (``damped-null-space``, ``self-motion-damping``,
``inverse-inertia-torque``, ``inverse-inertia-squared-torque``) on robots whose
joints all add (revolute or prismatic, :attr:`Robot.euclidean`), for the
``xy`` and ``position`` tasks, open loop. :func:`batch_supports` says
whether a case is; :func:`simulate_many` runs any list of movements,
batching what is supported and calling ``simulate`` for the rest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from .batch_resolvers import BATCHED_RESOLVERS, batched_step
from .checks import configuration_vector, positive_number, trajectory_dimension, whole_number
from .errors import InvalidInput
from .forest import RobotForest
from .linalg import inverse_condition_number, singular_message
from .resolvers import Resolver, get_resolver
from .result import SimResult, joint_limits_record
from .robot import Robot
from .run_log import speed_stop_reason, stop_ceilings, torque_stop_reason
from .self_motion import self_motion_energy
from .simulate import DEFAULT_MAX_JOINT_SPEED, DEFAULT_MAX_STEPS, DEFAULT_MAX_TORQUE_RATIO, step_budget
from .simulate import simulate as simulate_one
from .trajectory import Trajectory, check_trajectory, describe

__all__ = ["BATCHED_RESOLVERS", "BatchExtras", "batch_supports", "simulate_batch", "simulate_many"]


def batch_supports(robot: Robot, resolver: str | Resolver, feedback=None) -> bool:
    """True when :func:`simulate_batch` can run ``resolver`` on ``robot`` (else use :func:`torqueopt.simulate`)."""
    resolver = get_resolver(resolver)
    return (
        type(resolver) in BATCHED_RESOLVERS
        and robot.euclidean
        and robot.task in ("xy", "position")
        and feedback is None
    )


class BatchExtras:
    r"""Per-step quantities the batch computes beside the :class:`SimResult` rows, per movement.

    Attributes:
        kinetic_energy: :math:`T = \tfrac12\dot q^\top H\dot q` [J] at each recorded sample.
        self_motion_energy: :math:`T - \tfrac12\dot x^\top\Lambda\dot x` [J], with
            :math:`\dot x = J\dot q` and :math:`\Lambda = (J H^{-1} J^\top)^{-1}`:
            the kinetic energy beyond the least any joint motion with the
            same tip velocity has, i.e. the energy of the self-motion
            (zero exactly when :math:`\dot q` is the inertia-weighted
            pseudoinverse velocity :math:`J_H^\dagger\dot x`). See
            :func:`torqueopt.self_motion.self_motion_energy`, which computes it
            here and from a finished run.
    """

    __slots__ = ("kinetic_energy", "self_motion_energy")

    def __init__(self, kinetic_energy: np.ndarray, self_motion_energy: np.ndarray):
        self.kinetic_energy = kinetic_energy
        self.self_motion_energy = self_motion_energy


def simulate_many(
    robot: Robot,
    resolver: str | Resolver,
    trajectories: Sequence[Trajectory],
    q0s,
    dt: float = 1e-3,
    *,
    batch: bool = True,
    max_joint_speed: float = DEFAULT_MAX_JOINT_SPEED,
    max_torque_ratio: float = DEFAULT_MAX_TORQUE_RATIO,
) -> list[SimResult]:
    """One :class:`SimResult` per (trajectory, q0): batched where supported, else :func:`torqueopt.simulate` each.

    Movements of different durations are batched by duration.
    """
    resolver = get_resolver(resolver)
    trajectories = list(trajectories)
    _check_pairs(trajectories, q0s)
    if not (batch and batch_supports(robot, resolver)):
        return [
            simulate_one(
                robot, resolver, line, q0, dt=dt, max_joint_speed=max_joint_speed, max_torque_ratio=max_torque_ratio
            )
            for line, q0 in zip(trajectories, q0s)
        ]
    results: list[SimResult | None] = [None] * len(trajectories)
    for duration in sorted({line.duration for line in trajectories}):
        members = [i for i, line in enumerate(trajectories) if line.duration == duration]
        runs = simulate_batch(
            robot,
            resolver,
            [trajectories[i] for i in members],
            [q0s[i] for i in members],
            dt,
            max_joint_speed=max_joint_speed,
            max_torque_ratio=max_torque_ratio,
        )
        for i, run in zip(members, runs):
            results[i] = run
    return results


def simulate_batch(
    robot: Robot,
    resolver: str | Resolver,
    trajectories: Sequence[Trajectory],
    q0s,
    dt: float = 1e-3,
    *,
    max_joint_speed: float = DEFAULT_MAX_JOINT_SPEED,
    max_torque_ratio: float = DEFAULT_MAX_TORQUE_RATIO,
    threads: int = 1,
    extras: bool = False,
    max_steps: int = DEFAULT_MAX_STEPS,
):
    """Simulate every (trajectory, q0) pair with ``resolver``, all movements of one duration together.

    Args:
        robot: from :func:`torqueopt.load_robot`; its data is not touched
            (the batch makes its own Pinocchio Data).
        resolver: a supported resolver (see :func:`batch_supports`).
        trajectories: any :class:`~torqueopt.trajectory.Trajectory` objects of one duration, anchored at the tip
            at their q0 when they have no start, as in ``simulate``.
        q0s: one start configuration per trajectory (nq values or n angles).
        dt: step [s]; the torque is held over each.
        max_joint_speed, max_torque_ratio: the divergence stops of ``simulate``.
        threads: OpenMP threads for ``abaInParallel`` (1 inside a sweep
            worker, where the sweep's processes use the cores).
        extras: also return one :class:`BatchExtras` per movement.
        max_steps: the most steps a movement may take, as in ``simulate``.

    Returns:
        One :class:`SimResult` per movement, equal to what ``simulate``
        returns for it (to round-off); with ``extras``, (results, extras).

    Raises:
        InvalidInput: an unsupported case, mixed durations or bad values.
    """
    resolver = get_resolver(resolver)
    resolver.check(robot)
    if not batch_supports(robot, resolver):
        raise InvalidInput(
            f"the batched path does not support resolver '{resolver.name}' on robot '{robot.name}' (task "
            f"'{robot.task}'); it supports {', '.join(cls.name for cls in BATCHED_RESOLVERS)} on revolute/prismatic "
            "joints for the xy and position tasks: use torqueopt.simulate or simulate_many"
        )
    trajectories = list(trajectories)
    count = len(trajectories)
    if count == 0:
        return ([], []) if extras else []
    _check_pairs(trajectories, q0s)
    dt = positive_number(dt, "dt", "s")
    durations = {line.duration for line in trajectories}
    if len(durations) != 1:
        raise InvalidInput(f"a batch needs movements of one duration, got {sorted(durations)} s: use simulate_many")
    duration = durations.pop()
    step_budget(duration, dt, max_steps)
    threads = whole_number(threads, "threads", 1)

    model = robot.model
    data = model.createData()  # the batch's own: the robot's data is never written
    forest = RobotForest(robot)
    pool = pin.ModelPool(model, threads)

    def aba(q, v, tau):
        return _aba(pool, threads, q, v, tau)

    n, m, frame_id, rows = robot.nv, robot.m, robot.frame_id, robot.task_rows
    steps = step_budget(duration, dt)
    times = dt * np.arange(steps + 1)

    q = np.array([configuration_vector(robot, q0) for q0 in q0s], dtype=float).reshape(count, n)
    v = np.zeros((count, n))
    reference_position = np.empty((count, steps + 1, m))
    reference_acceleration = np.empty((count, steps + 1, m))
    descriptions = []
    for i, line in enumerate(trajectories):
        check_trajectory(line)
        linear_dimension = trajectory_dimension(robot, line)
        if line.start is None:
            pin.framesForwardKinematics(model, data, q[i])
            line = line.anchored(data.oMf[frame_id].translation[:linear_dimension].copy())
        descriptions.append(describe(line))
        sample = line.sample(times)
        reference_position[i] = sample.position
        reference_acceleration[i] = sample.acceleration

    step = batched_step(robot, resolver)
    torque_ceiling, speed_ceiling = stop_ceilings(robot, max_torque_ratio, max_joint_speed)

    # Logs, time-major (a step writes one contiguous block): [step, movement]; rows past a stop stay unused.
    q_log = np.empty((steps + 1, count, n))
    v_log = np.empty((steps + 1, count, n))
    acceleration_log = np.full((steps + 1, count, n), np.nan)
    torque_log = np.full((steps + 1, count, n), np.nan)
    x_log = np.empty((steps + 1, count, m))
    inverse_condition_log = np.empty((steps + 1, count))
    energy_log = np.empty((steps + 1, count)) if extras else None
    self_energy_log = np.empty((steps + 1, count)) if extras else None
    reference_acceleration = np.ascontiguousarray(np.swapaxes(reference_acceleration, 0, 1))
    recorded = np.zeros(count, dtype=int)
    stop_reason: list[str | None] = [None] * count
    stop_time: list[float | None] = [None] * count

    active = np.arange(count)  # movement index of each batch row
    h = dt
    for k, t in enumerate(times.tolist()):
        size = active.size
        if size == 0:
            break
        where = slice(None) if size == count else active  # plain slicing while no movement has stopped
        # Task terms of every movement still running, a few Pinocchio calls per forest of copies.
        H, b, jacobian, drift, tip = forest.terms(q, v)
        J, Jd = jacobian[:, rows], drift[:, rows]
        # Every state is recorded (q, v, x, inverse_condition); torque and q̈ only where the resolver ran.
        q_log[k, where] = q
        v_log[k, where] = v
        x_log[k, where] = tip[:, rows]
        recorded[where] = k + 1
        if k == steps:
            # The final state: the movement is over, no torque is applied from it (NaN rows, as simulate).
            inverse_condition_log[k, where] = inverse_condition_number(J)
            if extras:
                energy_log[k, where], self_energy_log[k, where] = self_motion_energy(H, v, jacobian=J)
            break
        command = reference_acceleration[k, where]
        torque, joint_acceleration, inverse_condition, singular, basis = step(H, b, J, Jd, command, v)
        if extras:
            kinetic, self_motion = self_motion_energy(H, v, null_space_basis=basis)
            if singular.any():  # the QR basis of a singular J is not its null space
                kinetic[singular], self_motion[singular] = self_motion_energy(
                    H[singular], v[singular], jacobian=J[singular]
                )
            energy_log[k, where], self_energy_log[k, where] = kinetic, self_motion
        inverse_condition_log[k, where] = inverse_condition
        if singular.any():
            resolved = ~singular
            acceleration_log[k, active[resolved]] = joint_acceleration[resolved]
            torque_log[k, active[resolved]] = torque[resolved]
            over = resolved & ~(np.abs(torque) <= torque_ceiling).all(axis=1)
        else:
            acceleration_log[k, where] = joint_acceleration
            torque_log[k, where] = torque
            over = ~(np.abs(torque) <= torque_ceiling).all(axis=1)
        stopping = singular | over
        for row in np.flatnonzero(stopping).tolist():
            movement = int(active[row])
            if singular[row]:
                message = singular_message(inverse_condition[row], resolver.singular_tolerance)
                stop_reason[movement] = f"{message} at t = {t:.4f} s"
            else:
                stop_reason[movement] = torque_stop_reason(robot, torque[row], max_torque_ratio, t)
            stop_time[movement] = t
        if stopping.any():
            keep = ~stopping
            active, q, v = active[keep], q[keep], v[keep]
            torque, joint_acceleration = torque[keep], joint_acceleration[keep]
            if active.size == 0:
                break

        # RK4 with the torque held; k1 is the resolver's q̈ (= ABA(q, v, τ)), as in simulate.
        k1 = joint_acceleration
        k2 = aba(q + (h / 2) * v, v + (h / 2) * k1, torque)
        k3 = aba(q + ((h / 2) * v + (h * h / 4) * k1), v + (h / 2) * k2, torque)
        k4 = aba(q + (h * v + (h * h / 2) * k2), v + h * k3, torque)
        q = q + (h * v + (h * h / 6) * (k1 + k2 + k3))
        v = v + ((h / 6) * k1 + (h / 3) * k2 + (h / 3) * k3 + (h / 6) * k4)
        fast = ~(np.abs(v) <= speed_ceiling).all(axis=1)
        if fast.any():
            for row in np.flatnonzero(fast).tolist():
                movement = int(active[row])
                stop_reason[movement] = speed_stop_reason(robot, v[row], max_joint_speed, t, dt)
                stop_time[movement] = t + dt
            keep = ~fast
            active, q, v = active[keep], q[keep], v[keep]

    results = []
    joint_names = list(robot.joint_names)
    limits = joint_limits_record(*robot.joint_limits)
    options = resolver.settings_for_file()
    for i in range(count):
        length = int(recorded[i])
        q_rows = q_log[:length, i].copy()
        results.append(
            SimResult(
                robot=robot.name,
                frame=robot.frame,
                task=robot.task,
                resolver=resolver.name,
                joint_names=joint_names,
                dt=dt,
                t=times[:length].copy(),
                q=q_rows,
                joint_angles=robot.joint_angles(q_rows).reshape(length, n),
                v=v_log[:length, i].copy(),
                acceleration=acceleration_log[:length, i].copy(),
                tau=torque_log[:length, i].copy(),
                x=x_log[:length, i].copy(),
                x_ref=reference_position[i, :length].copy(),
                jacobian_inverse_condition=inverse_condition_log[:length, i].copy(),
                torque_upper=robot.torque_upper.copy(),
                torque_lower=robot.torque_lower.copy(),
                duration=duration,
                stop_reason=stop_reason[i],
                stop_time=stop_time[i],
                trajectory=descriptions[i],
                joint_limits=limits,
                task_error=np.zeros(length),
                infeasible=np.zeros(length, dtype=bool),
                resolver_options=options,
            )
        )
    if not extras:
        return results
    more = [
        BatchExtras(energy_log[: recorded[i], i].copy(), self_energy_log[: recorded[i], i].copy()) for i in range(count)
    ]
    return results, more


def _check_pairs(trajectories: Sequence[Trajectory], q0s) -> None:
    """InvalidInput unless there is one start configuration per trajectory."""
    if len(trajectories) != len(q0s):
        raise InvalidInput(f"{len(trajectories)} trajectories but {len(q0s)} start configurations")


def _aba(pool, threads: int, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """ABA for every row of the (B, n) stacks in one ``pin.abaInParallel`` call; returns (B, n)."""
    out = np.empty_like(v)
    # Eigen's matrices are column-major: the transpose of a C-ordered (B, n) array is an (n, B) one without a copy.
    pin.abaInParallel(threads, pool, q.T, v.T, tau.T, out.T)
    return out
