"""``torqueopt run`` and ``torqueopt optimize`` declare their settings once (dataclasses of torqueopt.settings):
every setting is an option of the command and every option is a setting."""

from __future__ import annotations

import dataclasses

from torqueopt.cli import build_parser
from torqueopt.cli.optimize import OptimizeSettings
from torqueopt.cli.run import RunSettings
from torqueopt.settings import Settings

#: What argparse and the CLI's plumbing put beside the options.
NOT_SETTINGS = {"help", "command", "handler", "parser"}


def options_of(command: str) -> dict[str, list[str]]:
    """The command's options by destination: ``{dest: [--flag, ...]}``."""
    subparsers = next(action for action in build_parser()._actions if action.dest == "command")
    options = {}
    for action in subparsers.choices[command]._actions:
        if action.dest not in NOT_SETTINGS:
            options.setdefault(action.dest, []).extend(action.option_strings)
    return options


def command_line_names(settings: type[Settings]) -> list[str]:
    """The settings of ``settings`` that the command line gives (the groups' included)."""
    names = []
    for field in dataclasses.fields(settings):
        if "group" in field.metadata:
            names += command_line_names(field.metadata["group"])
        elif field.metadata.get("cli", True):
            names.append(field.name)
    return names


def test_every_setting_of_run_is_an_option_and_every_option_a_setting():
    assert set(RunSettings.names()) == set(options_of("run"))


def test_every_option_of_optimize_is_a_setting():
    # Its API-only settings (v0, joint_dynamics: optimize starts at rest, without joint dynamics) are no options.
    assert set(command_line_names(OptimizeSettings)) == set(options_of("optimize"))
    assert set(OptimizeSettings.names()) - set(options_of("optimize")) == {"v0", "joint_dynamics"}


def test_optimize_gives_the_apis_keywords_at_the_apis_defaults():
    """The command's solver settings are torqueopt.optimize's keywords, at its defaults (weight: None is identity)."""
    import inspect

    from torqueopt.cli.optimize import SolverSettings
    from torqueopt.optimal import optimize

    parameters = inspect.signature(optimize).parameters
    defaults = SolverSettings.from_keywords().as_keywords()
    assert {name: parameters[name].default for name in defaults} == {**defaults, "weight": None}
