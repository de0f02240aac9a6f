r"""Fig. 7 of the paper: the arm swinging freely, with zero torque, under a gravity that replaces the line.

Gravity points along the former straight-line direction, with the magnitude
that gives the tip an initial acceleration equal to the movement's
tangential acceleration; the swing lasts as long as the long movement. It
runs through :func:`torqueopt.simulate` like every resolver, with a
zero-torque resolver (:class:`ZeroTorque`) on a copy of the arm that has
this gravity; the caller's robot is never changed.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin

from ..errors import InvalidInput, TorqueoptWarning
from ..resolvers import Resolution, Resolver
from ..result import SimResult
from ..robot import Robot, TaskTerms
from ..simulate import simulate
from ..trajectory import StraightLine
from .scenario import PaperScenario

__all__ = ["FREE_SWING", "ZeroTorque", "free_swing", "free_swing_gravity"]

#: The resolver name a free swing's SimResult carries.
FREE_SWING = "free swing"


class ZeroTorque(Resolver):
    r"""No actuation at all: :math:`\tau = 0` and :math:`\ddot q = \mathrm{ABA}(q, \dot q, 0) = -H^{-1} b`.

    The task acceleration is ignored: the arm moves under gravity and its
    own velocity only. Not in the registry of resolvers (it resolves no
    redundancy); it lets a free swing run through the one simulation loop.
    """

    name = FREE_SWING

    def solver(self, robot: Robot):
        model = robot.model
        # Its own Pinocchio data, so the step leaves the run's terms alone.
        data = model.createData()
        n = robot.nv

        def step(terms: TaskTerms, task_acceleration: np.ndarray):
            acceleration = pin.aba(
                model, data, terms.configuration, terms.joint_velocity, np.zeros(n), pin.Convention.WORLD
            )
            # The swing does not try to realise the task: its shortfall is all of it that gravity misses.
            shortfall = float(np.linalg.norm(terms.jacobian.dot(acceleration) + terms.drift - task_acceleration))
            return Resolution(np.zeros(n), acceleration, float("nan"), shortfall, False)

        return step


def free_swing_gravity(robot: Robot, scenario: PaperScenario) -> np.ndarray:
    r"""Gravity [m/s²] along the line direction that gives the tip an initial acceleration of ``accel``.

    From rest the tip's acceleration is :math:`J\ddot q` with
    :math:`\ddot q` = ABA(q0, 0, 0), linear in the gravity vector; Pinocchio
    computes it for unit gravity along the direction (on a copy of
    ``robot``), then it is scaled.
    """
    direction = np.zeros(3)
    planar = np.asarray(scenario.direction, float)
    direction[: planar.size] = planar / np.linalg.norm(planar)
    unit_gravity = robot.with_gravity(direction)
    q = unit_gravity.configuration(scenario.q0)
    zero = np.zeros(robot.nv)
    tip_acceleration = unit_gravity.terms(q, zero).jacobian.dot(unit_gravity.forward_dynamics(q, zero, zero))
    size = float(np.linalg.norm(tip_acceleration))
    if size == 0.0:
        raise InvalidInput(f"gravity along {planar.tolist()} does not move the tip from q0; choose another direction")
    return direction * scenario.accel / size


def free_swing(scenario: PaperScenario, robot: Robot | None = None, duration: float | None = None) -> SimResult:
    """Fig. 7: the arm released at q0 with zero torque under :func:`free_swing_gravity`.

    Simulated by :func:`torqueopt.simulate` with :class:`ZeroTorque`, so by
    the same held-torque RK4 as the resolvers. ``x_ref`` holds the long
    movement's straight line (of ``duration``), the path the swing
    replaces; torques are zero, so no torque limit is ever reached and the
    Jacobian condition column is NaN.
    """
    robot = robot or scenario.load_robot()
    duration = scenario.durations[-1] if duration is None else duration
    swinging = robot.with_gravity(free_swing_gravity(robot, scenario))
    line = StraightLine(scenario.direction, accel=scenario.accel, duration=duration)
    with warnings.catch_warnings():
        # The swing is released, not held: what holding its start would cost says nothing about it.
        warnings.filterwarnings("ignore", message="holding the start against gravity", category=TorqueoptWarning)
        return simulate(swinging, ZeroTorque(), line, scenario.q0, dt=scenario.dt)
