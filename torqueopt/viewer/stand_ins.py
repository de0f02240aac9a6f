r"""Shapes drawn for links that have no visual to show: the box of each link's inertia.

A URDF whose meshes are missing, or that has no visuals at all, still plays:
each such link is drawn as the solid box with the link's mass and principal
moments of inertia, centred at its centre of mass along its principal axes.
A box of sides :math:`a, b, c` and mass :math:`m` has the principal moments

.. math::

    I_a = \tfrac{m}{12}(b^2 + c^2),\quad I_b = \tfrac{m}{12}(a^2 + c^2),\quad I_c = \tfrac{m}{12}(a^2 + b^2),

so the box of given moments has the sides

.. math::

    a = \sqrt{6\,(I_b + I_c - I_a)/m},\quad b = \sqrt{6\,(I_a + I_c - I_b)/m},\quad c = \sqrt{6\,(I_a + I_b - I_c)/m}.

A physical inertia satisfies the triangle inequalities :math:`I_a \le I_b + I_c`
(and the others), so the roots are real; where one holds with equality (a rod,
a plate) that side is zero, and it is drawn at :data:`THINNEST` of the longest
side instead, so that the link is seen. The link's inertia and its centre of
mass are Pinocchio's (the URDF's ``<inertial>`` as the model holds it), the
principal axes the eigenvectors of its rotational inertia about the centre
of mass.

A link with no box (no mass, or a point mass: no rotational inertia) is
drawn as thin rods from its origin to each of its child joints, so that a
chain of point masses still shows its joints; such a link with no child
joint (a massless leaf) is not drawn.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = [
    "ROD_RADIUS",
    "STAND_IN_COLOR",
    "THINNEST",
    "child_joint_offsets",
    "equivalent_box",
    "link_inertia",
    "stand_ins",
]

#: RGBA colour of the stand-in shapes, each in [0, 1] (a grey blue, unlike any mesh's default).
STAND_IN_COLOR = np.array([0.55, 0.6, 0.7, 1.0])
#: The thinnest side a stand-in box is drawn with, as a fraction of its longest side.
THINNEST = 0.1
#: Radius of the rods drawn from joint to joint, as a fraction of the sum of the model's joint-to-joint distances.
ROD_RADIUS = 0.01
#: Below this side [m] a box is not drawn.
_SHORTEST = 1e-6
#: Below this mass [kg] a link counts as massless (what is left of a body's inertia once its fixed children's are
#: taken away, for a link of none).
_MASSLESS = 1e-9


def link_inertia(model: pin.Model, frame_id: int) -> pin.Inertia:
    """Spatial inertia of the link of BODY frame ``frame_id`` alone, in the link's frame.

    Pinocchio keeps a root link's inertia on its BODY frame and a link fixed to
    its parent's on the fixed joint's frame (which coincides with the link's);
    a joint's body inertia holds its link and every link fixed to it, so the
    link attached by a moving joint is that body without those.
    """
    frame = model.frames[frame_id]
    if frame.inertia.mass > _MASSLESS:
        return frame.inertia
    parent = model.frames[frame.parentFrame]
    if parent.type == pin.FrameType.FIXED_JOINT and frame.parentFrame != 0:
        return frame.placement.actInv(parent.placement.act(parent.inertia))
    if frame.parentJoint == 0:
        return pin.Inertia.Zero()
    body = model.inertias[frame.parentJoint]
    for other in model.frames:
        fixed_here = other.type == pin.FrameType.FIXED_JOINT and other.parentJoint == frame.parentJoint
        if fixed_here and other.inertia.mass > _MASSLESS:
            body = body - other.placement.act(other.inertia)
    return frame.placement.actInv(body)


def equivalent_box(inertia: pin.Inertia) -> tuple[np.ndarray, pin.SE3] | None:
    """Sides [m] and placement (in the inertia's frame) of the box of ``inertia``; None for no mass or a point mass.

    The box is centred at the centre of mass, its edges along the principal
    axes; its sides are those of the module's formula, each at least
    :data:`THINNEST` of the longest.
    """
    mass = float(inertia.mass)
    if mass <= _MASSLESS:
        return None
    moments, axes = np.linalg.eigh(inertia.inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    # a_i² = 6 (I_j + I_k − I_i) / m: the inverse of I_i = m (a_j² + a_k²) / 12.
    squares = 6.0 * (moments.sum() - 2.0 * moments) / mass
    sides = np.sqrt(np.clip(squares, 0.0, None))
    if sides.max() < _SHORTEST:
        return None  # a point mass, give or take the rounding of a body's inertia less its fixed children's
    return np.maximum(sides, THINNEST * sides.max()), pin.SE3(axes, np.array(inertia.lever))


def child_joint_offsets(model: pin.Model, frame_id: int) -> list[np.ndarray]:
    """Origins of the joints (moving or fixed) whose parent is the link of BODY frame ``frame_id``, in its frame [m]."""
    link = model.frames[frame_id]
    offsets = []
    for child in model.frames:
        if child.parentFrame != frame_id or child.type not in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT):
            continue
        # A moving joint's frame is its own joint's origin, placed in the parent joint by jointPlacements.
        moving = child.type == pin.FrameType.JOINT
        in_parent_joint = model.jointPlacements[child.parentJoint] if moving else child.placement
        offsets.append(link.placement.actInv(in_parent_joint).translation.copy())
    return offsets


def stand_ins(model: pin.Model, links) -> list[pin.GeometryObject]:
    """Shapes for the links of ``links`` (names of BODY frames of ``model``): the box of each link's inertia, or
    rods to its child joints for a link with no box."""
    import coal

    bodies = [index for index, frame in enumerate(model.frames) if frame.type == pin.FrameType.BODY]
    reach = sum(float(np.linalg.norm(offset)) for index in bodies for offset in child_joint_offsets(model, index))
    radius = max(ROD_RADIUS * reach, 1e-3)
    shapes = []
    for link in links:
        frame_id = model.getFrameId(link, pin.FrameType.BODY)
        frame = model.frames[frame_id]
        box = equivalent_box(link_inertia(model, frame_id))
        if box is not None:
            sides, placement = box
            shapes.append(_shape(f"{link}_inertia_box", frame, frame_id, placement, coal.Box(*sides)))
            continue
        for index, offset in enumerate(child_joint_offsets(model, frame_id)):
            length = float(np.linalg.norm(offset))
            if length <= radius:
                continue
            # A coal cylinder lies along its z axis, centred on its origin.
            turn = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), offset / length).matrix()
            rod = coal.Cylinder(radius, length)
            shapes.append(_shape(f"{link}_rod_{index}", frame, frame_id, pin.SE3(turn, offset / 2), rod))
    return shapes


def _shape(name: str, frame: pin.Frame, frame_id: int, placement: pin.SE3, geometry) -> pin.GeometryObject:
    """A stand-in shape at ``placement`` in the link's frame, on the link's joint, in :data:`STAND_IN_COLOR`."""
    shape = pin.GeometryObject(name, frame.parentJoint, frame_id, frame.placement * placement, geometry)
    shape.meshColor = STAND_IN_COLOR.copy()
    return shape
