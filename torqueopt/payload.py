r"""A payload: a rigid load the task frame carries (a tool, a part in the gripper), added to the arm's model.

:func:`torqueopt.load_robot` adds a :class:`Payload` to the body that carries
the task frame, before the joints outside the chain are locked, so every
term Pinocchio computes (the inertia :math:`H`, the bias torques, the
forward dynamics of the plant) includes it; the MuJoCo plant adds it to its
own model of the same body.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .checks import finite_vector, positive_number
from .errors import InvalidInput

__all__ = ["Payload", "add_payload"]


@dataclass(frozen=True)
class Payload:
    r"""A rigid load fixed to the task frame.

    Attributes:
        mass: its mass [kg], positive.
        position: its centre of mass in the task frame [m]; at the frame's
            origin by default.
        inertia: its principal moments of inertia about its centre of mass,
            along the task frame's axes (:math:`I_{xx}, I_{yy}, I_{zz}`)
            [kg·m²]; all three zero (the default) for a point mass, else all
            three positive and each at most the sum of the other two, as a
            rigid body's are.

    Raises:
        InvalidInput: a mass that is not a positive finite number, a
            position or inertia that is not three finite numbers, or an
            inertia that is neither zero nor positive definite.
    """

    mass: float
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        mass = positive_number(self.mass, "payload mass", "kg")
        position = finite_vector(self.position, 3, "payload position")
        inertia = finite_vector(self.inertia, 3, "payload inertia")
        shown = ", ".join(f"{moment:g}" for moment in inertia)
        if inertia.any() and not (inertia > 0).all():
            raise InvalidInput(
                f"payload inertia ({shown}) kg·m² is not positive definite: give three positive principal moments, "
                "or none (zeros) for a point mass"
            )
        if (inertia > inertia.sum() - inertia).any():
            raise InvalidInput(
                f"payload inertia ({shown}) kg·m² is no rigid body's: each principal moment must be at most the sum "
                "of the other two"
            )
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "position", tuple(position.tolist()))
        object.__setattr__(self, "inertia", tuple(inertia.tolist()))

    def spatial_inertia(self) -> pin.Inertia:
        """Its spatial inertia in the task frame (Pinocchio's ``Inertia``: mass, centre of mass, moments about it)."""
        return pin.Inertia(self.mass, np.array(self.position), np.diag(self.inertia))

    def record(self) -> dict:
        """Its fields, JSON-ready; ``Payload(**record)`` rebuilds it."""
        return {"mass": self.mass, "position": list(self.position), "inertia": list(self.inertia)}


def add_payload(model: pin.Model, frame_id: int, payload: Payload) -> None:
    """Add ``payload``, fixed to frame ``frame_id``, to the inertia of the body of that frame's parent joint.

    The payload's inertia is carried from the frame to its joint by
    Pinocchio's ``SE3.act`` (the parallel-axis rule included) and summed
    with the body's by ``Inertia.__add__``. ``model`` is changed in place.
    """
    frame = model.frames[frame_id]
    joint = frame.parentJoint
    model.inertias[joint] = model.inertias[joint] + frame.placement.act(payload.spatial_inertia())
