r"""Resolvers with hard torque bounds: a QP (``bounded-torque``) and the paper's LP (``minmax-torque``).

Both work in the null-space coordinates of Eq. (26): with the particular
solution :math:`p = J^\dagger(\ddot x - \dot J\dot q)`, an orthonormal basis
:math:`Z` of the null space of :math:`J` and :math:`y \in \mathbb{R}^{n-m}`,

.. math::

    \ddot q = p + Z y, \qquad
    \tau = \tilde\tau + H Z y, \qquad
    \tilde\tau = H p + \dot q\cdot C\cdot\dot q + g \quad\text{(Eq. (27), Eq. (28))},

so every :math:`y` realises the task and the bounds
:math:`\tau^- \le \tau \le \tau^+` are :math:`2\,n_b` general inequalities
on n − m variables (:math:`n_b` joints with finite limits; a joint without a
limit has no bound rows). Each row is divided by the joint's torque range
:math:`\tau^+_i - \tau^-_i`, so the solver's feasibility tolerance (DAQP's
``primal_tol``, :data:`~torqueopt.resolvers.bounded.programs.FEASIBILITY_TOLERANCE`) is a fraction of each range.

The solver is DAQP (Arnström, Bemporad & Axehill, IEEE TAC 67(8), 2022), a
dual active-set method for small dense QPs that also solves LPs, called
through its ``daqp.Model`` workspace: each program is set up once per run
and only its numbers change at each step, with the previous step's active
set as the warm start. BENCHMARKS.md has the measurements behind the choice
(DAQP against proxsuite, quadprog and HiGHS on these problems) and the
comparison with a formulation in :math:`\ddot q` with the task as equality.
A program on which DAQP fails (cycling or its iteration limit: it stopped one
``minmax-torque`` run on tiago and one on baxter in their atlases, and
``energy-bounded-torque`` runs on tiago and panda circles) is solved again by
DAQP from a cold start, then, if that fails too, by HiGHS: an LP through
``scipy.optimize.linprog``, a QP through CasADi's ``conic`` interface. Their
answers meet the same feasibility checks (and an LP's the same optimality
certificate); where every solver fails the run stops with their words.

When no torque within the bounds realises the task, the ``infeasible``
option says what to do (the step is marked infeasible either way and its
task error recorded):

``scale`` (default)
    the largest task-acceleration scaling :math:`s \in [0, 1]` for which
    :math:`\ddot q = J^\dagger(s\ddot x - \dot J\dot q) + Z y` has a torque
    within bounds (an LP in :math:`(s, y)`), then the resolver's own optimum
    at :math:`s\ddot x`: the optimal task scaling of Flacco, De Luca &
    Khatib, "Motion control of redundant robots under joint constraints:
    saturation in the null space", ICRA 2012. The direction of the task
    acceleration is kept; task error :math:`(1 - s)\|\ddot x\|`.
``least-error``
    the task acceleration :math:`a` closest to :math:`\ddot x`,
    :math:`\min \|a - \ddot x\|` over the torques within bounds (a QP in
    :math:`(a, y)`; it is always feasible: H is invertible, so every torque
    in the box is some :math:`(a, y)`), then the resolver's optimum at
    :math:`a`. Task error :math:`\|a - \ddot x\|`.
``exceed``
    realise the task with the torque of least largest normalised excess
    (the ``minmax-torque`` LP); torques leave their bounds, the step is
    flagged, task error 0.
``stop``
    raise :class:`~torqueopt.errors.TorqueBoundsInfeasible`; inside
    :func:`torqueopt.simulate` the run stops there and says why.

With ``scale``, a state where even :math:`s = 0` has no torque within bounds
(the velocity or gravity torques alone beyond a limit while the tip is held
on its path) gets the ``least-error`` answer: the torque stays within bounds
and the tip leaves its path, the step flagged with its task error. Only
``stop`` ends a run, and only ``exceed`` leaves the bounds.

The LPs and the policies' programs use an orthonormal basis of the range of
:math:`HZ` instead of :math:`y` itself (see ``_RangeBasis`` in :mod:`torqueopt.resolvers.bounded.programs`).

Modules: :mod:`~torqueopt.resolvers.bounded.bounded_torque` (the QP),
:mod:`~torqueopt.resolvers.bounded.minmax_torque` (the LP),
:mod:`~torqueopt.resolvers.bounded.energy_bounded_torque` (the QP with the
energy barrier), :mod:`~torqueopt.resolvers.bounded.base` (what they share:
checks, the ``infeasible`` option, the step on stacks),
:mod:`~torqueopt.resolvers.bounded.infeasible` (the step on one state and
the ``infeasible`` policies, each a function) and
:mod:`~torqueopt.resolvers.bounded.programs` (each program as a
``BoundProgram``, solved by ``solve_program``: DAQP, then its fall-backs).
"""

from .base import INFEASIBLE_OPTION, INFEASIBLE_POLICIES, torque_utilisation
from .bounded_torque import TORQUE_WEIGHTS, BoundedTorque
from .energy_bounded_torque import EnergyBoundedTorque
from .minmax_torque import MinMaxTorque
from .programs import BOUND_MARGIN, FEASIBILITY_TOLERANCE

__all__ = [
    "FEASIBILITY_TOLERANCE",
    "INFEASIBLE_POLICIES",
    "BoundedTorque",
    "EnergyBoundedTorque",
    "MinMaxTorque",
    "torque_utilisation",
    "BOUND_MARGIN",
    "INFEASIBLE_OPTION",
    "TORQUE_WEIGHTS",
]
