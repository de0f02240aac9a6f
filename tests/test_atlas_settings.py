"""The atlas's settings, declared once (torqueopt.atlas.settings): the committed atlases' configs rebuilt byte for
byte from the commands their pages document, and the command line and the API reading the same settings."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from torqueopt.atlas import AtlasSettings, run_atlas
from torqueopt.atlas.jobs import RobotSpec
from torqueopt.atlas.population import arm_reach
from torqueopt.atlas.settings import atlas_config
from torqueopt.atlas.sweep import config_digest
from torqueopt.cli import build_parser
from torqueopt.cli.atlas import robot_spec
from torqueopt.errors import InvalidInput

DOCS = Path(__file__).resolve().parents[1] / "docs" / "atlas"
CONFIGS = sorted(DOCS.rglob("atlas-config.json"))


def documented_command(folder: str) -> list[str]:
    """The ``torqueopt atlas ... --out FOLDER`` command of the docs' pages, as arguments."""
    text = "\n".join(page.read_text() for page in DOCS.glob("*.md")).replace("\\\n", " ")
    lines = [line for line in text.splitlines() if line.startswith("torqueopt atlas ") and line.split()[-1] == folder]
    assert len(lines) == 1, f"the pages document {len(lines)} commands for {folder}"
    return shlex.split(lines[0])[1:]


def settings_of(argv: list[str]) -> AtlasSettings:
    args = build_parser().parse_args(argv)
    return AtlasSettings.from_arguments(args, robot=robot_spec(args))


@pytest.mark.parametrize("config", CONFIGS, ids=[path.parent.name for path in CONFIGS])
def test_a_committed_atlas_config_is_rebuilt_byte_for_byte_from_its_documented_command(config):
    """The fingerprint a sweep resumes by: the settings of the page's command, the robot they load, its reach and
    the population's size give the committed atlas-config.json, byte for byte, and so its digest."""
    settings = settings_of(documented_command(config.parent.name))
    robot = settings.robot.load()
    movements = settings.paths * len(settings.durations)  # random mode draws every path (each config says so)
    rebuilt = atlas_config(settings, robot, arm_reach(robot)[1], movements)
    assert json.dumps(rebuilt, indent=2, sort_keys=True).encode() == config.read_bytes()
    assert config_digest(rebuilt) == config_digest(json.loads(config.read_text()))


def test_every_committed_atlas_has_its_command():
    assert len(CONFIGS) == 13
    for config in CONFIGS:
        documented_command(config.parent.name)


#: One value for every option of ``torqueopt atlas``, away from its default: (command-line text, the API's value).
EVERY_OPTION = {
    "paths": ("7", 7),
    "durations": ("0.4,0.8", (0.4, 0.8)),
    "resolvers": ("pinv,bounded-torque[joint_limits=off]", ("pinv", "bounded-torque[joint_limits=off]")),
    "out": ("there", "there"),
    "seed": ("3", 3),
    "mode": ("random", "random"),
    "reach_fraction": ("0.8", 0.8),
    "min_condition": ("0.1", 0.1),
    "grid_spacing": ("0.5", 0.5),
    "grid_directions": ("4", 4),
    "path": ("circle", "circle"),
    "length_range": ("0.3,0.9", (0.3, 0.9)),
    "accel": ("1.5", 1.5),
    "dt": ("0.002", 0.002),
    "limit_factor": ("3", 3.0),
    "pinv_factor": ("2.5", 2.5),
    "energy_factor": ("8", 8.0),
    "scheduler": ("tcp://10.0.0.5:8786", "tcp://10.0.0.5:8786"),
    "workers": ("3", 3),
    "chunk_size": ("16", 16),
    "max_steps": ("1e6", 1_000_000),
    "batch": (None, False),
    "progress": (None, False),
    "figures": (None, False),
    "keep_traces": ("5", 5),
    "global_optimum": (None, True),
    "global_bounded": (None, True),
    "global_max_iterations": ("50", 50),
    "global_max_time": ("30", 30.0),
    "margin": (None, True),
    "margin_every": ("0.04", 0.04),
    "plant": ("mujoco", "mujoco"),
    "plant_options": ("perturb=0.1,seed=3", {"perturb": "0.1", "seed": "3"}),
}
FLAGS = {
    "batch": "--no-batch",
    "progress": "--no-progress",
    "figures": "--no-figures",
    "global_optimum": "--global",
    "plant_options": "--plant-option",
    "global_bounded": "--global-bounded",
    "margin": "--margin",
}


def test_every_option_of_the_command_sets_its_setting_as_the_api_does():
    """Each option is read into the setting of its name, with the value the API's keyword gives."""
    assert set(EVERY_OPTION) == set(AtlasSettings.names()) - {"robot"}
    argv = ["atlas", "--robot", "panda", "--task", "position", "--torque-limit", "80"]
    for name, (text, _) in EVERY_OPTION.items():
        argv += [FLAGS[name]] if text is None else [FLAGS.get(name, "--" + name.replace("_", "-")), text]
    from_command = settings_of(argv)
    robot = RobotSpec("panda", task="position", torque_limit=(80.0,))
    from_api = AtlasSettings.from_keywords(robot=robot, **{name: value for name, (_, value) in EVERY_OPTION.items()})
    assert comparable(from_command) == comparable(from_api)
    defaults = comparable(AtlasSettings())
    assert [name for name in EVERY_OPTION if comparable(from_command)[name] == defaults[name]] == ["mode"]
    assert comparable(from_command)["resolvers"] == ["pinv", "bounded-torque[joint_limits=off]"]


def comparable(settings: AtlasSettings) -> dict:
    """The settings' keywords, the resolvers by their labels (Resolver objects compare by identity)."""
    return {**settings.as_keywords(), "resolvers": [resolver.label for resolver in settings.resolvers]}


def test_a_keyword_that_is_no_setting_is_refused_with_the_settings_named():
    with pytest.raises(TypeError, match=r"unknown setting chunksize; the settings are: robot, paths, .*chunk_size"):
        run_atlas("planar3", chunksize=4)
    with pytest.raises(TypeError, match="by position and by keyword"):
        run_atlas("planar3", 3, paths=4)
    with pytest.raises(TypeError, match="AtlasSettings alone"):
        run_atlas(AtlasSettings(), paths=4)


def test_settings_are_checked_when_made_with_the_apis_one_line_messages():
    with pytest.raises(InvalidInput, match=r"^chunk_size=0 must be a whole number >= 1$"):
        AtlasSettings.from_keywords(chunk_size=0)
    with pytest.raises(InvalidInput, match=r"^limit_factor=-1 must be a positive finite number \(a multiple"):
        AtlasSettings.from_keywords(limit_factor=-1)
    with pytest.raises(InvalidInput, match=r"^dt=0.003 s does not divide the duration 0.5 s"):
        AtlasSettings.from_keywords(dt=0.003)
    settings = AtlasSettings.from_keywords(paths=3, workers=0)
    assert settings.replace(seed=4).seed == 4 and settings.replace(seed=4).paths == 3


def test_run_atlas_documents_every_setting():
    for name in AtlasSettings.names():
        assert f"\n        {name}: " in run_atlas.__doc__, name
