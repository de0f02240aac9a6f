"""The stops every loop of the engine applies and their messages: divergence ceilings, torque, speed, joint rates.

:class:`StopRules` holds the divergence ceilings of one robot and words every
stop (a torque or a joint speed beyond its ceiling, joint rates of a
velocity-level method beyond theirs, a resolver that cannot go on), the same
for every lanes form of :mod:`torqueopt.engine`.
"""

from __future__ import annotations

import operator
import sys

import numpy as np

from .robot import Robot

__all__ = ["StopRules", "speed_stop_reason", "stop_ceilings", "torque_stop_reason"]


def stop_ceilings(robot: Robot, max_torque_ratio: float, max_joint_speed: float):
    """The divergence stops' ceilings: per-joint torque [N·m] (an array) and joint speed [rad/s] (a float).

    Both are capped at the largest float, so the one test a loop makes per
    step, all(|value| <= ceiling), also fails inf and NaN (which compare
    False); the reason is worked out only then.
    """
    largest = sys.float_info.max
    with np.errstate(over="ignore"):  # a limit near the largest float times the ratio is inf: capped just below
        ceiling = np.minimum(max_torque_ratio * robot.torque_upper, largest)
    return ceiling, min(max_joint_speed, largest)


def torque_stop_reason(robot: Robot, tau: np.ndarray, max_torque_ratio: float, t: float) -> str:
    """Why torques that failed the ceiling test end the run at time t [s]."""
    if not np.isfinite(tau).all():
        return f"torque became non-finite at t = {t:.4f} s"
    limit = robot.torque_upper
    joint = int(np.argmax(np.abs(tau) / limit))
    unit = robot.joint_unit(joint, "torque")
    return (
        f"torque of joint {robot.joint_names[joint]} reached {tau[joint]:.4g} {unit}, more than "
        f"{max_torque_ratio:g} times its limit {limit[joint]:g} {unit}, at t = {t:.4f} s"
    )


def speed_stop_reason(robot: Robot, v: np.ndarray, max_joint_speed: float, t: float, dt: float) -> str:
    """Why joint velocities that failed the ceiling test after the step from t to t + dt [s] end the run."""
    if not np.isfinite(v).all():
        return f"state became non-finite during the step from t = {t:.4f} s"
    joint = int(np.argmax(np.abs(v)))
    unit = robot.joint_unit(joint, "velocity")
    return (
        f"speed of joint {robot.joint_names[joint]} reached {v[joint]:.4g} {unit}, beyond "
        f"{max_joint_speed:g} {unit}, at t = {t + dt:.4f} s"
    )


class StopRules:
    r"""The stops every loop applies, and their messages, for one robot and one pair of ceilings.

    ``torque_ceiling`` (per joint, [N·m]) and ``speed_ceiling`` ([rad/s]) are
    those of :func:`stop_ceilings`: a loop's one test per vector and step is
    all(|value| <= ceiling), which also fails inf and NaN; the wording comes
    from the methods here only once a test failed.
    """

    def __init__(self, robot: Robot, max_torque_ratio: float, max_joint_speed: float):
        self.robot, self.max_torque_ratio, self.max_joint_speed = robot, max_torque_ratio, max_joint_speed
        self.torque_ceiling, self.speed_ceiling = stop_ceilings(robot, max_torque_ratio, max_joint_speed)
        # A stack of one held as its row (n,) is tested on plain lists, cheaper than numpy's reductions at that size.
        self._torque_ceilings = self.torque_ceiling.tolist()
        self._speed_ceilings = [self.speed_ceiling] * robot.nv

    def torques_over(self, torque: np.ndarray) -> np.ndarray:
        """Per row of a (B, n) stack: True where a torque fails its ceiling (or is not finite)."""
        return ~(np.abs(torque) <= self.torque_ceiling).all(axis=1)

    def speeds_over(self, velocity: np.ndarray) -> np.ndarray:
        """Per row of a (B, n) stack: True where a joint speed fails the ceiling (or is not finite)."""
        return ~(np.abs(velocity) <= self.speed_ceiling).all(axis=1)

    def any_torque_over(self, torque: np.ndarray) -> bool:
        """Whether some row of a non-empty (B, n) stack (or one row, (n,)) fails :meth:`torques_over`: one reduction
        over the stack (a NaN carries through the maximum and fails the test), the rows sought only when it is True."""
        if torque.ndim == 1:
            return not all(map(operator.le, map(abs, torque.tolist()), self._torque_ceilings))
        return not (np.abs(torque).max(axis=0) <= self.torque_ceiling).all()

    def any_speed_over(self, velocity: np.ndarray) -> bool:
        """Whether some row of a non-empty (B, n) stack fails :meth:`speeds_over`, by one reduction over the stack."""
        if velocity.ndim == 1:
            return not all(map(operator.le, map(abs, velocity.tolist()), self._speed_ceilings))
        return not np.abs(velocity).max() <= self.speed_ceiling

    def torque(self, tau: np.ndarray, t: float) -> str:
        """Why torques that failed the ceiling at time t [s] end the run."""
        return torque_stop_reason(self.robot, tau, self.max_torque_ratio, t)

    def speed(self, v: np.ndarray, t: float, dt: float) -> str:
        """Why velocities that failed the ceiling after the step from t to t + dt [s] end the run."""
        return speed_stop_reason(self.robot, v, self.max_joint_speed, t, dt)

    def rates(self, velocity: np.ndarray, t: float) -> str:
        """Why joint rates a velocity-level method gave at time t [s] end the run (they failed the ceiling)."""
        if not np.isfinite(velocity).all():
            return f"joint rates became non-finite at t = {t:.4f} s"
        joint = int(np.argmax(np.abs(velocity)))
        unit = self.robot.joint_unit(joint, "velocity")
        return (
            f"speed of joint {self.robot.joint_names[joint]} reached {velocity[joint]:.4g} {unit}, beyond "
            f"{self.max_joint_speed:g} {unit}, at t = {t:.4f} s"
        )

    @staticmethod
    def unresolved(error, t: float) -> str:
        """Why a resolver that could not resolve the state at t [s] ends the run (``error``: its exception or message)."""
        return f"{error} at t = {t:.4f} s"

    @staticmethod
    def unresolved_during_step(error, t: float) -> str:
        """Why a velocity-level method undefined at a stage of the step from t [s] ends the run."""
        return f"{error} during the step from t = {t:.4f} s"
