"""The plant: what a simulated torque acts on, one control step at a time.

A resolver computes its torque from torqueopt's own Pinocchio model; the
plant is the physics that torque is applied to. Two are registered:

``pinocchio``
    the same Pinocchio model, integrated by classical RK4 with the torque
    held over the step (:mod:`torqueopt.integrators`): the controller knows
    its plant exactly, as in the paper.
``mujoco``
    a MuJoCo model of the arm (the robot's URDF compiled by MuJoCo, or a
    user's MJCF whose joint names match), advanced by MuJoCo's own
    integrator (:mod:`torqueopt.plants.mujoco`; needs the ``mujoco`` extra).

Every plant has the same small interface, :class:`Plant`:
``reset(dt)`` before a run, ``step(q, v, tau, dt) -> (q, v)`` for each control
step (q a Pinocchio configuration vector, v the joint velocities [rad/s], tau
the torques [N·m] held over the step of dt [s]), and ``record()``, the
JSON-ready description of the plant and of what it did that the run file keeps.
"""

from __future__ import annotations

import difflib
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InvalidInput
from .pinocchio import PinocchioPlant

__all__ = ["Plant", "PinocchioPlant", "PLANT_NAMES", "make_plant"]

#: The registered plants, by the name ``simulate(..., plant=...)`` and ``--plant`` take.
PLANT_NAMES = ("pinocchio", "mujoco")


@runtime_checkable
class Plant(Protocol):
    """What :func:`torqueopt.simulate` needs of a plant."""

    name: str

    def reset(self, dt: float) -> None:
        """Before a run of control step dt [s]: check the step, forget what the previous run did."""

    def step(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The state (q, v) one control step of dt [s] after (q, v) with the torque tau [N·m] held."""

    def record(self) -> dict:
        """The plant and what it did since :meth:`reset`, JSON-ready, for the run file."""


def make_plant(robot, plant="pinocchio", options: dict | None = None) -> Plant:
    """The plant named ``plant`` (or ``plant`` itself when it is a :class:`Plant`) for ``robot``.

    ``options`` are the plant's options by name (for ``mujoco``, those of
    :func:`torqueopt.plants.mujoco.mujoco_options`: ``mjcf``, ``integrator``,
    ``timestep``, ``contacts``, ``joint-limits``, ``damping``, ...).

    Raises:
        InvalidInput: an unknown plant name, or options given to a plant that takes none.
        MissingDependency: ``mujoco`` without the mujoco package.
    """
    if not isinstance(plant, str):
        if not isinstance(plant, Plant):
            raise InvalidInput(f"plant {plant!r} is neither a plant name ({', '.join(PLANT_NAMES)}) nor a Plant")
        if options:
            raise InvalidInput("plant options go with a plant name; this plant object is already built")
        return plant
    if plant == "pinocchio":
        if options:
            raise InvalidInput(
                f"plant options ({', '.join(options)}) apply to the mujoco plant; the pinocchio plant takes none"
            )
        return PinocchioPlant(robot)
    if plant == "mujoco":
        from .mujoco import OPTION_NAMES, MujocoPlant

        keywords = _keyword_options(options or {})
        unknown = [key for key in keywords if key not in OPTION_NAMES]
        if unknown:
            raise InvalidInput(
                f"unexpected plant option '{unknown[0].replace('_', '-')}'; the mujoco plant's options are "
                + ", ".join(name.replace("_", "-") for name in OPTION_NAMES)
            )
        return MujocoPlant(robot, **keywords)
    close = difflib.get_close_matches(plant, PLANT_NAMES, n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    raise InvalidInput(f"unknown plant '{plant}'{hint}; choose one of {', '.join(PLANT_NAMES)}")


def _keyword_options(options: dict) -> dict:
    """Plant options as keyword arguments: ``joint-limits`` and ``joint_limits`` both name one option."""
    return {str(key).replace("-", "_"): value for key, value in options.items()}
