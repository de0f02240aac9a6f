r"""The paper's experiment as a named scenario: ``paper``.

Hollerbach & Suh (Section 3) simulate a planar arm of three 1 m, 10 kg thin
rods, without gravity, with torque limits of 54, 24 and 6 N·m, tracking
rest-to-rest straight lines; Fig. 7 is the same arm swinging freely under
gravity. This sub-package holds, one job per module:

=================  ===============================================================
``scenario``       :class:`PaperScenario` and :data:`PAPER`: arm, start, line, durations
``runner``         :func:`run_paper`, :func:`run_movement`, :class:`PaperResults`
``free_swing``     Fig. 7: :func:`free_swing` through :func:`torqueopt.simulate`
``alignment``      :func:`alignment_times`: when links 2 and 3 pass through alignment
``claims``         :func:`check_claims`: the paper's six claims on the numbers
``figures``        :func:`write_figures`: Figures 2-7, stick-figure strips, tip paths
``report``         :func:`write_paper`: the figures, ``summary.json`` and ``summary.md``
=================  ===============================================================

:data:`PAPER` is the scenario; :func:`dataclasses.replace` (or
:meth:`PaperScenario.replace`) gives one with another start, direction or
durations. :func:`run_paper` simulates every (movement, resolver) pair and
the free swing, judges each run with :func:`torqueopt.whiplash.detect_whiplash`
and checks the paper's six claims; :func:`write_paper` writes Figures 2-7,
a stick-figure strip per resolver for the long movement, ``summary.json``
and ``summary.md``.
"""

from .alignment import alignment_times
from .claims import Claim, check_claims
from .figures import write_figures
from .free_swing import free_swing, free_swing_gravity
from .report import format_summary_markdown, paper_files, summary_entries, write_paper
from .runner import PAPER_RUNS, PaperResults, run_movement, run_paper
from .scenario import MOVEMENTS, PAPER, PAPER_RESOLVERS, PaperScenario

__all__ = [
    "PAPER_RUNS",
    "paper_files",
    "MOVEMENTS",
    "PAPER_RESOLVERS",
    "PaperScenario",
    "PAPER",
    "PaperResults",
    "Claim",
    "run_paper",
    "run_movement",
    "free_swing",
    "free_swing_gravity",
    "alignment_times",
    "check_claims",
    "format_summary_markdown",
    "summary_entries",
    "write_figures",
    "write_paper",
]
