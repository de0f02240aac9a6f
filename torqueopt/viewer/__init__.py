r"""Meshcat playback of a run: live in a browser, or as one self-contained HTML file.

One job per module:

==================  ==============================================================
``frames``          :func:`sample_frames`: which rows are shown when, and the over-limit flags
``visual_model``    :func:`visual_model`: the URDF visuals, reduced as the dynamic model is
``scene``           :class:`Playback`: the meshcat scene of a run, its animation
``shapes``          tubes along paths and the transforms meshcat takes
``page``            :func:`export_html`: the self-contained HTML page and its JS
``live``            :class:`LiveViewer`: the localhost server in a subprocess
``server``          the server itself, ``python -m torqueopt.viewer.server``
``screenshot``      :func:`screenshot_html`: headless Chromium screenshots
``dependency``      :func:`require_meshcat`
==================  ==============================================================

Live playback binds every socket to 127.0.0.1 (meshcat 0.3's own server binds every interface); the static
export needs no server. meshcat is imported, and a browser for screenshots looked for, only when needed; their
absence raises :class:`~torqueopt.errors.MissingDependency` naming what to install (docs/playback.md).
"""

from .dependency import require_meshcat
from .frames import DEFAULT_FPS, PlaybackFrames, over_limit, sample_frames
from .live import LOCALHOST, LiveViewer
from .page import export_html
from .scene import HIGHLIGHT_COLOR, Playback, check_run_matches
from .screenshot import find_browser, screenshot_html
from .visual_model import visual_model

__all__ = [
    "DEFAULT_FPS",
    "HIGHLIGHT_COLOR",
    "LOCALHOST",
    "LiveViewer",
    "Playback",
    "PlaybackFrames",
    "check_run_matches",
    "export_html",
    "find_browser",
    "over_limit",
    "require_meshcat",
    "sample_frames",
    "screenshot_html",
    "visual_model",
]
