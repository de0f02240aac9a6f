"""Tuning a remedy per arm: the setting that saves the most torque without whipping or leaving a limit.

:func:`tune` runs a seeded atlas (:func:`torqueopt.atlas.run_atlas`) of ``pinv`` on one arm, then every setting
of a grid of a resolver's options on the paths ``pinv`` handles (:func:`torqueopt.atlas.pinv_paths.handled_paths`),
longest first, in chunks, dropping a setting as soon as the paths run so far decide that it fails; and chooses
the setting with the largest median torque saving against ``pinv`` among those that whip with a Wilson 95 %
upper bound of at most ``whiplash_bound``, stay within the torque, position and velocity limits on every one of
those paths, and save torque at all (:func:`evidence`, :func:`choose`). Dropping early is exact: what decides a
failure cannot be undone by the paths still to come (``eliminate=False`` runs every setting on every path, and a
test compares). The guide, docs/guide/tune.md, says why each rule is what it is.

Files in ``out``: ``tune-config.json`` (the settings; what lets a killed tune resume), ``pinv/`` (the baseline's
atlas), ``settings/chunks/`` (each chunk of the settings' rows, with a fingerprint of the tune and of the settings
it ran), and at the end, together, ``tune.json`` (criteria, every setting's evidence, the choice) and ``tune.md``
(the same as tables). Nothing is written before every check has passed, and only into a folder that is new, empty
or this tune's.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .atlas.jobs import RobotSpec
from .atlas.pinv_paths import BASELINE, counts_on, handled_paths
from .atlas.settings import path_kind
from .atlas.stats import wilson_interval
from .checks import number_in_range
from .errors import InvalidInput, OutputError
from .io import atomic_write, json_text, resumable_folder, writable_path, writable_paths, written_together
from .resolvers import Resolver, get_resolver
from .resolvers.options import label_value
from .settings import Settings, number, numbers, positive, setting, time_step, whole, whole_at_least

__all__ = [
    "DEFAULT_GRIDS",
    "TuneSettings",
    "DEFAULT_PATHS",
    "DEFAULT_CHUNK_SIZE",
    "MAX_SETTINGS",
    "WHIPLASH_BOUND",
    "TuneResult",
    "evidence",
    "choose",
    "option_flags",
    "tune",
    "tuned_options",
]

#: The grid of each remedy's options tuned by default, μ (relative to ‖S H Z‖_F) and K_D in 1/s for
#: damped-null-space, spanning the planar arm's defaults (0.5 and 10) by factors of 2 to 16 either way; E_max in J
#: and the joint acceleration limit (rad/s², or 'torque', none but the torque limits') for energy-bounded-torque,
#: from panda's measured setting (0.01 J, 10 rad/s², docs/atlas/tune-energy-panda.md) to 3 times planar3's
#: default E_max (α is left at 20 1/s: on planar3, 5 to 100 1/s moved the median peak torque by 0.002).
DEFAULT_GRIDS = {
    "damped-null-space": {"kinematic_weight": (0.25, 0.5, 1.0, 2.0, 4.0, 8.0), "damping": (5.0, 10.0, 20.0, 40.0)},
    "energy-bounded-torque": {
        "energy_limit": (0.01, 0.03, 0.1, 0.3, 1.0, 3.0),
        "joint_acceleration_limit": ("torque", 10.0),
    },
}
#: The most settings a grid may have.
MAX_SETTINGS = 64
#: A qualifying setting's whiplash rate on the paths pinv handles has a Wilson 95 % upper bound at most this.
WHIPLASH_BOUND = 0.01
DEFAULT_PATHS = 200
DEFAULT_CHUNK_SIZE = 64
#: Largest tune (trajectory-steps: pinv, then every setting surviving on every path) started without being told.
DEFAULT_MAX_STEPS = 1_000_000_000
_FORMAT = 1
_CONFIG = "tune-config.json"
_RESULT_FILES = ("tune.json", "tune.md")


def _option_pairs(texts: list[str], flag: str, example: str) -> dict[str, str]:
    """``{NAME: VALUE}`` of repeated ``flag NAME=VALUE`` options."""
    pairs = {}
    for text in texts:
        name, separator, value = text.partition("=")
        name = name.strip()
        if not separator or not name or not value.strip():
            raise InvalidInput(f"{flag} '{text}' must be NAME=VALUE, e.g. {flag} {example}")
        if name in pairs:
            raise InvalidInput(f"{flag} {name} is given twice; give it once")
        pairs[name] = value.strip()
    return pairs


def _grid_values(texts: list[str], name: str) -> dict | None:
    values = _option_pairs(texts, "--values", "damping=5,10,20")
    grid = {option: [v.strip() for v in text.split(",")] for option, text in values.items()} or None
    if grid and any(not v for vs in grid.values() for v in vs):
        raise InvalidInput("--values: an empty value between commas; give NAME=V1,V2,...")
    return grid


def _robot(value, name) -> RobotSpec:
    return value if isinstance(value, RobotSpec) else RobotSpec(str(value))


def default_grids_text() -> str:
    """The default grids as `torqueopt tune --help` lists them."""
    return "; ".join(
        f"{name}: "
        + " x ".join(f"{option} {','.join(label_value(v) for v in values)}" for option, values in grid.items())
        for name, grid in DEFAULT_GRIDS.items()
    )


@dataclass(frozen=True)
class TuneSettings(Settings):
    """Every setting of a tune (see the module docstring); the fields are checked when the settings are made."""

    robot: object = setting(
        "panda",
        "robot name or URDF (panda, xarm7, tiago, baxter, ...)",
        check=_robot,
        cli=False,
        doc="a robot name or URDF, or a :class:`torqueopt.atlas.jobs.RobotSpec`",
    )
    resolver: str = setting("damped-null-space", "resolver to tune (default damped-null-space)")
    grid: dict | None = setting(
        None,
        f"an option of the grid and its values, repeatable (replaces the default grid; at most {MAX_SETTINGS} "
        "settings in all)",
        flag="--values",
        metavar="NAME=V1,V2,...",
        parse=_grid_values,
        repeat=True,
        doc="``{option: values}``, the settings are every combination (at most ``MAX_SETTINGS``, 64); default "
        ":data:`DEFAULT_GRIDS` of the resolver",
    )
    options: dict | None = setting(
        None,
        "an option held fixed in every setting, repeatable (e.g. --option torque_weight=range)",
        flag="--option",
        metavar="NAME=VALUE",
        parse=lambda texts, name: _option_pairs(texts, "--option", "torque_weight=range"),
        repeat=True,
        doc='options held fixed in every setting (e.g. ``torque_weight="range"``)',
    )
    paths: int = setting(
        DEFAULT_PATHS,
        f"movements per duration (default {DEFAULT_PATHS})",
        check=whole_at_least(1),
        parse=whole(1),
        metavar="N",
    )
    chunk_size: int = setting(
        DEFAULT_CHUNK_SIZE,
        f"paths per chunk of the settings' runs; settings certain to fail are dropped between chunks "
        f"(default {DEFAULT_CHUNK_SIZE})",
        check=whole_at_least(1),
        parse=whole(1),
        metavar="N",
    )
    durations: tuple[float, ...] = setting(
        (0.5, 1.0, 1.5, 2.0), "movement durations [s] (default 0.5,1,1.5,2)", unit="s", parse=numbers(), metavar="T,..."
    )
    seed: int = setting(0, "seed of the population (default 0)", parse=whole())
    out: str | os.PathLike = setting(
        "tune",
        "output folder (default tune-ROBOT; resumed if it holds this tune)",
        metavar="DIR",
        doc="the folder (new, empty, or this tune's to resume it)",
    )
    whiplash_bound: float = setting(
        WHIPLASH_BOUND,
        "largest Wilson 95 %% upper bound of a qualifying whiplash rate (default 0.01)",
        check=lambda value, name: number_in_range(value, name, 0.0, 1.0, low_open=True),
        parse=number,
        metavar="P",
        doc="the largest Wilson 95 % upper bound of a qualifying setting's whiplash rate",
    )
    path: str = setting("line", "line, min-jerk or circle (default line)", metavar="KIND", parse=path_kind)
    accel: float | None = setting(
        None, "acceleration [m/s²] (default: sized to the arm, √2 x reach / 3 m)", unit="m/s²", metavar="A",
        parse=positive,
    )  # fmt: skip
    dt: float = time_step()
    workers: int | None = setting(
        None, "local Dask worker processes (default: the machine's cores; 0: no Dask)", parse=whole(), metavar="N"
    )
    max_steps: int = setting(
        DEFAULT_MAX_STEPS,
        "refuse tunes of more trajectory-steps, pinv and every setting on every path (default 1e9)",
        parse=whole(1),
        metavar="N",
    )
    progress: bool = setting(True, "no progress bars", switch="off",
                             flag="--no-progress", doc="progress bars on stderr")  # fmt: skip
    eliminate: bool = setting(
        True,
        "drop a setting as soon as a chunk shows it certain to fail (False: every setting on every path; the same "
        "choice)",
        check=lambda value, name: bool(value),
        cli=False,
    )

    def check_together(self) -> None:
        count = len(settings_grid(self.resolver, self.grid, self.options)[1])
        durations = self.population_spec().durations
        needed, paths = least_trials(self.whiplash_bound), self.paths
        if paths * len(durations) < needed:  # even if pinv handled every movement, no setting could qualify
            plural = "s" if len(durations) > 1 else ""
            raise InvalidInput(
                f"whiplash_bound={self.whiplash_bound:g} needs at least {needed} movements that pinv handles, and "
                f"paths={paths} over {len(durations)} duration{plural} gives {paths * len(durations)} at most: give "
                f"paths={math.ceil(needed / len(durations))} or more, or a larger whiplash_bound"
            )
        total = self.paths * sum(round(d / self.dt) + 1 for d in durations) * (count + 2)
        if total > self.max_steps:
            raise InvalidInput(
                f"the tune would simulate up to {total:.3g} trajectory-steps (pinv, then {count} settings with "
                f"pinv beside them, on {self.paths} paths x {len(durations)} durations), more than "
                f"max_steps={self.max_steps:.3g}: fewer settings, paths or durations, or raise max_steps (--max-steps)"
            )

    def population_spec(self):
        """The population of the pinv atlas (its acceleration given apart: run_atlas sizes it to the arm)."""
        from .atlas.population import PopulationSpec

        return PopulationSpec(
            paths=self.paths, durations=tuple(np.atleast_1d(self.durations).tolist()), seed=self.seed, path=self.path
        )


@dataclass
class TuneResult:
    """What :func:`tune` found: every setting's evidence (dicts, as ``tune.json``), the choice, the folder.

    ``chosen`` is the chosen setting's evidence row (its ``options``, ``label`` and ``flags``), None when no
    setting qualifies.
    """

    resolver: str
    settings: list[dict]
    chosen: dict | None
    summary: dict
    out: Path


def tune(settings: TuneSettings | object = None, resolver: str | None = None, **keywords) -> TuneResult:
    """Choose ``resolver``'s options on ``robot`` from a seeded atlas (see the module docstring).

    Call it with a :class:`TuneSettings`, or with the settings themselves: ``robot`` and ``resolver`` by position
    or keyword, every other one by keyword (``tune("panda", "damped-null-space", paths=300)``).

    Args:
        {arguments}

    Raises:
        InvalidInput: bad settings, a resolver without a grid (give one), a grid too large, an ``out`` folder
            that holds anything but this tune.
        OutputError: a file cannot be written.
        TypeError: a keyword that is no setting, or settings given twice.
    """
    from .atlas import run_atlas
    from .progress import speaking_for

    settings = _settings_of(settings, resolver, keywords)
    spec, paths, dt, accel = settings.robot, settings.paths, settings.dt, settings.accel
    workers, progress, whiplash_bound = settings.workers, settings.progress, settings.whiplash_bound
    name, resolvers, fixed = settings_grid(settings.resolver, settings.grid, settings.options)
    grid_options = tuple(settings.grid) if settings.grid is not None else tuple(DEFAULT_GRIDS[name])
    population = settings.population_spec()
    needed = least_trials(whiplash_bound)
    out = writable_path(settings.out, directory=True)
    if out.exists() and not out.is_dir():
        raise OutputError(f"cannot write the tune to '{out}': it is a file; give a folder")
    writable_paths(out / file for file in (_CONFIG, *_RESULT_FILES))
    loaded = spec.load()
    for setting_ in resolvers:
        setting_.check(loaded)
    config = _tune_config(settings, name, resolvers, fixed, grid_options, population)
    resume = resumable_folder(out, _CONFIG, config, "tune")  # True: this tune is there to resume
    if not resume:
        text = json.dumps(config, indent=2, sort_keys=True).encode()
        atomic_write(out / _CONFIG, lambda handle: handle.write(text))

    # 1. pinv on the whole population: the paths it handles.
    with speaking_for("torqueopt tune (the pinv atlas)"):
        baseline = run_atlas(
            spec, paths=paths, resolvers=[BASELINE], out=out / "pinv", durations=population.durations,
            seed=population.seed, accel=accel, path=population.path, dt=dt, workers=workers, progress=progress,
            figures=False,
        )  # fmt: skip
    atlas_config = baseline.summary["config"]
    handled = handled_paths(baseline.table)
    if len(handled) < needed:
        rows_by_label = {setting_.label: _not_run(setting_.label, len(handled), needed) for setting_ in resolvers}
    else:
        # 2. The settings on those paths, longest movements first, chunk by chunk, each setting dropped as
        # soon as it is certain to fail (the module docstring).
        chunks = _longest_first(loaded, population, handled, settings.chunk_size)
        rows_by_label = _run_settings(
            spec, resolvers, chunks, handled, out / "settings", config, dt=dt, workers=workers,
            progress=progress, whiplash_bound=whiplash_bound, eliminate=settings.eliminate,
        )  # fmt: skip
    rows = [_with_options(rows_by_label[setting_.label], setting_, name, grid_options, fixed) for setting_ in resolvers]
    chosen = choose(rows)
    summary = {
        "format": _FORMAT,
        "config": config,
        "robot_name": loaded.name,
        "criteria": _criteria(whiplash_bound),
        "atlas_config": atlas_config,
        "pinv_handles": len(handled),
        "movements": len(baseline.table),
        "least_paths_for_the_bound": needed,
        "settings": rows,
        "chosen": chosen,
    }
    markdown, text = write_markdown(summary).encode(), json_text(summary).encode()
    with written_together():
        atomic_write(out / "tune.json", lambda handle: handle.write(text))
        atomic_write(out / "tune.md", lambda handle: handle.write(markdown))
    return TuneResult(resolver=name, settings=rows, chosen=chosen, summary=summary, out=out)


def _with_options(row: dict, setting: Resolver, name: str, grid_options, fixed: dict) -> dict:
    """A setting's evidence row with its options spelled out and the flags that reproduce it."""
    row["options"] = {key: _json_value(value) for key, value in options_of(setting, grid_options, fixed).items()}
    row["flags"] = option_flags(name, row["options"])
    return row


def _settings_of(settings, resolver, keywords: dict) -> TuneSettings:
    """The TuneSettings of tune's arguments: given whole, or made from the settings themselves."""
    if isinstance(settings, TuneSettings):
        if resolver is not None or keywords:
            raise TypeError("tune() takes TuneSettings alone, or the settings themselves, not both")
        return settings
    positional = {"robot": settings, "resolver": resolver}
    positional = {key: value for key, value in positional.items() if value is not None}
    twice = sorted(set(positional) & set(keywords))
    if twice:
        raise TypeError(f"tune() got {', '.join(twice)} by position and by keyword")
    return TuneSettings.from_keywords(**positional, **keywords)


def _criteria(whiplash_bound: float) -> dict:
    """The bars a setting must pass on the paths pinv handles, as tune.json records them (docs/guide/tune.md)."""
    return {"whip_high_at_most": whiplash_bound, "peak_torque_ratio_at_most": 1.0, "median_torque_vs_pinv_below": 1.0}


def _tune_config(settings: TuneSettings, name: str, resolvers, fixed: dict, grid_options, population) -> dict:
    """The settings as tune-config.json records them: the tune's fingerprint."""
    return {
        "format": _FORMAT,
        "robot": settings.robot.as_dict(),
        "resolver": name,
        "fixed_options": {key: _json_value(value) for key, value in fixed.items()},
        "grid": [
            {key: _json_value(value) for key, value in options_of(s, grid_options, fixed).items()} for s in resolvers
        ],
        "paths": settings.paths,
        "durations": list(population.durations),
        "seed": population.seed,
        "accel": settings.accel,
        "path": population.path,
        "dt": float(settings.dt),
        "whiplash_bound": settings.whiplash_bound,
        "eliminate": settings.eliminate,
    }


def least_trials(bound: float) -> int:
    """The fewest paths on which no whip at all has a Wilson 95 % upper bound of at most ``bound``."""
    z2 = 1.959963984540054**2
    count = max(1, math.floor(z2 * (1.0 - bound) / bound) - 1)  # z²/(n + z²) <= bound, from just below
    while wilson_interval(0, count)[1] > bound:
        count += 1
    return count


def _longest_first(robot, population, handled: list[int], size: int) -> list[list]:
    """The movements of the ``handled`` paths (run_atlas's draw), longest first, in chunks of ``size``."""
    from .atlas.population import draw_population

    by_path = {movement.path: movement for movement in draw_population(robot, population)}
    ordered = sorted(handled, key=lambda path: (-by_path[path].duration, path))
    return [[by_path[path] for path in ordered[i : i + size]] for i in range(0, len(ordered), size)]


def _not_run(label: str, handled: int, needed: int) -> dict:
    return {
        "label": label, "paths": 0, "pinv_handles": 0, "whips": 0, "whip_rate": math.nan, "whip_low": math.nan,
        "whip_high": math.nan, "over_torque": 0, "over_position": 0, "over_velocity": 0, "over_limits": 0,
        "lost_path": 0, "not_below_pinv": 0, "median_torque_vs_pinv": math.nan, "saving": math.nan, "qualifies": False,
        "reason": f"pinv handles {handled} paths; no whip at all needs {needed} for the bound", "stage": "not run",
    }  # fmt: skip


def _run_settings(spec, settings, chunks, handled, folder, config, *, dt, workers, progress, whiplash_bound, eliminate):
    """Every setting on the chunks of paths pinv handles, in order, dropping the certain failures between waves.

    A wave is as many chunks as there are workers. Each chunk's rows are written (``folder/chunks``,
    with a fingerprint of the tune, the chunk and the settings it ran), so a killed tune resumes.
    """
    import pandas

    from .atlas.jobs import ResolverChunk
    from .atlas.sweep import chunk_path, config_digest, executor, read_chunk, remove_partial_chunks, run_chunks
    from .atlas.verdicts import Thresholds
    from .progress import speaking_for

    alive = list(settings)
    frames, dropped = [], {}
    wave_size = (os.cpu_count() or 1) if workers is None else max(workers, 1)
    tune_digest = config_digest(config)
    done_paths = 0
    with speaking_for("torqueopt tune"), executor(None, workers, progress) as client:
        remove_partial_chunks(folder)
        for start in range(0, len(chunks), wave_size):
            if not alive:
                break
            resolvers = [get_resolver(BASELINE), *alive]
            # The chunk size only sets when settings are dropped, not the result: it is in the chunks'
            # fingerprint, not in the tune's, so a tune resumes with another one (its pinv atlas kept).
            digest = config_digest(
                {"tune": tune_digest, "chunk_size": len(chunks[0]), "settings": [r.label for r in resolvers]}
            )
            jobs = {}
            for index in range(start, min(start + wave_size, len(chunks))):
                frame = (
                    read_chunk(chunk_path(folder, index), digest, index)[0]
                    if chunk_path(folder, index).is_file()
                    else None
                )
                if frame is not None:
                    frames.append(frame)
                    continue
                jobs[index] = ResolverChunk(
                    spec, tuple(resolvers), tuple(chunks[index]), float(dt), Thresholds(), True, digest
                )
            if jobs:
                written = run_chunks(
                    jobs, folder, client, progress=progress, total_paths=len(handled), done_paths=done_paths,
                    description=f"torqueopt tune: {len(alive)} settings on the {len(handled)} paths pinv handles",
                )  # fmt: skip
                frames.extend(written[index] for index in sorted(written))
            done_paths += sum(len(chunks[index]) for index in range(start, min(start + wave_size, len(chunks))))
            if not eliminate:
                continue
            table = pandas.concat(frames, ignore_index=True)
            for row in evidence(table, [s.label for s in alive], whiplash_bound, handled=handled):
                failures = _certain_failures(row, len(handled), whiplash_bound)
                if failures:
                    # Only what is decided: the other criteria are not, on the paths run so far.
                    stage = f"dropped after {row['pinv_handles']} paths"
                    dropped[row["label"]] = {**row, "stage": stage, "reason": "; ".join(failures)}
            alive = [s for s in alive if s.label not in dropped]
    rows = dict(dropped)
    if alive:
        table = pandas.concat(frames, ignore_index=True)
        for row in evidence(table, [s.label for s in alive], whiplash_bound, handled=handled):
            rows[row["label"]] = {**row, "stage": f"all {len(handled)} paths"}
    return rows


def settings_grid(resolver: str, grid: dict | None, options: dict | None) -> tuple[str, list[Resolver], dict]:
    """(the resolver's name, one Resolver per setting in grid order, the fixed options as checked values).

    Raises:
        InvalidInput: pinv (the baseline) or an unknown resolver, a resolver without a default grid and none
            given, an option the resolver does not declare, a value it refuses, an option both fixed and in the
            grid, an empty list of values, or more than ``MAX_SETTINGS`` (64) settings.
    """
    made = get_resolver(resolver)
    name = made.spec.split("[", 1)[0]  # its registry name, or a plug-in's module:Class: what get_resolver takes
    if made.name == BASELINE:
        raise InvalidInput("pinv is the baseline every setting is measured against; tune another resolver")
    if grid is None:
        if made.name not in DEFAULT_GRIDS:
            tunable = ", ".join(DEFAULT_GRIDS)
            raise InvalidInput(
                f"resolver '{made.name}' has no default grid (those with one: {tunable}); give the values to try, "
                "e.g. --values damping=5,10,20"
            )
        grid = DEFAULT_GRIDS[made.name]
    options = dict(options or {})
    both = sorted(set(grid) & set(options))
    if both:
        raise InvalidInput(f"option {', '.join(both)} is both held fixed and in the grid; give it once")
    declared = [option.name for option in made.declared_options()]
    for option, values in grid.items():
        if option not in declared:
            get_resolver(name, **{option: None})  # the resolver's own one-line message for an unknown option
        if not len(values):
            raise InvalidInput(f"option {option} of the grid has no values; give at least one")
    count = math.prod(len(values) for values in grid.values())
    if count > MAX_SETTINGS:
        sizes = " x ".join(f"{len(v)} {k}" for k, v in grid.items())
        raise InvalidInput(f"the grid has {count} settings ({sizes}), more than {MAX_SETTINGS}: give fewer values")
    fixed = get_resolver(name, **options).settings
    fixed = {key: fixed[key] for key in options}
    settings = [
        get_resolver(name, **options, **dict(zip(grid, values))) for values in itertools.product(*grid.values())
    ]
    labels = [setting.label for setting in settings]
    if len(set(labels)) != len(labels):
        raise InvalidInput(f"the grid repeats a setting ({', '.join(labels)}); give each value once")
    return name, settings, fixed


def options_of(setting: Resolver, grid_options, fixed: dict) -> dict:
    """The options that make the setting, spelled out: the grid's (defaults included) and the fixed ones."""
    return {key: value for key, value in setting.settings.items() if key in grid_options or key in fixed}


def option_flags(resolver: str, options: dict) -> str:
    """The command-line flags that reproduce a setting: ``--resolver NAME --option NAME=VALUE ...``."""
    return " ".join([f"--resolver {resolver}", *(f"--option {key}={label_value(v)}" for key, v in options.items())])


def evidence(table, labels: list[str], whiplash_bound: float = WHIPLASH_BOUND, handled=None) -> list[dict]:
    """Every setting's figures on the paths pinv handles (see the module docstring), one dict per label.

    ``handled``: those paths (default: from the pinv rows of ``table``, :func:`handled_paths`).

    Keys: ``label``, ``paths`` (movements), ``pinv_handles`` (the count of P), ``whips`` and ``whip_rate``, ``whip_low``,
    ``whip_high`` (on P), ``over_torque``, ``over_position``, ``over_velocity`` and
    ``over_limits`` (paths of P outside a limit), ``lost_path`` (on P), ``not_below_pinv`` (paths where
    ``torque_vs_pinv`` is not below 1), ``median_torque_vs_pinv``, ``saving``,
    ``qualifies`` and ``reason`` (the first criterion it fails, or None).
    """
    handled = handled_paths(table) if handled is None else list(handled)
    rows = []
    for label in labels:
        runs = table[table["resolver"] == label].set_index("path")
        on_handled = runs.loc[runs.index.intersection(handled)]
        count = len(on_handled)
        ratios = on_handled["torque_vs_pinv"].to_numpy(dtype=float)
        median = float(np.median(ratios)) if count and np.isfinite(ratios).all() else math.nan
        row = {
            "label": label,
            "paths": len(runs),
            "pinv_handles": count,
            **counts_on(on_handled),
            "not_below_pinv": int((~(ratios < 1.0)).sum()),
            "median_torque_vs_pinv": median,
            "saving": 1.0 - median,
        }
        row["reason"] = _failed_criterion(row, whiplash_bound)
        row["qualifies"] = row["reason"] is None
        rows.append(row)
    return rows


def _failed_criterion(row: dict, whiplash_bound: float) -> str | None:
    """Every criterion the row fails, in words (None when it fails none)."""
    if not row["pinv_handles"]:
        return "pinv handles no path"
    failed = []
    if not row["whip_high"] <= whiplash_bound:
        failed.append(f"whiplash upper bound {row['whip_high']:.2%} > {whiplash_bound:.0%}")
    if row["over_limits"]:
        failed.append(f"outside a limit on {row['over_limits']} of the paths pinv handles")
    if not row["saving"] > 0:
        failed.append("saves no torque")
    return "; ".join(failed) or None


def _certain_failures(row: dict, handled: int, whiplash_bound: float) -> list[str]:
    """What the paths run so far already decide against a setting, whatever the rest of the paths give."""
    failures = []
    if row["over_limits"]:
        failures.append(f"outside a limit on {row['over_limits']} of the paths pinv handles")
    # More than half of all the paths at or above pinv's torque: the median is too, whatever the rest do.
    if row["not_below_pinv"] > handled / 2:
        failures.append(f"at or above pinv's peak torque on {row['not_below_pinv']} of the {handled} paths")
    if row["whips"] and wilson_interval(row["whips"], handled)[1] > whiplash_bound:
        failures.append(f"{row['whips']} whips: the upper bound stays above {whiplash_bound:.0%} on all {handled}")
    return failures


def choose(rows: list[dict]) -> dict | None:
    """The qualifying row with the largest saving (the first of equals), or None."""
    best = None
    for row in rows:
        if row["qualifies"] and (best is None or row["saving"] > best["saving"]):
            best = row
    return best


def tuned_options(path: str | os.PathLike, robot: str | None = None) -> tuple[str, dict]:
    """(resolver, options) of the setting a ``tune.json`` chose, for ``get_resolver(name, **options)``,
    ``simulate(..., resolver_options=options)`` and ``torqueopt run --options-from``.

    ``robot``: the name of the robot the options are for; a tune made on another robot is refused (its options
    were chosen for that arm's inertia and limits).

    Raises:
        InvalidInput: the file does not exist or is not a tune's, its tune chose no setting, or it was made
            on another robot than ``robot``.
    """
    path = Path(path)
    if not path.exists():
        raise InvalidInput(f"tune file '{path}' does not exist")
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
        resolver, chosen, tuned_on = summary["config"]["resolver"], summary["chosen"], summary["robot_name"]
        options = None if chosen is None else dict(chosen["options"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        raise InvalidInput(f"'{path}' is not a tune.json written by torqueopt tune") from None
    if options is None:
        raise InvalidInput(f"the tune in '{path}' chose no setting (none qualified): it has no options to give")
    if robot is not None and robot != tuned_on:
        raise InvalidInput(
            f"the tune in '{path}' was made on robot '{tuned_on}', not '{robot}': tune on '{robot}' "
            "(torqueopt tune) or give the options with --option"
        )
    return resolver, options


def write_markdown(summary: dict) -> str:
    """tune.md: the settings, the evidence and the choice, as tables (docs/guide/tune.md says what they mean)."""
    config = summary["config"]
    accel = (summary.get("atlas_config") or {}).get("population", {}).get("accel", config["accel"])
    sized = " (sized to the arm)" if config["accel"] is None else ""
    settings = {
        "fixed options": _options_text(config["fixed_options"], "none"),
        "settings": len(config["grid"]),
        "seed": config["seed"],
        "path": f"`{config['path']}`",
        "acceleration [m/s²]": ("-" if accel is None else f"{accel:.4g}") + sized,
        "durations [s]": ", ".join(f"{d:g}" for d in config["durations"]),
        "movements per duration": config["paths"],
        "dt [ms]": f"{config['dt'] * 1e3:g}",
        "whiplash bound": f"{config['whiplash_bound']:.0%}",
        "paths pinv handles": f"{summary['pinv_handles']} of {summary['movements']}",
    }
    lines = [
        f"# Tuning {config['resolver']} on {summary['robot_name']}",
        "",
        "| " + " | ".join(settings) + " |",
        "|" + "---|" * len(settings),
        "| " + " | ".join(str(value) for value in settings.values()) + " |",
        "",
        "| setting | stage | paths run (of those pinv handles) | whiplash [95 % CI] | over torque / position / velocity limits "
        "| lost path | median peak torque vs pinv | saving | qualifies |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in summary["settings"]:
        whiplash = (
            f"{row['whips']} ({_percent(row['whip_rate'])} [{_percent(row['whip_low'])}, {_percent(row['whip_high'])}])"
        )
        limits = f"{row['over_torque']} / {row['over_position']} / {row['over_velocity']}"
        verdict = "**yes**" if row["qualifies"] else f"no: {row['reason']}"
        lines.append(
            f"| {_options_text(row['options'])} | {row['stage']} | {row['pinv_handles']} | {whiplash} | {limits} | "
            f"{row['lost_path']} | {_number(row['median_torque_vs_pinv'])} | {_signed_percent(row['saving'])} | "
            f"{verdict} |"
        )
    chosen = summary["chosen"]
    if chosen is None:
        return "\n".join([*lines, "", "**No setting qualifies**", ""])
    command = f"torqueopt run --robot {config['robot']['source']} {chosen['flags']}"
    return "\n".join([*lines, "", f"**Chosen:** {_options_text(chosen['options'])}", "", "```", command, "```", ""])


def _options_text(options: dict, empty: str = "defaults") -> str:
    return ", ".join(f"{key}={label_value(value)}" for key, value in options.items()) or empty


def _percent(value) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.1%}"


def _signed_percent(value) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:+.1%}"


def _number(value) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.3f}"


def _json_value(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value


tune.__doc__ = tune.__doc__.replace("        {arguments}", TuneSettings.arguments_doc("        "))
