"""The atlas's settings, declared once: :func:`~torqueopt.atlas.run_atlas`'s keywords, ``torqueopt atlas``'s
options and the settings ``atlas-config.json`` records (whose digest lets a sweep resume) all come from here.

:class:`AtlasSettings` holds the movements (robot, paths, durations, resolvers, folder, seed) and four groups,
as ``torqueopt atlas --help`` lists them: :class:`PopulationSettings`, the verdicts'
:class:`~torqueopt.atlas.verdicts.Thresholds`, :class:`ExecutionSettings` and :class:`FrontierSettings` (the
global optimum and the stability margin).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass

import numpy as np

from ..checks import step_count
from ..errors import InvalidInput
from ..resolvers import Resolver, resolver_names
from ..resolvers.options import split_resolver_list
from ..robot import Robot
from ..settings import (
    Settings,
    group,
    number,
    numbers,
    positive,
    positive_in,
    setting,
    time_step,
    whole,
    whole_at_least,
)
from .explorer import DEFAULT_KEEP_TRACES
from .global_optimum import DEFAULT_GLOBAL_MAX_ITERATIONS, DEFAULT_GLOBAL_MAX_TIME
from .global_optimum import settings as global_settings
from .jobs import RobotSpec
from .margins import DEFAULT_MARGIN_EVERY
from .population import PATH_KINDS, PopulationSpec
from .sweep import resolvers_from, scheduler_address
from .verdicts import Thresholds

__all__ = [
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_MAX_STEPS",
    "PAPER_RESOLVERS",
    "AtlasSettings",
    "ExecutionSettings",
    "FrontierSettings",
    "PlantSettings",
    "PopulationSettings",
    "atlas_config",
    "path_kind",
]

#: Largest sweep (movements × resolvers × steps) run_atlas starts without being told otherwise.
DEFAULT_MAX_STEPS = 10_000_000_000
#: Movements per chunk of work.
DEFAULT_CHUNK_SIZE = 256
#: The paper's four resolvers, the atlas's default.
PAPER_RESOLVERS = ("pinv", "inertia-pinv", "null-space", "weighted-null-space")
#: The version of atlas-config.json's layout.
CONFIG_FORMAT = 1


def path_kind(text: str, name: str = "path") -> str:
    """``text`` when it names a kind of path of the atlas (``--path``), else InvalidInput listing them."""
    if text not in PATH_KINDS:
        raise InvalidInput(
            f"--{name}: '{text}' is not a kind of path for the atlas; choose one of {', '.join(PATH_KINDS)}"
        )
    return text


def _optional(check):
    return lambda value, name: None if value is None else check(value, name)


@dataclass(frozen=True)
class PopulationSettings(Settings):
    """How the movements are drawn and stepped (:class:`~torqueopt.atlas.population.PopulationSpec` checks them)."""

    TITLE = "population"

    mode: str = setting("random", "random starts, or a grid of start points", choices=("random", "grid"))
    reach_fraction: float = setting(
        0.9, "the whole line within F of the arm's reach (default 0.9)", metavar="F", parse=positive
    )
    min_condition: float = setting(
        0.05, "start Jacobian σmin/σmax at least C (default 0.05)", metavar="C", parse=number
    )
    grid_spacing: float = setting(
        0.25, "grid mode: start-point spacing [m] (default 0.25)", unit="m", metavar="M", parse=positive
    )
    grid_directions: int = setting(8, "grid mode: directions per start point (default 8)", metavar="K", parse=whole(1))
    path: str = setting(
        "line",
        "tip paths: line (the paper's bang-bang line), min-jerk (minimum-jerk lines of random length) or "
        "circle (one turn in a random plane about a random centre); default line",
        metavar="KIND",
        parse=path_kind,
    )
    length_range: tuple[float, float] = setting(
        (0.25, 1.0),
        "min-jerk: length, circle: circumference, uniform in LOW..HIGH times a·T²/4 (default 0.25,1)",
        metavar="LOW,HIGH",
        parse=numbers(2),
    )
    accel: float | None = setting(
        None,
        "tangential acceleration a [m/s²] (default: sized to the arm, √2 x reach / 3 m: √2 on planar3)",
        unit="m/s²",
        metavar="A",
        parse=positive,
    )
    dt: float = time_step()


@dataclass(frozen=True)
class ExecutionSettings(Settings):
    """Where and how the sweep runs, and what it writes beside the table."""

    TITLE = "execution"

    scheduler: str | None = setting(
        None,
        "existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a local cluster)",
        check=lambda value, name: scheduler_address(value),
        metavar="ADDRESS",
    )
    workers: int | None = setting(
        None,
        "local cluster worker processes (default: the machine's cores; 0: no Dask)",
        check=_optional(whole_at_least(0, 1024)),
        parse=whole(),
        metavar="N",
    )
    chunk_size: int = setting(
        DEFAULT_CHUNK_SIZE,
        f"movements per chunk of work (default {DEFAULT_CHUNK_SIZE})",
        check=whole_at_least(1),
        parse=whole(1),
        metavar="N",
    )
    max_steps: int = setting(
        DEFAULT_MAX_STEPS,
        "refuse sweeps of more trajectory-steps (default 1e10)",
        parse=whole(1),
        metavar="N",
        doc="refuse a sweep of more trajectory-steps than this (a global optimum counts as "
        "``GLOBAL_STEP_EQUIVALENT`` (25) runs of its path, a margin evaluation as ``MARGIN_STEP_EQUIVALENT`` steps)",
    )
    batch: bool = setting(
        True,
        "simulate each movement alone (the reference path)",
        switch="off",
        flag="--no-batch",
        doc="use the batched simulation path where it applies",
    )
    progress: bool = setting(
        True,
        "no progress bar",
        switch="off",
        flag="--no-progress",
        doc="show a progress bar (paths done, rate, time left) on stderr",
    )
    figures: bool = setting(
        True,
        "skip the figures and explorer.html (no traces are kept)",
        switch="off",
        flag="--no-figures",
        doc="draw the figures (needs matplotlib) and write explorer.html (needs plotly); False writes neither "
        "and keeps no traces",
    )
    keep_traces: int = setting(
        DEFAULT_KEEP_TRACES,
        f"explorer.html keeps the runs of N paths (default {DEFAULT_KEEP_TRACES}): every resolver's torque, the "
        "arm at the instability; paths where a resolver whips first, then the others, kept from the sweep's "
        "runs; 0: the map only",
        check=whole_at_least(0),
        parse=whole(),
        metavar="N",
    )


@dataclass(frozen=True)
class FrontierSettings(Settings):
    """The global optimum of every movement, and the stability margin of every run (both off by default)."""

    TITLE = "the global optimum and the stability margin"

    global_optimum: bool = setting(
        False,
        "also run torqueopt.optimize on every movement: rows with resolver global-optimum (judged from the "
        "open-loop replay of its torques) and the columns cost_vs_global, peak_vs_global on every row",
        switch="on",
        flag="--global",
    )
    global_bounded: bool = setting(
        False,
        "with --global: solve under the torque bounds and the URDF's joint limits (shooting transcription); a path "
        "on which no motion within them exists gets the verdict 'infeasible for every resolver'",
        switch="on",
        flag="--global-bounded",
    )
    global_max_iterations: int = setting(
        DEFAULT_GLOBAL_MAX_ITERATIONS,
        f"IPOPT iterations per Hessian tried, per path (default {DEFAULT_GLOBAL_MAX_ITERATIONS})",
        check=whole_at_least(1, 100_000),
        parse=whole(1),
        metavar="N",
    )
    global_max_time: float = setting(
        DEFAULT_GLOBAL_MAX_TIME,
        f"wall time of one path's solve [s] (default {DEFAULT_GLOBAL_MAX_TIME:g})",
        unit="s",
        check=positive_in("s"),
        parse=positive,
        metavar="S",
    )
    margin: bool = setting(
        False,
        "record peak_stability_margin and margin_warning_time per row (the margin on a subsample of each run)",
        switch="on",
    )
    margin_every: float = setting(
        DEFAULT_MARGIN_EVERY,
        f"time between the states whose margin is evaluated [s] (default {DEFAULT_MARGIN_EVERY:g})",
        unit="s",
        check=positive_in("s"),
        parse=positive,
        metavar="S",
    )


def _plant_name(value, name) -> str:
    from ..plants import plant_names

    if value not in plant_names():
        raise InvalidInput(f"--plant: '{value}' is not a plant; choose one of {', '.join(plant_names())}")
    return str(value)


def _plant_options(value, name) -> tuple[tuple[str, str], ...]:
    """The plant's options as sorted (key, text) pairs (a mapping or pairs given to the API; the command line's
    KEY=VALUE texts are read by :func:`_parse_plant_options`); the plant checks them when it is built."""
    pairs = value.items() if isinstance(value, dict) else value
    options = {}
    for key, text in pairs:
        key = str(key).strip().replace("_", "-")
        if not key or str(text).strip() == "":
            raise InvalidInput(f"--plant-option '{key}={text}' must be KEY=VALUE, e.g. --plant-option perturb=0.1")
        if key in options:
            raise InvalidInput(f"--plant-option {key} is given twice; give it once")
        options[key] = str(text).strip()
    return tuple(sorted(options.items()))


def _parse_plant_options(texts, name) -> tuple[tuple[str, str], ...]:
    from ..plants import plant_option_texts

    return _plant_options(plant_option_texts(texts), name)


@dataclass(frozen=True)
class PlantSettings(Settings):
    """What the resolvers' torques act on (:mod:`torqueopt.plants`): the robot's own model, or MuJoCo's model of
    the arm, perturbed if asked (a model-error atlas)."""

    TITLE = "plant (what the torque acts on)"

    plant: str = setting(
        "pinocchio",
        "pinocchio (the robot's own model, the paper's) or mujoco (MuJoCo's model of the arm; needs pip install "
        "'torqueopt[mujoco]'); default pinocchio",
        check=_plant_name,
        metavar="NAME",
    )
    plant_options: tuple[tuple[str, str], ...] = setting(
        (),
        "a plant option KEY=VALUE, repeatable or comma-separated, as torqueopt run takes them (e.g. perturb=0.1, "
        "seed=3, integrator=euler: torqueopt run --help)",
        check=_plant_options,
        parse=_parse_plant_options,
        flag="--plant-option",
        repeat=True,
        metavar="KEY=VALUE",
        doc="the plant's options by name ({'perturb': '0.1'}), as :func:`torqueopt.plants.make_plant` takes them",
    )

    def is_default(self) -> bool:
        return self.plant == "pinocchio" and not self.plant_options


def _robot(value, name) -> RobotSpec:
    return value if isinstance(value, RobotSpec) else RobotSpec(str(value))


def _resolvers(value, name) -> tuple[Resolver, ...]:
    return tuple(resolvers_from(value))


def _resolvers_help() -> str:
    return (
        f"comma-separated resolvers, of {', '.join(resolver_names())} (default the paper's four; pinv is always "
        "run); a resolver with options as NAME[OPTION=VALUE,...], quoted for the shell, e.g. "
        "'pinv,bounded-torque,bounded-torque[joint_limits=off]': each setting is its own resolver, labelled so "
        "in every table (options: torqueopt resolvers)"
    )


@dataclass(frozen=True)
class AtlasSettings(Settings):
    """Every setting of an atlas (see the module docstring); the fields are checked when the settings are made.

    ``robot`` is a :class:`~torqueopt.atlas.jobs.RobotSpec` (a name or URDF is made one); ``resolvers`` the
    Resolver objects, ``pinv`` (its defaults) first.
    """

    robot: RobotSpec = setting(
        "planar3",
        "robot name or URDF (default planar3)",
        check=_robot,
        cli=False,
        doc="a robot name or URDF (as :func:`torqueopt.load_robot`), or a "
        ":class:`~torqueopt.atlas.jobs.RobotSpec` with frame, task, limits",
    )
    paths: int = setting(
        100, "movements per duration (random mode; required there on the command line)", parse=whole(1), metavar="N"
    )
    durations: tuple[float, ...] = setting(
        (0.5, 1.0, 1.5, 2.0),
        "movement durations [s] (default 0.5,1,1.5,2)",
        unit="s",
        parse=numbers(),
        metavar="T,...",
    )
    resolvers: tuple[Resolver, ...] = setting(
        PAPER_RESOLVERS,
        _resolvers_help,
        check=_resolvers,
        parse=lambda text, name: split_resolver_list(text),
        metavar="NAMES",
        doc="names, labels with options (``bounded-torque[joint_limits=off]``) or Resolver objects; each setting "
        "of a resolver is its own resolver under its label; ``pinv`` (its defaults) is always run, first, as the "
        "baseline of the runaway criterion",
    )
    out: str | os.PathLike = setting(
        "atlas",
        "output folder (created if missing; resumed if it holds this atlas)",
        metavar="DIR",
        cli_required=True,
    )
    seed: int = setting(0, "seed of the population (default 0)", parse=whole())
    population: PopulationSettings = group(PopulationSettings)
    verdicts: Thresholds = group(Thresholds)
    execution: ExecutionSettings = group(ExecutionSettings)
    frontier: FrontierSettings = group(FrontierSettings)
    simulation: PlantSettings = group(PlantSettings)

    def check_together(self) -> None:
        self.population_spec()
        dt, frontier = self.population.dt, self.frontier
        if frontier.margin and frontier.margin_every < dt:
            raise InvalidInput(
                f"margin_every={frontier.margin_every:g} s is shorter than the step dt={dt:g} s; give at least dt"
            )
        for duration in self.population_spec().durations:
            step_count(duration, dt)  # a dt that does not divide a duration would simulate another movement

    def population_spec(self) -> PopulationSpec:
        """The population these settings draw (its acceleration None when it is sized to the arm)."""
        population = self.population
        return PopulationSpec(
            mode=population.mode,
            paths=self.paths,
            durations=tuple(np.atleast_1d(np.asarray(self.durations, dtype=float)).tolist()),
            seed=self.seed,
            accel=population.accel,
            path=population.path,
            length_range=tuple(population.length_range),
            reach_fraction=population.reach_fraction,
            min_condition=population.min_condition,
            grid_spacing=population.grid_spacing,
            grid_directions=population.grid_directions,
        )


def atlas_config(settings: AtlasSettings, robot: Robot, reach: float, movements: int) -> dict:
    """The settings as ``atlas-config.json`` records them (and as it reads back): the atlas's fingerprint.

    Args:
        settings: the atlas's settings.
        robot: the robot they load.
        reach: the arm's reach [m], which sizes the acceleration when none is given.
        movements: how many movements the population drew.
    """
    population = settings.population_spec()
    frontier = settings.frontier
    config = {
        "format": CONFIG_FORMAT,
        "robot": settings.robot.as_dict(),
        "robot_name": robot.name,
        "task": robot.task,
        "joint_names": list(robot.joint_names),
        "torque_limit": [x if math.isfinite(x) else None for x in robot.torque_upper.tolist()],
        "population": population.sized(reach).as_dict(),
        "reach": float(reach),
        "accel_from_reach": population.accel is None,
        "resolvers": [_resolver_description(r) for r in settings.resolvers],
        "thresholds": settings.verdicts.as_dict(),
        "dt": float(settings.population.dt),
        "chunk_size": int(settings.execution.chunk_size),
        "batch": bool(settings.execution.batch),
        "movements": int(movements),
    }
    # Only on an arm with a slider, so that the atlases of revolute arms keep their fingerprint (and resume).
    if "prismatic" in robot.joint_kinds:
        config["joint_kinds"] = list(robot.joint_kinds)
    # Only when asked, so that an atlas without them keeps its fingerprint (and resumes).
    if frontier.global_optimum:
        config["global"] = global_settings(
            frontier.global_max_iterations, frontier.global_max_time, frontier.global_bounded
        )
    if frontier.margin:
        config["margin"] = {"every": float(frontier.margin_every)}
    if not settings.simulation.is_default():  # only then, so that the Pinocchio plant's atlases keep their digest
        config["plant"] = {"name": settings.simulation.plant, "options": dict(settings.simulation.plant_options)}
    return json.loads(json.dumps(config, default=_json_default))


def _json_default(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    raise TypeError(type(value).__name__)


def _resolver_description(resolver: Resolver) -> dict:
    # The declared options as JSON values (a resolver's other attributes may be objects: task stacks, criteria).
    return {
        "name": resolver.name,
        "label": resolver.label,
        "class": type(resolver).__name__,
        "options": resolver.settings_for_file(),
    }
