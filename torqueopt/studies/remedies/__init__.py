r"""The Discussion's remedies for the whiplash, run on the paper's scenario and judged by numbers.

The paper ends with two questions a local method could answer: can the
criterion be weighted "with a kinematic term to avoid high velocity
buildup", and would "linear programming rather than least squares be more
satisfactory" for staying within torque bounds? This study runs every
registered remedy (:data:`REMEDIES`; those not registered in this build are
skipped and said so) on the short, medium and long movements beside ``pinv``
and ``null-space``, sweeps the blend ``damped-null-space`` over its kinematic
weight μ and damping :math:`K_D`, and writes the numbers (key ``remedies`` of
``summary.json``) and their tables; docs/discussion/remedies.md says what
they answer.

Measures (all on the paper's arm, open loop, as the paper):

* the **torque cost** :math:`C = \int \|\tau - \tau_{mid}\|^2 dt` [N²·m²·s]
  over the applied (held) torques; the short movement's **cut kept** is
  :math:`(C_{pinv} - C)/(C_{pinv} - C_{null\text{-}space})`, the share of
  null-space's reduction against pinv that a remedy keeps;
* **stability**: the whiplash detector's verdict
  (:func:`torqueopt.whiplash.detect_whiplash`, the paper's thresholds) and
  the peak :math:`|\tau_i|/\tau^+_i`; within limits means a peak ≤ 1.

The study's modules, one job each:

* :mod:`~torqueopt.studies.remedies.measures`: what it runs and how it measures a run;
* :mod:`~torqueopt.studies.remedies.runner`: running it (:func:`run_remedies`);
* :mod:`~torqueopt.studies.remedies.study`: its record and numbers (:class:`RemediesStudy`, :class:`SweepPoint`);
* :mod:`~torqueopt.studies.remedies.discussion_answers`: the numbers of its answers to the Discussion;
* :mod:`~torqueopt.studies.remedies.report`: its tables in ``summary.md``;
* :mod:`~torqueopt.studies.remedies.figures`: its figures.
"""

from .figures import plot_long_torques, plot_tradeoff
from .measures import (
    BASELINES,
    BOUNDED_QP,
    DEFAULT_DAMPINGS,
    DEFAULT_KINEMATIC_WEIGHTS,
    LEAST_SQUARES_REFERENCE,
    LINEAR_PROGRAM,
    REMEDIES,
    SELF_MOTION_DAMPING,
    SWEEP_REFERENCES,
    SWEPT_RESOLVER,
    registered_remedies,
    torque_cost,
)
from .report import percent
from .runner import planned_runs, run_remedies
from .study import RemediesStudy, SweepPoint

__all__ = [
    "planned_runs",
    "REMEDIES",
    "BASELINES",
    "SWEPT_RESOLVER",
    "DEFAULT_KINEMATIC_WEIGHTS",
    "DEFAULT_DAMPINGS",
    "SweepPoint",
    "RemediesStudy",
    "registered_remedies",
    "run_remedies",
    "torque_cost",
    "BOUNDED_QP",
    "LEAST_SQUARES_REFERENCE",
    "LINEAR_PROGRAM",
    "SELF_MOTION_DAMPING",
    "SWEEP_REFERENCES",
    "percent",
    "plot_long_torques",
    "plot_tradeoff",
]
