r"""Whole-movement torque optimisation: the global counterpart of the paper's local resolvers.

``optimize(robot, trajectory, q0, ...)`` returns an :class:`OptimalResult`:
the joint motion that keeps the task frame on the path and minimises
:math:`\int_0^T\|S(\tau - \tau_{mid})\|^2 dt`, its torques on the
simulation grid, the cost evaluated there, the solver's status and the tip
deviation of an open-loop RK4 replay of those torques.

Modules: :mod:`~torqueopt.optimal.transcription` (the NLP and its
analytical derivatives), :mod:`~torqueopt.optimal.ipopt` (the solver),
:mod:`~torqueopt.optimal.whole_path` (warm start, mapping to the simulation
grid, validation), :mod:`~torqueopt.optimal.result` (:class:`OptimalResult`,
its summary and files), :mod:`~torqueopt.optimal.cost` (the cost of any run),
:mod:`~torqueopt.optimal.replay` (open-loop replay), :mod:`~torqueopt.optimal.shooting` (the same
program with CasADi's exact derivatives, from several starts: ``optimize``'s default) and
:mod:`~torqueopt.optimal.symbolic` (RNEA and the task frame as CasADi expressions).
"""

from .cost import WEIGHTS, run_cost, torque_cost, weight_root
from .ipopt import STATUSES
from .replay import Replay, replay_torques
from .shooting import ShootingTranscription, solve_shooting
from .symbolic import symbolic_dynamics
from .transcription import Transcription, TranscriptionSize
from .whole_path import (
    DEFAULT_GRID_STEP,
    DEFAULT_MAX_NONZEROS,
    DEFAULT_STARTS,
    DEFAULT_TRANSCRIPTION,
    ENDS,
    HESSIANS,
    TRANSCRIPTIONS,
    OptimalResult,
    optimize,
)

__all__ = [
    "DEFAULT_MAX_NONZEROS",
    "TranscriptionSize",
    "DEFAULT_GRID_STEP",
    "DEFAULT_STARTS",
    "DEFAULT_TRANSCRIPTION",
    "ShootingTranscription",
    "TRANSCRIPTIONS",
    "solve_shooting",
    "symbolic_dynamics",
    "ENDS",
    "HESSIANS",
    "STATUSES",
    "WEIGHTS",
    "OptimalResult",
    "Replay",
    "Transcription",
    "optimize",
    "replay_torques",
    "run_cost",
    "torque_cost",
    "weight_root",
]
