r"""Local against global: the paper's last question, answered with numbers.

"The broader question is whether any local algorithm can ever be completely
successful, or whether ultimately only a global resolution of redundancy can
be guaranteed problem-free." (Discussion.) This study runs, on the paper's
arm and its short, medium and long movements,

* the local resolvers :data:`LOCAL` (``pinv``, ``null-space``,
  ``weighted-null-space`` with the paper's W = diag(1/limit²)) and every
  registered remedy of :data:`REMEDIES` (those not registered are skipped and
  listed), open loop as in the paper;
* the whole-movement optimum of :func:`torqueopt.optimize` in four variants
  (:data:`GLOBAL_VARIANTS`): unweighted or weighted by torque range
  (S = diag(2/(τ⁺ − τ⁻)), whose :math:`S^\top S` is the paper's W), each
  without and with the hard bounds :math:`\tau^- \le \tau \le \tau^+`.

The global problems start at rest at q0 and keep the tip on the path, as the
local methods do, and leave the final joint velocity free (a local run ends
with whatever self-motion it has), so every feasible local run is a candidate
of the global problem and the comparison is fair.

Every run is judged the same way, on the 1 ms simulation grid: the
unweighted cost :math:`\int\|\tau\|^2 dt` [N²·m²·s], the weighted cost
:math:`\int\sum_i(\tau_i/\tau_i^{+})^2 dt` [s] (both over the applied, held
torques; τ_mid = 0 for these symmetric limits), the peak
:math:`|\tau_i|/\tau_i^+`, and the whiplash detector's verdict
(:func:`torqueopt.whiplash.detect_whiplash`, the paper's thresholds). A
global solution is also replayed open loop through the same RK4 and its
largest tip deviation reported.

The study's modules, one job each:

* :mod:`~torqueopt.studies.local_global.study`: what it compares and its record (:class:`Row`, :class:`LocalGlobalStudy`);
* :mod:`~torqueopt.studies.local_global.runner`: running it (:func:`run_local_global`);
* :mod:`~torqueopt.studies.local_global.report`: its files, ``global.json`` and ``global.md`` (:func:`write_local_global`);
* :mod:`~torqueopt.studies.local_global.figures`: its figures.
"""

from .figures import plot_long_torques
from .report import local_global_files, write_local_global
from .runner import run_local_global
from .study import GLOBAL_VARIANTS, LOCAL, REMEDIES, STUDY_GRID_STEP, LocalGlobalStudy, Row

__all__ = [
    "local_global_files",
    "GLOBAL_VARIANTS",
    "LOCAL",
    "REMEDIES",
    "STUDY_GRID_STEP",
    "LocalGlobalStudy",
    "Row",
    "plot_long_torques",
    "run_local_global",
    "write_local_global",
]
