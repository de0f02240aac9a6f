"""Loading a robot: a URDF path, a file in ``robots/`` or an example-robot-data arm, checked, built and reduced.

:func:`load_robot` finds the description (:mod:`torqueopt.catalog`),
checks the URDF's syntax here and its physics in
:mod:`torqueopt.urdf_checks` before Pinocchio reads it, builds the model
(with mimic joints where they move the task frame), locks every joint
outside the task frame's chain at the reference configuration (the SRDF's
when there is one) and returns the :class:`~torqueopt.robot.Robot`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from .catalog import RobotSource, find_robot
from .checks import check_task_rank, finite_vector
from .errors import FrameNotFound, InvalidInput, UrdfError
from .payload import Payload, add_payload
from .robot import DEFAULT_JOINT_DYNAMICS, Robot, check_joint_dynamics, check_task_and_frame
from .urdf_checks import build_model, check_chain_moves_mass, checked_urdf_text

__all__ = ["load_robot"]


#: The most degrees of freedom a URDF may have. Pinocchio's ``Data`` holds second-order derivative tensors of
#: nv³ numbers each, about 64·nv³ bytes in all (measured with pin 4.1: 68 MB at nv = 100, 513 MB at 200; a
#: 1000-joint chain asked for 64 GB and died in ``createData``). 250 keeps one ``Data`` near 1 GB; real arms,
#: and humanoids with their hands, have fewer than 100.
MAX_DOFS = 250


def load_robot(
    source: str | Path,
    frame: str | None = None,
    task: str | None = None,
    *,
    torque_limit=None,
    gravity=None,
    lock: tuple[str, ...] | list[str] = (),
    reference_configuration=None,
    payload: Payload | None = None,
    joint_dynamics: str | None = None,
) -> Robot:
    """Load a robot from a URDF path, a file in ``robots/`` or an example-robot-data name.

    Args:
        source: URDF path, ``planar3``, ``panda``, ``xarm7``, ``baxter``, ...
        frame: task frame; defaults to the catalogue's choice for known
            robots, else the single leaf link of the URDF.
        task: ``xy``, ``position`` or ``pose``; defaults to ``xy`` for
            planar3 and ``position`` otherwise.
        torque_limit: override of the URDF effort limits [N·m], see
            :meth:`Robot.with_torque_limit`.
        gravity: ``True`` (−9.81 m/s² along z), ``False`` or a 3-vector;
            defaults to off for the paper's arm and on otherwise.
        lock: joints of the task chain to lock as well (the joints outside
            the chain are always locked).
        reference_configuration: full-model configuration at which locked
            joints are held; defaults to the SRDF configuration or neutral.
        payload: a :class:`~torqueopt.Payload` fixed to the task frame, added
            to the inertia of the body that carries the frame (and to the
            MuJoCo plant's model of it); none by default.
        joint_dynamics: ``"urdf"`` models the URDF's joint damping and
            friction (in the resolvers' bias torque, the Pinocchio plant and
            the MuJoCo plant alike), ``"off"`` none of them; defaults to
            :data:`~torqueopt.robot.DEFAULT_JOINT_DYNAMICS` (``"off"``).

    Raises:
        RobotNotFound, UrdfError, FrameNotFound, TaskNotFound, InvalidInput: a bad source, file, frame, task or value.
    """
    if payload is not None and not isinstance(payload, Payload):
        raise InvalidInput(
            f"payload must be a torqueopt.Payload(mass, position, inertia), not {type(payload).__name__} {payload!r}"
        )
    joint_dynamics = DEFAULT_JOINT_DYNAMICS if joint_dynamics is None else check_joint_dynamics(joint_dynamics)
    robot_source = find_robot(source)
    full_model, frame, task, chain = _full_model(robot_source, frame, task)
    if payload is not None:
        # Into the full model, before any joint is locked: a locked joint's body, payload included, then
        # joins its parent's by Pinocchio's reduction, whichever joint of the chain the frame ends up on.
        add_payload(full_model, full_model.getFrameId(frame), payload)
    full_reference = _full_reference_configuration(full_model, robot_source, reference_configuration)
    extra_locks = set(robot_source.locked_joints) | set(lock)
    model, locked_ids = _locked_model(full_model, chain, extra_locks, full_reference, robot_source.name)
    if model.nv == 0:
        raise InvalidInput(f"frame '{frame}' of robot '{robot_source.name}' is not moved by any joint")
    _refuse_free_joints(model, robot_source.name)
    check_chain_moves_mass(robot_source.urdf, [model.names[j] for j in range(1, model.njoints)])

    default_configuration = _reduce_configuration(full_model, model, full_reference)
    robot = Robot(
        model,
        frame,
        task,
        name=robot_source.name,
        source=robot_source,
        torque_limit=torque_limit,
        gravity=robot_source.gravity if gravity is None else gravity,
        locked_joints=tuple(full_model.names[j] for j in locked_ids),
        full_model=full_model,
        locked_configuration=full_reference,
        default_configuration=default_configuration,
        payload=payload,
        joint_dynamics=joint_dynamics,
    )
    check_task_rank(robot)  # a task the chain can never realise is an input mistake, not a failed run
    return robot


def _full_model(robot_source: RobotSource, frame: str | None, task: str | None):
    """The URDF's checked full model (with its mimic joints where they move the task frame), the task frame and
    task (the catalogue's or the URDF's defaults when None), and the ids of the joints that move the frame."""
    mimic_joints = _validate_urdf(robot_source.urdf, with_yourdfpy=not robot_source.vetted)
    full_model = build_model(robot_source.urdf, mimic=False)
    if full_model.nv == 0:
        raise UrdfError(f"URDF '{robot_source.urdf}' has no movable joint")
    if full_model.nv > MAX_DOFS:
        raise UrdfError(
            f"URDF '{robot_source.urdf}' has {full_model.nv:,} degrees of freedom, more than the {MAX_DOFS} torqueopt "
            f"takes: Pinocchio's data for it would need about {64.0 * full_model.nv**3 / 1e9:.3g} GB "
            "(its second-order derivative tensors grow with the cube of the joints)"
        )

    frame = frame or robot_source.frame or _single_leaf_frame(full_model, robot_source.urdf)
    task = task or robot_source.task or "position"
    check_task_and_frame(full_model, frame, task, robot_source.name)

    chain = set(full_model.supports[full_model.frames[full_model.getFrameId(frame)].parentJoint])
    if any(full_model.names[j] in mimic_joints for j in chain):
        # A mimic joint that moves the task frame must follow its leader;
        # mimic joints elsewhere (grippers) are locked and can stay independent.
        full_model = build_model(robot_source.urdf, mimic=True)
        chain = set(full_model.supports[full_model.frames[full_model.getFrameId(frame)].parentJoint])
    return full_model, frame, task, chain


def _locked_model(full_model: pin.Model, chain: set[int], extra_locks: set[str], reference, robot_name: str):
    """The model with every joint outside the task ``chain`` and every joint of ``extra_locks`` locked at
    ``reference`` (Pinocchio's reduction), and the ids of the joints locked."""
    for joint in extra_locks:
        if not full_model.existJointName(joint):
            raise InvalidInput(
                f"cannot lock joint '{joint}': robot '{robot_name}' has joints {', '.join(list(full_model.names)[1:])}"
            )
    locked_ids = [
        j
        for j in range(1, full_model.njoints)
        if full_model.joints[j].nv > 0 and (j not in chain or full_model.names[j] in extra_locks)
    ]
    model = pin.buildReducedModel(full_model, locked_ids, reference) if locked_ids else full_model.copy()
    return model, locked_ids


#: Joints whose degrees of freedom no actuator drives: a floating base, a planar base.
_FREE_JOINTS = {"JointModelFreeFlyer": "floating", "JointModelPlanar": "planar"}


def _refuse_free_joints(model: pin.Model, robot_name: str) -> None:
    """Every joint left in the model is driven by a torque; a free base would get one and be resolved as if driven."""
    for j in range(1, model.njoints):
        kind = _FREE_JOINTS.get(model.joints[j].shortname())
        if kind is not None:
            name = model.names[j]
            raise InvalidInput(
                f"joint '{name}' of robot '{robot_name}' is a {kind} joint ({model.joints[j].nv} degrees of freedom "
                f"that no actuator drives): torqueopt resolves fixed-base arms, every joint driven; make it a fixed "
                f"joint in the URDF, or lock it with --lock {name}"
            )


# Attributes that must hold numbers, by tag: checked before yourdfpy, whose
# message for a bad number does not say where it is.
_NUMERIC_ATTRIBUTES = {
    "mass": ("value",),
    "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
    "origin": ("xyz", "rpy"),
    "axis": ("xyz",),
    "limit": ("lower", "upper", "effort", "velocity"),
    "mimic": ("multiplier", "offset"),
}


def _validate_urdf(path: Path, with_yourdfpy: bool = True) -> set[str]:
    """Check a URDF before Pinocchio reads it, naming the broken tag when it is broken.

    Our own checks of the XML run always; yourdfpy's load and ``validate()``
    run when ``with_yourdfpy``. Returns the names of the URDF's mimic joints.
    """
    import logging
    import xml.etree.ElementTree as ElementTree

    try:
        root = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as error:
        raise UrdfError(f"malformed URDF '{path}': XML syntax error: {error}") from None
    if root.tag != "robot":
        raise UrdfError(f"malformed URDF '{path}': the root element is <{root.tag}>, a URDF's must be <robot>")
    if not root.get("name"):
        raise UrdfError(f"malformed URDF '{path}': <robot> has no name attribute")
    link_names = {link.get("name") for link in root.iter("link") if link.get("name")}
    for element in root:
        if element.tag in ("link", "joint") and not element.get("name"):
            raise UrdfError(f"malformed URDF '{path}': a <{element.tag}> has no name attribute")
    for joint in root.findall("joint"):
        for tag in ("parent", "child"):
            reference = joint.find(tag)
            link = None if reference is None else reference.get("link")
            if not link:
                raise UrdfError(
                    f'malformed URDF \'{path}\': <joint name="{joint.get("name")}"> has no <{tag} link="..."/>'
                )
            if link not in link_names:
                raise UrdfError(
                    f"malformed URDF '{path}': <joint name=\"{joint.get('name')}\"> has {tag} link '{link}', "
                    "which is not a <link> of the file"
                )
    for owner in root:
        for element in owner.iter():
            for attribute in _NUMERIC_ATTRIBUTES.get(element.tag, ()):
                text = element.get(attribute)
                if text is None:
                    continue
                try:
                    [float(value) for value in text.split()]
                except ValueError:
                    raise UrdfError(
                        f"malformed URDF '{path}': <{element.tag} {attribute}=\"{text}\"> in "
                        f'<{owner.tag} name="{owner.get("name")}"> is not a number'
                    ) from None

    checked_urdf_text(path)  # every physical quantity, one line naming the link or joint
    mimic_joints = {joint.get("name") for joint in root.findall("joint") if joint.find("mimic") is not None}
    if not with_yourdfpy:
        return mimic_joints

    import yourdfpy

    logger = logging.getLogger("yourdfpy")
    level = logger.level
    logger.setLevel(logging.CRITICAL)  # its fallback parser logs noise for files we already checked
    try:
        urdf = yourdfpy.URDF.load(
            str(path), load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False
        )
    except Exception as error:  # yourdfpy raises lxml, KeyError, ValueError... for broken files
        detail = " ".join(str(error).split()) or type(error).__name__
        raise UrdfError(f"malformed URDF '{path}': {detail}") from None
    finally:
        logger.setLevel(level)
    if not urdf.validate():
        problems = "; ".join(str(problem) for problem in urdf.errors) or "yourdfpy validation failed"
        raise UrdfError(f"malformed URDF '{path}': {problems}")
    return mimic_joints


def _single_leaf_frame(model: pin.Model, urdf: Path) -> str:
    parents = {model.frames[f].parentFrame for f in range(len(model.frames))}
    leaves = [
        frame.name
        for index, frame in enumerate(model.frames)
        if frame.type == pin.FrameType.BODY and index not in parents
    ]
    if len(leaves) == 1:
        return leaves[0]
    raise FrameNotFound(
        f"URDF '{urdf}' has several end links; name the task frame with --frame, one of {', '.join(leaves)}"
    )


def _full_reference_configuration(full_model, robot_source: RobotSource, reference_configuration) -> np.ndarray:
    if reference_configuration is not None:
        return finite_vector(reference_configuration, full_model.nq, "reference configuration")
    configuration = pin.neutral(full_model)
    if robot_source.srdf is not None and robot_source.srdf_configuration:
        pin.loadReferenceConfigurations(full_model, str(robot_source.srdf), False)
        if robot_source.srdf_configuration in full_model.referenceConfigurations:
            configuration = np.array(full_model.referenceConfigurations[robot_source.srdf_configuration])
    # The catalogue's measured start (see catalog._KNOWN_ARMS), on top of the SRDF state.
    for joint_name, angle in robot_source.start:
        joint = full_model.joints[full_model.getJointId(joint_name)]
        configuration[joint.idx_q] = angle
    return configuration


def _reduce_configuration(full_model, model, full_configuration) -> np.ndarray:
    reduced = pin.neutral(model)
    for joint_id in range(1, model.njoints):
        full_id = full_model.getJointId(model.names[joint_id])
        full_joint, joint = full_model.joints[full_id], model.joints[joint_id]
        reduced[joint.idx_q : joint.idx_q + joint.nq] = full_configuration[
            full_joint.idx_q : full_joint.idx_q + full_joint.nq
        ]
    return reduced
