"""Rules for numbers and vectors given to the Python API: one function per rule, each naming the value it refuses.

Two forms share these rules. The API's messages name the value as
``name=value`` (:func:`positive_number`, :func:`whole_number`, ...). A
declared resolver option (:mod:`torqueopt.resolvers.options`) is named by the
option machinery, so its converters (:func:`number_at_least`,
:func:`finite_array`) raise :class:`Refused` with only what the value must be,
which the machinery completes as ``option NAME=VALUE of resolver 'R' ...``.

Which vector check to use:

* :func:`finite_vector`: exactly n values, one per joint (names the joints);
* :func:`finite_numbers`: a point, direction or target of 2 or 3 (or a given number of) coordinates;
* :func:`finite_values`: any number of values, a list of durations or a sweep grid;
* :func:`finite_array`: an option's vector or matrix, keeping its shape.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from numbers import Real

import numpy as np

from ..errors import InvalidInput

__all__ = [
    "Refused",
    "positive_number",
    "non_negative_number",
    "number_at_least",
    "number_in_range",
    "number_in_interval",
    "whole_number",
    "finite_values",
    "finite_vector",
    "finite_numbers",
    "finite_array",
    "show_number",
    "count_values",
    "decimal",
]


class Refused(ValueError):
    """A value a converter refuses; its text completes "NAME=VALUE ..." (e.g. "must be a finite number >= 0")."""


def _at_least(number: float, minimum: float, strict: bool) -> bool:
    """The one test of "a finite number >= minimum" (> when ``strict``)."""
    return math.isfinite(number) and (number > minimum if strict else number >= minimum)


def _is_whole(number: float, minimum: int, maximum: int | None) -> bool:
    """The one test of "a whole number from minimum (to maximum)"."""
    return (
        math.isfinite(number) and number == int(number) and number >= minimum and (maximum is None or number <= maximum)
    )


def _whole_wording(minimum: int, maximum: int | None) -> str:
    return f"a whole number >= {minimum}" if maximum is None else f"a whole number from {minimum} to {maximum:,}"


def show_number(value) -> str:
    """A number as the user gave it: ``-1``, ``-100.0``, ``inf`` (numpy scalars as plain numbers, never ``np.float64(-100.0)``)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**16:
        return f"{value:.4g}"  # 1e+308 given as a count, not its 309 digits
    return repr(value)


def count_values(count: int, noun: str = "value") -> str:
    """``1 value``, ``3 values``."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


#: A number as a person types it: ASCII digits, an optional sign, point and exponent, or inf/nan.
_DECIMAL = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf(?:inity)?|nan)", re.IGNORECASE)


def decimal(text: str) -> float:
    """The number written in ``text`` (blanks around it allowed), or ValueError.

    ``float`` alone reads more than a person means as a number: digit
    separators (``1_0``) and the digits of every script (``١``, ``５``).
    """
    stripped = str(text).strip()
    if not _DECIMAL.fullmatch(stripped):
        raise ValueError(f"not a decimal number: {text!r}")
    return float(stripped)


def _as_float(value, name: str, suffix: str) -> float:
    try:
        return decimal(value) if isinstance(value, str) else float(value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}={show_number(value)} is not a number{suffix}") from None


def positive_number(value, name: str, unit: str | None = None, hint: str | None = None) -> float:
    """``value`` as a float, or InvalidInput unless it is a finite number > 0.

    Args:
        name: how the message names the value (``dt``, ``limit_factor``).
        unit: appended as `` [unit]``.
        hint: appended as `` (hint)``, e.g. "a multiple, such as 2".
    """
    suffix = (f" [{unit}]" if unit else "") + (f" ({hint})" if hint else "")
    number = _as_float(value, name, suffix)
    if not _at_least(number, 0.0, strict=True):
        raise InvalidInput(f"{name}={show_number(value)} must be a positive finite number{suffix}")
    return number


def non_negative_number(value, name: str, unit: str | None = None) -> float:
    """``value`` as a float, or InvalidInput unless it is a finite number >= 0 (a gain, a clearance)."""
    suffix = f" [{unit}]" if unit else ""
    number = _as_float(value, name, suffix)
    if not _at_least(number, 0.0, strict=False):
        raise InvalidInput(f"{name}={show_number(value)} must be a finite number >= 0{suffix}")
    return number


def number_in_range(
    value, name: str, low: float, high: float, low_open: bool = False, high_open: bool = False, unit: str | None = None
) -> float:
    """``value`` as a float within the interval from ``low`` to ``high`` (open at an end when ``*_open``), else InvalidInput.

    Example message: ``reach_fraction=1.5 must be a number in (0, 1]``.
    """
    suffix = f" [{unit}]" if unit else ""
    number = _as_float(value, name, suffix)
    try:
        return number_in_interval(number, low, high, low_open, high_open)
    except Refused as refusal:
        raise InvalidInput(f"{name}={show_number(value)} {refusal}{suffix}") from None


def whole_number(value, name: str, minimum: int = 0, maximum: int | None = None) -> int:
    """``value`` as an int, or InvalidInput unless it is an integer (not a bool, not a float) within the bounds.

    Example messages: ``paths=0 must be a whole number from 1 to 1,000,000``,
    ``turns=1.5 must be a whole number >= 1``.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not _is_whole(value, minimum, maximum):
        raise InvalidInput(f"{name}={show_number(value)} must be {_whole_wording(minimum, maximum)}")
    return int(value)


def _real(value, wanted: str) -> float:
    """A converter's reading of a real number or its text as a float, else :class:`Refused` saying to give ``wanted``."""
    if isinstance(value, str):
        try:
            return decimal(value)
        except ValueError:
            raise Refused(f"is not a number; give {wanted}") from None
    if isinstance(value, bool) or not isinstance(value, Real):
        raise Refused(f"is not a number; give {wanted}")
    return float(value)


def number_at_least(value, minimum: float = 0.0, strict: bool = False, unit: str = "") -> float:
    """A converter's rule: a finite real number >= ``minimum`` (> when ``strict``), or its text; else :class:`Refused`."""
    wanted = f"a finite number {'>' if strict else '>='} {minimum:g}" + (f" [{unit}]" if unit else "")
    number = _real(value, wanted)
    if not _at_least(number, minimum, strict):
        raise Refused(f"must be {wanted}")
    return number


def number_in_interval(
    value, low: float, high: float, low_open: bool = False, high_open: bool = False, unit: str = ""
) -> float:
    """A converter's rule: a real number (or its text) in the interval from ``low`` to ``high``, else :class:`Refused`.

    The message writes the interval as mathematics does, open ends in round brackets: ``[0, 1)``.
    """
    interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    wanted = f"a number in {interval}" + (f" [{unit}]" if unit else "")
    number = _real(value, wanted)
    above = number > low if low_open else number >= low
    below = number < high if high_open else number <= high
    if not (math.isfinite(number) and above and below):
        raise Refused(f"must be {wanted}")
    return number


def finite_array(value, what: str, example: str = "1,1,1") -> np.ndarray:
    """A converter's rule: a non-empty array of finite floats from comma-separated text or array-like values.

    Args:
        what: what the value should be, in words, for :class:`Refused`'s text ("a vector").
        example: comma-separated numbers shown when text is not numbers.
    """
    if isinstance(value, str):
        try:
            array = np.array([decimal(part) for part in value.split(",")])
        except ValueError:
            raise Refused(f"is not {what}; give comma-separated numbers, e.g. {example}") from None
    else:
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise Refused(f"is not {what}") from None
    if array.size == 0 or not np.isfinite(array).all():
        raise Refused(f"must be {what} of finite numbers")
    return array


def finite_values(
    values, name: str, minimum: float | None = None, strict: bool = False, unit: str | None = None
) -> tuple[float, ...]:
    """One or more finite numbers as a tuple of floats (any count), or InvalidInput naming ``name``.

    Args:
        minimum: when given, every value must be >= it (> when ``strict``):
            ``sweep dampings [-1.0] must be finite numbers >= 0``, ``torque_limit [0.0] must be positive numbers``.
        unit: appended as `` [unit]``.
    """
    suffix = f" [{unit}]" if unit else ""
    try:
        array = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a list of numbers{suffix}") from None
    if not array.size or not np.isfinite(array).all():
        raise InvalidInput(f"{name} {array.tolist()} must be finite numbers{suffix}")
    if minimum is not None and not all(_at_least(value, minimum, strict) for value in array.tolist()):
        wanted = (
            "positive numbers" if strict and minimum == 0 else f"finite numbers {'>' if strict else '>='} {minimum:g}"
        )
        raise InvalidInput(f"{name} {array.tolist()} must be {wanted}{suffix}")
    return tuple(array.tolist())


def _flat_vector(values, name: str) -> np.ndarray:
    try:
        return np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name} {values!r} is not a vector of numbers") from None


def finite_vector(values, size: int, name: str, names=None) -> np.ndarray:
    """A float vector of ``size`` finite entries, or InvalidInput naming ``name`` (and the joints ``names``)."""
    vector = _flat_vector(values, name)
    if vector.size != size:
        joints = f" (joints {', '.join(names)})" if names else ""
        raise InvalidInput(f"{name} has {count_values(vector.size)} but needs {size}{joints}")
    if not np.isfinite(vector).all():
        raise InvalidInput(f"{name} {vector.tolist()} has a non-finite value; all {size} values must be finite")
    return vector


def finite_numbers(
    values,
    name: str,
    size: int | tuple[int, ...] = (2, 3),
    unit: str | None = None,
    context: str | Callable[[], str] = "",
) -> np.ndarray:
    """``values`` as a finite float vector of ``size`` entries (one of them, for a tuple), else InvalidInput.

    A point, a direction or a target: ``start [1.0] must be 2 or 3 finite numbers``.

    Args:
        unit: appended as `` [unit]``.
        context: appended after a space, e.g. "for FrameTask('tip', 'xy')"; a callable
            is called for it only when the check fails (a repr of an object still being made).
    """
    sizes = (size,) if isinstance(size, int) else size
    vector = _flat_vector(values, name)
    if vector.size not in sizes or not np.isfinite(vector).all():
        wanted = " or ".join(str(s) for s in sizes)
        context = context() if callable(context) else context
        suffix = (f" [{unit}]" if unit else "") + (f" {context}" if context else "")
        raise InvalidInput(f"{name} {vector.tolist()} must be {wanted} finite numbers{suffix}")
    return vector
