"""``torqueopt run`` and ``torqueopt optimize`` declare their settings once (dataclasses of torqueopt.settings):
every setting is an option of the command, every option is a setting, and a run's sidecar records every
setting, so that a setting cannot be declared and forgotten."""

from __future__ import annotations

import dataclasses
import json

from torqueopt.cli import build_parser, main
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


def test_run_records_every_setting_in_its_sidecar_as_given(tmp_path):
    out = tmp_path / "run.csv"
    argv = [
        "run", "--robot", "planar3", "--resolver", "weighted-null-space", "--weight", "1,4,9", "--q0=-45,135,-135",
        "--degrees", "--direction", "1,1", "--duration", "0.1", "--dt", "0.002", "--torque-limit", "54,24,inf",
        "--no-dexterity", "--feedback", "100,20", "--limit-factor", "3", "--out", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    record = json.loads(out.with_name("run.csv.json").read_text())["settings"]
    assert list(record) == RunSettings.names()
    given = {
        "robot": "planar3", "resolver": "weighted-null-space", "weight": "1,4,9", "q0": [-45.0, 135.0, -135.0],
        "degrees": True, "direction": [1.0, 1.0], "duration": 0.1, "dt": 0.002, "torque_limit": [54.0, 24.0, None],
        "dexterity": False, "feedback": [100.0, 20.0], "limit_factor": 3.0, "out": str(out),
    }  # fmt: skip
    assert {name: record[name] for name in given} == given
    defaults = RunSettings.from_keywords().record()
    assert {name: value for name, value in record.items() if name not in given} == {
        name: value for name, value in defaults.items() if name not in given
    }


def test_a_run_of_the_api_writes_no_settings(tmp_path):
    from torqueopt import StraightLine, get_resolver, load_robot, simulate

    robot = load_robot("planar3")
    result = simulate(robot, get_resolver("pinv"), StraightLine([1, 1], duration=0.05), robot.default_configuration)
    result.to_csv(tmp_path / "api.csv")
    assert "settings" not in json.loads((tmp_path / "api.csv.json").read_text())


def test_optimize_gives_the_apis_keywords_at_the_apis_defaults():
    """The command's solver settings are torqueopt.optimize's keywords, at its defaults (weight: None is identity)."""
    import inspect

    from torqueopt.cli.optimize import SolverSettings
    from torqueopt.optimal import optimize

    parameters = inspect.signature(optimize).parameters
    defaults = SolverSettings.from_keywords().as_keywords()
    assert {name: parameters[name].default for name in defaults} == {**defaults, "weight": None}
