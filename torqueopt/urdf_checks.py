r"""Physical checks of a URDF before Pinocchio reads it, and a quiet Pinocchio parse (the list: docs/robots.md).

urdfdom (the C++ parser inside Pinocchio) turns a mass of ``nan`` into 0 with a warning on stderr, accepts
negative masses and inertias no body can have, drops the element of a number it cannot read (``1_0``, Unicode
digits: a link's whole ``<inertial>``) and refuses ``effort="inf"``. :func:`check_urdf` checks every physical
quantity first and names the link or joint in one line: masses, inertia tensors (positive semi-definite about
the centre of mass, within a relative 1e-9 of the largest moment and at least 1e-7 kg·m², for rounding in the
file), origins and axes, limits (``inf`` is given to Pinocchio as 0: both mean unbounded), damping and friction,
a tree of links, and every joint a task moves moving some mass. An inertia that breaks the triangle inequality
:math:`I_i \le I_j + I_k` is impossible for a body but harmless to the dynamics, and shipped files have them
(pr2, romeo, allegro): a :class:`~torqueopt.errors.TorqueoptWarning`, not a refusal. :func:`build_model` then
parses the checked text with the process's stderr captured, so that only the one-line message reaches the user.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import tempfile
import warnings
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple
from xml.etree import ElementTree

import numpy as np

from .errors import TorqueoptWarning, UrdfError

__all__ = ["UrdfCheck", "build_model", "check_chain_moves_mass", "check_urdf", "checked_urdf_text", "quiet_stderr"]

_MOVING = ("revolute", "continuous", "prismatic")
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Tolerance of the inertia tests: relative to the largest moment, and absolute [kg·m²]
#: (a gram at a centimetre is 1e-7 kg·m²; shipped files, tiago's antennas among them,
#: carry moments of -3.5e-8 kg·m² from rounding).
_INERTIA_TOLERANCE = 1e-9
_INERTIA_FLOOR = 1e-7


def check_urdf(root: ElementTree.Element, path) -> UrdfCheck:
    """Check every physical quantity of the URDF tree ``root`` (read from ``path``), as the module docstring lists.

    Returns:
        what the checks found: whether some value had to be rewritten for
        Pinocchio (an ``inf`` effort or velocity limit, given to it as 0; the
        tree is changed in place), the moving joints that move no mass (an
        error only for the joints a task moves, see
        :func:`check_chain_moves_mass`), and notes on harmless oddities.

    Raises:
        UrdfError: naming the link or joint and the valid range.
    """
    where = f"URDF '{path}'"
    notes: list[str] = []
    for kind in ("link", "joint"):
        seen = set()
        for element in root.findall(kind):
            name = element.get("name")
            if name in seen:
                raise UrdfError(
                    f"{where} has two <{kind}> elements named '{name}'; every {kind} needs a name of its own"
                )
            seen.add(name)
    masses = {}
    for link in root.findall("link"):
        name = link.get("name")
        masses[name] = _check_inertial(link, f"{where}: link '{name}'", notes)
        for origin in link.iter("origin"):
            _finite_triple(origin, "xyz", f"{where}: an <origin> of link '{name}'")
            _finite_triple(origin, "rpy", f"{where}: an <origin> of link '{name}'")
    rewritten = False
    parent_of, children, moving = {}, {}, []
    for joint in root.findall("joint"):
        name, kind = joint.get("name"), joint.get("type")
        label = f"{where}: joint '{name}'"
        if kind not in _JOINT_TYPES:
            raise UrdfError(f"{label} has type '{kind}'; choose one of {', '.join(_JOINT_TYPES)}")
        parent, child = joint.find("parent").get("link"), joint.find("child").get("link")
        if child in parent_of:
            raise UrdfError(
                f"{where}: link '{child}' is the child of both joint '{parent_of[child][0]}' and joint '{name}', "
                "which closes a kinematic loop; a URDF describes a tree, and neither Pinocchio's URDF parser nor "
                "torqueopt models loop closures: remove one of the two joints"
            )
        parent_of[child] = (name, parent)
        children.setdefault(parent, []).append(child)
        rewritten |= _check_joint(joint, kind, label)
        if kind in _MOVING:
            moving.append((name, child))
    _check_tree(where, [link.get("name") for link in root.findall("link")], parent_of, children)
    massless = {}
    for name, child in moving:
        if not any(value > 0.0 for link in _descendants(child, children) for value in masses.get(link, ())):
            massless[name] = (
                f"{where}: joint '{name}' moves no mass: link '{child}' and every link below it have zero mass and "
                "inertia, so its joint-space inertia is zero; give them an <inertial> or make the joint fixed"
            )
    return UrdfCheck(rewritten, massless, tuple(notes))


def _check_joint(joint: ElementTree.Element, kind: str, label: str) -> bool:
    """Check a joint's origin, axis, limit, mimic and dynamics; True when an ``inf`` limit was rewritten."""
    origin = joint.find("origin")
    if origin is not None:
        _finite_triple(origin, "xyz", f"{label}: <origin>")
        _finite_triple(origin, "rpy", f"{label}: <origin>")
    axis = joint.find("axis")
    if kind in _MOVING and axis is not None:
        values = _finite_triple(axis, "xyz", f"{label}: <axis>")
        if values is not None and not np.any(values):
            raise UrdfError(f'{label} has <axis xyz="0 0 0">; a {kind} joint needs a non-zero axis')
    limit = joint.find("limit")
    rewritten = limit is not None and _check_limit(limit, kind, label)
    mimic = joint.find("mimic")
    if mimic is not None:
        for attribute in ("multiplier", "offset"):
            _finite_number(mimic, attribute, f"{label}: <mimic>")
    dynamics = joint.find("dynamics")
    if dynamics is not None:
        for attribute in ("damping", "friction"):
            value = _finite_number(dynamics, attribute, f"{label}: <dynamics>")
            if value is not None and value < 0:
                raise UrdfError(f"{label} has {attribute} {value:g}; give a finite number >= 0")
    return rewritten


def _check_tree(where: str, links: list[str], parent_of: dict, children: dict) -> None:
    """Refuse links that do not form one tree: none, no root, several roots, or a loop apart from the root."""
    if not links:
        raise UrdfError(f"{where} has no <link>: there is no robot to model")
    roots = [link for link in links if link not in parent_of]
    if not roots:
        raise UrdfError(
            f"{where}: every link is the child of a joint, so the joints close a kinematic loop; a URDF describes "
            "a tree with one root link, and loop closures cannot be modelled"
        )
    if len(roots) > 1:
        raise UrdfError(
            f"{where}: links {', '.join(repr(r) for r in roots)} are each the child of no joint; a URDF describes "
            "one tree, so all but one root link must hang from a joint"
        )
    reached = _descendants(roots[0], children)
    if len(reached) != len(links):
        loop = sorted(set(links) - reached)
        raise UrdfError(
            f"{where}: links {', '.join(repr(link) for link in loop)} hang from each other in a closed loop, apart "
            "from the root; a URDF describes a tree, and loop closures cannot be modelled"
        )


class UrdfCheck(NamedTuple):
    """What :func:`check_urdf` found in a file that passed it.

    Attributes:
        rewritten: some ``inf`` limit was rewritten to 0 for Pinocchio.
        massless: per moving joint that moves no mass, the message to refuse it with.
        notes: one line per harmless oddity (an inertia that breaks the triangle inequality).
    """

    rewritten: bool
    massless: dict
    notes: tuple


def _check_inertial(link: ElementTree.Element, label: str, notes: list[str]) -> tuple[float, float]:
    """Mass [kg] and inertia trace [kg·m²] of a link's <inertial> (0, 0 without one), checked."""
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, 0.0
    origin = inertial.find("origin")
    if origin is not None:
        _finite_triple(origin, "xyz", f"{label}: <inertial><origin>")
        _finite_triple(origin, "rpy", f"{label}: <inertial><origin>")
    mass_element = inertial.find("mass")
    mass = 0.0 if mass_element is None else _finite_number(mass_element, "value", f"{label}: <mass>")
    if mass is not None and mass < 0:
        raise UrdfError(f"{label} has mass {_text(mass_element, 'value')}; a mass must be a finite number >= 0 [kg]")
    inertia = inertial.find("inertia")
    if inertia is None:
        return mass or 0.0, 0.0
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    values = {}
    for attribute in names:
        value = _finite_number(inertia, attribute, f"{label}: <inertia>")
        values[attribute] = 0.0 if value is None else value
    tensor = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    moments = np.linalg.eigvalsh(tensor)
    slack = max(_INERTIA_TOLERANCE * float(np.abs(moments).max()), _INERTIA_FLOOR)
    shown = ", ".join(f"{moment:.4g}" for moment in moments)
    if moments[0] < -slack:
        raise UrdfError(
            f"{label} has an inertia that is not positive semi-definite: principal moments ({shown}) kg·m²; "
            "every moment of a body is >= 0"
        )
    if moments[2] > moments[0] + moments[1] + slack:
        # Impossible for a body, yet harmless to the dynamics (H stays positive definite), and common in
        # shipped files (pr2, romeo, allegro): said, not refused.
        notes.append(
            f"{label} has an inertia that no body can have: principal moments ({shown}) kg·m² break the triangle "
            "inequality (the largest must be at most the sum of the other two); simulating it as given"
        )
    return mass or 0.0, float(np.trace(tensor))


def _check_limit(limit: ElementTree.Element, kind: str, label: str) -> bool:
    """Check a joint's <limit>; rewrite an ``inf`` effort or velocity to 0 (unbounded) for urdfdom."""
    rewritten = False
    for attribute, unit in (("effort", "N·m or N"), ("velocity", "rad/s or m/s")):
        text = limit.get(attribute)
        if text is None:
            continue
        value = _number(text, f"{label}: <limit {attribute}>")
        if math.isnan(value) or value < 0:
            raise UrdfError(
                f"{label} has {attribute} limit {text.strip()}; give a number >= 0 [{unit}] (0 or inf: unbounded)"
            )
        if math.isinf(value):
            limit.set(attribute, "0")  # urdfdom cannot read inf; torqueopt reads 0 as unbounded
            rewritten = True
    if kind in ("revolute", "prismatic"):
        bounds = {}
        for attribute in ("lower", "upper"):
            text = limit.get(attribute)
            if text is None:
                continue
            value = _number(text, f"{label}: <limit {attribute}>")
            if not math.isfinite(value):
                raise UrdfError(
                    f"{label} has {attribute} position limit {text.strip()}; give a finite number "
                    '(a revolute joint without position limits is type="continuous")'
                )
            bounds[attribute] = value
        if bounds.get("lower", -math.inf) > bounds.get("upper", math.inf):
            raise UrdfError(
                f"{label} has lower position limit {bounds['lower']:g} above its upper limit {bounds['upper']:g}"
            )
    return rewritten


#: A number as urdfdom reads it (``std::istringstream >> double`` in the C locale, the whole text consumed):
#: blanks before it, none after; no digit separators, no Unicode digits. Python's ``float`` reads more
#: (" 10.0 ", "5_0", "５"), and urdfdom drops the whole element whose number it cannot read (a link's
#: <inertial> goes, and the link weighs nothing), so a number is read here as urdfdom reads it, or refused.
_URDF_NUMBER = re.compile(r"[ \t\n\r\f\v]*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _number(text: str, label: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise UrdfError(f'{label}="{text}" is not a number') from None
    if math.isfinite(value) and not _URDF_NUMBER.fullmatch(text):
        raise UrdfError(
            f'{label}="{text}" is not a number as URDF parsers read it (Pinocchio\'s would drop the element): '
            "write digits with an optional sign, point and exponent, and nothing after them"
        )
    return value


def _text(element: ElementTree.Element, attribute: str) -> str:
    return (element.get(attribute) or "").strip()


def _finite_number(element: ElementTree.Element, attribute: str, label: str) -> float | None:
    text = element.get(attribute)
    if text is None:
        return None
    value = _number(text, f"{label} {attribute}")
    if not math.isfinite(value):
        raise UrdfError(f'{label} has {attribute}="{text.strip()}"; it must be a finite number')
    return value


def _finite_triple(element: ElementTree.Element, attribute: str, label: str) -> np.ndarray | None:
    text = element.get(attribute)
    if text is None:
        return None
    # urdfdom splits a vector at spaces only (a tab is part of a number, which it then cannot read).
    parts = [part for part in text.split(" ") if part]
    try:
        values = np.array([_number(part, f"{label} {attribute}") for part in parts])
    except UrdfError:
        raise UrdfError(
            f'{label} {attribute}="{text}" is not three numbers as URDF parsers read them: '
            "digits with an optional sign, point and exponent, separated by spaces"
        ) from None
    if values.size != 3 or not np.isfinite(values).all():
        raise UrdfError(f'{label} has {attribute}="{text.strip()}"; it must be three finite numbers')
    return values


def _descendants(link: str, children: dict[str, list[str]]) -> set[str]:
    found, stack = set(), [link]
    while stack:
        current = stack.pop()
        if current in found:
            continue
        found.add(current)
        stack.extend(children.get(current, ()))
    return found


@lru_cache(maxsize=16)
def _checked(path: str, modified: int, size: int) -> tuple[str, UrdfCheck]:
    text = Path(path).read_text()
    root = ElementTree.fromstring(text)
    found = check_urdf(root, path)
    for note in found.notes:
        warnings.warn(note, TorqueoptWarning, stacklevel=2)
    return (ElementTree.tostring(root, encoding="unicode") if found.rewritten else text), found


def checked_urdf_text(path) -> str:
    """The URDF at ``path`` as the text Pinocchio should parse, after :func:`check_urdf`.

    The file's own text, or (when an ``inf`` limit had to be rewritten) the
    checked tree serialised again. Cached per file and modification time;
    each note of the check is issued once as a :class:`TorqueoptWarning`.
    """
    status = os.stat(path)
    return _checked(str(path), status.st_mtime_ns, status.st_size)[0]


def check_chain_moves_mass(path, joint_names) -> None:
    """UrdfError when one of ``joint_names`` (the joints a task moves) moves no mass (see :func:`check_urdf`).

    Massless joints elsewhere (a gripper's, a sensor's) are locked, so they are no obstacle.
    """
    status = os.stat(path)
    massless = _checked(str(path), status.st_mtime_ns, status.st_size)[1].massless
    for name in joint_names:
        if name in massless:
            raise UrdfError(massless[name])


@contextlib.contextmanager
def quiet_stderr():
    """Capture file descriptor 2 (where urdfdom's C++ code writes) for the block; yields a function giving the text.

    Python's own ``sys.stderr`` is flushed first and writes through the same
    descriptor, so nothing is reordered; the captured text is dropped unless
    the caller asks for it.
    """
    import sys

    with tempfile.TemporaryFile(mode="w+b") as capture:
        try:
            sys.stderr.flush()
            saved = os.dup(2)
        except (OSError, ValueError, AttributeError):
            yield lambda: ""  # no real descriptor 2 (an embedding host): nothing to silence
            return
        os.dup2(capture.fileno(), 2)
        try:
            yield lambda: (capture.seek(0), capture.read().decode(errors="replace"))[1]
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def build_model(path, mimic: bool):
    """Pinocchio's model of the checked URDF at ``path``, parsed with urdfdom's stderr captured.

    Raises:
        UrdfError: the file fails :func:`check_urdf`, or Pinocchio cannot
            build it (one line, with urdfdom's first error message).
    """
    import pinocchio as pin

    text = checked_urdf_text(path)
    with quiet_stderr() as captured:
        try:
            return pin.buildModelFromXML(text, mimic=mimic)
        except (RuntimeError, ValueError) as error:
            detail = _first_error(captured()) or " ".join(str(error).split())
    raise UrdfError(f"Pinocchio cannot build a model from '{path}': {detail}")


def _first_error(text: str) -> str:
    """urdfdom's first ``Error:`` message, on one line, without the C++ source location."""
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("Error:"):
            return line[len("Error:") :].strip()
    return ""
