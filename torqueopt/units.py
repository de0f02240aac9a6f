"""The units of a joint's coordinate, rates and effort: rad, rad/s, rad/s², N·m for a revolute or continuous
joint, m, m/s, m/s², N for a prismatic one.

Every table, message, plot label and file that gives a per-joint number takes its unit from here, so that a
slider is never reported in N·m or rad/s.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["QUANTITIES", "joint_kind", "joint_unit", "shared_unit"]

#: The per-joint quantities, in the order of the unit tuples below.
QUANTITIES = ("position", "velocity", "acceleration", "torque")

_ROTATION = ("rad", "rad/s", "rad/s²", "N·m")
_TRANSLATION = ("m", "m/s", "m/s²", "N")


def joint_kind(joint) -> str:
    """``'revolute'``, ``'continuous'`` or ``'prismatic'``: the kind of a Pinocchio joint model with one degree of
    freedom, read from its short name (``JointModelRZ``, ``JointModelRUBX``, ``JointModelPY``,
    ``JointModelPrismaticUnaligned``, ...)."""
    name = joint.shortname()[len("JointModel") :]
    if name.startswith("Prismatic") or (len(name) == 2 and name[0] == "P"):
        return "prismatic"
    if name.startswith("RUB") or name.startswith("RevoluteUnbounded"):
        return "continuous"
    return "revolute"


def joint_unit(kind: str | None, quantity: str) -> str:
    """The unit of ``quantity`` (one of :data:`QUANTITIES`) for a joint of ``kind`` (None: a run file written
    before joint kinds were recorded, read as revolute)."""
    units = _TRANSLATION if kind == "prismatic" else _ROTATION
    return units[QUANTITIES.index(quantity)]


def shared_unit(kinds: Sequence[str | None] | None, quantity: str) -> str:
    """The unit of ``quantity`` over several joints: the one unit when they share it, else both
    (``'N·m or N'``) for a label that covers a mixed arm."""
    units = list(dict.fromkeys(joint_unit(kind, quantity) for kind in (kinds or [None])))
    return " or ".join(units)
