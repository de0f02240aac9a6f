"""``torqueopt play``: animate a saved run in meshcat, live in a browser or as an offline HTML file.

``torqueopt run`` takes the same playback options (plus ``--play``) through
:class:`PlaybackSettings` and :func:`prepare_playback`.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

from ..checks import count_values
from ..io import writable_path, writable_paths
from ..result import SimResult, load_result
from ..result_files import run_files
from ..robot import TASK_DIMENSIONS, Robot
from ..run_robot import robot_of_run
from ..settings import Settings, positive, setting, whole
from ..viewer.frames import DEFAULT_FPS, DEFAULT_MAX_FRAMES
from . import EXIT_OK

__all__ = [
    "PlaybackSettings",
    "ReplaySettings",
    "add_parser",
    "prepare_playback",
    "show_playback",
]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "play",
        help="animate a saved run in meshcat (live, or as an offline HTML file)",
        description=(
            "Animate a run written by 'torqueopt run --out' in meshcat: the arm with its meshes, the reference "
            "path and the tip's trace, and a red sphere at each joint while its torque is over its limit. "
            "Live, the meshcat server listens on 127.0.0.1 only and its URL is printed; with --html, a "
            "self-contained HTML file that plays offline is written instead."
        ),
    )
    parser.add_argument("run", metavar="RUN", help="run file: .csv (with its .csv.json sidecar) or .npz")
    group = parser.add_argument_group("robot (default: the run's)")
    group.add_argument(
        "--robot",
        help="URDF path, 'planar3' or an example-robot-data arm (default: the run's robot, its URDF found "
        "where the run was made)",
    )
    group.add_argument("--frame", help="task frame whose chain the run moved (default: the run's frame)")
    group.add_argument("--task", help=f"task: {', '.join(TASK_DIMENSIONS)} (default: the run's task)")
    group.add_argument(
        "--lock", metavar="JOINTS", help="comma-separated joints to lock (default: the joints the run locked)"
    )
    ReplaySettings.add_arguments(parser)
    parser.set_defaults(handler=play_command)


def _writable(value, name) -> Path | None:
    return None if value is None else writable_path(value)


@dataclass(frozen=True)
class PlaybackSettings(Settings):
    """What the user asked to see: live playback in meshcat (``play``, on 127.0.0.1), an HTML file, or both."""

    TITLE = "playback in meshcat"

    play: bool = setting(
        False, "animate the run live in meshcat (server on 127.0.0.1; its URL is printed)", switch="on"
    )
    html: Path | None = setting(
        None,
        "write a self-contained HTML file with the animation, which plays offline",
        check=_writable,
        metavar="FILE",
    )
    speed: float = setting(
        1.0,
        "simulated seconds per second of playback: 1 real time, 0.25 four times slower (default 1)",
        metavar="S",
        parse=positive,
    )
    fps: float = setting(
        DEFAULT_FPS,
        f"frames per second of playback; fewer frames make smaller HTML files (default {DEFAULT_FPS:g})",
        unit="1/s",
        metavar="N",
        parse=positive,
    )
    max_frames: int = setting(
        DEFAULT_MAX_FRAMES,
        f"refuse a playback of more than N display frames (duration / speed × fps; default {DEFAULT_MAX_FRAMES})",
        metavar="N",
        parse=whole(1),
    )

    def check_together(self) -> None:
        if self.wanted:
            from ..viewer import require_meshcat

            require_meshcat()

    @property
    def wanted(self) -> bool:
        return self.play or self.html is not None


@dataclass(frozen=True)
class ReplaySettings(PlaybackSettings):
    """The playback of ``torqueopt play``: live unless ``--html`` is given."""

    play: bool = setting(False, cli=False)


def check_frames(options: PlaybackSettings, simulated_time: float) -> None:
    """Refuse, before any work, a playback of ``simulated_time`` [s] with more frames than ``--max-frames``."""
    from ..viewer.frames import frame_count

    if options.wanted:
        frame_count(simulated_time, options.speed, options.fps, options.max_frames, option="--max-frames")


def play_command(args: argparse.Namespace) -> int:
    options = ReplaySettings.from_arguments(args, play=args.html is None)
    if options.html is not None:
        writable_paths([options.html], reading=run_files(args.run))  # the page never replaces the run it shows
    result = load_result(args.run)
    if len(result.t):
        check_frames(options, float(result.t[-1] - result.t[0]))
    robot = _robot_for_run(args, result)
    show_playback(options, robot, result)
    return EXIT_OK


def _robot_for_run(args: argparse.Namespace, result: SimResult) -> Robot:
    """The robot the run records (its URDF, frame, task and locked joints); the options override."""
    lock = [name.strip() for name in args.lock.split(",") if name.strip()] if args.lock else None
    return robot_of_run(result, args.robot, frame=args.frame, task=args.task, lock=lock)


def prepare_playback(options: PlaybackSettings, robot: Robot, result: SimResult):
    """Build the playback and write its HTML file when asked; returns the playback and the lines to print.

    Nothing is printed here, so a command can write every file before it
    prints (its files never depend on stdout). Each line is a function to
    call once the files have landed (inside :func:`torqueopt.io.written_together`
    the HTML file is there only at the end of the block).
    """
    from ..viewer import Playback, export_html

    playback = Playback(robot, result, speed=options.speed, fps=options.fps, max_frames=options.max_frames)
    frames = playback.frames
    lines = []
    if options.html is not None:
        path = export_html(playback, options.html)
        lines.append(
            lambda: (
                f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB): {count_values(len(frames), 'frame')} over "
                f"{frames.duration:.2f} s at speed {options.speed:g}"
            )
        )
    return playback, lines


def show_playback(options: PlaybackSettings, robot: Robot, result: SimResult) -> None:
    """Write the HTML file and/or play live, as ``options`` say."""
    playback, lines = prepare_playback(options, robot, result)
    for line in lines:
        print(line())
    if options.play:
        play_live(playback)


def play_live(playback) -> None:
    """Serve the playback on 127.0.0.1 and play it when a browser connects (again on Enter, when interactive)."""
    from ..viewer import LiveViewer

    with LiveViewer() as live:
        playback.draw_scene(live.visualizer)
        print(f"meshcat viewer (listening on 127.0.0.1 only): {live.url}", flush=True)
        print("open it in a browser; playback starts when it connects (Ctrl+C quits)", flush=True)
        live.wait_for_browser()
        interactive = sys.stdin is not None and sys.stdin.isatty()
        while True:
            playback.play(live.visualizer)
            print(
                f"played {playback.frames.duration:.2f} s ({len(playback.frames)} frames) at speed {playback.speed:g}"
            )
            if not interactive:
                return
            try:
                input("Enter plays it again, Ctrl+C quits: ")
            except EOFError:
                return
