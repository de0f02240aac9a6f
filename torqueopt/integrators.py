r"""Classical fourth-order Runge-Kutta for the forward dynamics with the torque held over the step.

The state is :math:`(q, \dot q)` and the dynamics
:math:`\dot q = v,\ \dot v = a(q, v) = \mathrm{ABA}(q, v, \tau)` with
:math:`\tau` constant over the step :math:`h`. Configurations move by
Pinocchio's ``integrate``, :math:`q \oplus \delta`, so continuous joints stay
on their circle; for revolute and prismatic joints it is plain addition.

Two implementations of the same step live here:

* :func:`rk4_reference_step`, the textbook stages written out one by one,
  to read and to test against;
* :func:`rk4_stepper`, the step :func:`torqueopt.simulate` takes at every
  step: the same arithmetic folded into a few small matrix products. The
  tests hold it to the reference (to 1e-12 per step, and over whole runs).

Why the fast one is written as it is, and what it costs, is in
BENCHMARKS.md.
"""

from __future__ import annotations

import numpy as np

from .robot import Robot

__all__ = ["rk4_reference_step", "rk4_step", "rk4_stepper"]


def rk4_reference_step(robot: Robot, q, v, tau, dt: float, data=None):
    r"""One classical RK4 step, the textbook stages one by one.

    .. math::

        k_1^q = v, && k_1^v = a(q, v),

        k_2^q = v + \tfrac{h}{2} k_1^v, && k_2^v = a(q \oplus \tfrac{h}{2} k_1^q,\ v + \tfrac{h}{2} k_1^v),

        k_3^q = v + \tfrac{h}{2} k_2^v, && k_3^v = a(q \oplus \tfrac{h}{2} k_2^q,\ v + \tfrac{h}{2} k_2^v),

        k_4^q = v + h k_3^v, && k_4^v = a(q \oplus h k_3^q,\ v + h k_3^v),

        q^+ = q \oplus \tfrac{h}{6}(k_1^q + 2k_2^q + 2k_3^q + k_4^q), &&
        v^+ = v + \tfrac{h}{6}(k_1^v + 2k_2^v + 2k_3^v + k_4^v),

    with :math:`a(q, v) = \mathrm{ABA}(q, v, \tau)` [rad/s²] for the held torque τ [N·m].

    Args:
        q: configuration vector (nq); v: joint velocities (n) [rad/s];
        tau: joint torques (n) [N·m]; dt: the step h [s];
        data: Pinocchio data to compute in (a fresh one when None).

    Returns:
        (q, v) after the step.
    """
    data = robot.model.createData() if data is None else data
    h = float(dt)

    def acceleration(configuration, velocity):
        return robot.forward_dynamics(configuration, velocity, tau, data=data)

    k1_q, k1_v = v, acceleration(q, v)
    k2_q, k2_v = v + h / 2 * k1_v, acceleration(robot.integrate(q, h / 2 * k1_q), v + h / 2 * k1_v)
    k3_q, k3_v = v + h / 2 * k2_v, acceleration(robot.integrate(q, h / 2 * k2_q), v + h / 2 * k2_v)
    k4_q, k4_v = v + h * k3_v, acceleration(robot.integrate(q, h * k3_q), v + h * k3_v)
    q_next = robot.integrate(q, h / 6 * (k1_q + 2 * k2_q + 2 * k3_q + k4_q))
    v_next = v + h / 6 * (k1_v + 2 * k2_v + 2 * k3_v + k4_v)
    return q_next, v_next


def rk4_step(robot: Robot, q, v, tau, dt: float, acceleration=None):
    """One classical RK4 step of the forward dynamics with the torque held, by :func:`rk4_stepper`.

    Args:
        acceleration: ABA(q, v, tau) when the caller already has it.

    Returns:
        (q, v) after the step.
    """
    data = robot.model.createData()
    if acceleration is None:
        acceleration = robot.forward_dynamics(q, v, tau, data=data)
    return rk4_stepper(robot, dt, data)(q, v, tau, acceleration)


def rk4_stepper(robot: Robot, dt: float, data=None):
    r"""The RK4 step of :func:`rk4_reference_step` for one robot and step, as a function ``(q, v, τ, k1) -> (q, v)``.

    ``k1`` is the first stage's acceleration, ABA(q, v, τ), which a
    simulation already has from its resolver. Writing the stages in terms of
    :math:`v` and the stage accelerations :math:`k_i` alone,

    .. math::

        v_2 = v + \tfrac{h}{2} k_1,\quad v_3 = v + \tfrac{h}{2} k_2,\quad v_4 = v + h k_3,

        k_2 = a(q \oplus \tfrac{h}{2} v, v_2),\quad
        k_3 = a(q \oplus \tfrac{h}{2} v_2, v_3),\quad
        k_4 = a(q \oplus h v_3, v_4),

        v^+ = v + \tfrac{h}{6}(k_1 + 2k_2 + 2k_3 + k_4),\qquad
        q^+ = q \oplus \tfrac{h}{6}(v + 2v_2 + 2v_3 + v_4) = q \oplus \big(h v + \tfrac{h^2}{6}(k_1 + k_2 + k_3)\big),

    each stage's configuration increment (:math:`\tfrac{h}{2} v`,
    :math:`\tfrac{h}{2} v_2 = \tfrac{h}{2} v + \tfrac{h^2}{4} k_1`,
    :math:`h v_3 = h v + \tfrac{h^2}{2} k_2`) and velocity, and the final
    update, are fixed linear combinations of :math:`v, k_1, \dots, k_4`: the
    rows of one array allocated here. Each stage is then one small matrix
    product written into a buffer whose rows ABA reads, and the rows are
    filled through views made once. When every joint is revolute or
    prismatic (``robot.euclidean``), :math:`q \oplus \delta = q + \delta`
    and q joins those rows, so no ``integrate`` call is needed. (The sums
    are grouped differently from the reference, so the two agree to
    round-off, not bit for bit.)

    Args:
        data: Pinocchio data the stages compute in; a fresh one when None.
            The returned function keeps it: one stepper per run.
    """
    h = float(dt)
    n = robot.nv
    # Weights of (v, k1, k2, k3, k4) in each stage's (configuration increment, velocity).
    stage2 = [[h / 2, 0.0], [1.0, h / 2]]
    stage3 = [[h / 2, h * h / 4, 0.0], [1.0, 0.0, h / 2]]
    stage4 = [[h, 0.0, h * h / 2, 0.0], [1.0, 0.0, 0.0, h]]
    update = [[h, h * h / 6, h * h / 6, h * h / 6, 0.0], [1.0, h / 6, h / 3, h / 3, h / 6]]
    forward_dynamics = robot.forward_dynamics_function(data)
    buffer = np.empty((2, n))
    increment, velocity = buffer[0], buffer[1]  # views that every stage's product refills

    if robot.euclidean:
        # Rows q, v, k1..k4; q enters the configuration row with weight 1.
        stages = np.zeros((6, n))
        weights = [np.array([[1.0, *row0], [0.0, *row1]]) for row0, row1 in (stage2, stage3, stage4, update)]
        weight2, weight3, weight4, weight_update = weights
        rows3, rows4, rows5 = stages[:3], stages[:4], stages[:5]
        q_row, v_row, k1_row, k2_row, k3_row, k4_row = stages

        def rk4(q, v, tau, k1):
            q_row[...] = q
            v_row[...] = v
            k1_row[...] = k1
            weight2.dot(rows3, out=buffer)
            k2_row[...] = forward_dynamics(increment, velocity, tau)
            weight3.dot(rows4, out=buffer)
            k3_row[...] = forward_dynamics(increment, velocity, tau)
            weight4.dot(rows5, out=buffer)
            k4_row[...] = forward_dynamics(increment, velocity, tau)
            combination = weight_update.dot(stages)
            return combination[0], combination[1]

        return rk4

    stages = np.zeros((5, n))  # rows: v, k1, k2, k3, k4
    weight2, weight3, weight4, weight_update = (np.array(w) for w in (stage2, stage3, stage4, update))
    rows2, rows3, rows4 = stages[:2], stages[:3], stages[:4]
    integrate = robot.integrate

    v_row, k1_row, k2_row, k3_row, k4_row = stages

    def rk4(q, v, tau, k1):
        v_row[...] = v
        k1_row[...] = k1
        weight2.dot(rows2, out=buffer)
        k2_row[...] = forward_dynamics(integrate(q, increment), velocity, tau)
        weight3.dot(rows3, out=buffer)
        k3_row[...] = forward_dynamics(integrate(q, increment), velocity, tau)
        weight4.dot(rows4, out=buffer)
        k4_row[...] = forward_dynamics(integrate(q, increment), velocity, tau)
        combination = weight_update.dot(stages)
        return integrate(q, combination[0]), combination[1]

    return rk4
