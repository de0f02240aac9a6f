"""Figures of simulated runs: torques against limits, joint motion, tip path, stick figures.

Every function draws one figure with matplotlib's object API on the Agg
canvas (no pyplot, no global backend switch, no window) and writes it as a
file in the format its suffix names (PNG at :data:`DEFAULT_DPI`, or vector
PDF and SVG) through :func:`torqueopt.io.atomic_write`, so a figure file is
either complete or absent. A run that stopped early is drawn up to where it stopped,
with a dashed line there and a note saying why.

matplotlib is imported inside the functions; without it they raise
:class:`torqueopt.errors.MissingDependency`.

One module per family of figure, every public name re-exported here:

* :mod:`~torqueopt.plots.canvas`: making a figure and writing its file, formats, the symlog torque scale;
* :mod:`~torqueopt.plots.panels`: what several figures draw on their axes (colours, limits, stops, the tip path);
* :mod:`~torqueopt.plots.comparison`: runs compared over time (torques, joint motion, tip paths);
* :mod:`~torqueopt.plots.stick`: stick figures of the arm;
* :mod:`~torqueopt.plots.dexterity`: the dexterity panel and ellipses;
* :mod:`~torqueopt.plots.run`: the overview figure of one run.

The paper's figures are drawn in :mod:`torqueopt.paper.figures`, each
study's in its own package (:mod:`torqueopt.studies`).
"""

from .canvas import DEFAULT_DPI, FIGURE_FORMATS, MAX_DPI, check_title, figure_format, parse_dpi
from .comparison import plot_motion, plot_tip_path, plot_torques
from .dexterity import dexterity_ellipses, draw_dexterity
from .panels import RESOLVER_COLORS
from .run import plot_run
from .stick import arm_points, plot_stick_strip

__all__ = [
    "DEFAULT_DPI",
    "MAX_DPI",
    "check_title",
    "parse_dpi",
    "FIGURE_FORMATS",
    "RESOLVER_COLORS",
    "figure_format",
    "plot_torques",
    "plot_motion",
    "plot_tip_path",
    "plot_stick_strip",
    "plot_run",
    "arm_points",
    "draw_dexterity",
    "dexterity_ellipses",
]
