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

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from ...errors import InvalidInput
from ...linalg import JacobianSolver
from ...robot import Robot
from ...tasks import FrameTask
from ..base import Resolver
from ..options import LARGEST_WEIGHT, Option, number

__all__ = ["VelocityResolver", "VelocityStack", "pseudoinverse_solver", "POSITION_GAIN_OPTION"]

#: The option every velocity-level resolver accepts: closed-loop inverse kinematics.
POSITION_GAIN_OPTION = Option(
    name="position_gain",
    kind="number in [0, 1e6]",
    unit="1/s",
    default=0.0,
    meaning="closed-loop inverse kinematics: commanded task velocity ẋ_ref + K(x_ref − x); 0 is the paper's open loop",
    convert=number(0.0, unit="1/s", maximum=LARGEST_WEIGHT),
)


class VelocityResolver(Resolver):
    """Maps a task velocity to joint velocities; run through :func:`torqueopt.simulate`.

    Every velocity-level resolver declares ``position_gain`` (K [1/s]: the
    commanded task velocity is :math:`\\dot x_{ref} + K(x_{ref} - x)`, 0 the
    paper's open loop) after its own options, and ``singular_tolerance``.
    """

    #: The simulation loop that runs this resolver (joint rates integrated, torques by inverse dynamics).
    level: ClassVar[str] = "velocity"
    options: ClassVar[tuple[Option, ...]] = (POSITION_GAIN_OPTION,)

    @abstractmethod
    def rate_function(self, robot: Robot, task: FrameTask):
        r"""How this resolver maps task velocity to joint rates on ``robot``.

        Returns a function ``(kinematics, task_velocity) -> (q̇, inverse_condition)``:
        ``kinematics`` is a :class:`torqueopt.tasks.Kinematics` already
        updated at q, ``task_velocity`` the commanded :math:`\dot x` of
        ``task`` [m/s, rad/s], q̇ the joint rates [rad/s] and inverse_condition
        :math:`\sigma_{min}/\sigma_{max}` of the task Jacobian. The map must
        be affine in ``task_velocity`` (every Section 1.1 method is): the
        simulation differentiates it in time through that. It raises
        SingularJacobian where the method is undefined.
        """

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""The joint acceleration of the motion in closed form, or None (the default).

        A function ``(kinematics, q̇, c, ċ) -> q̈``: :math:`\ddot q = \frac{d}{dt} f(q(t), c(t))`
        at the kinematics' configuration, with :math:`\dot q = f(q, c)` the
        rates this resolver gave for the command c and :math:`\dot c` the
        command's total rate. With None the loop takes q̈ by a central
        difference of f along q̇ (``torqueopt.kinematic``), the reference
        a closed form is held to.
        """
        return None

    def step_functions(self, robot: Robot, task: FrameTask):
        """The pair (:meth:`rate_function`, :meth:`acceleration_function`) for one run.

        A resolver whose q̈ reads what its rates compute at the same configuration (a pseudoinverse, a
        criterion's gradient) builds the two together, sharing it through a
        :class:`~torqueopt.tasks.PerConfiguration`: the loop evaluates the rates at each step start and then q̈
        there.
        """
        return self.rate_function(robot, task), self.acceleration_function(robot, task)

    def stack_rate_function(self, robot: Robot) -> VelocityStack | None:
        """The joint rates and q̈ on (B, ...) stacks, for the batch, or None (the default: one movement at a time):
        a :class:`VelocityStack`, the stacked forms of :meth:`rate_function` and :meth:`acceleration_function`."""
        return None

    def settings_for_file(self) -> dict:
        """The option values as JSON-ready values: vectors as lists, task objects and callables by their repr."""
        settings = {}
        for key, value in self.settings.items():
            if isinstance(value, np.ndarray):
                settings[key] = value.tolist()
            elif value is None or isinstance(value, (bool, int, float, str)):
                settings[key] = value
            else:
                settings[key] = repr(value)
        return settings

    def stop_diagnosis(self, kinematics, task: FrameTask) -> str | None:
        """What the method's own state says at a configuration where a run had to stop, or None."""
        return None

    def solver(self, robot: Robot):
        """Refused: a velocity-level resolver has no torque step (InvalidInput saying how to run it)."""
        raise InvalidInput(
            f"resolver '{self.name}' resolves joint velocities, not torques from a task acceleration: "
            "run it through torqueopt.simulate (joint rates integrated, torques by inverse dynamics) "
            "or torqueopt.kinematic.joint_rates"
        )


class VelocityStack:
    r"""A velocity-level resolver's step on (B, ...) stacks of states, what the batch's lanes call
    (``torqueopt.batch.KinematicStack``).

    ``rates(J, c, q, kinematics) -> (q̇, σmin/σmax, failures, state)``: J (B, m, n) the task Jacobians, c (B, m)
    the commands, q (B, nq) the configurations, ``kinematics`` the forest's
    ``TaskKinematics`` (``torqueopt.robot_copies``) at q; ``failures`` {row: why the method is undefined there}
    (such a row gets a finite, unused answer); ``state`` what ``rates`` computed that ``acceleration`` reuses.
    ``acceleration(J, J̇, q̇, ċ, state, moving) -> q̈`` (B, n): ``moving`` the forest's kinematics at (q, q̇).

    The flags say what the forest's pass must add to ``kinematics`` (at q) and ``moving`` (at (q, q̇)):
    :math:`H^{-1}`, :math:`\dot H\dot q`, :math:`H` (``inertia``), and every joint's kinematics (``joints``, for tasks
    on other points).
    The task frame's six rows of J and :math:`\dot J` are always there beside the task's (``frame_jacobian``,
    ``frame_rate``: references to what the pass computed, no copy).
    """

    reads_inverse_inertia: bool = False
    reads_inertia_rate: bool = False
    reads_joints: bool = False
    reads_inertia: bool = False
    #: Joints per forest pass of the batch's forest, None for the forest's own (``FOREST_DOFS``).
    forest_dofs: int | None = None

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        raise NotImplementedError

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        raise NotImplementedError

    def energies(self, jacobian, velocity, state, kinematics):
        r"""``(T, E_N)`` (B,) each [J] at the configurations ``rates`` was last given, from what it computed there
        (``state``, ``kinematics``), or None (the default): the batch's energy extras then take them from
        ``torqueopt.self_motion.self_motion_energy`` (H by CRBA), the figures a stack's own must equal to round-off.

        J (B, m, n) and ``kinematics`` those ``rates`` was given, :math:`\dot q` (B, n) any joint velocities;
        :math:`T = \tfrac12\dot q^\top H\dot q`, :math:`E_N = T - \tfrac12\dot x^\top(JH^{-1}J^\top)^{-1}\dot x`,
        :math:`\dot x = J\dot q`. A row in ``rates``' failures may get any finite value (the batch does not
        record it).
        """
        return None


def pseudoinverse_solver(robot: Robot, tolerance: float, null_space: bool = True) -> JacobianSolver:
    r"""SVD solver returning :math:`(J^\dagger r, Z, \sigma_{min}/\sigma_{max})`, Eq. (3), Z a null-space basis."""
    return JacobianSolver(robot.m, robot.nv, tolerance, null_space=null_space and robot.nv > robot.m)
