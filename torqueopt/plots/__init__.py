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

# The package's names are its modules' names, each listed once in its module's ``__all__``.
from . import canvas, comparison, dexterity, panels, run, stick
from .canvas import *  # noqa: F403
from .comparison import *  # noqa: F403
from .dexterity import *  # noqa: F403
from .panels import *  # noqa: F403
from .run import *  # noqa: F403
from .stick import *  # noqa: F403

__all__ = canvas.__all__ + comparison.__all__ + dexterity.__all__ + panels.__all__ + run.__all__ + stick.__all__
