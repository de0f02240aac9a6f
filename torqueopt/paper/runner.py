"""Run the paper's experiment: every (movement, resolver) pair and the free swing, judged and checked."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInput, SingularJacobian
from ..linalg import JacobianSolver
from ..result import SimResult
from ..robot import Robot
from ..simulate import simulate
from ..whiplash import DEFAULT_GROWTH_FACTOR, DEFAULT_LIMIT_FACTOR, WhiplashReport, detect_whiplash
from .claims import Claim, check_claims
from .free_swing import free_swing, free_swing_gravity
from .scenario import MOVEMENTS, PAPER, PAPER_RESOLVERS, PaperScenario

__all__ = ["PAPER_RUNS", "PaperResults", "check_scenario", "run_movement", "run_paper"]


@dataclass
class PaperResults:
    """Everything :func:`run_paper` computed.

    Attributes:
        scenario: the scenario that was run.
        robot: the arm it was run on (gravity off).
        runs: SimResult per (movement, resolver).
        whiplash: WhiplashReport per (movement, resolver).
        free_swing: the zero-torque swing of Fig. 7 (resolver name ``free swing``).
        free_swing_gravity: the gravity vector used for it [m/s²].
        claims: the paper's six claims, checked (see :mod:`torqueopt.paper.claims`).
        limit_factor, growth_factor: the whiplash thresholds used.
    """

    scenario: PaperScenario
    robot: Robot
    runs: dict[tuple[str, str], SimResult]
    whiplash: dict[tuple[str, str], WhiplashReport]
    free_swing: SimResult
    free_swing_gravity: np.ndarray
    limit_factor: float
    growth_factor: float
    claims: list[Claim] = field(default_factory=list)

    @property
    def stopped_early(self) -> list[tuple[str, str]]:
        """(movement, resolver) of the runs that stopped before their duration."""
        return [key for key, result in self.runs.items() if not result.completed]


#: The simulations of :func:`run_paper`: every paper resolver on every movement, and the free swing.
PAPER_RUNS = len(MOVEMENTS) * len(PAPER_RESOLVERS) + 1


def run_movement(scenario: PaperScenario, movement: str, resolver: str, robot: Robot | None = None) -> SimResult:
    """Simulate one resolver on one of the scenario's movements."""
    robot = robot or scenario.load_robot()
    return simulate(
        robot,
        resolver,
        scenario.line(movement),
        scenario.q0,
        dt=scenario.dt,
        resolver_options=scenario.resolver_options(resolver) or None,
    )


def run_paper(
    scenario: PaperScenario = PAPER,
    *,
    limit_factor: float = DEFAULT_LIMIT_FACTOR,
    growth_factor: float = DEFAULT_GROWTH_FACTOR,
    on_run=None,
) -> PaperResults:
    """Simulate every resolver on every movement, and the free swing; judge and check the claims.

    ``on_run``, when given, is called after each of the :data:`PAPER_RUNS`
    simulations (a progress bar's ``update``).

    Raises:
        InvalidInput: q0 is a singular configuration, where no resolver can start.
    """
    robot = check_scenario(scenario)
    done = on_run or (lambda: None)
    runs = {}
    for movement in MOVEMENTS:
        for name in PAPER_RESOLVERS:
            runs[movement, name] = run_movement(scenario, movement, name, robot)
            done()
    whiplash = {key: detect_whiplash(result, limit_factor, growth_factor) for key, result in runs.items()}
    swing = free_swing(scenario, robot)
    done()
    results = PaperResults(
        scenario=scenario,
        robot=robot,
        runs=runs,
        whiplash=whiplash,
        free_swing=swing,
        free_swing_gravity=free_swing_gravity(robot, scenario),
        limit_factor=float(limit_factor),
        growth_factor=float(growth_factor),
    )
    results.claims = check_claims(results)
    return results


def check_scenario(scenario: PaperScenario) -> Robot:
    """The scenario's robot, after checking that its start is not singular (what :func:`run_paper` checks first).

    Raises:
        InvalidInput: q0 is a singular configuration, where no resolver can start.
    """
    robot = scenario.load_robot()
    _check_start(robot, scenario)
    return robot


def _check_start(robot: Robot, scenario: PaperScenario) -> None:
    q = robot.configuration(scenario.q0)
    jacobian = robot.terms(q, np.zeros(robot.nv)).jacobian
    try:
        # Only its singularity check is wanted here.
        JacobianSolver(robot.m, robot.nv, null_space=False)(jacobian, np.zeros(robot.m))
    except SingularJacobian as error:
        degrees = ", ".join(f"{a:g}°" for a in np.degrees(scenario.q0).round(4))
        raise InvalidInput(f"q0 = ({degrees}) is a singular configuration ({error}); choose another start") from None
