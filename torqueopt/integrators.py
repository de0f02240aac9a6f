r"""The engine's integrators: how a state moves over one step, for one movement or a (B, ...) stack.

Two integrators live here, each a small object with a readable reference
step beside the fast one, held to it by the tests (1e-12 per step):

* :class:`HeldTorqueRK4`, the acceleration level: classical fourth-order
  Runge-Kutta of the forward dynamics with the torque held over the step.
  The state is :math:`(q, \dot q)` and the dynamics
  :math:`\dot q = v,\ \dot v = a(q, v) = \mathrm{ABA}(q, v, \tau)` with
  :math:`\tau` constant over the step :math:`h`;
* :class:`VelocityRK4`, the velocity level: classical RK4 of
  :math:`\dot q = f(q, t)` (a velocity-level resolver's joint rates, the
  reference sampled at the stage times), with the torques of the motion by
  inverse dynamics (Pinocchio's RNEA), Eq. (20).

Configurations move by Pinocchio's ``integrate``, :math:`q \oplus \delta`,
so continuous joints stay on their circle; for revolute and prismatic
joints it is plain addition.

How a plant plugs in
--------------------

The stepping loop advances the state through one function per run,
``advance(q, v, tau, acceleration) -> (q, v)``, and through
``advance_stack`` of the same shape on (B, nq) and (B, n) stacks;
``acceleration`` is the resolver's :math:`\ddot q` at the step start,
which RK4 on the resolver's own model reuses as its first stage
(:math:`k_1`) and any other plant ignores. :func:`plant_stepper` and
:func:`plant_stack_stepper` make them from a plant of
:mod:`torqueopt.plants` (``step(q, v, tau, dt) -> (q, v)``): for the
Pinocchio plant, :class:`HeldTorqueRK4`'s fast steps; for any other plant
(MuJoCo), its own ``step``, row by row on stacks. A new plant is one more
object with that ``step``; the loop does not change.

Why the fast RK4 is written as it is, and what it costs, is in
BENCHMARKS.md.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .robot import Robot

__all__ = [
    "HeldTorqueRK4",
    "VelocityRK4",
    "plant_stack_stepper",
    "plant_stepper",
    "rk4_reference_step",
    "rk4_step",
    "rk4_stepper",
]


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
    """One classical RK4 step of the forward dynamics with the torque held, by :func:`~torqueopt.integrators.rk4_stepper`.

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
    r"""The RK4 step of :func:`~torqueopt.integrators.rk4_reference_step` for one robot and step, as a function ``(q, v, τ, k1) -> (q, v)``.

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


def plant_stepper(plant, robot: Robot, dt: float, data=None):
    """The loop's ``advance(q, v, tau, acceleration) -> (q, v)`` for one movement on ``plant`` (see the module docstring).

    The Pinocchio plant (:class:`torqueopt.plants.PinocchioPlant`) gets
    :class:`HeldTorqueRK4`'s folded step computing in ``data``; another plant its own
    ``step(q, v, tau, dt)``, whose state the next torque is computed from.
    """
    from .plants import PinocchioPlant

    if plant is None or isinstance(plant, PinocchioPlant):
        return HeldTorqueRK4(robot, dt, data).step
    plant_step = plant.step

    def advance(q, v, tau, _acceleration):
        # The plant reports its own state; the resolver's next torque is computed from it.
        return plant_step(q, v, tau, dt)

    return advance


def plant_stack_stepper(plant, robot: Robot, dt: float, threads: int = 1):
    """The loop's ``advance_stack`` on (B, ...) stacks: :meth:`HeldTorqueRK4.step_stack`, or ``plant.step`` per row."""
    from .plants import PinocchioPlant

    if plant is None or isinstance(plant, PinocchioPlant):
        return HeldTorqueRK4(robot, dt, threads=threads).step_stack
    advance = plant_stepper(plant, robot, dt)

    def advance_stack(q, v, tau, acceleration):
        rows = [advance(*row) for row in zip(q, v, tau, acceleration)]
        if not rows:
            return q.copy(), v.copy()
        next_q, next_v = zip(*rows)
        return np.array(next_q), np.array(next_v)

    return advance_stack


class HeldTorqueRK4:
    r"""Classical RK4 of the forward dynamics with the torque held over each step of ``dt`` [s].

    :meth:`reference_step` is :func:`rk4_reference_step`, the textbook
    stages; :meth:`step` is :func:`rk4_stepper`'s folded form, which takes
    the resolver's :math:`\ddot q` as :math:`k_1` (it is ABA(q, v, τ));
    :meth:`step_stack` is the folded form on (B, n) stacks, the three later
    stages of the whole stack by one ``pin.abaInParallel`` call each (over a
    ``pin.ModelPool`` of ``threads`` models), for robots whose joints all add
    (``Robot.euclidean``; other robots' stacks go row by row through
    :meth:`step`).

    Args:
        data: the Pinocchio data :meth:`step` computes in (a fresh one when
            None); one integrator per run, so runs in threads never share one.
        threads: OpenMP threads of ``abaInParallel`` for stacks.
    """

    def __init__(self, robot: Robot, dt: float, data=None, threads: int = 1):
        self.robot, self.dt, self.threads = robot, float(dt), int(threads)
        self.data = robot.model.createData() if data is None else data
        # An instance attribute, not a method: one call per step, no bound-method frame.
        #: The folded step ``(q, v, τ, k1) -> (q, v)`` of :func:`rk4_stepper`.
        self.step = rk4_stepper(robot, self.dt, self.data)
        self._pool = None

    def reference_step(self, q, v, tau):
        """The textbook step of :func:`rk4_reference_step` (computes its own k1)."""
        return rk4_reference_step(self.robot, q, v, tau, self.dt, self.data)

    def _aba(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """ABA for every row of the (B, n) stacks in one ``pin.abaInParallel`` call; (B, n)."""
        if self._pool is None:
            self._pool = pin.ModelPool(self.robot.model, self.threads)
        out = np.empty_like(v)
        # Eigen's matrices are column-major: the transpose of a C-ordered (B, n) array is an (n, B) one, no copy.
        pin.abaInParallel(self.threads, self._pool, q.T, v.T, tau.T, out.T)
        return out

    def step_rows(self, q, v, tau, acceleration):
        """:meth:`step` on every row of (B, ...) stacks, one movement at a time (the arithmetic of ``simulate``)."""
        step = self.step
        rows = [step(*row) for row in zip(q, v, tau, acceleration)]
        return np.array([row[0] for row in rows]).reshape(q.shape), np.array([row[1] for row in rows]).reshape(v.shape)

    def step_stack(self, q, v, tau, acceleration):
        r"""The folded step of :func:`rk4_stepper` on (B, n) stacks (see there for the weights); k1 = ``acceleration``."""
        if not self.robot.euclidean:
            rows = [self.step(*row) for row in zip(q, v, tau, acceleration)]
            return np.array([row[0] for row in rows]).reshape(q.shape), np.array([row[1] for row in rows]).reshape(
                v.shape
            )
        h, aba = self.dt, self._aba
        k1 = acceleration
        k2 = aba(q + (h / 2) * v, v + (h / 2) * k1, tau)
        k3 = aba(q + ((h / 2) * v + (h * h / 4) * k1), v + (h / 2) * k2, tau)
        k4 = aba(q + (h * v + (h * h / 2) * k2), v + h * k3, tau)
        next_q = q + (h * v + (h * h / 6) * (k1 + k2 + k3))
        next_v = v + ((h / 6) * k1 + (h / 3) * k2 + (h / 3) * k3 + (h / 6) * k4)
        return next_q, next_v


class VelocityRK4:
    r"""Classical RK4 of the velocity-level system :math:`\dot q = f(q, t)`, torques by inverse dynamics.

    ``rates(q, index) -> (q̇, σmin/σmax)`` is the resolver's map at the
    reference sample ``index`` of a half-step grid (sample ``2k`` at
    :math:`t_k`, ``2k + 1`` at :math:`t_k + h/2`), so a step from sample
    ``index`` evaluates f at ``index``, ``index + 1`` and ``index + 2``:

    .. math::

        k_1 = f(q, t),\ k_2 = f(q \oplus \tfrac h2 k_1, t + \tfrac h2),\
        k_3 = f(q \oplus \tfrac h2 k_2, t + \tfrac h2),\ k_4 = f(q \oplus h k_3, t + h),\qquad
        q^+ = q \oplus \tfrac h6(k_1 + 2k_2 + 2k_3 + k_4).

    :meth:`reference_step` computes every stage; ``step`` takes
    :math:`k_1` from the caller, who has it from the row it recorded, and
    folds the stages as :func:`rk4_stepper` does: each stage's configuration
    (or, for joints that do not add, its increment) and the final update are
    fixed linear combinations of :math:`q, k_1, \dots, k_4`, the rows of one
    array each stage's rates are written into, so a stage costs one row
    write and one small product instead of a scalar product and a sum of
    arrays (the sums are grouped differently from the reference: the two
    agree to round-off, not bit for bit).
    :meth:`torque` is Eq. (20) on the motion,
    :math:`\tau = H\ddot q + \dot q\cdot C\cdot\dot q + g` (Pinocchio's RNEA).
    """

    def __init__(self, robot: Robot, rates, dt: float, data=None):
        self.robot, self.rates, self.dt = robot, rates, float(dt)
        self.model = robot.model
        self.data = robot.model.createData() if data is None else data
        # q ⊕ δ is q + δ when every joint adds (Pinocchio's integrate does that addition for them).
        self.integrate = np.add if robot.euclidean else robot.integrate
        # An instance attribute, not a method: one call per step, no bound-method frame.
        #: The folded step ``(q, k1, index) -> q⁺`` with ``k1`` = f(q, t) given.
        self.step = self._folded_step()

    def reference_step(self, q: np.ndarray, index: int) -> np.ndarray:
        """q after one step from reference sample ``index``, the four stages one by one."""
        h, f, integrate = self.dt, self.rates, self.integrate
        k1 = f(q, index)[0]
        k2 = f(integrate(q, h / 2 * k1), index + 1)[0]
        k3 = f(integrate(q, h / 2 * k2), index + 1)[0]
        k4 = f(integrate(q, h * k3), index + 2)[0]
        return integrate(q, h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))

    def _folded_step(self):
        """The step ``(q, k1, index) -> q⁺`` with ``k1`` = f(q, t) given, stages folded (see the class docstring)."""
        h, f, euclidean = self.dt, self.rates, self.robot.euclidean
        # Weights of (q, k1, k2, k3, k4) in the configurations of stages 2, 3, 4 and of the step's end; where
        # joints do not add, q leaves the rows and the weights give the increments δ of q ⊕ δ instead.
        weights = [[1.0, h / 2], [1.0, 0.0, h / 2], [1.0, 0.0, 0.0, h], [1.0, h / 6, h / 3, h / 3, h / 6]]
        weights = [np.array(row if euclidean else row[1:]) for row in weights]
        weight2, weight3, weight4, weight_end = weights
        stages = np.zeros((len(weight_end), self.robot.nv))
        # views made once: each stage writes its row, and reads the rows its weights cover
        upto2, upto3, upto4 = (stages[: len(weight)] for weight in weights[:3])
        k1_row, k2_row, k3_row, k4_row = stages[-4:]

        if euclidean:
            q_row = stages[0]

            def step(q: np.ndarray, k1: np.ndarray, index: int) -> np.ndarray:
                q_row[...] = q
                k1_row[...] = k1
                k2_row[...] = f(weight2.dot(upto2), index + 1)[0]
                k3_row[...] = f(weight3.dot(upto3), index + 1)[0]
                k4_row[...] = f(weight4.dot(upto4), index + 2)[0]
                return weight_end.dot(stages)

            return step

        integrate = self.integrate

        def step(q: np.ndarray, k1: np.ndarray, index: int) -> np.ndarray:
            k1_row[...] = k1
            k2_row[...] = f(integrate(q, weight2.dot(upto2)), index + 1)[0]
            k3_row[...] = f(integrate(q, weight3.dot(upto3)), index + 1)[0]
            k4_row[...] = f(integrate(q, weight4.dot(upto4)), index + 2)[0]
            return integrate(q, weight_end.dot(stages))

        return step

    def torque(self, q: np.ndarray, v: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """The inverse-dynamics torque of the motion at (q, q̇, q̈) [N·m], Eq. (20), in RNEA's own fresh array."""
        return pin.rnea(self.model, self.data, q, v, acceleration)  # Eq. (20) on the motion
