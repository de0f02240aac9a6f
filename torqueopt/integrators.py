r"""Classical fourth-order Runge-Kutta, written once, over a system, for one state or a (B, ...) stack.

:class:`RK4` advances a system over one step :math:`h`; two systems exist:

* :class:`HeldTorque`, the acceleration level: the forward dynamics
  :math:`\ddot q = a(q, \dot q) = \mathrm{ABA}(q, \dot q, \tau)` with the
  torque τ held over the step, a second-order system of state :math:`(q, \dot q)`;
* :class:`VelocityRates`, the velocity level: a resolver's joint rates
  :math:`\dot q = f(q, t)` (the reference sampled at the stage times), a
  first-order system of state q, with the torques of the motion by
  inverse dynamics (Pinocchio's RNEA), Eq. (20).

Configurations move by Pinocchio's ``integrate``, :math:`q \oplus \delta`,
so continuous joints stay on their circle; for revolute and prismatic
joints (``Robot.euclidean``) it is plain addition.

The stages are those of the Butcher tableau (``TABLEAU``),

.. math::

    k_1 = f(x, t),\ k_2 = f(x \oplus \tfrac h2 k_1, t + \tfrac h2),\
    k_3 = f(x \oplus \tfrac h2 k_2, t + \tfrac h2),\ k_4 = f(x \oplus h k_3, t + h),\qquad
    x^+ = x \oplus \tfrac h6(k_1 + 2k_2 + 2k_3 + k_4).

For the second-order system the configuration's own rates are velocities,
:math:`v_i = v + h\sum_j a_{ij}k_j`, so every stage's configuration
increment, :math:`h\sum_j a_{ij}v_j = h(\sum_j a_{ij})v + h^2\sum_l (AA)_{il}k_l`,
is a fixed linear combination of :math:`v` and the stage accelerations
:math:`k_l` (Runge-Kutta-Nyström form). So for either system each stage's
configuration (or increment) and velocity, and the step's end, are one
matrix of weights (:func:`stage_weights`) times the rows
``[q, v, k1, ..., k4]`` of one array, filled as the stages run; a state is
one row per quantity, a stack of B states is the same rows, B times longer.
:math:`k_1` comes from the caller, who has it from the step's start (the
resolver's :math:`\ddot q`, or the rates it recorded).

The tests hold this step to the textbook stages written one by one, on
single states and on stacks, at 1e-12.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pinocchio as pin

from .robot import Robot

__all__ = ["HeldTorque", "RK4", "TABLEAU", "VelocityRates", "rk4_step", "rk4_stepper", "stage_weights"]

#: Classical RK4's Butcher tableau: the rows of a (stages 2, 3, 4 on k1..k4), then the weights b of the end.
TABLEAU = (
    (Fraction(1, 2), 0, 0, 0),
    (0, Fraction(1, 2), 0, 0),
    (0, 0, 1, 0),
    (Fraction(1, 6), Fraction(1, 3), Fraction(1, 3), Fraction(1, 6)),
)
#: Each stage's time after the step start, in half steps: f is read at t + h/2, t + h/2 and t + h.
STAGE_HALF_STEPS = (1, 1, 2)


def _times(power: float, coefficient) -> float:
    """``power * coefficient`` rounded as ``power * numerator / denominator`` (``h / 2``, ``h * h / 6``)."""
    coefficient = Fraction(coefficient)
    if coefficient == 0:
        return 0.0
    return power * coefficient.numerator / coefficient.denominator


def stage_weights(dt: float, order: int, with_configuration: bool) -> list[np.ndarray]:
    r"""The weights of the rows ``[q, v, k1, ..., k4]`` in stages 2, 3, 4 and the end, from ``TABLEAU``.

    ``order`` 1 has no ``v`` row and gives one row of weights per stage (the
    configuration); order 2 gives two, the configuration (increment) and the
    velocity. Without ``with_configuration`` (joints that do not add) the
    ``q`` column is left out and the first row is the increment δ of
    :math:`q \oplus \delta`. Stage s reads the rows up to :math:`k_{s-1}`.
    """
    h = float(dt)
    rows_a = [[Fraction(value) for value in row] for row in TABLEAU]
    full = [[Fraction(0)] * 4, *rows_a[:3]]  # A as a 4 x 4 matrix: stage i's weights on k1..k4
    weights = []
    for stage, a in enumerate(rows_a):
        used = stage + 1  # k1..k_used
        own = [1.0] if with_configuration else []
        if order == 1:
            weights.append(np.array(own + [_times(h, a[j]) for j in range(used)]))
            continue
        # (AA) row: Σ_j a_j A_jl, the h² weights of the configuration on k_l
        squared = [sum(a[j] * full[j][col] for j in range(4)) for col in range(used)]
        configuration = own + [_times(h, sum(a))] + [_times(h * h, value) for value in squared]
        velocity = ([0.0] if with_configuration else []) + [1.0] + [_times(h, a[j]) for j in range(used)]
        weights.append(np.array([configuration, velocity]))
    return weights


class HeldTorque:
    r"""The forward dynamics with the torque held over the step: :math:`\ddot q = \mathrm{ABA}(q, \dot q, \tau)`.

    A second-order system; the step's parameter is τ [N·m]. A robot that
    models joint damping and friction gets :math:`\mathrm{ABA}(q, \dot q,
    \tau - \tau_j(\dot q))` (:meth:`torqueopt.Robot.forward_dynamics`), the resistance
    read at each stage's velocity. One state's
    accelerations are Pinocchio's ``aba`` in ``data``; a (B, n) stack's one
    ``pin.abaInParallel`` call (over a ``pin.ModelPool`` of ``threads``
    models) per stage.

    Args:
        data: the Pinocchio data one state computes in (a fresh one when
            None); one system per run, so runs in threads never share one.
        threads: OpenMP threads of ``abaInParallel`` for stacks.
    """

    order = 2

    def __init__(self, robot: Robot, data=None, threads: int = 1):
        self.robot, self.threads = robot, int(threads)
        self.data = robot.model.createData() if data is None else data
        self._pool = None

    def derivative(self, stacked: bool):
        """``(configuration, velocity, τ) -> q̈`` for one state or for (B, ...) stacks."""
        if not stacked:
            return self.robot.forward_dynamics_function(self.data)
        if self._pool is None:
            self._pool = pin.ModelPool(self.robot.model, self.threads)
        pool, threads = self._pool, self.threads
        robot = self.robot
        resists = robot.models_joint_dynamics

        def accelerations(configuration, velocity, tau):
            out = np.empty_like(velocity)
            if resists:
                # The joints' damping and friction at this stage's velocity, as Robot.forward_dynamics takes it off.
                tau = tau - robot.joint_resistance(velocity)
            # Eigen's matrices are column-major: the transpose of a C-ordered (B, n) array is an (n, B) one, no copy.
            pin.abaInParallel(threads, pool, configuration.T, velocity.T, tau.T, out.T)
            return out

        return accelerations


class VelocityRates:
    r"""A velocity-level resolver's joint rates :math:`\dot q = f(q, t)`, torques by inverse dynamics.

    A first-order system; the step's parameter is the reference sample
    index of the step's start on a half-step grid (sample ``2k`` at
    :math:`t_k`, ``2k + 1`` at :math:`t_k + h/2`), so a step from sample
    ``index`` reads f at ``index``, ``index + 1`` and ``index + 2``.

    Args:
        rates: ``(q, index) -> q̇`` for one state (n) or a stack (B, n), as the
            caller steps one or the other.
    """

    order = 1

    def __init__(self, robot: Robot, rates, data=None):
        self.robot, self.rates = robot, rates
        self.model = robot.model
        self.data = robot.model.createData() if data is None else data

    def derivative(self, stacked: bool):
        """``(configuration, index) -> q̇`` at reference sample ``index``."""
        return self.rates

    def torque(self, q: np.ndarray, v: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        r"""The inverse-dynamics torque of the motion at (q, q̇, q̈) [N·m], Eq. (20), in RNEA's own fresh array.

        A robot that models joint damping and friction adds their torque :math:`\tau_j(\dot q)`: the motor's.
        """
        torque = pin.rnea(self.model, self.data, q, v, acceleration)  # Eq. (20) on the motion
        if self.robot.models_joint_dynamics:
            torque += self.robot.joint_resistance(v)
        return torque


class RK4:
    """Classical RK4 of ``system`` over steps of ``dt`` [s], for one state or a (B, ...) stack of states.

    ``step(q, v, parameter, k1) -> (q, v)``: ``q`` a configuration (nq) or
    a stack (B, nq), ``v`` the velocities (n) or (B, n) (None for a
    first-order system, which returns it as given), ``parameter`` what the
    system's derivative reads besides the state, ``k1`` the derivative at
    the step's start. A second-order system's ``derivative(stacked)`` is
    ``(configuration, velocity, parameter) -> acceleration`` (τ held over the
    step: it does not read the time); a first-order one's is
    ``(configuration, sample) -> rate`` with the parameter the step start's
    reference sample on the half-step grid, read at ``parameter + 1``,
    ``+ 1`` and ``+ 2`` (``STAGE_HALF_STEPS``).
    The arithmetic of a stack's rows is that of one state's (see the
    module docstring); its buffers are made once per state shape.
    """

    def __init__(self, system, dt: float):
        self.system, self.dt = system, float(dt)
        self.robot = system.robot
        self._shape = None
        self._step = None

    def step(self, q, v, parameter, k1):
        """The state after one step from (q, v) (see the class docstring)."""
        if q.shape != self._shape:
            self._step, self._shape = self.stepper(q.shape), q.shape
        return self._step(q, v, parameter, k1)

    def stepper(self, shape):
        """:meth:`step` on states of ``shape`` alone, as a function: its rows' views and weights made once."""
        robot, system = self.robot, self.system
        stacked = len(shape) > 1
        size = int(np.prod(shape[:-1], dtype=int)) * robot.nv
        velocity_shape = (*shape[:-1], robot.nv)
        euclidean = robot.euclidean
        second_order = system.order == 2
        weight2, weight3, weight4, weight_end = stage_weights(self.dt, system.order, euclidean)
        derivative = system.derivative(stacked)
        # Rows [q] [v] k1 k2 k3 k4, each one state (or stack) long.
        names = (["q"] if euclidean else []) + (["v"] if second_order else []) + ["k1", "k2", "k3", "k4"]
        stages = np.zeros((len(names), size))
        rows = {name: stages[index].reshape(velocity_shape) for index, name in enumerate(names)}
        q_row, v_row, k1_row = rows.get("q"), rows.get("v"), rows["k1"]
        k2_row, k3_row, k4_row = rows["k2"], rows["k3"], rows["k4"]
        upto2, upto3, upto4 = (stages[: weight.shape[-1]] for weight in (weight2, weight3, weight4))
        if stacked and not euclidean:
            integrate_one = robot.integrate

            def integrate(q, increment):
                return np.array([integrate_one(row, delta) for row, delta in zip(q, increment)])

        else:
            integrate = robot.integrate

        if second_order:
            buffer = np.empty((2, size))
            end_shape = (2, *velocity_shape)
            # views that every stage's product refills: the configuration (or its increment) and the velocity
            position, velocity = buffer[0].reshape(velocity_shape), buffer[1].reshape(velocity_shape)

            def rk4(q, v, tau, k1):
                if euclidean:
                    q_row[...] = q
                v_row[...] = v
                k1_row[...] = k1
                weight2.dot(upto2, out=buffer)
                k2_row[...] = derivative(position if euclidean else integrate(q, position), velocity, tau)
                weight3.dot(upto3, out=buffer)
                k3_row[...] = derivative(position if euclidean else integrate(q, position), velocity, tau)
                weight4.dot(upto4, out=buffer)
                k4_row[...] = derivative(position if euclidean else integrate(q, position), velocity, tau)
                end = weight_end.dot(stages)
                if stacked:
                    end = end.reshape(end_shape)
                return (end[0] if euclidean else integrate(q, end[0])), end[1]

            return rk4

        half2, half3, half4 = STAGE_HALF_STEPS
        if euclidean:

            def moved(_q, combination):
                return combination.reshape(velocity_shape)

        else:

            def moved(q, combination):
                return integrate(q, combination.reshape(velocity_shape))

        def rk4(q, v, index, k1):
            if euclidean:
                q_row[...] = q
            k1_row[...] = k1
            # fresh configurations: the rates may keep the one they were given
            k2_row[...] = derivative(moved(q, weight2.dot(upto2)), index + half2)
            k3_row[...] = derivative(moved(q, weight3.dot(upto3)), index + half3)
            k4_row[...] = derivative(moved(q, weight4.dot(upto4)), index + half4)
            return moved(q, weight_end.dot(stages)), v

        return rk4


def rk4_stepper(robot: Robot, dt: float, data=None):
    """:class:`RK4` of :class:`HeldTorque` as a function ``(q, v, τ, k1) -> (q, v)``, computing in ``data``."""
    return RK4(HeldTorque(robot, data), dt).step


def rk4_step(robot: Robot, q, v, tau, dt: float, acceleration=None):
    """One classical RK4 step of the forward dynamics with the torque ``tau`` [N·m] held over ``dt`` [s].

    Args:
        acceleration: ABA(q, v, tau) when the caller already has it.

    Returns:
        (q, v) after the step.
    """
    data = robot.model.createData()
    if acceleration is None:
        acceleration = robot.forward_dynamics(q, v, tau, data=data)
    return rk4_stepper(robot, dt, data)(q, v, tau, acceleration)
