"""Checks of values that enter the API, with messages that name the value and what would be valid."""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidInput

__all__ = ["finite_vector", "positive_number"]


def positive_number(value, name: str, unit: str | None = None, hint: str | None = None) -> float:
    """``value`` as a float, or InvalidInput unless it is a finite number > 0.

    Args:
        name: how the message names the value (``dt``, ``limit_factor``).
        unit: appended as `` [unit]``.
        hint: appended as `` (hint)``, e.g. "a multiple, such as 2".
    """
    suffix = (f" [{unit}]" if unit else "") + (f" ({hint})" if hint else "")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}={value!r} is not a number{suffix}") from None
    if not (math.isfinite(number) and number > 0):
        raise InvalidInput(f"{name}={value!r} must be a positive finite number{suffix}")
    return number


def finite_vector(values, size: int, name: str, names=None) -> np.ndarray:
    """A float vector of ``size`` finite entries, or InvalidInput naming ``name`` (and the joints ``names``)."""
    try:
        vector = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a vector of numbers") from None
    if vector.size != size:
        joints = f" (joints {', '.join(names)})" if names else ""
        raise InvalidInput(f"{name} has {vector.size} values but needs {size}{joints}")
    if not np.isfinite(vector).all():
        raise InvalidInput(f"{name} {vector.tolist()} has a non-finite value; all {size} values must be finite")
    return vector
