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
        self._center = tuple(self.center.tolist())  # the centre's coordinates as floats, for the float loops
        self._chain_key = None
        self._chain: tuple[list[int], int] = ([], 0)
        self._views_of: Kinematics | None = None
        self._views: tuple = ()
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
        """(the chain's joint ids from the base, their rows in :meth:`Kinematics.joint_origins`, the end frame's id),
        built once per model: segment i runs from joint i's origin to joint i + 1's, the last to the end frame's
        origin."""
        model = kinematics.model
        key = id(model)
        if self._chain_key != key:
            joints, frame_id = self.chain(model, kinematics.robot.frame)
            first = joints[0] if joints else 0
            # a chain of consecutive joints (a serial arm's) is read by a slice, without a copy
            rows = slice(first, first + len(joints)) if joints == list(range(first, first + len(joints))) else joints
            self._chain = (joints, rows, frame_id)
            self._chain_key = key
        return self._chain

    def _chain_views(self, kinematics: Kinematics):
        """(the chain's joint ids, their rows in :meth:`Kinematics.joint_origins`, a view of those rows (None for a
        chain that is not consecutive, read by a copy), a view of the end frame's position), kept for the last
        kinematics read: views of Pinocchio's data that hold its latest update."""
        if kinematics is not self._views_of:
            joints, rows, end_frame = self._segments(kinematics)
            origins = kinematics.joint_origins()[rows] if type(rows) is slice else None
            self._views = joints, rows, origins, kinematics.frame_position_view(end_frame)
            self._views_of = kinematics
        return self._views

    def chain(self, model: pin.Model, task_frame: str) -> tuple[list[int], int]:
        """The joint ids of the chain from the base, and the id of the frame that ends it (this task's ``frame``,
        else ``task_frame``): segment i starts at joint i's origin and moves with that joint's body, the last ends
        at the frame's origin."""
        frame_id = model.getFrameId(self.frame or task_frame)
        return [j for j in model.supports[model.frames[frame_id].parentJoint] if j > 0], frame_id

    def closest_point(self, kinematics: Kinematics) -> ClosestPoint:
        r"""The closest point of the arm's segments to the obstacle, with its clearance [m].

        On segment i from :math:`a_i` to :math:`b_i` the closest point is :math:`a_i + s_i(b_i - a_i)`, with
        :math:`s_i = (c - a_i)\cdot(b_i - a_i)/\|b_i - a_i\|^2` clipped to [0, 1] (0 for a segment of no
        length); the arm's is the nearest of these (the first of equals).

        The few coordinates are Python floats: on 3-vectors a numpy operation costs more than the arithmetic it
        does, so floats beat both a loop on numpy 3-vectors and the segments at once in numpy (measured by
        callgrind: BENCHMARKS.md, "Velocity-level methods batched, timed").
        """
        distance, segment, joint, (px, py, pz), _, _, _ = self.closest_values(kinematics)
        cx, cy, cz = self._center
        ox, oy, oz = px - cx, py - cy, pz - cz
        normal = np.array((ox / distance, oy / distance, oz / distance) if distance > 0 else (1.0, 0.0, 0.0))
        return ClosestPoint(np.array((px, py, pz)), normal, distance - self.radius, joint, segment)

    def closest_values(self, kinematics: Kinematics, end=None):
        r""":meth:`closest_point`'s geometry as Python floats, for the steps on floats: (the distance
        :math:`\|x_o - c\|` [m], the segment's index, the joint that carries it, :math:`x_o`, the segment's start a
        (its joint's origin), its axis u = b − a, and whether :math:`x_o` is inside the segment,
        :math:`0 < (c - a)\cdot u < \|u\|^2`, where it slides along it as the arm moves), the 3-vectors as tuples;
        the first of equally near segments. ``end``: the position [m] of the frame that ends the chain (3 floats) when
        the caller has read it at this configuration, else None (read here)."""
        joints, rows, origins_view, end_view = self._chain_views(kinematics)
        # the origins once each, from views of Pinocchio's data (a segment's end is the next one's start)
        origins = (kinematics.joint_origins()[rows] if origins_view is None else origins_view).tolist()
        origins.append(end_view.tolist() if end is None else end)
        cx, cy, cz = self._center
        # The nearest by squared distance, the first of equals; x_o and one square root for the nearest only. Inside a
        # segment the squared distance is ‖c − a‖² − ((c − a)·u)²/‖u‖² (Pythagoras), without x_o; at an end it is
        # ‖x_o − c‖² from x_o = a or a + u, the floats x_o takes below.
        nearest = math.inf
        ax, ay, az = origins[0]
        for index in range(len(origins) - 1):
            bx, by, bz = origins[index + 1]
            ux, uy, uz = bx - ax, by - ay, bz - az
            dx, dy, dz = cx - ax, cy - ay, cz - az
            length_squared = ux * ux + uy * uy + uz * uz
            along = dx * ux + dy * uy + dz * uz
            # s = (c − a)·u/‖u‖² clipped to [0, 1]
            if along <= 0.0 or length_squared == 0.0:
                squared = dx * dx + dy * dy + dz * dz
            elif along >= length_squared:
                ox, oy, oz = ax + ux - cx, ay + uy - cy, az + uz - cz
                squared = ox * ox + oy * oy + oz * oz
            else:
                squared = dx * dx + dy * dy + dz * dz - along * along / length_squared
            if not squared >= nearest:  # (a NaN state keeps a segment too)
                nearest = squared
                best = index, ax, ay, az, ux, uy, uz, along, length_squared
            ax, ay, az = bx, by, bz
        index, ax, ay, az, ux, uy, uz, along, length_squared = best
        if along <= 0.0 or length_squared == 0.0:
            px, py, pz = ax, ay, az
        elif along >= length_squared:
            px, py, pz = ax + ux, ay + uy, az + uz
        else:
            fraction = along / length_squared
            px, py, pz = ax + fraction * ux, ay + fraction * uy, az + fraction * uz
        ox, oy, oz = px - cx, py - cy, pz - cz
        distance = math.sqrt(ox * ox + oy * oy + oz * oz)
        return distance, index, joints[index], (px, py, pz), (ax, ay, az), (ux, uy, uz), 0.0 < along < length_squared

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
        r"""3×n Jacobian :math:`J_o` of the material point at ``closest`` (world axes).

        Pinocchio's Jacobian of the carrying joint at its origin :math:`o` in world-aligned axes,
        :math:`(J_v; J_\omega)`, moved to the point (a change of frame): the point's velocity is
        :math:`v + \omega\times(x_o - o)`, so :math:`J_o = J_v - [x_o - o]_\times J_\omega`, what
        ``getFrameJacobian`` gives for a frame placed at :math:`x_o` on that body (a test holds the two equal).
        """
        joint_jacobian = pin.getJointJacobian(kinematics.model, kinematics.data, closest.joint_id, _LWA)
        lever = closest.point - kinematics.joint_origins()[closest.joint_id]
        return joint_jacobian[:3] - pin.skew(lever).dot(joint_jacobian[3:])

    def point_rates(self, kinematics: Kinematics, closest: ClosestPoint, v: np.ndarray):
        r"""How the closest point moves as the arm moves at joint velocity v [rad/s]: its velocity :math:`v_p`
        [m/s], the rate of its normal :math:`\dot{\hat n}` [1/s] and :math:`\dot J_o`, where it moves smoothly
        (not at the instant it passes from one segment to another, or onto or off a segment's end).

        On segment i from the joint origin a to b (both fixed in that joint's body, moving at :math:`v_a` and
        angular velocity :math:`\omega`), :math:`x_o = a + s u`, :math:`u = b - a`: inside the segment
        :math:`\dot s = ((c - a)\cdot(\omega\times u) - v_a\cdot u)/\|u\|^2` (:math:`\dot u = \omega\times u`
        is normal to u), at an end 0. So the closest point moves at
        :math:`v_p = J_o v + \dot s u` (the material point's velocity plus its slide; not the repulsive
        :math:`\dot x_o`), its lever
        :math:`r = x_o - a` at :math:`\dot r = \omega\times r + \dot s u`, and
        :math:`\dot J_o = \dot J_v - [\dot r]_\times J_\omega - [r]_\times\dot J_\omega` from Pinocchio's joint
        Jacobian and its time variation (world-aligned); :math:`\dot{\hat n} = (I - \hat n\hat n^\top)v_p/\|x_o - c\|`.
        A test holds the three to central differences of :meth:`closest_point` and :meth:`point_jacobian`.
        """
        model, data, joint = kinematics.model, kinematics.data, closest.joint_id
        pin.computeJointJacobiansTimeVariation(model, data, kinematics.q, v)
        joint_jacobian = pin.getJointJacobian(model, data, joint, _LWA)
        joint_jacobian_rate = pin.getJointJacobianTimeVariation(model, data, joint, _LWA)
        joints, _, end_frame = self._segments(kinematics)
        following = closest.segment + 1
        end = (
            kinematics.joint_origins()[joints[following]]
            if following < len(joints)
            else kinematics.frame_position_view(end_frame)
        )
        # 3-vectors as floats, as in closest_point: v_a and ω, a, b, x_o, n̂, c
        vx, vy, vz, wx, wy, wz = joint_jacobian.dot(v).tolist()
        (ax, ay, az), (bx, by, bz) = kinematics.joint_origins()[joint].tolist(), end.tolist()
        (px, py, pz), (nx, ny, nz), (cx, cy, cz) = closest.point.tolist(), closest.normal.tolist(), self.center.tolist()
        ux, uy, uz = bx - ax, by - ay, bz - az
        rx, ry, rz = px - ax, py - ay, pz - az  # the lever r = x_o − a
        length_squared = ux * ux + uy * uy + uz * uz
        along = (cx - ax) * ux + (cy - ay) * uy + (cz - az) * uz
        slide = 0.0
        if 0.0 < along < length_squared:  # inside the segment: ṡ = ((c − a)·(ω × u) − v_a·u)/‖u‖²
            turn = (cx - ax) * (wy * uz - wz * uy) + (cy - ay) * (wz * ux - wx * uz) + (cz - az) * (wx * uy - wy * ux)
            slide = (turn - (vx * ux + vy * uy + vz * uz)) / length_squared
        # ṙ = ω × r + ṡ u, and ẋ_o = v_a + ṙ
        dx, dy, dz = wy * rz - wz * ry + slide * ux, wz * rx - wx * rz + slide * uy, wx * ry - wy * rx + slide * uz
        ox, oy, oz = vx + dx, vy + dy, vz + dz
        distance = closest.clearance + self.radius
        normal_speed = nx * ox + ny * oy + nz * oz
        point_velocity = np.array((ox, oy, oz))
        normal_rate = np.array(
            (
                (ox - nx * normal_speed) / distance,
                (oy - ny * normal_speed) / distance,
                (oz - nz * normal_speed) / distance,
            )
        )
        point_jacobian_rate = (
            joint_jacobian_rate[:3]
            - pin.skew(np.array((dx, dy, dz))).dot(joint_jacobian[3:])
            - pin.skew(np.array((rx, ry, rz))).dot(joint_jacobian_rate[3:])
        )
        return point_velocity, normal_rate, point_jacobian_rate

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
