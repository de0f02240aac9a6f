r"""A frame task: the planar position, the position or the pose of a named frame.

Kinds (the same as a :class:`torqueopt.Robot`'s task string):

``xy``
    the frame origin's x and y in world axes (m = 2), the paper's task;
``position``
    the frame origin in world axes (m = 3);
``pose``
    position and orientation (m = 6); the orientation coordinates are the
    rotation vector :math:`\log(R R_0^\top)` relative to a reference rotation
    :math:`R_0` (world axes), whose rates are taken as the world angular
    velocity, as in :mod:`torqueopt.robot`.

The Jacobian is Pinocchio's frame Jacobian at the frame origin with
world-aligned axes, the drift its classical acceleration at zero q̈.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..checks import check_frame, check_task
from .task import Kinematics, Task

__all__ = ["FrameTask", "FRAME_TASK_KINDS"]

#: Rows of Pinocchio's 6-D frame Jacobian (linear first) that each kind uses.
FRAME_TASK_KINDS = {"xy": slice(0, 2), "position": slice(0, 3), "pose": slice(0, 6)}


class FrameTask(Task):
    """Planar position (``xy``), position or pose of the frame ``frame``.

    Args:
        frame: a frame name of the robot's model (``tip`` for planar3).
        kind: ``xy``, ``position`` or ``pose``.
        target: task coordinates to regulate to, or None.
        gain: regulation gain [1/s].
        reference_rotation: :math:`R_0` for ``pose`` (3×3, world axes); identity by default.
    """

    def __init__(self, frame: str, kind: str = "position", *, target=None, gain: float = 1.0, reference_rotation=None):
        check_task(kind, "task kind")
        self.frame = frame
        self.kind = kind
        self.rows = FRAME_TASK_KINDS[kind]
        self.dimension = self.rows.stop
        self.reference_rotation = np.eye(3) if reference_rotation is None else np.asarray(reference_rotation, float)
        self._frame_id: int | None = None
        self._model_id: int | None = None
        # (n × 6 zeros, its view on the task's rows, its flat view) for jacobian_derivative_traces
        super().__init__(target, gain)

    @classmethod
    def of_robot(cls, robot, **options) -> FrameTask:
        """The robot's own task (its frame and task string) as a task object."""
        return cls(robot.frame, robot.task, **options)

    @property
    def closed_form_rates(self) -> bool:
        """True for ``xy`` and ``position``, whose J̇ and desired-velocity rate hold in closed form (the rate of a
        pose's rotation vector is J's angular rows times v only at its reference rotation)."""
        return self.kind != "pose"

    def check(self, robot) -> None:
        check_frame(robot.model, self.frame, robot.name)

    def frame_id(self, kinematics: Kinematics) -> int:
        """The frame's index in the kinematics' model (looked up once per model)."""
        if self._model_id != id(kinematics.model):
            self._frame_id = kinematics.model.getFrameId(self.frame)
            self._model_id = id(kinematics.model)
        return self._frame_id

    def value(self, kinematics: Kinematics) -> np.ndarray:
        if self.kind != "pose":
            return kinematics.frame_position(self.frame_id(kinematics))[self.rows]
        placement = kinematics.data.oMf[self.frame_id(kinematics)]
        return np.concatenate([placement.translation, pin.log3(placement.rotation.dot(self.reference_rotation.T))])

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.frame_jacobian(self.frame_id(kinematics))[self.rows]

    def drift(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.frame_drift(self.frame_id(kinematics))[self.rows].copy()

    def jacobian_rate(self, kinematics: Kinematics, v: np.ndarray) -> np.ndarray:
        r""":math:`\dot J` of the task rows at the kinematics' configuration, moving at joint velocity v."""
        return kinematics.frame_jacobian_time_variation(self.frame_id(kinematics), v)[self.rows]

    def jacobian_derivative(self, kinematics: Kinematics) -> np.ndarray:
        r"""(m, n, n) array D with :math:`D[:, i, k] = \partial J_{:,i}/\partial q_k` (kinematic Hessian)."""
        return kinematics.frame_jacobian_derivative(self.frame_id(kinematics))[self.rows]

    def jacobian_derivative_traces(self, kinematics: Kinematics, weights: np.ndarray, scale: float = 1.0) -> np.ndarray:
        r""":math:`s\,\mathrm{tr}(W\,\partial J/\partial q_k)` for each k (n values), for W (n × m) and the scale s:
        :math:`s\sum_{ij} W_{ij} D[j, i, k]` with D of :meth:`jacobian_derivative`, as one product of Pinocchio's
        layout (:meth:`Kinematics.frame_jacobian_derivative_rows`) with W written into the task's rows of an
        n × 6 array (zero elsewhere)."""
        # a fresh array per call, not one kept on the task: a task may serve runs in several threads at once
        padded = np.zeros((weights.shape[0], 6))
        padded[:, self.rows] = weights
        return scale * kinematics.frame_jacobian_derivative_rows(self.frame_id(kinematics)).dot(padded.reshape(-1))

    def desired_velocity(self, kinematics: Kinematics) -> np.ndarray:
        r""":math:`\dot x_d = k(x^* - x)` [m/s, rad/s] (:meth:`Task.desired_velocity`), for ``xy`` and ``position``
        read straight from the frame's position, as :meth:`value` reads it."""
        if self.kind == "pose" or self.target is None:
            return super().desired_velocity(kinematics)
        return self.gain * (self.target - kinematics.frame_position(self.frame_id(kinematics))[self.rows])

    def error(self, kinematics: Kinematics) -> np.ndarray:
        """Target minus value; for ``pose`` the orientation rows are the rotation vector from R to the target's."""
        if self.kind != "pose" or self.target is None:
            return super().error(kinematics)
        placement = kinematics.data.oMf[self.frame_id(kinematics)]
        target_rotation = pin.exp3(self.target[3:]).dot(self.reference_rotation)
        return np.concatenate(
            [self.target[:3] - placement.translation, pin.log3(target_rotation.dot(placement.rotation.T))]
        )

    def __repr__(self) -> str:
        return f"FrameTask({self.frame!r}, {self.kind!r})"
