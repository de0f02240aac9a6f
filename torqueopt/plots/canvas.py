"""The figure and its file: a matplotlib figure on the Agg canvas, written in the format its suffix names.

Every figure of torqueopt (runs, the paper, the studies) is made by
:func:`new_figure` and written by :func:`save_figure`, which sets a floor on
tick label size and writes through :func:`torqueopt.io.atomic_write`, so a
figure file is either complete or absent. The torque scale that is linear
within the limits and logarithmic beyond (:func:`symlog_scale`) lives here
too, since figures of every family use it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InvalidInput, MissingDependency
from ..io import atomic_write

__all__ = [
    "DEFAULT_DPI",
    "MAX_DPI",
    "check_title",
    "parse_dpi",
    "FIGURE_FORMATS",
    "SYMLOG_ABOVE",
    "few_ticks",
    "figure_format",
    "new_figure",
    "save_figure",
    "symlog_scale",
]

#: Resolution of raster (PNG) figures [dots per inch]; PDF and SVG are vector output.
DEFAULT_DPI = 170
#: The finest resolution a figure takes: a 10-inch figure at 1200 dpi is 12,000 pixels wide, within
#: what Agg draws (2¹⁶ pixels a side); 1e6 dpi made matplotlib raise.
MAX_DPI = 1200
#: The figure formats, by file suffix: the suffix of the path names the format.
FIGURE_FORMATS = ("png", "pdf", "svg")
#: No tick label is smaller than this [pt], so a figure stays readable when printed at its size.
_MIN_TICK_POINTS = 8.0
# Above this multiple of its limit a torque panel switches to a scale that is
# linear within ±limit and logarithmic beyond, so a runaway of 100 times the
# limit and the limit itself are both readable.
SYMLOG_ABOVE = 1.5


def new_figure(width: float, height: float, constrained: bool = True):
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingDependency("plotting needs matplotlib: pip install matplotlib") from None
    return Figure(figsize=(width, height), layout="constrained" if constrained else None)


def few_ticks():
    from matplotlib.ticker import MaxNLocator

    return lambda: MaxNLocator(nbins=3)


def symlog_scale(ax, linthresh: float, peak: float) -> None:
    """Linear within ±linthresh (the limit), logarithmic beyond, with ticks a reader can tell apart.

    Ticks at 0, ±limit and, beyond it, at 1, 2 and 5 times each decade up to
    the peak; a tick less than a factor 1.95 above the limit (or above the
    tick below it) is left out, so that no two labels overlap (100 over 54).
    """
    from matplotlib.ticker import FixedLocator, NullLocator, StrMethodFormatter

    ax.set_yscale("symlog", linthresh=linthresh, linscale=1.0)
    candidates = [
        step * 10.0**k
        for k in range(int(np.floor(np.log10(linthresh))), int(np.floor(np.log10(peak))) + 2)
        for step in (1.0, 2.0, 5.0)
    ]
    # On a short panel even a factor 1.95 is too close (1 and 2 over a ±1 limit): a tick must also be at least
    # one label height, with a margin, from the one below it on the scale the panel draws.
    scale = ax.yaxis.get_transform()
    low, high = scale.transform(np.array(ax.get_ylim(), float))
    figure_height = ax.get_figure().get_figheight() * ax.get_position().height
    label = 1.6 * _MIN_TICK_POINTS / 72.0  # a label's height and a gap [in]
    gap = abs(high - low) * label / figure_height if figure_height > 0 else 0.0

    def position(value: float) -> float:
        return float(scale.transform(np.array([value]))[0])

    beyond = []
    last = linthresh
    for value in sorted(candidates):
        if value >= 1.95 * last and value <= 1.3 * peak and position(value) - position(last) >= gap:
            beyond.append(value)
            last = value
    ticks = sorted({0.0, linthresh, -linthresh, *beyond, *(-v for v in beyond)})
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(StrMethodFormatter("{x:g}"))
    ax.yaxis.set_minor_locator(NullLocator())


def figure_format(path: str | os.PathLike) -> str:
    """The format a figure path names by its suffix (``png``, ``pdf`` or ``svg``), or InvalidInput."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FIGURE_FORMATS:
        shown = f"'.{suffix}'" if suffix else "no suffix"
        raise InvalidInput(
            f"figure '{path}' has {shown}; give a name ending in {', '.join('.' + f for f in FIGURE_FORMATS)}"
        )
    return suffix


def save_figure(fig, path: str | os.PathLike, dpi: float | None = None) -> Path:
    """Write ``fig`` in the format its suffix names (PNG at ``dpi``, default :data:`DEFAULT_DPI`; PDF, SVG)."""
    path = Path(path)
    fmt = figure_format(path)
    for ax in fig.axes:
        for label in (*ax.get_xticklabels(), *ax.get_yticklabels()):
            if label.get_fontsize() < _MIN_TICK_POINTS:
                label.set_fontsize(_MIN_TICK_POINTS)
    resolution = DEFAULT_DPI if dpi is None else dpi
    atomic_write(path, lambda handle: fig.savefig(handle, format=fmt, dpi=resolution))
    return path


def parse_dpi(text) -> float:
    """The resolution of option ``--dpi``: a number in (0, :data:`MAX_DPI`]."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise InvalidInput(f"--dpi: '{text}' is not a number") from None
    if not (0.0 < value <= MAX_DPI):
        raise InvalidInput(f"--dpi: {text} must be a number in (0, {MAX_DPI}]")
    return value


def check_title(title: str) -> None:
    """Refuse a title whose math (text between pairs of $) matplotlib cannot parse, before any figure is drawn."""
    from matplotlib import cbook
    from matplotlib.mathtext import MathTextParser

    if not cbook.is_math_text(title):
        return
    try:
        MathTextParser("path").parse(title)
    except ValueError:
        raise InvalidInput(
            f"--title '{title}' is not valid mathtext (put math between $...$, or escape a literal $ as \\$)"
        ) from None
