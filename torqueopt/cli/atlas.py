"""``torqueopt atlas``: the stability atlas, how often and where each resolver goes unstable."""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

from ..errors import InvalidInput
from ..resolvers.options import split_resolver_list
from ..settings import numbers, setting
from . import EXIT_OK
from .common import RobotModelSettings, importable_from_here

__all__ = ["AtlasRobotSettings", "add_parser", "robot_spec"]


def add_parser(subparsers) -> None:
    from ..atlas.settings import AtlasSettings

    parser = subparsers.add_parser(
        "atlas",
        help="stability atlas: a seeded population of movements x resolvers, on a Dask cluster",
        description=(
            "Run every resolver on a seeded population of movements (the paper's straight lines by default; --path min-jerk or circle; random starts and "
            "directions, or a grid over the workspace), judge each run (the 2x-limit rule and a runaway criterion "
            "that separates whiplash from a path that is simply too demanding), and write results.parquet, "
            "atlas.md, atlas.json, figures and explorer.html (a page to explore the runs) into DIR. Runs on a local Dask cluster (one worker per core) or on "
            "--scheduler ADDRESS. Killed and started again with the same command, it resumes where it stopped."
        ),
    )
    AtlasRobotSettings.add_arguments(parser)
    AtlasSettings.add_arguments(parser)
    parser.set_defaults(handler=atlas_command)


@dataclass(frozen=True)
class AtlasRobotSettings(RobotModelSettings):
    """The atlas's arm (its :meth:`~RobotModelSettings.spec` is the atlas's ``robot`` setting)."""

    robot: str | None = setting("planar3", "robot name or URDF (default planar3)")
    task: str | None = setting(None, "task: xy or position (default xy for planar3, position otherwise)")
    torque_limit: tuple[float, ...] | None = setting(
        None, "symmetric torque limits [N·m], one value or one per joint", metavar="TAU", parse=numbers()
    )


def robot_spec(args: argparse.Namespace):
    """The :class:`~torqueopt.atlas.jobs.RobotSpec` of the options :class:`AtlasRobotSettings` adds."""
    return AtlasRobotSettings.from_arguments(args).spec()


def atlas_command(args: argparse.Namespace) -> int:
    from ..atlas import run_atlas
    from ..atlas.settings import AtlasSettings

    started = time.perf_counter()
    if args.paths is None and args.mode != "grid":
        raise InvalidInput("--paths N is required in random mode (the default); grid mode places its own starts")
    for spec in split_resolver_list(args.resolvers or ""):
        importable_from_here(spec)  # before the cluster forks its workers, which then import it too
    settings = AtlasSettings.from_arguments(args, robot=robot_spec(args))
    result = run_atlas(settings)
    summary = result.summary
    width = max([22, *(len(resolver) + 2 for resolver in summary["resolvers"])])
    print(
        f"{'resolver':<{width}}"
        + "".join(f"{f'T={d:g} s':>12}" for d in summary["durations"])
        + "   (unstable by the 2x-limit rule / whiplash verdict)"
    )
    fraction = {
        (criterion, item["resolver"], item["duration"]): f"{item['fraction']:.0%}"
        for criterion in ("unstable", "whiplash")
        for item in summary["unstable_fraction"][criterion]
    }
    for resolver in summary["resolvers"]:
        cells = [
            f"{fraction['unstable', resolver, d]}/{fraction['whiplash', resolver, d]}" for d in summary["durations"]
        ]
        print(f"{resolver:<{width}}" + "".join(f"{cell:>12}" for cell in cells))
    for claim in summary["claims"]["whiplash"]:
        # These are the whiplash verdict's figures (the 2x-limit rule's are in atlas.md): the line says so.
        figure = claim["figure"].replace(" unstable", " whips")
        print(f'claim ({claim["holds"]}, by the whiplash verdict): "{claim["paper"]}": {figure}: {claim["text"]}')
    resumed = summary.get("resumed_chunks", 0)
    note = f", {resumed} chunks resumed from an earlier run" if resumed else ""
    written = (
        "results.parquet, atlas.md, atlas.json, figures and explorer.html"
        if settings.execution.figures
        else ("results.parquet, atlas.md and atlas.json")
    )
    print(f"wrote {result.out}/{written} in {time.perf_counter() - started:.1f} s{note}")
    return EXIT_OK
