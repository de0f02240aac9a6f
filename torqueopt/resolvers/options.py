"""Declared resolver options: one declaration per option, read by the API, the CLI and the listing.

A resolver lists its options as :class:`Option` objects in its class
attribute ``options``. :func:`validate_options` turns the keyword arguments
given to :func:`torqueopt.get_resolver` (Python values) or to
``torqueopt run --option NAME=VALUE`` (text) into checked values, so the two
entry points accept exactly the same things and fail with the same one-line
messages. The converters' rules are those of :mod:`torqueopt.checks`
(:func:`~torqueopt.checks.number_at_least`, :func:`~torqueopt.checks.finite_array`).
Checks that need the robot (a vector's length) are the resolver's, in its ``check``.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..checks import Refused, finite_array, number_at_least, number_in_interval
from ..errors import InvalidInput

__all__ = [
    "Option",
    "number",
    "LARGEST_WEIGHT",
    "vector_or_matrix",
    "choice_or_vector",
    "validate_options",
    "format_value",
    "label_value",
    "resolver_label",
    "parse_resolver_spec",
    "split_resolver_list",
]


@dataclass(frozen=True)
class Option:
    """One option a resolver accepts.

    Attributes:
        name: the keyword (``get_resolver(name, kinematic_weight=1.0)``, ``--option kinematic_weight=1``).
        kind: the accepted type in words, e.g. ``number >= 0`` or ``'unit' | 'range' | vector``.
        unit: the unit of the value, e.g. ``1/s``; empty when it has none.
        default: the value used when the option is not given (None: described by ``default_text``).
        meaning: one sentence: what the option does.
        convert: checks a value (a Python value or the CLI's text) and returns the normalised
            value; raises :class:`~torqueopt.checks.Refused` saying what it must be (its text
            completes "option NAME=VALUE of resolver 'R' ...").
        default_text: how the listing shows the default, when ``default`` alone does not say it.
        text: how a resolver's label writes a value, as text that ``convert`` reads back, for a value that is
            not numbers (an obstacle); None: ``label_value``.
    """

    name: str
    kind: str
    unit: str
    default: object
    meaning: str
    convert: Callable[[object], object]
    default_text: str | None = None
    text: Callable[[object], str] | None = None

    def describe_default(self) -> str:
        return self.default_text if self.default_text is not None else format_value(self.default)


#: The largest gain or weight an option takes where the arithmetic squares it (1e308² overflows; a
#: weight of 1e6 already makes its term outweigh the rest by 1e12).
LARGEST_WEIGHT = 1e6


def number(
    minimum: float = 0.0, strict: bool = False, unit: str = "", maximum: float | None = None
) -> Callable[[object], float]:
    """A converter accepting a finite real number >= ``minimum`` (> when ``strict``), or its text;
    with ``maximum``, also <= ``maximum``."""
    if maximum is not None:
        return partial(number_in_interval, low=minimum, high=maximum, low_open=strict, unit=unit)
    return partial(number_at_least, minimum=minimum, strict=strict, unit=unit)


def vector_or_matrix(value) -> np.ndarray:
    """A converter accepting a vector (comma-separated on the CLI) or a square matrix of finite numbers."""
    array = finite_array(value, "a vector or a matrix")
    if array.ndim > 2 or (array.ndim == 2 and array.shape[0] != array.shape[1]):
        raise Refused(f"must be a vector or a square matrix, got shape {array.shape}")
    return array


def choice_or_vector(*choices: str) -> Callable[[object], object]:
    """A converter accepting one of the named ``choices`` or a vector of finite numbers."""
    listed = " | ".join(f"'{choice}'" for choice in choices)

    def convert(value):
        if isinstance(value, str) and value.strip() in choices:
            return value.strip()
        if isinstance(value, str) and not any(ch.isdigit() for ch in value):
            raise Refused(f"must be {listed} or a vector of numbers")
        array = finite_array(value, f"{listed} or a vector")
        if array.ndim != 1:
            raise Refused(f"must be {listed} or a vector, got shape {array.shape}")
        return array

    return convert


def format_value(value) -> str:
    """A value as the listing and the messages show it: numbers by ``%g``, vectors comma-separated."""
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            return str(value)
        if array.ndim == 0:
            return f"{float(array):g}"
        if array.ndim == 1:
            return ",".join(f"{x:g}" for x in array)
        return "x".join(str(size) for size in array.shape) + " matrix"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def validate_options(resolver: str, declared: tuple[Option, ...], given: Mapping[str, object]) -> dict[str, object]:
    """Every declared option's value: the given ones checked and converted, the rest their defaults.

    Raises:
        InvalidInput: an option that is not declared (naming the close match and every valid
            one), or a value its converter refuses (naming the value and what it must be).
    """
    by_name = {option.name: option for option in declared}
    for name in given:
        if name not in by_name:
            raise InvalidInput(unknown_option_message(resolver, name, list(by_name)))
    values = {}
    for option in declared:
        if option.name not in given or given[option.name] is None:
            values[option.name] = option.default
            continue
        raw = given[option.name]
        try:
            values[option.name] = option.convert(raw)
        except Refused as error:
            shown = raw if isinstance(raw, str) else format_value(raw)
            unit = f" [{option.unit}]" if option.unit and option.unit not in str(error) else ""
            raise InvalidInput(f"option {option.name}={shown} of resolver '{resolver}' {error}{unit}") from None
    return values


def unknown_option_message(resolver: str, name: str, valid: list[str]) -> str:
    """One line: the unknown option, the close match if any, and every valid option."""
    close = difflib.get_close_matches(str(name), valid, n=1, cutoff=0.7)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    listed = ", ".join(valid) if valid else "none"
    return f"unknown option '{name}' for resolver '{resolver}'{hint}; valid options: {listed}"


def label_value(value) -> str:
    """A value as a resolver's label writes it: exact (a float by its shortest text that reads back the same),
    vectors comma-separated, a matrix's rows separated by ``;``."""
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            return str(value)
        if array.ndim == 0:
            return label_value(float(array))
        if array.ndim == 1:
            return ",".join(label_value(float(x)) for x in array)
        return ";".join(label_value(row) for row in array)
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, (float, np.floating, int, np.integer)):
        number = float(value)
        short = f"{number:g}"
        return short if float(short) == number else repr(number)
    return str(value)


def resolver_label(name: str, declared: tuple[Option, ...], settings: Mapping[str, object]) -> str:
    """``name``, or ``name[OPTION=VALUE,...]`` with the options whose values differ from their defaults, in the
    order they are declared: the same settings always give the same label, and :func:`parse_resolver_spec`
    reads it back."""
    changed = [
        f"{option.name}={(option.text or label_value)(settings[option.name])}"
        for option in declared
        if label_value(settings[option.name]) != label_value(option.default)
    ]
    return f"{name}[{','.join(changed)}]" if changed else name


def split_resolver_list(text: str) -> list[str]:
    """The resolver specs of a comma-separated list, the commas inside ``[...]`` kept with their spec.

    ``"pinv,bounded-torque[joint_limits=off,damping=2],null-space"`` gives three specs.

    Raises:
        InvalidInput: a ``[`` without its ``]`` or the reverse.
    """
    specs, depth, current = [], 0, []
    for character in str(text):
        if character == "[":
            depth += 1
            if depth > 1:
                raise InvalidInput(f"resolver list '{text}' opens a '[' inside another; give NAME[OPTION=VALUE,...]")
        elif character == "]":
            depth -= 1
            if depth < 0:
                raise InvalidInput(f"resolver list '{text}' closes a ']' it did not open; give NAME[OPTION=VALUE,...]")
        if character == "," and depth == 0:
            specs.append("".join(current))
            current = []
        else:
            current.append(character)
    if depth:
        raise InvalidInput(f"resolver list '{text}' leaves a '[' unclosed; give NAME[OPTION=VALUE,...]")
    specs.append("".join(current))
    return [spec.strip() for spec in specs if spec.strip()]


_SPEC = re.compile(r"^\s*([^\[\]=,\s]+)\s*(?:\[(.*)\])?\s*$", re.DOTALL)


def parse_resolver_spec(text: str) -> tuple[str, dict[str, str]]:
    """``NAME`` or ``NAME[OPTION=VALUE,OPTION=VALUE]`` as (name, {option: value text}).

    Inside the brackets the options are separated by commas; a comma followed by
    no ``=`` before the next comma continues a vector value
    (``weighted-null-space[weight=1,2,3,singular_tolerance=1e-6]``). The values
    are text, checked by the resolver's own options.

    Raises:
        InvalidInput: text that is not of that form, an option given twice, or empty brackets.
    """
    match = _SPEC.match(str(text))
    if not match:
        raise InvalidInput(
            f"resolver '{text}' is not NAME or NAME[OPTION=VALUE,...], e.g. bounded-torque[joint_limits=off]"
        )
    name, inside = match.group(1), match.group(2)
    options: dict[str, str] = {}
    if inside is None:
        return name, options
    if not inside.strip():
        raise InvalidInput(f"resolver '{text}' has empty brackets; give NAME[OPTION=VALUE,...] or NAME alone")
    last = None
    for piece in inside.split(","):
        option, separator, value = piece.partition("=")
        if not separator:
            if last is None or not piece.strip():
                raise InvalidInput(
                    f"resolver '{text}': '{piece.strip()}' is not OPTION=VALUE; give NAME[OPTION=VALUE,...], "
                    "e.g. bounded-torque[joint_limits=off,damping=2]"
                )
            options[last] += "," + piece.strip()  # the next element of a vector value
            continue
        option = option.strip()
        if not option or not value.strip():
            raise InvalidInput(
                f"resolver '{text}': '{piece.strip()}' is not OPTION=VALUE; give NAME[OPTION=VALUE,...], "
                "e.g. bounded-torque[joint_limits=off,damping=2]"
            )
        if option in options:
            raise InvalidInput(f"resolver '{text}' gives option {option} twice; give it once")
        options[option] = value.strip()
        last = option
    return name, options
