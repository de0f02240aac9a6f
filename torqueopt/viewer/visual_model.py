"""The robot's URDF visuals, reduced as its dynamic model is."""

from __future__ import annotations

import pinocchio as pin

from ..errors import InvalidInput, TorqueoptError
from ..robot import Robot
from ..urdf_checks import checked_urdf_text, quiet_stderr

__all__ = ["visual_model"]


def visual_model(robot: Robot) -> tuple[pin.Model, pin.GeometryModel]:
    """Kinematic model and visual geometry of the robot's moving chain.

    The URDF's visuals are loaded on the full model (mesh URIs resolved
    through ``robot.source.package_dirs``), then both are reduced by locking
    the joints :attr:`Robot.locked_joints` at :attr:`Robot.locked_configuration`,
    as :func:`torqueopt.load_robot` reduced the dynamic model; the result has
    the same joints, in the same order, as ``robot.model``.
    """
    if robot.source is None:
        raise InvalidInput(f"robot '{robot.name}' was not loaded from a URDF, so it has no visuals to show")
    full_model = robot.full_model
    package_dirs = [str(path) for path in robot.source.package_dirs]
    # The same checked text the dynamic model was built from, with urdfdom's stderr captured.
    text = checked_urdf_text(robot.source.urdf)
    try:
        with quiet_stderr():
            geometry = pin.buildGeomFromUrdfString(full_model, text, pin.GeometryType.VISUAL, package_dirs=package_dirs)
    except (RuntimeError, ValueError) as error:
        raise TorqueoptError(f"cannot load the visuals of '{robot.source.urdf}': {error}") from None
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
