"""Settings declared once: frozen dataclasses whose fields carry their help, unit, rule and command-line form.

A command's settings are a frozen dataclass of :class:`Settings`; each field is declared with :func:`setting`:
its default, its help (the ``--help`` text), its unit, the rule that checks and normalises a value given to the
API (``check(value, name)``, raising :class:`~torqueopt.errors.InvalidInput` in one line), and how the command
line spells and reads it (``flag``, ``metavar``, ``parse(text, name)``). A field declared with :func:`group` holds a
group, another :class:`Settings` dataclass: its fields are listed under its ``TITLE`` in ``--help`` and given flat by keyword
(``run_atlas(limit_factor=3)``). From these declarations come the argparse options
(:meth:`Settings.add_arguments`), the settings of parsed arguments (:meth:`Settings.from_arguments`), the
settings of keyword arguments, checked against the fields (:meth:`Settings.from_keywords`), and the
``Args:`` text of the API's docstring (:meth:`Settings.arguments_doc`).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
from collections.abc import Callable
from typing import Any, ClassVar

from .checks import parse_number, parse_positive, parse_vector, parse_whole, positive_number, whole_number

__all__ = ["Settings", "group", "number", "numbers", "positive", "positive_in", "setting", "time_step", "whole",
           "whole_at_least"]  # fmt: skip


def setting(
    default: Any = dataclasses.MISSING,
    help: str | Callable[[], str] = "",
    *,
    unit: str | None = None,
    check: Callable[[Any, str], Any] | None = None,
    parse: Callable[[str, str], Any] | None = None,
    flag: str | None = None,
    metavar: str | None = None,
    choices: tuple | None = None,
    switch: str | None = None,
    const: Any = None,
    negation: tuple[str, str] | None = None,
    section: str | None = None,
    repeat: bool = False,
    cli: bool = True,
    cli_required: bool = False,
    doc: str | None = None,
) -> Any:
    """A field of a :class:`Settings` dataclass.

    Args:
        default: the value when none is given.
        help: the command line's help text (or a function of nothing that returns it).
        unit: the value's unit (``s``, ``m/s²``), for the docs.
        check: ``check(value, name)`` returns the value checked and normalised, or raises InvalidInput.
        parse: ``parse(text, name)`` reads the option's text (``name`` is the flag without its dashes); None
            passes the text as it is.
        flag: the option (default ``--`` and the name with dashes).
        metavar, choices: as argparse's.
        switch: ``"on"`` for a flag that turns the setting on (``--global``), ``"off"`` for one that turns it
            off (``--no-figures``), ``"both"`` for a pair (``--dexterity``/``--no-dexterity``); the setting is then
            a bool (any value given is made one).
        const: the value of the option given alone, without its text (``--gravity`` is ``True``).
        negation: ``(flag, help)`` of a second option that sets the setting False (``--no-gravity``).
        section: the ``--help`` section of the option, when not its class's ``TITLE``.
        repeat: the option may be given several times; ``parse`` reads the list of their texts.
        cli: False for a setting of the API only.
        cli_required: the command line requires the option although the API has a default.
        doc: the API's description, when it differs from the help text.
    """
    metadata = {
        "help": help, "unit": unit, "check": check, "parse": parse, "flag": flag, "metavar": metavar,
        "choices": choices, "switch": switch, "const": const, "negation": negation, "section": section, "repeat": repeat, "cli": cli, "cli_required": cli_required, "doc": doc,
    }  # fmt: skip
    return dataclasses.field(default=default, metadata=metadata)


def whole_at_least(minimum: int = 0, maximum: int | None = None) -> Callable[[Any, str], int]:
    """The API's rule for a whole number within the bounds (``name=value must be a whole number ...``)."""
    return lambda value, name: whole_number(value, name, minimum, maximum)


def positive_in(unit: str | None = None, hint: str | None = None) -> Callable[[Any, str], float]:
    """The API's rule for a positive finite number in ``unit`` (``name=value must be a positive ...``)."""
    return lambda value, name: positive_number(value, name, unit, hint)


def whole(minimum: int = 0, maximum: int | None = None) -> Callable[[str, str], int]:
    """The command line's reading of a whole number within the bounds."""
    return lambda text, name: parse_whole(text, name, minimum, maximum)


def positive(text: str, name: str) -> float:
    """The command line's reading of a positive finite number."""
    return parse_positive(text, name)


def number(text: str, name: str) -> float:
    """The command line's reading of a finite number."""
    return parse_number(text, name)


def numbers(size: int | None = None, allow_infinite: bool = False) -> Callable[[str, str], tuple[float, ...]]:
    """The command line's reading of comma-separated numbers (``size`` of them when given)."""
    return lambda text, name: tuple(parse_vector(text, name, size, allow_infinite).tolist())


def time_step(help: str = "integration step [s] (default 0.001)", **options) -> Any:
    """The integration step ``dt`` [s] of every command that simulates (1 ms by default, positive)."""
    return setting(1e-3, help, unit="s", check=positive_in("s"), parse=positive, **options)


def group(settings: type[Settings]) -> Any:
    """A field that holds a group of settings (its own :class:`Settings` dataclass, at its defaults by default)."""
    return dataclasses.field(default_factory=settings, metadata={"group": settings})


def _switched(value, name) -> bool:
    return bool(value)


def _is_group(field: dataclasses.Field) -> bool:
    return "group" in field.metadata


def _group(field: dataclasses.Field) -> type[Settings]:
    return field.metadata["group"]


def _flag(field: dataclasses.Field) -> str:
    return field.metadata.get("flag") or "--" + field.name.replace("_", "-")


def _section(parser: argparse.ArgumentParser, title: str | None):
    """The ``--help`` section titled ``title`` (the parser's own options for None), made once and shared."""
    if title is None:
        return parser
    existing = [section for section in parser._action_groups if section.title == title]
    return existing[0] if existing else parser.add_argument_group(title)


def _json(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (tuple, list)):
        return [_json(item) for item in value]
    if isinstance(value, dict):
        return {str(key): _json(item) for key, item in value.items()}
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return value.record() if hasattr(value, "record") else value  # a Payload: its fields


class Settings:
    """The base of a frozen settings dataclass (see the module docstring).

    ``__post_init__`` checks every field that declares a rule, in the order of the fields, then
    :meth:`check_together` (rules that join several fields).
    """

    #: The ``--help`` section of the fields (None: the parser's own options); sections of one title are one.
    TITLE: ClassVar[str | None] = None

    def __post_init__(self):
        for field in dataclasses.fields(self):
            check = field.metadata.get("check") or (_switched if field.metadata.get("switch") else None)
            if check is not None:
                object.__setattr__(self, field.name, check(getattr(self, field.name), field.name))
        self.check_together()

    def check_together(self) -> None:
        """Rules over several fields; none by default."""

    @classmethod
    def names(cls) -> list[str]:
        """Every setting's keyword, the groups' included, in the order of the fields."""
        names = []
        for field in dataclasses.fields(cls):
            names.extend(_group(field).names() if _is_group(field) else [field.name])
        return names

    @classmethod
    def from_keywords(cls, **values):
        """Settings from flat keywords (the groups' fields by their own names); an unknown keyword is a TypeError
        naming the valid ones, as Python's own."""
        unknown = sorted(set(values) - set(cls.names()))
        if unknown:
            raise TypeError(f"unknown setting {', '.join(unknown)}; the settings are: {', '.join(cls.names())}")
        return cls._build(values)

    @classmethod
    def _build(cls, values: dict):
        own = {}
        for field in dataclasses.fields(cls):
            if _is_group(field):
                inner = {name: values[name] for name in _group(field).names() if name in values}
                own[field.name] = _group(field)._build(inner)
            elif field.name in values:
                own[field.name] = values[field.name]
        return cls(**own)

    def as_keywords(self) -> dict:
        """The flat keywords that give these settings again (:meth:`from_keywords`)."""
        values = {}
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            values.update(value.as_keywords() if _is_group(field) else {field.name: value})
        return values

    def record(self) -> dict:
        """Every setting by its flat keyword as a JSON value (tuples as lists, inf as None): what a command's
        files record of the settings that made them."""
        return {name: _json(value) for name, value in self.as_keywords().items()}

    def replace(self, **values):
        """These settings with some changed, by flat keyword."""
        return type(self).from_keywords(**{**self.as_keywords(), **values})

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        """The command line's options, in the order of the fields, each under its class's ``TITLE`` (or its own
        ``section``)."""
        for field in dataclasses.fields(cls):
            if _is_group(field):
                _group(field).add_arguments(parser)
                continue
            meta = field.metadata
            if not meta.get("cli", True):
                continue
            text = meta["help"]
            options = {"dest": field.name, "help": text() if callable(text) else text}
            if meta.get("switch") == "both":
                options.update(action=argparse.BooleanOptionalAction, default=None)
            elif meta.get("switch"):
                options.update(action="store_true", default=None)
            elif meta.get("repeat"):
                options.update(action="append", default=None, metavar=meta.get("metavar"))
            else:
                options.update(default=None, required=meta.get("cli_required", False))
                if meta.get("const") is not None:
                    options.update(nargs="?", const=meta["const"])
                for key in ("metavar", "choices"):
                    if meta.get(key) is not None:
                        options[key] = meta[key]
            where = _section(parser, meta.get("section") or cls.TITLE)
            where.add_argument(_flag(field), **options)
            if meta.get("negation"):
                flag, text = meta["negation"]
                where.add_argument(flag, dest=field.name, action="store_const", const=False, help=text)

    @classmethod
    def from_arguments(cls, args: argparse.Namespace, **extra):
        """Settings from parsed options: each given option read by its field's ``parse``, the others left at
        their defaults; ``extra`` keywords are added (settings the command line gives in another form)."""
        return cls.from_keywords(**cls._given(args), **extra)

    @classmethod
    def _given(cls, args: argparse.Namespace) -> dict:
        values = {}
        for field in dataclasses.fields(cls):
            if _is_group(field):
                values.update(_group(field)._given(args))
                continue
            text = getattr(args, field.name, None)
            if text is None or not field.metadata.get("cli", True):
                continue
            switch, parse = field.metadata.get("switch"), field.metadata.get("parse")
            if switch in ("on", "off"):
                values[field.name] = switch == "on"
            elif isinstance(text, bool):  # a pair of switches, an option given alone (const) or its negation
                values[field.name] = text
            else:
                values[field.name] = parse(text, _flag(field)[2:]) if parse else text
        return values

    @classmethod
    def arguments_doc(cls, indent: str = "        ") -> str:
        """The ``name: description [unit]`` lines of every setting, for the API's docstring."""
        lines = []
        for field in dataclasses.fields(cls):
            if _is_group(field):
                lines.append(_group(field).arguments_doc(indent))
                continue
            meta = field.metadata
            text = meta.get("doc") or meta["help"]
            text = text() if callable(text) else text
            unit = f" [{meta['unit']}]" if meta.get("unit") and f"[{meta['unit']}]" not in text else ""
            lines.append(f"{indent}{field.name}: {text.replace('%%', '%')}{unit}.")
        return "\n".join(lines)
