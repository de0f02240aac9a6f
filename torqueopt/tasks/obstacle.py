r"""The point of the arm closest to an obstacle, for obstacle avoidance (Maciejewski & Klein, Eq. (12), Eq. (13)).

The arm is modelled as a chain of segments: from each joint origin of the
chain that carries the task frame to the next, and from the last joint to
the task frame's origin. Each segment is rigid in the body of the joint it
starts at. For a point obstacle at :math:`c` or a sphere of radius
:math:`r` about it, the closest point :math:`x_o` of the arm is the closest
point over the segments; its clearance is :math:`d = \|x_o - c\| - r` [m]
and its outward normal :math:`\hat n = (x_o - c)/\|x_o - c\|`.

The Jacobian :math:`J_o` with :math:`\dot x_o = J_o\dot q` is Pinocchio's
Jacobian of a frame placed at :math:`x_o` on that segment's body
(``getFrameJacobian(model, data, joint, placement, LOCAL_WORLD_ALIGNED)``),
the velocity of the material point that is closest at this instant, as in
Maciejewski & Klein. The repulsive velocity is :math:`\dot x_o = v_o \hat n`
with a speed :math:`v_o` [m/s].
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ..checks import check_frame, finite_numbers, non_negative_number
from ..errors import InvalidInput
from .task import Kinematics, Task, identity

__all__ = ["ObstacleTask", "ClosestPoint"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class ClosestPoint(NamedTuple):
    """The point of the arm closest to the obstacle.

    Attributes:
        point: its world position :math:`x_o` [m].
        normal: unit vector from the obstacle centre to it.
        clearance: distance to the obstacle's surface [m] (negative inside).
        joint_id: the joint whose body carries it.
        segment: index of the segment along the chain (0 at the base).
    """

    point: np.ndarray
    normal: np.ndarray
    clearance: float
    joint_id: int
    segment: int


class ObstacleTask(Task):
    r"""The closest point of the arm to a point or sphere obstacle (dimension 3).

    Args:
        center: obstacle centre in world axes [m]: 3 values, or 2 (z = 0) for planar arms.
        radius: sphere radius [m]; 0 for a point obstacle.
        speed: repulsive speed :math:`v_o` [m/s] of :meth:`desired_velocity`.
        frame: the frame that ends the chain; the robot's task frame by default.
    """

    dimension = 3

    def __init__(self, center, radius: float = 0.0, *, speed: float = 0.5, frame: str | None = None):
        values = finite_numbers(center, "obstacle centre", (2, 3), unit="m")
        self.center = np.concatenate([values, np.zeros(3 - values.size)])
        self.radius = non_negative_number(radius, "obstacle radius", "m")
        self.speed = non_negative_number(speed, "obstacle speed", "m/s")
        self.frame = frame
        self._chain_key = None
        self._chain: tuple[list[int], int] = ([], 0)
        super().__init__(None, 1.0)

    @classmethod
    def from_spec(cls, spec) -> ObstacleTask:
        """An obstacle from an ObstacleTask, or from numbers: (x, y), (x, y, z) or (x, y, z, radius) [m]."""
        if isinstance(spec, ObstacleTask):
            return spec
        try:
            values = np.asarray(spec, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InvalidInput(
                f"obstacle {spec!r} is not an ObstacleTask or 2-4 numbers (x, y[, z[, radius]])"
            ) from None
        if values.size == 4:
            return cls(values[:3], values[3])
        return cls(values)

    def check(self, robot) -> None:
        check_frame(robot.model, self.frame or robot.frame, robot.name)

    def _segments(self, kinematics: Kinematics):
        """(the chain's joint ids from the base, the end frame's id), built once per model: segment i runs from
        joint i's origin to joint i + 1's, the last to the end frame's origin."""
        model = kinematics.model
        key = id(model)
        if self._chain_key != key:
            frame_id = model.getFrameId(self.frame or kinematics.robot.frame)
            self._chain = ([j for j in model.supports[model.frames[frame_id].parentJoint] if j > 0], frame_id)
            self._chain_key = key
        return self._chain

    def closest_point(self, kinematics: Kinematics) -> ClosestPoint:
        """The closest point of the arm's segments to the obstacle, with its clearance [m]."""
        joints, end_frame = self._segments(kinematics)
        # each origin read once from Pinocchio's data (a segment's end is the next one's start)
        origins = [kinematics.data.oMi[joint].translation for joint in joints]
        origins.append(kinematics.data.oMf[end_frame].translation)
        center, best = self.center, None
        for index, joint in enumerate(joints):
            start = origins[index]
            axis = origins[index + 1] - start
            length_squared = float(axis.dot(axis))
            fraction = (
                0.0 if length_squared == 0.0 else min(1.0, max(0.0, float((center - start).dot(axis)) / length_squared))
            )
            point = start + fraction * axis
            offset = point - center
            distance = math.sqrt(offset.dot(offset))  # what np.linalg.norm computes, without its wrapper
            if best is None or distance < best[0]:
                best = (distance, point, offset, joint, index)
        distance, point, offset, joint, index = best
        normal = offset / distance if distance > 0 else np.array([1.0, 0.0, 0.0])
        return ClosestPoint(point, normal, distance - self.radius, joint, index)

    def clearance(self, kinematics: Kinematics) -> float:
        """Distance from the arm to the obstacle's surface [m]."""
        return self.closest_point(kinematics).clearance

    def _placement(self, kinematics: Kinematics, closest: ClosestPoint) -> pin.SE3:
        joint_placement = kinematics.data.oMi[closest.joint_id]
        local_point = joint_placement.rotation.T.dot(closest.point - joint_placement.translation)
        return pin.SE3(identity(3), local_point)

    def value(self, kinematics: Kinematics) -> np.ndarray:
        return self.closest_point(kinematics).point

    def point_jacobian(self, kinematics: Kinematics, closest: ClosestPoint) -> np.ndarray:
        r"""3×n Jacobian :math:`J_o` of the material point at ``closest`` (world axes)."""
        placement = self._placement(kinematics, closest)
        return pin.getFrameJacobian(kinematics.model, kinematics.data, closest.joint_id, placement, _LWA)[:3]

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return self.point_jacobian(kinematics, self.closest_point(kinematics))

    def drift(self, kinematics: Kinematics) -> np.ndarray:
        if kinematics.v is None:
            raise InvalidInput("a task drift J̇q̇ needs the joint velocity: call Kinematics.update(q, v)")
        closest = self.closest_point(kinematics)
        placement = self._placement(kinematics, closest)
        return pin.getFrameClassicalAcceleration(
            kinematics.model, kinematics.data, closest.joint_id, placement, _LWA
        ).linear.copy()

    def desired_velocity(self, kinematics: Kinematics) -> np.ndarray:
        r"""The repulsive velocity :math:`\dot x_o = v_o \hat n` [m/s], away from the obstacle."""
        return self.speed * self.closest_point(kinematics).normal

    def __repr__(self) -> str:
        return f"ObstacleTask(center={self.center.tolist()}, radius={self.radius:g})"
