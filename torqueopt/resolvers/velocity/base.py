r"""The contract of a velocity-level (kinematic) resolver.

A velocity-level resolver maps the commanded task velocity to joint rates,
:math:`\dot q = f(q, \dot x)`, as Section 1.1 of the paper does, with the
task velocity :math:`\dot x = J\dot q` (Eq. (1)). It has no torque step of
its own: :func:`torqueopt.simulate` sees its ``level`` and hands it to
:func:`torqueopt.kinematic.simulate_kinematic`, which integrates
:math:`\dot q = f(q, t)` by RK4 and finds the torques by inverse dynamics on
the resulting motion.

Subclasses implement :meth:`VelocityResolver.rate_function`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ...errors import InvalidInput
from ...linalg import DEFAULT_SINGULAR_TOLERANCE, JacobianSolver
from ...robot import Robot
from ...tasks import FrameTask
from ..base import Resolver

__all__ = ["VelocityResolver", "pseudoinverse_solver"]


class VelocityResolver(Resolver):
    """Maps a task velocity to joint velocities; run through :func:`torqueopt.simulate`.

    Args:
        position_gain: closed-loop inverse kinematics gain K [1/s]: the
            commanded task velocity is :math:`\\dot x_{ref} + K(x_{ref} - x)`;
            0 (the default) is the paper's open loop.
        singular_tolerance: relative singular-value cutoff of the task Jacobian.
    """

    #: The simulation loop that runs this resolver: joint rates integrated, torques by inverse dynamics.
    level: ClassVar[str] = "velocity"

    def __init__(self, position_gain: float = 0.0, singular_tolerance: float = DEFAULT_SINGULAR_TOLERANCE):
        super().__init__(singular_tolerance)
        position_gain = float(position_gain)
        if not (np.isfinite(position_gain) and position_gain >= 0):
            raise InvalidInput(f"position_gain={position_gain!r} must be a finite number >= 0 [1/s]")
        self.position_gain = position_gain

    def rate_function(self, robot: Robot, task: FrameTask):
        r"""How this resolver maps task velocity to joint rates on ``robot``.

        Returns a function ``(kinematics, task_velocity) -> (q̇, condition)``:
        ``kinematics`` is a :class:`torqueopt.tasks.Kinematics` already
        updated at q, ``task_velocity`` the commanded :math:`\dot x` of
        ``task`` [m/s, rad/s], q̇ the joint rates [rad/s] and condition
        :math:`\sigma_{min}/\sigma_{max}` of the task Jacobian. The map must
        be affine in ``task_velocity`` (every Section 1.1 method is): the
        simulation differentiates it in time through that. It raises
        SingularJacobian where the method is undefined.
        """
        raise NotImplementedError

    def stop_diagnosis(self, kinematics, task: FrameTask) -> str | None:
        """What the method's own state says at a configuration where a run had to stop, or None."""
        return None

    def null_space_solver(self, robot: Robot):
        raise InvalidInput(self._torque_message())

    def solver(self, robot: Robot):
        raise InvalidInput(self._torque_message())

    def _torque_message(self) -> str:
        return (
            f"resolver '{self.name}' resolves joint velocities, not torques from a task acceleration: "
            "run it through torqueopt.simulate (joint rates integrated, torques by inverse dynamics) "
            "or torqueopt.kinematic.joint_rates"
        )


def pseudoinverse_solver(robot: Robot, tolerance: float, null_space: bool = True) -> JacobianSolver:
    r"""SVD solver returning :math:`(J^\dagger r, Z, \sigma_{min}/\sigma_{max})`, Eq. (3), Z a null-space basis."""
    return JacobianSolver(robot.m, robot.nv, tolerance, null_space=null_space and robot.nv > robot.m)
