"""Rules for the text of command-line options: each message names the option, ``--name: text``.

The rules are those of :mod:`torqueopt.checks.numbers` (finite, positive,
whole), applied to text, so an option of the CLI and the API's argument it
sets accept the same numbers.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInput
from .numbers import _at_least, _is_whole, _whole_wording, count_values, decimal

__all__ = ["parse_vector", "parse_number", "parse_positive", "parse_count", "parse_whole"]


def parse_vector(text: str, name: str, size: int | None = None, allow_infinite: bool = False) -> np.ndarray:
    """The numbers of option ``--name``, comma-separated (``-0.785,2.356,-2.356``); rejects text, NaN,
    wrong sizes and (unless ``allow_infinite``) inf."""
    values = []
    for part in (part.strip() for part in str(text).split(",")):
        try:
            value = decimal(part)
        except ValueError:
            raise InvalidInput(f"--{name}: '{part}' is not a number (give comma-separated numbers, e.g. 1,1)") from None
        if math.isnan(value) or (math.isinf(value) and not allow_infinite):
            raise InvalidInput(f"--{name}: '{part}' is not finite; give finite numbers")
        values.append(value)
    if size is not None and len(values) != size:
        raise InvalidInput(f"--{name} has {count_values(len(values))} but needs {size}")
    return np.array(values)


def _parse_number(text: str, name: str) -> float:
    try:
        return decimal(text)
    except ValueError:
        raise InvalidInput(f"--{name}: '{text}' is not a number") from None


def parse_number(text: str, name: str) -> float:
    """The finite number of option ``--name`` (its range, if any, is the API's to check)."""
    value = _parse_number(text, name)
    if not math.isfinite(value):
        raise InvalidInput(f"--{name}: {text} must be a finite number")
    return value


def parse_positive(text: str, name: str) -> float:
    """The positive finite number of option ``--name``."""
    value = _parse_number(text, name)
    if not _at_least(value, 0.0, strict=True):
        raise InvalidInput(f"--{name}: {text} must be a positive finite number")
    return value


def parse_whole(text: str, name: str, minimum: int = 0, maximum: int | None = None) -> int:
    """The whole number of option ``--name`` within the bounds (``2e6`` and ``3.0`` are accepted too).

    Example message: ``--chunk-size: 0 must be a whole number >= 1``.
    """
    try:
        value = decimal(text)
    except ValueError:
        raise InvalidInput(f"--{name}: '{text}' is not a whole number") from None
    if not _is_whole(value, minimum, maximum):
        raise InvalidInput(f"--{name}: {text} must be {_whole_wording(minimum, maximum)}")
    return int(value)


def parse_count(text: str, name: str) -> int:
    """The positive whole number of option ``--name``, e.g. ``--max-steps 2000000`` (``2e6`` is accepted too)."""
    return parse_whole(text, name, minimum=1)
