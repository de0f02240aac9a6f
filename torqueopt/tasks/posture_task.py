r"""A posture task: every joint toward a reference configuration (joint space, m = n).

Its coordinates are the joint angles (one per joint, as :meth:`Robot.joint_angles`),
its Jacobian the identity and its drift zero. As a low-priority task it keeps a
redundant arm's self-motion near a chosen posture, the remedy users of
velocity-level IK ask for when arms drift into awkward configurations.
"""

from __future__ import annotations

import numpy as np

from ..checks import joint_vector
from .task import Kinematics, Task, identity

__all__ = ["PostureTask"]


class PostureTask(Task):
    """Joint angles toward ``target`` (n values [rad]); the robot's default configuration when None.

    Args:
        target: joint angles to regulate to [rad, m], one per joint; the robot's
            SRDF or neutral configuration by default.
        gain: regulation gain [1/s].
    """

    closed_form_rates = True

    def __init__(self, target=None, gain: float = 1.0):
        self.dimension = None if target is None else int(np.size(target))
        self._given = target
        super().__init__(target, gain)

    def check(self, robot) -> None:
        if self._given is None:
            self.dimension = robot.nv
            self.target = robot.joint_angles(robot.default_configuration)
        else:
            joint_vector(robot, self.target, "posture target")

    def _require(self, kinematics: Kinematics) -> None:
        if self.target is None:
            self.check(kinematics.robot)

    def value(self, kinematics: Kinematics) -> np.ndarray:
        self._require(kinematics)
        return kinematics.robot.joint_angles(kinematics.q)

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        """The identity (n×n, read-only)."""
        return identity(kinematics.nv)

    def drift(self, kinematics: Kinematics) -> np.ndarray:
        return np.zeros(kinematics.nv)

    def jacobian_rate(self, kinematics: Kinematics, v: np.ndarray) -> np.ndarray:
        return np.zeros((kinematics.nv, kinematics.nv))

    def desired_velocity_rate(self, kinematics: Kinematics, v: np.ndarray) -> np.ndarray:
        r""":math:`-k v` [rad/s²]: the joint angles move at v."""
        return -self.gain * v

    def error(self, kinematics: Kinematics) -> np.ndarray:
        self._require(kinematics)
        return self.target - self.value(kinematics)

    def desired_velocity(self, kinematics: Kinematics) -> np.ndarray:
        return self.gain * self.error(kinematics)

    def __repr__(self) -> str:
        target = (
            "default configuration" if self._given is None else np.round(np.asarray(self._given, float), 4).tolist()
        )
        return f"PostureTask(target={target}, gain={self.gain:g})"
