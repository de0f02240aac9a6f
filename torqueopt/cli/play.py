"""``torqueopt play``: animate a saved run in meshcat, live in a browser or as an offline HTML file.

``torqueopt run`` takes the same playback options (plus ``--play``) through
:func:`add_playback_options`, :func:`playback_options` and :func:`show_playback`.
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
from . import EXIT_OK
from .common import parse_count, parse_positive

__all__ = [
    "PlaybackOptions",
    "add_parser",
    "add_playback_options",
    "playback_options",
    "prepare_playback",
    "show_playback",
]


@dataclass(frozen=True)
class PlaybackOptions:
    """What the user asked to see: live playback, an HTML file, or both.

    Attributes:
        live: play in a meshcat server on 127.0.0.1.
        html: path of the HTML file to write, or None.
        speed: simulated seconds per second of playback.
        fps: display frames per second of playback.
        max_frames: the most display frames a playback may have.
    """

    live: bool
    html: Path | None
    speed: float
    fps: float
    max_frames: int

    @property
    def wanted(self) -> bool:
        return self.live or self.html is not None


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
    add_playback_options(parser, play_flag=False)
    parser.set_defaults(handler=play_command)


def add_playback_options(parser: argparse.ArgumentParser, play_flag: bool = True) -> None:
    """Options --speed, --fps, --html, and --play when ``play_flag`` (for ``torqueopt run``)."""
    from ..viewer import DEFAULT_FPS
    from ..viewer.frames import DEFAULT_MAX_FRAMES

    group = parser.add_argument_group("playback in meshcat")
    if play_flag:
        group.add_argument(
            "--play",
            action="store_true",
            help="animate the run live in meshcat (server on 127.0.0.1; its URL is printed)",
        )
    group.add_argument(
        "--html", metavar="FILE", help="write a self-contained HTML file with the animation, which plays offline"
    )
    group.add_argument(
        "--speed",
        default="1.0",
        metavar="S",
        help="simulated seconds per second of playback: 1 real time, 0.25 four times slower (default 1)",
    )
    group.add_argument(
        "--fps",
        default=f"{DEFAULT_FPS:g}",
        metavar="N",
        help=f"frames per second of playback; fewer frames make smaller HTML files (default {DEFAULT_FPS:g})",
    )
    group.add_argument(
        "--max-frames",
        default=str(DEFAULT_MAX_FRAMES),
        metavar="N",
        help=f"refuse a playback of more than N display frames (duration / speed × fps; default {DEFAULT_MAX_FRAMES})",
    )


def playback_options(args: argparse.Namespace, live: bool) -> PlaybackOptions:
    """Validated playback options; checks meshcat is installed when playback is wanted."""
    options = PlaybackOptions(
        live=live,
        html=None if args.html is None else writable_path(args.html),
        speed=parse_positive(args.speed, "speed"),
        fps=parse_positive(args.fps, "fps"),
        max_frames=parse_count(args.max_frames, "max-frames"),
    )
    if options.wanted:
        from ..viewer import require_meshcat

        require_meshcat()
    return options


def check_frames(options: PlaybackOptions, simulated_time: float) -> None:
    """Refuse, before any work, a playback of ``simulated_time`` [s] with more frames than ``--max-frames``."""
    from ..viewer.frames import frame_count

    if options.wanted:
        frame_count(simulated_time, options.speed, options.fps, options.max_frames, option="--max-frames")


def play_command(args: argparse.Namespace) -> int:
    options = playback_options(args, live=args.html is None)
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


def prepare_playback(options: PlaybackOptions, robot: Robot, result: SimResult):
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


def show_playback(options: PlaybackOptions, robot: Robot, result: SimResult) -> None:
    """Write the HTML file and/or play live, as ``options`` say."""
    playback, lines = prepare_playback(options, robot, result)
    for line in lines:
        print(line())
    if options.live:
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
