"""The robot's URDF visuals, reduced as its dynamic model is; boxes of the links' inertia where there are none.

A URDF whose meshes cannot be found, or that has no visuals at all, still
plays: the visuals whose mesh file is missing are left out, and each link
left with nothing to show is drawn as the box of its inertia
(:mod:`torqueopt.viewer.stand_ins`), with one note saying so.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pinocchio as pin

from ..catalog import mesh_file
from ..errors import InvalidInput, TorqueoptError, TorqueoptWarning
from ..robot import Robot
from ..urdf_checks import checked_urdf_text, quiet_stderr
from .stand_ins import stand_ins

__all__ = ["visual_model", "without_missing_meshes"]


def visual_model(robot: Robot) -> tuple[pin.Model, pin.GeometryModel]:
    """Kinematic model and visual geometry of the robot's moving chain.

    The URDF's visuals are loaded on the full model (mesh URIs resolved
    through ``robot.source.package_dirs``), then both are reduced by locking
    the joints :attr:`Robot.locked_joints` at :attr:`Robot.locked_configuration`,
    as :func:`torqueopt.load_robot` reduced the dynamic model; the result has
    the same joints, in the same order, as ``robot.model``.

    Warns:
        TorqueoptWarning: meshes were missing, or the URDF has no visuals, and
            links are drawn as the boxes of their inertia.
    """
    if robot.source is None:
        raise InvalidInput(f"robot '{robot.name}' was not loaded from a URDF, so it has no visuals to show")
    full_model = robot.full_model
    urdf = Path(robot.source.urdf)
    package_dirs = [str(path) for path in robot.source.package_dirs]
    # The same checked text the dynamic model was built from, with urdfdom's stderr captured.
    text = checked_urdf_text(urdf)
    try:
        geometry = _visuals(full_model, text, package_dirs)
    except (RuntimeError, ValueError) as error:
        # Only a failed load looks for missing meshes, so a URDF that loads is drawn exactly as Pinocchio reads it.
        text, missing, bare_links = without_missing_meshes(text, urdf.parent, package_dirs)
        if not missing:
            raise TorqueoptError(f"cannot load the visuals of '{urdf}': {error}") from None
        geometry = _visuals(full_model, text, package_dirs)
        rods = _add_stand_ins(full_model, geometry, bare_links)
        shown = ", ".join(missing[:3]) + (f" and {len(missing) - 3} more" if len(missing) > 3 else "")
        warnings.warn(
            f"{len(missing)} mesh{'es' if len(missing) != 1 else ''} of '{urdf.name}' not found ({shown}): "
            f"drawn as the boxes of their links' inertia{rods}",
            TorqueoptWarning,
            stacklevel=2,
        )
    if geometry.ngeoms == 0:
        links = [frame.name for frame in full_model.frames if frame.type == pin.FrameType.BODY]
        rods = _add_stand_ins(full_model, geometry, links)
        warnings.warn(
            f"URDF '{urdf.name}' has no visuals: its links are drawn as the boxes of their inertia{rods}",
            TorqueoptWarning,
            stacklevel=2,
        )
    locked_ids = [full_model.getJointId(name) for name in robot.locked_joints]
    if locked_ids:
        model, geometry = pin.buildReducedModel(full_model, geometry, locked_ids, robot.locked_configuration)
    else:
        model = full_model
    if list(model.names) != list(robot.model.names):
        raise TorqueoptError(
            f"the visual model of '{robot.name}' has joints {list(model.names)[1:]}, "
            f"not the robot's {list(robot.model.names)[1:]}"
        )
    return model, geometry


def _visuals(model: pin.Model, text: str, package_dirs: list[str]) -> pin.GeometryModel:
    with quiet_stderr():
        return pin.buildGeomFromUrdfString(model, text, pin.GeometryType.VISUAL, package_dirs=package_dirs)


def _add_stand_ins(model: pin.Model, geometry: pin.GeometryModel, links) -> str:
    """Add the shapes of :func:`~torqueopt.viewer.stand_ins.stand_ins` for ``links`` to ``geometry``; returns the
    note's ending on the links drawn as rods (empty when none is)."""
    shapes = stand_ins(model, links)
    for shape in shapes:
        geometry.addGeometryObject(shape)
    rods = sorted({shape.name.rsplit("_rod_", 1)[0] for shape in shapes if "_rod_" in shape.name})
    if not rods:
        return ""
    return f", and {', '.join(rods)} (no rotational inertia) as rods to {'its' if len(rods) == 1 else 'their'} child joints"


def without_missing_meshes(text: str, base: Path, package_dirs) -> tuple[str, list[str], list[str]]:
    """The URDF ``text`` without the visuals whose mesh file cannot be found; the meshes left out; the bare links.

    Mesh files that are found are named by their absolute path, so that
    Pinocchio reads the same files (``base``: the URDF's folder, for relative
    names). The bare links are those whose every visual was left out.
    """
    root = ElementTree.fromstring(text)
    missing, bare_links = [], []
    for link in root.findall("link"):
        visuals = link.findall("visual")
        for visual in visuals:
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            found = mesh_file(mesh.get("filename", ""), base, package_dirs)
            if found is None:
                missing.append(mesh.get("filename", ""))
                link.remove(visual)
            else:
                mesh.set("filename", str(found))
        if visuals and not link.findall("visual"):
            bare_links.append(link.get("name"))
    return ElementTree.tostring(root, encoding="unicode"), missing, bare_links
