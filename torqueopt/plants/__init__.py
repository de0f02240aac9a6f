"""The plant: what a simulated torque acts on, one control step at a time, for one movement or a stack of them.

A resolver computes its torque from torqueopt's own Pinocchio model; the
plant is the physics that torque is applied to, and it is the integrator of
the run. Two are registered:

``pinocchio``
    the same Pinocchio model, integrated by classical RK4 with the torque
    held over the step (:mod:`torqueopt.integrators`): the controller knows
    its plant exactly, as in the paper.
``mujoco``
    a MuJoCo model of the arm (the robot's URDF compiled by MuJoCo, or a
    user's MJCF whose joint names match), advanced by MuJoCo's own
    integrator (:mod:`torqueopt.plants.mujoco`; needs the ``mujoco`` extra).

Every plant has the interface of :class:`Plant`. Another plant registers
with :func:`register_plant` (a class decorator) or, from an installed
package, with an entry point in the group ``torqueopt.plants``
(``myplant = "mypackage.module:MyPlant"``); :func:`make_plant` then builds
it by name, for :func:`torqueopt.simulate`, ``simulate_batch`` and the CLI's
``--plant``.
"""

from __future__ import annotations

from . import base
from .base import *  # noqa: F403

# isort: off
# Importing a plant's module registers it, in the order --plant lists them: the paper's first.
from . import pinocchio
from .pinocchio import *  # noqa: F403
from . import mujoco  # noqa: F401  (mujoco itself is imported only when a MuJoCo plant is built)
# isort: on

__all__ = base.__all__ + pinocchio.__all__
