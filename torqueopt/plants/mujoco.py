r"""MuJoCo as the plant: the resolver's torque applied to a MuJoCo model of the arm (docs/guide/mujoco.md).

The controller (the resolver, with torqueopt's Pinocchio model) computes the torque from the state the plant
reports; the plant applies it, held over the control step ``dt``, as a generalised force (``qfrc_applied``) and
lets MuJoCo advance with its own integrator and timestep, ``dt / timestep`` calls of ``mj_step`` per step.

The model is the robot's URDF compiled by MuJoCo (the URDF's inertias, never MuJoCo's estimate from the
geometry; a mesh MuJoCo cannot read is dropped with its geom, with a note), or a user's MJCF whose joint names
match the URDF's. Joints the controller does not move are welded at the angle Pinocchio locks them at, so both
models carry the same inertia; an MJCF's actuators, sensors and keyframes are removed (the torque enters as
generalised force), as are the tendons and equality constraints of welded joints. The robot's payload becomes
a body fixed where Pinocchio has it. The options (:data:`OPTIONS`, :class:`MujocoOptions`; the CLI's
``--plant-option KEY=VALUE``) choose the integrator, timestep, contacts, joint-limit forces, joint damping
(``damping`` follows the robot's ``joint_dynamics`` unless given, so controller and plant agree by default), an
inertia floor and a seeded perturbation of the links' masses and inertias. With matched settings (the URDF,
``contacts=off``, ``joint-limits=off``, ``damping`` following the robot, ``integrator=rk4``, ``timestep=dt``)
MuJoCo integrates the same equations as the Pinocchio plant: the tests hold the two runs to 1e-9 rad on xarm7
and panda.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ..catalog import mesh_file
from ..checks import show_number
from ..errors import InvalidInput, MissingDependency, PlantError
from ..settings import Settings, setting
from ..units import joint_kind
from .base import register_plant

__all__ = [
    "MujocoPlant",
    "MujocoOptions",
    "mujoco_options",
    "OPTIONS",
    "OPTION_DEFAULTS",
    "OPTION_NAMES",
    "INTEGRATORS",
    "import_mujoco",
]

#: The integrators ``integrator=`` takes, by name: MuJoCo's ``mjtIntegrator`` members.
INTEGRATORS = {"rk4": "mjINT_RK4", "implicitfast": "mjINT_IMPLICITFAST", "euler": "mjINT_EULER"}
#: The options ``--plant-option`` takes: (the default as ``--help`` states it, the help text).
OPTIONS = {
    "integrator": ("rk4", "rk4|implicitfast|euler, MuJoCo's integrator"),
    "timestep": ("dt", "MuJoCo's step [s], dividing --dt (sub-steps)"),
    "contacts": ("off", "on|off"),
    "joint-limits": ("on", "on|off, MuJoCo's joint-limit forces"),
    "damping": (
        "robot",
        "urdf|zero|robot: the model's joint damping, friction loss and armature, none, or as --joint-dynamics says",
    ),
    "inertia-floor": ("none", "raise principal moments of inertia below this [kg·m²] to it (planar3's thin rods)"),
    "perturb": ("0", "scale each link's mass and inertia by a factor from U(1−p, 1+p)"),
    "seed": ("0", "seed of those factors"),
}
#: The defaults of the plant options, as ``--help`` states them.
OPTION_DEFAULTS = {name: default for name, (default, _) in OPTIONS.items()}
#: Mesh files MuJoCo reads; any other (COLLADA .dae, ...) is dropped with its geom.
_MESH_SUFFIXES = (".stl", ".obj", ".msh")
#: A principal moment of inertia at or below this [kg·m²] is refused by MuJoCo (its mjMINVAL).
_SMALLEST_MOMENT = 1e-15
_ON_OFF = {"on": True, "off": False, "true": True, "false": False}


def import_mujoco():
    """The mujoco module, or a :class:`~torqueopt.MissingDependency` that says how to install it."""
    try:
        import mujoco
    except ImportError:
        raise MissingDependency(
            "the mujoco plant needs the mujoco package: pip install 'torqueopt[mujoco]' (or pip install mujoco)"
        ) from None
    return mujoco


def _on_off(value, name: str) -> bool:
    if isinstance(value, bool):
        return value
    key = str(value).strip().lower()
    if key not in _ON_OFF:
        raise InvalidInput(f"plant option {name}={value} is not on or off")
    return _ON_OFF[key]


def _choice(value, name: str, choices) -> str:
    key = str(value).strip().lower()
    if key not in choices:
        raise InvalidInput(f"plant option {name}={value} is not one of {', '.join(choices)}")
    return key


#: The rules of a plant option's number: (its reading, the test, the wording of its message).
_NUMBER_RULES = {
    "positive": (float, lambda x: math.isfinite(x) and x > 0, "a positive finite number"),
    "fraction": (float, lambda x: 0 <= x < 1, "a number in [0, 1)"),
    "seed": (int, lambda x: x >= 0, "a whole number >= 0"),
}


def _option_number(value, name: str, rule: str, unit: str = ""):
    """A plant option's number from a value or its text; ``rule`` is ``positive``, ``fraction`` or ``seed``."""
    text = value.strip() if isinstance(value, str) else show_number(value)
    read, valid, wording = _NUMBER_RULES[rule]
    try:
        number = read(text)
    except ValueError:
        number = None
    if number is None or not valid(number):
        raise InvalidInput(f"plant option {name}={text} must be {wording}{f' [{unit}]' if unit else ''}")
    return number


def _unset(value) -> bool:
    return value is None or (isinstance(value, str) and value.strip().lower() in ("none", "dt", ""))


def _mjcf_file(value, name: str) -> Path | None:
    if value is None:
        return None
    if not Path(value).is_file():
        raise InvalidInput(f"MJCF file '{Path(value)}' does not exist")
    return Path(value)


def _damping(value, name: str) -> str | None:
    if _unset(value) or str(value).strip().lower() == "robot":
        return None
    return _choice(value, "damping", ("urdf", "zero", "robot"))


@dataclass(frozen=True)
class MujocoOptions(Settings):
    """The MuJoCo plant's settings, each checked and read from its value or its text (``"on"``, ``"0.0005"``,
    ``"dt"``); an InvalidInput names the option, the bad value and what would be valid."""

    mjcf: Path | None = setting(None, check=_mjcf_file)
    integrator: str = setting("rk4", check=lambda value, name: _choice(value, "integrator", INTEGRATORS))
    timestep: float | None = setting(
        None, check=lambda value, name: None if _unset(value) else _option_number(value, "timestep", "positive", "s")
    )
    contacts: bool = setting(False, check=lambda value, name: _on_off(value, "contacts"))
    joint_limits: bool = setting(True, check=lambda value, name: _on_off(value, "joint-limits"))
    #: ``urdf``, ``zero``, or None: follow the robot's joint dynamics.
    damping: str | None = setting(None, check=_damping)
    inertia_floor: float | None = setting(
        None,
        check=lambda value, name: (
            None if _unset(value) else _option_number(value, "inertia-floor", "positive", "kg·m²")
        ),
    )
    perturb: float = setting(0.0, check=lambda value, name: _option_number(value, "perturb", "fraction"))
    seed: int = setting(0, check=lambda value, name: _option_number(value, "seed", "seed"))


#: The keyword names of the options (the CLI writes joint_limits as joint-limits, inertia_floor as inertia-floor).
OPTION_NAMES = tuple(field.name for field in fields(MujocoOptions))


def mujoco_options(**values) -> MujocoOptions:
    """Checked :class:`MujocoOptions` from values or their text, by keyword (``integrator="euler"``)."""
    return MujocoOptions(**values)


@register_plant("mujoco")
class MujocoPlant:
    """A MuJoCo model of ``robot``'s arm as the plant; see the module docstring for the model and options.

    One plant holds one MuJoCo data for :meth:`step`, and one more per
    movement of a stack for :meth:`step_stack` (each movement's state and
    record its own, as if it ran alone): give each thread its own plant.
    While a step runs, MuJoCo's warning handler (process-wide) is the
    plant's, so that MuJoCo writes no ``MUJOCO_LOG.TXT``; the previous
    handler is restored after.

    Args:
        robot: the controller's :class:`~torqueopt.robot.Robot`; the plant's
            joints are matched to ``robot.joint_names``.
        options: a :class:`MujocoOptions`, or leave it out and give the
            options by keyword (``integrator="euler"``, ``joint_limits=False``).

    Raises:
        MissingDependency: mujoco is not installed.
        torqueopt.errors.PlantError: the MJCF's joints do not match the robot's, or MuJoCo
            refuses the model (a zero principal moment of inertia, a bad file).
        InvalidInput: a bad option, or a payload with an MJCF.
    """

    OPTION_NAMES = OPTION_NAMES

    def __init__(self, robot, options: MujocoOptions | None = None, **keywords):
        if options is None:
            options = mujoco_options(**keywords)
        elif keywords:
            raise InvalidInput("give the MuJoCo plant either options or keywords, not both")
        if robot.payload is not None and options.mjcf is not None:
            raise InvalidInput(
                f"robot '{robot.name}' carries a payload, which torqueopt adds to the URDF's model; the MJCF "
                f"'{options.mjcf}' is the plant as written: put the payload in the MJCF, or leave out the mjcf option"
            )
        mujoco = import_mujoco()
        self._mujoco = mujoco
        self.robot = robot
        self.options = options
        self.notes: list[str] = []
        spec, self.source = self._spec(mujoco)
        self._weld_unmoved_joints(mujoco, spec)
        self._add_payload(spec)
        self._floor_inertias(spec)
        try:
            model = spec.compile()
        except ValueError as error:
            raise PlantError(f"MuJoCo refuses the model of {self.source}: {_one_line(error)}") from None
        self.model = model
        self._configure(mujoco, model)
        self.perturbation = self._perturb(mujoco, model)
        self.data = mujoco.MjData(model)
        self._map_joints(mujoco, model)
        self._set_joint_dynamics(model)
        self._warnings = [
            int(getattr(mujoco.mjtWarning, name)) for name in ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")
        ]
        self._limit_type = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
        self.start_inertia_difference = self._inertia_difference(robot.default_configuration)
        self.reset()

    # -- building the model ---------------------------------------------------
    def _spec(self, mujoco):
        """The MjSpec of the plant's model and a phrase naming where it came from."""
        if self.options.mjcf is not None:
            path = self.options.mjcf
            try:
                spec = mujoco.MjSpec.from_file(str(path))
            except ValueError as error:
                raise PlantError(f"MuJoCo cannot read the MJCF '{path}': {_one_line(error)}") from None
            return spec, f"the MJCF '{path}'"
        source = self.robot.source
        if source is None:
            raise InvalidInput(
                f"robot '{self.robot.name}' was not loaded from a URDF (load_robot), so MuJoCo has no model of it; "
                "give an MJCF"
            )
        urdf = Path(source.urdf)
        try:
            spec = mujoco.MjSpec.from_string(urdf.read_text())
        except ValueError as error:
            raise PlantError(f"MuJoCo cannot read the URDF '{urdf}': {_one_line(error)}") from None
        # The URDF's inertials, never MuJoCo's estimate from the collision geometry (which
        # Pinocchio does not make): a link with no <inertial> has no mass in either.
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        self._resolve_meshes(spec, urdf, source.package_dirs)
        return spec, f"robot '{self.robot.name}' (its URDF '{urdf.name}' compiled by MuJoCo {mujoco.__version__})"

    def _resolve_meshes(self, spec, urdf: Path, package_dirs) -> None:
        """Point each mesh at its file (``package://`` from the package folders); drop what MuJoCo cannot read."""
        spec.strippath = False
        dropped = {}
        for mesh in list(spec.meshes):
            path = mesh_file(mesh.file, urdf.parent, package_dirs)
            if path is not None and path.suffix.lower() in _MESH_SUFFIXES:
                mesh.file = str(path)
                continue
            dropped[mesh.name] = mesh.file if path is None else path.name
        if not dropped:
            return
        for geom in list(spec.geoms):
            if geom.meshname in dropped:
                spec.delete(geom)
        for mesh in list(spec.meshes):
            if mesh.name in dropped:
                spec.delete(mesh)
        files = sorted(set(dropped.values()))
        shown = ", ".join(files[:3]) + (f" and {len(files) - 3} more" if len(files) > 3 else "")
        self.notes.append(
            f"{len(dropped)} mesh{'es' if len(dropped) != 1 else ''} MuJoCo cannot read or find ({shown}) dropped "
            "with their geoms: contacts ignore them (the inertias are the URDF's either way)"
        )

    def _weld_unmoved_joints(self, mujoco, spec) -> None:
        """Remove every joint the controller does not move, fixing its body at Pinocchio's locked angle.

        Raises:
            torqueopt.errors.PlantError: a joint of the robot's chain is missing, or of another kind, or a free or ball joint.
        """
        robot = self.robot
        wanted = set(robot.joint_names)
        joints = {joint.name: joint for joint in spec.joints}
        missing = [name for name in robot.joint_names if name not in joints]
        if missing:
            raise PlantError(
                f"{self.source} has no joint {', '.join(missing)}: the plant's joints must carry the robot's names "
                f"({', '.join(robot.joint_names)}); its joints are {', '.join(joints) or 'none'}"
            )
        for name in robot.joint_names:
            expected = _mujoco_joint_kind(robot, name)
            kind = _joint_kind_name(mujoco, joints[name].type)
            if kind != expected:
                raise PlantError(
                    f"joint {name} of {self.source} is a {kind} joint, but robot '{robot.name}' has a {expected} joint "
                    "of that name"
                )
        # The torque enters as generalised force; the model's own actuators would add theirs.
        for kind, elements in (("actuator", spec.actuators), ("sensor", spec.sensors), ("keyframe", spec.keys)):
            elements = list(elements)
            for element in elements:
                spec.delete(element)
            if elements and kind == "actuator":
                self.notes.append(
                    f"the {len(elements)} actuator{'s' if len(elements) != 1 else ''} of {self.source} removed: the "
                    "resolver's torque enters as generalised force"
                )
        locked = _locked_angles(robot)
        welds = []
        for name, joint in joints.items():
            if name in wanted:
                continue
            kind = _joint_kind_name(mujoco, joint.type)
            if kind not in ("hinge", "slide"):
                raise PlantError(
                    f"joint '{name}' of {self.source} is a {kind} joint, which robot '{robot.name}' does not move; "
                    "give a model whose extra joints are hinge or slide joints (they are welded)"
                )
            if name in locked:
                angle = locked[name]
            else:
                angle = joint.ref
                self.notes.append(
                    f"joint '{name}' of {self.source} is not a joint of robot '{robot.name}': welded at its reference "
                    f"{show_number(angle)}"
                )
            welds.append((joint, angle))
        # Tendons and equalities name their joints: they go before the joints do.
        self._drop_welded_references(spec, {joint.name for joint, _ in welds})
        for joint, angle in welds:
            _weld(mujoco, spec, joint, angle)

    def _add_payload(self, spec) -> None:
        """The robot's payload as a body fixed to the body of the task frame's joint, where Pinocchio has it.

        A URDF's body frame in MuJoCo is its joint's frame in Pinocchio, so the
        payload's placement there is Pinocchio's: the task frame's placement
        on its joint, then the payload's centre of mass in the task frame.

        An MJCF is the plant as written (its bodies' frames need not be the
        URDF's): :meth:`__init__` refuses a payload with one.
        """
        payload = self.robot.payload
        if payload is None:
            return
        import pinocchio as pin

        model = self.robot.model
        frame = model.frames[self.robot.frame_id]
        placement = frame.placement * pin.SE3(np.eye(3), np.array(payload.position))
        x, y, z, w = pin.Quaternion(placement.rotation).coeffs()
        spec.joint(model.names[frame.parentJoint]).parent.add_body(
            name="torqueopt_payload",
            pos=placement.translation,
            quat=[w, x, y, z],
            mass=payload.mass,
            ipos=[0.0, 0.0, 0.0],  # its centre of mass is the body's origin (MuJoCo's unset ipos is not)
            iquat=[1.0, 0.0, 0.0, 0.0],
            inertia=list(payload.inertia),
            explicitinertial=True,
        )

    def _drop_welded_references(self, spec, welded: set[str]) -> None:
        """Remove the tendons and equality constraints that name a welded joint (they would name nothing)."""
        for equality in list(spec.equalities):
            if equality.name1 in welded or equality.name2 in welded:
                spec.delete(equality)
        for tendon in list(spec.tendons):
            if any(name in welded for name in _tendon_joints(self._mujoco, tendon)):
                spec.delete(tendon)

    def _floor_inertias(self, spec) -> None:
        """Refuse, or raise to ``inertia-floor``, the principal moments that MuJoCo would refuse.

        Only explicit full inertias (a URDF's) can be checked before compiling;
        an MJCF's own refusals come from MuJoCo's compiler.
        """
        floor = self.options.inertia_floor
        raised, static = [], []
        for body in spec.bodies:
            if not body.explicitinertial or body.mass <= 0 or np.isnan(body.fullinertia[0]):
                continue
            xx, yy, zz, xy, xz, yz = body.fullinertia
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            moments, axes = np.linalg.eigh(tensor)
            if moments[0] > _SMALLEST_MOMENT and (floor is None or moments[0] >= floor):
                continue
            if not _moves(spec, body):
                # No joint moves it (a mobile base's antenna): its inertia enters no equation of motion.
                body.mass, body.fullinertia, body.inertia = 0.0, [np.nan] * 6, [0.0, 0.0, 0.0]
                static.append(body.name)
                continue
            shown = ", ".join(f"{value:.4g}" for value in moments)
            if floor is None:
                kind = "zero (a thin rod)" if moments[0] > -_SMALLEST_MOMENT else "negative"
                raise PlantError(
                    f"MuJoCo refuses {self.source}: link '{body.name}' has principal moments of inertia ({shown}) "
                    f"kg·m², one of them {kind}; give --plant-option inertia-floor=1e-6 (API: plant_options="
                    "{'inertia-floor': 1e-6}) to raise every principal moment below that floor to it, recorded in the "
                    "run file"
                )
            moments = np.maximum(moments, floor)
            tensor = (axes * moments) @ axes.T
            body.fullinertia = [tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[0, 2], tensor[1, 2]]
            raised.append(f"{body.name} ({shown})")
        if static:
            self.notes.append(
                f"the inertias MuJoCo would refuse of links that no joint moves ({', '.join(static)}) left out: "
                "they enter no equation of motion"
            )
        if raised:
            self.notes.append(
                f"principal moments of inertia below {show_number(floor)} kg·m² raised to it (inertia-floor) on links "
                + "; ".join(raised)
            )

    def _configure(self, mujoco, model) -> None:
        """The options the compiled model takes: integrator, gravity, contacts, limits, damping."""
        options = self.options
        model.opt.integrator = getattr(mujoco.mjtIntegrator, INTEGRATORS[options.integrator])
        model.opt.gravity[:] = self.robot.gravity
        disabled = mujoco.mjtDisableBit
        flags = int(model.opt.disableflags)
        # MuJoCo would otherwise reset a diverged state to the start, silently; the run must stop instead.
        flags |= int(disabled.mjDSBL_AUTORESET)
        if not options.contacts:
            flags |= int(disabled.mjDSBL_CONTACT)
        if not options.joint_limits:
            flags |= int(disabled.mjDSBL_LIMIT)
        model.opt.disableflags = flags
        if self.damping == "zero":
            model.dof_damping[:] = 0.0
            model.dof_frictionloss[:] = 0.0
            model.dof_armature[:] = 0.0
            model.jnt_stiffness[:] = 0.0

    @property
    def damping(self) -> str:
        """``urdf`` or ``zero``: the option as given, else what the robot's joint dynamics say."""
        if self.options.damping is not None:
            return self.options.damping
        return "urdf" if self.robot.joint_dynamics == "urdf" else "zero"

    def _set_joint_dynamics(self, model) -> None:
        """Under ``damping=urdf`` on the robot's URDF, the damping and friction Pinocchio read, joint by joint.

        MuJoCo's URDF reader gives the same numbers; setting them from the
        robot makes the damping the controller models and the plant's one
        number. An MJCF keeps its own.
        """
        if self.damping != "urdf" or self.options.mjcf is not None:
            return
        model.dof_damping[self._dof] = self.robot.urdf_joint_damping
        model.dof_frictionloss[self._dof] = self.robot.urdf_joint_friction

    def _perturb(self, mujoco, model) -> dict | None:
        """Scale each moving link's mass and inertia by factors from U(1 − p, 1 + p), seeded; None when p = 0."""
        fraction = self.options.perturb
        if fraction == 0:
            return None
        generator = np.random.default_rng(self.options.seed)
        bodies = [body for body in range(1, model.nbody) if model.body_mass[body] > 0]
        mass_factors = generator.uniform(1 - fraction, 1 + fraction, len(bodies))
        inertia_factors = generator.uniform(1 - fraction, 1 + fraction, len(bodies))
        for body, mass_factor, inertia_factor in zip(bodies, mass_factors, inertia_factors):
            model.body_mass[body] *= mass_factor
            model.body_inertia[body] *= inertia_factor
        mujoco.mj_setConst(model, mujoco.MjData(model))
        return {
            "fraction": fraction,
            "seed": self.options.seed,
            "links": [model.body(body).name for body in bodies],
            "mass_factors": mass_factors.tolist(),
            "inertia_factors": inertia_factors.tolist(),
        }

    def _map_joints(self, mujoco, model) -> None:
        """Where each of the robot's joints sits in MuJoCo's qpos and qvel, and its angle offset (ref)."""
        robot = self.robot
        if model.nv != robot.nv or model.nq != robot.nv:
            raise PlantError(
                f"{self.source} keeps {model.nv} degrees of freedom after welding, robot '{robot.name}' has {robot.nv}"
            )
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in robot.joint_names]
        self._qpos = np.array([model.jnt_qposadr[j] for j in ids])
        self._dof = np.array([model.jnt_dofadr[j] for j in ids])
        # MuJoCo measures a joint from its ref: the model as written sits at qpos = ref, the URDF's at 0.
        self._offset = np.array([model.qpos0[address] for address in self._qpos])
        self._joint_of_id = {j: index for index, j in enumerate(ids)}

    # -- the plant interface ----------------------------------------------------
    def reset(self, dt: float | None = None) -> None:
        """Before a run: forget the previous run's limit events; with ``dt``, check and set the sub-steps."""
        self._time = 0.0
        self._limit_force_peak = np.zeros(self.robot.nv)
        self._limit_first = [None] * self.robot.nv
        self._limit_steps = np.zeros(self.robot.nv, dtype=int)
        self._diverged = None
        self._warning_texts = []
        self._dt = None
        self._movements: dict[int, MujocoPlant] = {}
        if dt is not None:
            self._set_control_step(dt)

    def _set_control_step(self, dt: float) -> None:
        timestep = dt if self.options.timestep is None else self.options.timestep
        if timestep > dt * (1 + 1e-12):
            raise InvalidInput(
                f"plant option timestep={show_number(timestep)} s is longer than the control step dt={show_number(dt)} s"
            )
        substeps = max(1, round(dt / timestep))
        if abs(substeps * timestep - dt) > 1e-9 * dt:
            raise InvalidInput(
                f"plant option timestep={show_number(timestep)} s does not divide the control step dt="
                f"{show_number(dt)} s; give timestep={show_number(dt / substeps)} ({substeps} MuJoCo steps per control step)"
            )
        self._dt, self.substeps = dt, substeps
        self.model.opt.timestep = dt / substeps

    def step(self, q, v, tau, dt: float, acceleration=None) -> tuple[np.ndarray, np.ndarray]:
        """Set MuJoCo's state to (q, v), hold tau [N·m] as generalised force over dt [s], return the new (q, v).

        A state MuJoCo flags as bad (NaN, infinite or beyond 1e10 in qpos,
        qvel or qacc) comes back as NaN, so that the run stops there. The
        controller's ``acceleration`` is not MuJoCo's and is ignored.
        """
        if dt != self._dt:
            self._set_control_step(dt)
        mujoco, model, data = self._mujoco, self.model, self.data
        robot = self.robot
        data.qpos[self._qpos] = robot.joint_angles(q) + self._offset
        data.qvel[self._dof] = v
        data.qfrc_applied[self._dof] = tau
        warnings_before = [data.warning[kind].number for kind in self._warnings]
        texts_before = len(self._warning_texts)
        # MuJoCo's own handler would append its warnings to MUJOCO_LOG.TXT in the working directory;
        # they are kept here instead, and the bad state ends the run.
        handler = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self._warning_texts.append)
        try:
            for substep in range(self.substeps):
                mujoco.mj_step(model, data)
                if data.nefc:
                    self._note_limit_forces(data, self._time + substep * model.opt.timestep)
        finally:
            mujoco.set_mju_user_warning(handler)
        if self._time == 0 and data.ncon:
            self._note_start_contacts(mujoco, model, data)
        self._time += dt
        if [data.warning[kind].number for kind in self._warnings] != warnings_before:
            if self._diverged is None:
                texts = self._warning_texts[texts_before:]
                detail = f": {texts[0].strip()}" if texts else ""
                self._diverged = f"MuJoCo flagged a bad state in the step ending at t = {self._time:.4f} s{detail}"
            return np.full(robot.nq, np.nan), np.full(robot.nv, np.nan)
        angles = data.qpos[self._qpos] - self._offset
        return robot.configuration(angles), data.qvel[self._dof].copy()

    def step_stack(self, q, v, tau, dt: float, acceleration=None, movements=None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`step` on each row of (B, ...) stacks, row r in the data of movement ``movements[r]``."""
        movements = range(len(q)) if movements is None else movements
        rows = [self._movement(int(m)).step(*row, dt) for m, *row in zip(movements, q, v, tau)]
        if not rows:
            return q.copy(), v.copy()
        return np.array([row[0] for row in rows]), np.array([row[1] for row in rows])

    def _movement(self, movement: int) -> MujocoPlant:
        """The plant of one movement of a stack: this model, a MuJoCo data and a record of its own."""
        plant = self._movements.get(movement)
        if plant is None:
            plant = copy.copy(self)
            plant.data = self._mujoco.MjData(self.model)
            plant.notes = list(self.notes)
            plant.reset(self._dt)
            self._movements[movement] = plant
        return plant

    def _note_start_contacts(self, mujoco, model, data) -> None:
        """Say which links touch in the first step: a URDF's collision geometry often overlaps at rest."""
        pairs = sorted(
            {
                tuple(sorted(model.body(model.geom_bodyid[geom]).name for geom in (contact.geom1, contact.geom2)))
                for contact in data.contact[: data.ncon]
            }
        )
        shown = ", ".join(f"{first}-{second}" for first, second in pairs[:4]) + (" ..." if len(pairs) > 4 else "")
        self.notes.append(
            f"with contacts on, MuJoCo found {data.ncon} contact{'s' if data.ncon != 1 else ''} in the first step "
            f"({shown}): the model's collision geometry overlaps there"
        )

    def _note_limit_forces(self, data, t: float) -> None:
        """Per joint, the joint-limit force MuJoCo applied in the step just taken (its efc rows of that type)."""
        nefc = data.nefc
        types, ids, forces = data.efc_type[:nefc], data.efc_id[:nefc], data.efc_force[:nefc]
        for row in np.flatnonzero(types == self._limit_type):
            index = self._joint_of_id.get(int(ids[row]))
            if index is None or forces[row] == 0:
                continue
            magnitude = abs(float(forces[row]))
            if self._limit_first[index] is None:
                self._limit_first[index] = t
            self._limit_steps[index] += 1
            self._limit_force_peak[index] = max(self._limit_force_peak[index], magnitude)

    def limit_events(self) -> list[dict]:
        """The joints whose limit force acted since :meth:`reset`: name, first time [s], peak [N·m], MuJoCo steps."""
        return [
            {"joint": name, "first_time": first, "peak_force": float(peak), "steps": int(steps)}
            for name, first, peak, steps in zip(
                self.robot.joint_names, self._limit_first, self._limit_force_peak, self._limit_steps
            )
            if first is not None
        ]

    def record(self, movement: int | None = None) -> dict:
        """The plant, its options, its notes and its limit events (of ``movement`` of a stack), JSON-ready."""
        if movement is not None:
            return self._movement(movement).record()
        options = self.options
        return {
            "name": "mujoco",
            "model": "mjcf" if options.mjcf is not None else "urdf",
            "model_file": str(options.mjcf if options.mjcf is not None else self.robot.source.urdf),
            "mujoco_version": self._mujoco.__version__,
            "integrator": options.integrator,
            "timestep": float(self.model.opt.timestep),
            "substeps": getattr(self, "substeps", None),
            "contacts": "on" if options.contacts else "off",
            "joint_limits": "on" if options.joint_limits else "off",
            "damping": self.damping,
            "inertia_floor": options.inertia_floor,
            "perturbation": self.perturbation,
            "start_inertia_difference": self.start_inertia_difference,
            "notes": list(self.notes),
            "limit_events": self.limit_events(),
            "bad_state": self._diverged,
        }

    # -- MuJoCo's terms, for the checks -----------------------------------------
    def terms(self, q, v) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo's joint-space inertia (``mj_fullM``) and bias forces (``qfrc_bias``) at (q, v), in the robot's joint order.

        Computed by ``mj_forward`` in a data of their own, so a run's state is untouched.
        """
        mujoco, model = self._mujoco, self.model
        data = mujoco.MjData(model)
        data.qpos[self._qpos] = self.robot.joint_angles(q) + self._offset
        data.qvel[self._dof] = v
        mujoco.mj_forward(model, data)
        inertia = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, inertia)
        order = self._dof
        return inertia[np.ix_(order, order)], data.qfrc_bias[order].copy()

    def _inertia_difference(self, q) -> float:
        """‖H_mujoco − H_pinocchio‖ / ‖H_pinocchio‖ at q (Frobenius): how far the plant's inertia is from the controller's."""
        plant_inertia, _ = self.terms(q, np.zeros(self.robot.nv))
        controller_inertia = self.robot.terms(q, np.zeros(self.robot.nv)).inertia
        return float(np.linalg.norm(plant_inertia - controller_inertia) / np.linalg.norm(controller_inertia))


def _one_line(error: Exception) -> str:
    """MuJoCo's compiler message on one line, without its ``Error:`` prefix."""
    text = " ".join(str(error).split())
    return re.sub(r"^Error:\s*", "", text)


def _moves(spec, body) -> bool:
    """True when a joint of ``body`` or of one of its ancestors moves it."""
    while body is not None and body.name != spec.worldbody.name:
        if len(body.joints):
            return True
        body = body.parent
    return False


def _mujoco_joint_kind(robot, name: str) -> str:
    """The MuJoCo joint kind (hinge or slide) of the robot's joint ``name``."""
    model = robot.model
    return "slide" if joint_kind(model.joints[model.getJointId(name)]) == "prismatic" else "hinge"


def _joint_kind_name(mujoco, kind) -> str:
    """``hinge``, ``slide``, ``ball`` or ``free``: MuJoCo's ``mjtJoint`` member without its prefix."""
    return mujoco.mjtJoint(kind).name.removeprefix("mjJNT_").lower()


def _locked_angles(robot) -> dict[str, float]:
    """The angle [rad or m] Pinocchio locks each of the robot's locked one-coordinate joints at."""
    full_model, configuration = robot.full_model, robot.locked_configuration
    angles = {}
    if configuration is None:
        return angles
    for name in robot.locked_joints:
        joint = full_model.joints[full_model.getJointId(name)]
        if joint.nq == 1:
            angles[name] = float(configuration[joint.idx_q])
        elif joint.nq == 2 and joint.nv == 1:  # a continuous joint, stored as (cos, sin)
            angles[name] = math.atan2(configuration[joint.idx_q + 1], configuration[joint.idx_q])
    return angles


def _weld(mujoco, spec, joint, angle: float) -> None:
    r"""Remove ``joint`` and fix its body where the joint at ``angle`` would hold it.

    For a hinge of axis a through p (body frame) turned by θ = angle − ref the
    body's frame becomes :math:`T\,\mathrm{Tr}(p)\,R(a, θ)\,\mathrm{Tr}(-p)`;
    for a slide it moves by :math:`θ a`.
    """
    body = joint.parent
    turn = angle - joint.ref
    quat = np.array(spec.resolve_orientation(spec.compiler.degree, spec.compiler.eulerseq, body.alt), dtype=float)
    if body.alt.type == mujoco.mjtOrientation.mjORIENTATION_QUAT:
        quat = np.array(body.quat, dtype=float)
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, quat / np.linalg.norm(quat))
    rotation = rotation.reshape(3, 3)
    axis = np.array(joint.axis, dtype=float)
    axis /= np.linalg.norm(axis)
    if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
        body.pos = np.array(body.pos) + rotation @ (turn * axis)
    else:
        pivot = np.array(joint.pos, dtype=float)
        turn_quat = np.zeros(4)
        mujoco.mju_axisAngle2Quat(turn_quat, axis, turn)
        turn_matrix = np.zeros(9)
        mujoco.mju_quat2Mat(turn_matrix, turn_quat)
        body.pos = np.array(body.pos) + rotation @ (pivot - turn_matrix.reshape(3, 3) @ pivot)
        new_quat = np.zeros(4)
        mujoco.mju_mulQuat(new_quat, quat, turn_quat)
        body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        body.quat = new_quat
    spec.delete(joint)


def _tendon_joints(mujoco, tendon) -> list[str]:
    """The joints a fixed tendon couples (the targets of its joint wraps; spatial tendons wrap sites and geoms)."""
    return [wrap.target.name for wrap in tendon.path if wrap.type == mujoco.mjtWrap.mjWRAP_JOINT and wrap.target]
