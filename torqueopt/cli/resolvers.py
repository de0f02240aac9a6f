"""``torqueopt resolvers``: the registered resolvers and the options each declares.

Also the shared CLI plumbing for resolver options: ``--option NAME=VALUE``
(repeatable) and the ``--weight`` alias, read generically from each
resolver's declaration, so no resolver is named here.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from ..errors import InvalidInput
from ..resolvers import RESOLVERS, Resolver, get_resolver
from ..resolvers.options import parse_resolver_spec
from ..settings import Settings, setting
from . import EXIT_OK
from .common import importable_from_here

__all__ = ["add_parser", "ResolverSettings", "describe_resolvers", "options_help"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "resolvers",
        help="list the resolvers and their options",
        description=(
            "List the registered resolvers (the built-in ones and those of installed plug-ins, entry points of "
            "the group torqueopt.resolvers), what each minimises, and the options each accepts "
            "(give them to torqueopt run as --option NAME=VALUE, or as keywords of get_resolver, resolve "
            "and simulate's resolver_options), with type, unit and default. A plug-in that failed to load is "
            "listed last, with why."
        ),
    )
    parser.set_defaults(handler=resolvers_command)


def resolvers_command(args: argparse.Namespace) -> int:
    print(describe_resolvers())
    return EXIT_OK


def describe_resolvers() -> str:
    """Every registered resolver with its one-line summary and a table of its declared options."""
    lines = []
    for name, cls in RESOLVERS.items():
        lines.append(f"{name}: {cls.summary()}")
        for option in cls.declared_options():
            unit = f" [{option.unit}]" if option.unit else ""
            lines.append(f"    {option.name}{unit}: {option.kind}, default {option.describe_default()}")
            lines.append(f"        {option.meaning}")
        lines.append("")
    failures = RESOLVERS.failures
    if failures:
        lines.append("plug-ins that failed to load:")
        lines.extend(f"    {name}: {why}" for name, why in failures.items())
    return "\n".join(lines).rstrip()


def options_help() -> str:
    """One short help line naming each resolver's own options, units and defaults (for ``--option``)."""
    entries = []
    for name, cls in RESOLVERS.items():
        own = [
            f"{option.name}" + (f" [{option.unit}]" if option.unit else "") + f" = {option.describe_default()}"
            for option in cls.options
        ]
        if own:
            entries.append(f"{name}: {'; '.join(own)}")
    return (
        "a resolver option, repeatable (e.g. --option damping=2). "
        + ". ".join(entries)
        + ". Every resolver also takes singular_tolerance. Details: torqueopt resolvers"
    )


@dataclass(frozen=True)
class ResolverSettings(Settings):
    """``--resolver`` with its options (``--option NAME=VALUE``, the ``--weight`` alias, ``--options-from``):
    the resolver a command runs (:meth:`resolver`)."""

    TITLE = "movement"

    resolver: str | None = setting(
        None,
        lambda: (
            f"resolver: {', '.join(RESOLVERS)}; or a class of yours, module:Class (importable from here); "
            "either may carry its options as NAME[OPTION=VALUE,...], quoted for the shell"
        ),
        metavar="RESOLVER",
        cli_required=True,
    )
    options: tuple[str, ...] = setting(
        (), options_help, flag="--option", repeat=True, metavar="NAME=VALUE", parse=lambda texts, name: tuple(texts)
    )
    weight: str | None = setting(
        None,
        "alias of --option weight=W (weighted-null-space: diagonal of W, one value per joint; default 1/(τ⁺−τ⁻)²)",
        metavar="W",
    )
    options_from: str | None = setting(
        None,
        "the options of the setting a torqueopt tune chose (its tune.json), for the same --resolver; "
        "an --option given too is refused",
        metavar="TUNE_JSON",
    )

    def build(self, robot: str | None = None) -> Resolver:
        """The resolver ``--resolver`` names (a name or module:Class, with or without [OPTION=VALUE,...]) with its
        options, checked against its declaration; ``robot`` (the ``--robot`` text) picks a tune.json's arm."""
        importable_from_here(self.resolver)
        name, options = parse_resolver_spec(self.resolver)
        for text in self.options:
            option, separator, value = text.partition("=")
            option = option.strip()
            if not separator or not option or not value.strip():
                raise InvalidInput(f"--option '{text}' must be NAME=VALUE, e.g. --option damping=2")
            if option in options:
                raise InvalidInput(
                    f"--option {option} is given twice (in --resolver's brackets or --option); give it once"
                )
            options[option] = value.strip()
        if self.weight is not None:
            if "weight" in options:
                raise InvalidInput("--weight and --option weight= are the same option; give one")
            options["weight"] = self.weight
        if self.options_from:
            from ..catalog import find_robot
            from ..tune import tuned_options

            tuned, chosen = tuned_options(self.options_from, None if robot is None else find_robot(robot).name)
            if get_resolver(name).name != tuned:
                raise InvalidInput(
                    f"--options-from {self.options_from} holds options of {tuned}, not of --resolver {self.resolver}; "
                    f"give --resolver {tuned}"
                )
            both = sorted(set(options) & set(chosen))
            if both:
                raise InvalidInput(
                    f"--option {', '.join(both)} is also in --options-from {self.options_from}; give it once"
                )
            options.update(chosen)
        return get_resolver(name, **options)
