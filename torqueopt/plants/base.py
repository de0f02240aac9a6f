"""The plant registry and protocol: :class:`Plant`, :func:`register_plant`, :func:`make_plant`."""

from __future__ import annotations

import difflib
from importlib.metadata import entry_points
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InvalidInput

__all__ = ["ENTRY_POINT_GROUP", "Plant", "make_plant", "plant_names", "plant_option_texts", "register_plant"]

#: The registered plants by name: name -> class (``cls(robot, **options)``).
_PLANTS: dict[str, type] = {}
#: The entry-point group other packages register plants in.
ENTRY_POINT_GROUP = "torqueopt.plants"


@runtime_checkable
class Plant(Protocol):
    """What :func:`torqueopt.simulate` and ``simulate_batch`` need of a plant.

    ``q`` is a Pinocchio configuration vector (nq) or a stack of them (B, nq),
    ``v`` the joint velocities [rad/s] (n) or (B, n), ``tau`` the torques
    [N·m] held over the step of ``dt`` [s]; ``acceleration`` is the resolver's
    q̈ at the step start, which a plant integrating the controller's own
    model may reuse (the others ignore it). In a stack, row r is movement
    ``movements[r]`` (the batch drops movements that stop), so a plant that
    keeps a record per movement knows whose row it steps.
    """

    name: str

    def reset(self, dt: float) -> None:
        """Before a run of control step dt [s]: check the step, forget what the previous run did."""

    def step(self, q, v, tau, dt: float, acceleration=None) -> tuple[np.ndarray, np.ndarray]:
        """One movement's state (q, v) one control step of dt [s] later, with the torque tau [N·m] held."""

    def step_stack(self, q, v, tau, dt: float, acceleration=None, movements=None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`step` on (B, ...) stacks; ``movements`` the movement of each row (0..B-1 when None)."""

    def record(self, movement: int | None = None) -> dict:
        """The plant and what it did since :meth:`reset` (for ``movement`` of a stack), JSON-ready, for the run file."""


def register_plant(name: str):
    """Class decorator: register a plant class under ``name`` (``@register_plant("myplant")``).

    The class is built as ``cls(robot, **options)`` and declares the option
    names it takes in ``OPTION_NAMES`` (none when it has no such attribute).

    Raises:
        InvalidInput: ``name`` is already registered to another class.
    """

    def decorate(cls):
        known = _PLANTS.get(name)
        if known is not None and known is not cls:
            raise InvalidInput(f"plant name '{name}' is already registered ({known.__module__}.{known.__qualname__})")
        _PLANTS[name] = cls
        cls.name = name
        return cls

    return decorate


def _load_entry_points() -> None:
    """Register the plants other installed packages declare in the ``torqueopt.plants`` group."""
    for entry in entry_points(group=ENTRY_POINT_GROUP):
        if entry.name not in _PLANTS:
            register_plant(entry.name)(entry.load())


def plant_names() -> tuple[str, ...]:
    """The names of the registered plants, built-in first."""
    _load_entry_points()
    return tuple(_PLANTS)


def make_plant(robot, plant="pinocchio", options: dict | None = None) -> Plant:
    """The plant named ``plant`` (or ``plant`` itself when it is a :class:`Plant`) for ``robot``.

    ``options`` are the plant's options by name (for ``mujoco``, those of
    :func:`torqueopt.plants.mujoco.mujoco_options`: ``mjcf``, ``integrator``,
    ``timestep``, ``contacts``, ``joint-limits``, ``damping``, ...);
    ``joint-limits`` and ``joint_limits`` name one option.

    Raises:
        InvalidInput: an unknown plant name, or an option the plant does not take.
        MissingDependency: ``mujoco`` without the mujoco package.
    """
    if not isinstance(plant, str):
        if not isinstance(plant, Plant):
            raise InvalidInput(f"plant {plant!r} is neither a plant name ({', '.join(plant_names())}) nor a Plant")
        if options:
            raise InvalidInput("plant options go with a plant name; this plant object is already built")
        return plant
    names = plant_names()
    if plant not in names:
        close = difflib.get_close_matches(plant, names, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise InvalidInput(f"unknown plant '{plant}'{hint}; choose one of {', '.join(names)}")
    cls = _PLANTS[plant]
    keywords = {str(key).replace("-", "_"): value for key, value in (options or {}).items()}
    accepted = getattr(cls, "OPTION_NAMES", ())
    if keywords and not accepted:
        raise InvalidInput(f"plant options ({', '.join(options)}) do not apply here: the {plant} plant takes none")
    unknown = [key for key in keywords if key not in accepted]
    if unknown:
        raise InvalidInput(
            f"unexpected plant option '{unknown[0].replace('_', '-')}'; the {plant} plant's options are "
            + ", ".join(name.replace("_", "-") for name in accepted)
        )
    return cls(robot, **keywords)


def plant_option_texts(texts) -> dict[str, str]:
    """``--plant-option`` texts, each repeatable and comma-separated ``KEY=VALUE``, as ``{key: value}``.

    Raises:
        InvalidInput: an item that is not KEY=VALUE, or a key given twice.
    """
    options = {}
    for text in texts:
        for item in text.split(","):
            key, separator, value = item.partition("=")
            key = key.strip()
            if not separator or not key or not value.strip():
                raise InvalidInput(f"--plant-option '{item}' must be KEY=VALUE, e.g. --plant-option integrator=euler")
            if key in options:
                raise InvalidInput(f"--plant-option {key} is given twice; give it once")
            options[key] = value.strip()
    return options
