"""Where robot descriptions come from: the project's ``robots/`` folder and
the URDFs that the ``example-robot-data`` package installs.

A robot is named by a URDF path, by the stem of a file in ``robots/``
(``planar3``) or by the stem of a URDF in example-robot-data (``panda``,
``xarm7``, ``baxter``, ``tiago``, ...). For the arms we know, the catalogue
also gives the task frame, task, SRDF configuration and locked joints to use
when the user names none.
"""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

__all__ = ["RobotSource", "find_robot", "available_robots", "example_robot_data_dir", "mesh_file"]

_PACKAGE_DIR = Path(__file__).resolve().parent


@dataclass(frozen=True)
class RobotSource:
    """A URDF on disk and the defaults that go with it.

    ``vetted`` marks the catalogue's own files (``robots/`` and the known
    example-robot-data arms): the test suite checks each with yourdfpy, so
    loading them skips that check, and the second it takes to import
    yourdfpy; any other URDF gets it at every load.
    """

    name: str
    urdf: Path
    package_dirs: tuple[Path, ...] = ()
    srdf: Path | None = None
    srdf_configuration: str | None = None
    frame: str | None = None
    task: str | None = None
    locked_joints: tuple[str, ...] = ()
    gravity: bool = True
    vetted: bool = False
    start: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class _KnownArm:
    urdf: str
    frame: str
    srdf: str | None = None
    srdf_configuration: str | None = None
    task: str = "position"
    locked_joints: tuple[str, ...] = field(default=())
    #: Joint angles [rad] set on top of the SRDF (or neutral) configuration for the default start.
    start: tuple[tuple[str, float], ...] = ()


# Defaults for the example-robot-data arms with seven joints in a chain (and
# kinova, a six-joint arm), so that ``--robot panda`` works with no more flags.
_KNOWN_ARMS = {
    "panda": _KnownArm(
        "panda_description/urdf/panda.urdf",
        frame="panda_hand",
        srdf="panda_description/srdf/panda.srdf",
        srdf_configuration="default",
    ),
    "xarm7": _KnownArm(
        "xarm_description/urdf/xarm7.urdf",
        frame="link_eef",
    ),
    "baxter": _KnownArm(
        "baxter_description/urdf/baxter.urdf",
        frame="right_gripper",
        srdf="baxter_description/srdf/baxter_manipulation.srdf",
        srdf_configuration="neutral",
        # The SRDF's all-zero "neutral" pose is stretched (σmin/σmax of the
        # position Jacobian 0.029) and needs 1.13 times joint s1's limit to hold
        # against gravity. Shoulder, elbow and wrist bent (chosen on a 9³ grid of
        # s1, e1, w1 for the largest σmin/σmax with gravity at most half of
        # every limit, 0.2 rad from the joint limits, and the 1 s line of docs/robots.md
        # along z completing within all limits): σmin/σmax 0.52, gravity 0.23
        # of the limits; the same for both arms.
        start=tuple(
            (f"{side}_{joint}", angle)
            for side in ("left", "right")
            for joint, angle in (("s1", 0.85), ("e1", 1.28), ("w1", 1.49))
        ),
    ),
    "tiago": _KnownArm(
        "tiago_description/robots/tiago.urdf",
        frame="arm_tool_link",
        locked_joints=("torso_lift_joint",),
        # All-zero is stretched (σmin/σmax 0.022) and sits on arm_1's lower
        # limit; chosen as baxter's (grid of arm_1, arm_2, arm_4): σmin/σmax
        # 0.175, gravity 0.47 of the limits, a 1 s line along z within all limits.
        start=(("arm_1_joint", 0.57), ("arm_2_joint", -0.5), ("arm_4_joint", 0.98)),
    ),
    "kinova": _KnownArm(
        "kinova_description/robots/kinova.urdf",
        frame="j2s6s200_end_effector",
        srdf="kinova_description/srdf/kinova.srdf",
        srdf_configuration="arm_up",
        # The SRDF has joint 3 at -1.5707, outside the URDF's [0.33, 5.95]; the
        # same pose one turn on is inside.
        start=(("j2s6s200_joint_3", -1.5707 + 2 * 3.141592653589793),),
    ),
}

_LOCAL_DEFAULTS = {
    "planar3": {"frame": "tip", "task": "xy", "gravity": False, "srdf_configuration": "paper"},
}


def _robots_dirs() -> list[Path]:
    # Installed wheels carry robots/ inside the package; a source checkout
    # (editable install, tests) has it beside the package.
    return [p for p in (_PACKAGE_DIR / "robots", _PACKAGE_DIR.parent / "robots") if p.is_dir()]


@lru_cache(maxsize=1)
def example_robot_data_dir() -> Path | None:
    """The ``robots`` folder of the installed example-robot-data, or None.

    example-robot-data 6.x is a cmeel package: its files live under
    ``cmeel.prefix/share/example-robot-data/robots`` in site-packages.
    """
    candidates = [Path(entry) for entry in sys.path if entry]
    # Found, not imported: cmeel's import makes a temporary folder it never removes (a ResourceWarning at exit).
    spec = importlib.util.find_spec("cmeel")
    if spec is not None and spec.origin:
        candidates.insert(0, Path(spec.origin).resolve().parent.parent)
    for base in candidates:
        robots = base / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if robots.is_dir():
            return robots
    return None


@lru_cache(maxsize=1)
def _example_robot_urdfs() -> dict[str, Path]:
    root = example_robot_data_dir()
    if root is None:
        return {}
    found: dict[str, Path] = {}
    for path in sorted(root.glob("*/**/*.urdf")):
        found.setdefault(path.stem, path)
    for name, arm in _KNOWN_ARMS.items():
        if (root / arm.urdf).is_file():
            found[name] = root / arm.urdf
    return found


def available_robots() -> list[str]:
    """Names accepted by :func:`find_robot`: local robots, the known arms, then the rest of example-robot-data."""
    local = sorted({p.stem for d in _robots_dirs() for p in d.glob("*.urdf")})
    urdfs = _example_robot_urdfs()
    arms = [name for name in _KNOWN_ARMS if name in urdfs and name not in local]
    return local + arms + sorted(set(urdfs) - set(local) - set(arms), key=str.lower)


def find_robot(source: str | Path) -> RobotSource:
    """Locate a robot by URDF path or by name.

    Raises:
        RobotNotFound: no such file, or no robot of that name.
    """
    from .errors import RobotNotFound

    text = str(source)
    path = Path(text).expanduser()
    looks_like_path = path.suffix.lower() == ".urdf" or "/" in text or "\\" in text
    if looks_like_path:
        _refuse_what_is_no_urdf(text, path)
        if not path.is_file():
            raise RobotNotFound(f"URDF file '{text}' does not exist")
        return RobotSource(name=path.stem, urdf=path.resolve(), package_dirs=_package_dirs_for(path.resolve()))

    for robots_dir in _robots_dirs():
        local = robots_dir / f"{text}.urdf"
        if local.is_file():
            defaults = dict(_LOCAL_DEFAULTS.get(text, {}))
            srdf = local.with_suffix(".srdf")
            if srdf.is_file():
                defaults["srdf"] = srdf
            return RobotSource(name=text, urdf=local, package_dirs=(robots_dir,), vetted=True, **defaults)

    urdfs = _example_robot_urdfs()
    if text in urdfs:
        root = example_robot_data_dir()
        # Meshes are named package://example-robot-data/robots/..., so the
        # package directory is the "share" folder that holds example-robot-data.
        package_dirs = (root.parent.parent,)
        arm = _KNOWN_ARMS.get(text)
        if arm is None:
            return RobotSource(name=text, urdf=urdfs[text], package_dirs=package_dirs)
        return RobotSource(
            name=text,
            urdf=urdfs[text],
            package_dirs=package_dirs,
            srdf=root / arm.srdf if arm.srdf else None,
            srdf_configuration=arm.srdf_configuration,
            frame=arm.frame,
            task=arm.task,
            locked_joints=arm.locked_joints,
            vetted=True,
            start=arm.start,
        )

    _refuse_what_is_no_urdf(text, path)
    names = available_robots()
    shown = names[: len(names) - len(set(urdfs) - set(_KNOWN_ARMS))]
    hint = ", ".join(shown)
    if len(names) > len(shown):
        hint += f", or one of {len(names) - len(shown)} more URDF names from example-robot-data (torqueopt robots lists them)"
    if example_robot_data_dir() is None:
        hint += " (example-robot-data is not installed: pip install example-robot-data)"
    raise RobotNotFound(f"unknown robot '{text}': give a URDF path or one of {hint}")


def _refuse_what_is_no_urdf(text: str, path: Path) -> None:
    """A folder, or a xacro file, given where a URDF (or a robot's name) is expected: say what it is."""
    from .errors import RobotNotFound

    if path.is_dir():
        inside = sorted(path.glob("*.urdf")) or sorted(path.glob("*/*.urdf"))
        example = f", e.g. {inside[0].as_posix()}" if inside else " (it holds no .urdf)"
        raise RobotNotFound(f"robot '{text}' is a folder; give the URDF file in it{example}")
    if path.is_file() and path.suffix.lower() == ".xacro":
        expanded = path.name[: -len(".xacro")]
        expanded = expanded if expanded.lower().endswith(".urdf") else f"{expanded}.urdf"
        raise RobotNotFound(
            f"robot '{text}' is a xacro file, which torqueopt does not expand; expand it to a URDF first "
            f"(xacro {path.name} -o {expanded}) and give that file"
        )


def _package_dirs_for(urdf: Path) -> tuple[Path, ...]:
    """Folders in which ``package://NAME/...`` mesh URIs of a user URDF may resolve.

    The URDF's own folder and its ancestors cover the usual layouts
    (``NAME/urdf/robot.urdf`` with meshes in ``NAME/meshes``), and the
    example-robot-data share folder covers URDFs that reuse its meshes.
    """
    dirs = [urdf.parent, *urdf.parent.parents][:4]
    root = example_robot_data_dir()
    if root is not None:
        dirs.append(root.parent.parent)
    return tuple(dirs)


def mesh_file(uri: str, base: Path, package_dirs) -> Path | None:
    """The file a URDF mesh filename names (``package://pkg/...``, ``file://...`` or a relative path), or None."""
    if uri.startswith("package://"):
        relative = uri[len("package://") :]
        package, _, inside = relative.partition("/")
        candidates = []
        for folder in package_dirs:
            folder = Path(folder)
            candidates += [folder / relative, folder / package / inside]
            if folder.name == package:
                candidates.append(folder / inside)
    elif uri.startswith("file://"):
        candidates = [Path(uri[len("file://") :])]
    else:
        candidates = [base / uri]
    return next((path.resolve() for path in candidates if path.is_file()), None)
