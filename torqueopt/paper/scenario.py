r"""The paper's scenario (Hollerbach & Suh, Section 3) as a frozen dataclass, :data:`PAPER`.

A planar arm of three 1 m, 10 kg thin rods, without gravity, with torque
limits of 54, 24 and 6 N·m, tracks rest-to-rest straight lines with a
tangential acceleration of √2 m/s² (RK4, 1 ms, torque held over each step).
The paper does not give the start configuration; torqueopt uses
q0 = (−45°, 135°, −135°), where the tip is at (√2, 1 − √2) m, and the
direction (1, 1)/√2. Movements last 0.5 s (short, Fig. 2), 1.25 s (medium,
2.5 times longer, Fig. 3) and 2 s (long, 4 times, Fig. 4); the weighted
null-space method uses W = diag(1/limit²).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..checks import finite_values, joint_vector, positive_number
from ..errors import InvalidInput
from ..loading import load_robot
from ..resolvers import RESOLVERS
from ..robot import Robot
from ..simulate import step_budget
from ..trajectory import StraightLine

__all__ = ["MOVEMENTS", "PAPER", "PAPER_RESOLVERS", "PaperScenario"]

#: Movement names, shortest first.
MOVEMENTS = ("short", "medium", "long")
#: The four methods the paper compares (Eq. (34), Eq. (35), Eq. (36), Eq. (37)); other registered resolvers are studied apart.
PAPER_RESOLVERS = ("pinv", "inertia-pinv", "null-space", "weighted-null-space")


@dataclass(frozen=True)
class PaperScenario:
    """The paper's experiment (Section 3); every field can be replaced.

    Attributes:
        q0: start joint angles [rad], one per joint.
        direction: direction of the straight line in the xy plane (normalised on use).
        accel: tangential acceleration and deceleration [m/s²].
        durations: (short, medium, long) movement durations [s].
        torque_limit: symmetric torque limits τ⁺ = −τ⁻ [N·m].
        dt: integration step [s]; the torque is held over each step.
        robot: the arm, ``planar3`` (gravity off).
    """

    q0: tuple[float, ...] = tuple(np.radians([-45.0, 135.0, -135.0]).tolist())
    direction: tuple[float, ...] = (1.0, 1.0)
    accel: float = math.sqrt(2.0)
    durations: tuple[float, float, float] = (0.5, 1.25, 2.0)
    torque_limit: tuple[float, ...] = (54.0, 24.0, 6.0)
    dt: float = 1e-3
    robot: str = "planar3"

    def __post_init__(self):
        object.__setattr__(self, "q0", finite_values(self.q0, "q0"))
        object.__setattr__(self, "direction", finite_values(self.direction, "direction"))
        durations = finite_values(self.durations, "durations")
        if len(durations) != len(MOVEMENTS) or min(durations) <= 0:
            raise InvalidInput(
                f"durations {list(durations)} must be {len(MOVEMENTS)} positive numbers of seconds "
                f"({', '.join(MOVEMENTS)})"
            )
        object.__setattr__(self, "durations", durations)
        object.__setattr__(
            self, "torque_limit", finite_values(self.torque_limit, "torque_limit", minimum=0.0, strict=True, unit="N·m")
        )
        for name in ("accel", "dt"):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        if self.dt > min(durations):
            raise InvalidInput(f"dt={self.dt} s is longer than the shortest movement, {min(durations)} s")
        if any(later <= earlier for earlier, later in zip(durations, durations[1:])):
            # The movements are named by their order: a 2 s movement first would be called "short".
            raise InvalidInput(
                f"durations {list(durations)} must increase from the short movement to the long one, e.g. 0.5,1.25,2"
            )
        for duration in durations:
            # The paper runs at the default step budget and has no option to raise it.
            step_budget(duration, self.dt, option=None)

    def replace(self, **changes) -> PaperScenario:
        """The same scenario with some fields changed, e.g. ``PAPER.replace(durations=(0.4, 1.0, 1.6))``."""
        return dataclasses.replace(self, **changes)

    def duration(self, movement: str) -> float:
        """Duration of ``short``, ``medium`` or ``long`` [s]."""
        try:
            return self.durations[MOVEMENTS.index(movement)]
        except ValueError:
            raise InvalidInput(f"unknown movement '{movement}': choose one of {', '.join(MOVEMENTS)}") from None

    @property
    def weight(self) -> np.ndarray:
        """Diagonal of the paper's W = diag(1/limit²).

        ``weighted-null-space`` runs with its default 1/(τ⁺−τ⁻)², which for
        these symmetric limits is W/4: the same minimiser, since scaling W
        does not move it.
        """
        return 1.0 / np.square(self.torque_limit)

    def line(self, movement: str) -> StraightLine:
        """The straight line of a movement, anchored by :func:`~torqueopt.simulate` at the tip's start."""
        return StraightLine(self.direction, accel=self.accel, duration=self.duration(movement))

    def resolver_options(self, resolver: str) -> dict:
        """The options the scenario runs ``resolver`` with: joint limits off where it has them.

        The paper's arm has torque limits and no joint limits; planar3's URDF
        writes ±2π position and 100 rad/s velocity limits only because a
        revolute joint needs some. A bounded resolver (``joint_limits`` on by
        default where the URDF has limits) would otherwise bound the paper's
        movements by them: its stopping-distance bound on a joint turning fast
        under the paper's small torque limits binds within 0.6 s.
        """
        declared = {option.name for option in RESOLVERS[resolver].declared_options()} if resolver in RESOLVERS else ()
        return {"joint_limits": "off"} if "joint_limits" in declared else {}

    def load_robot(self) -> Robot:
        """The arm with the scenario's limits and gravity off."""
        robot = load_robot(self.robot, torque_limit=np.array(self.torque_limit), gravity=False)
        joint_vector(robot, self.q0, "q0")
        return robot

    def as_dict(self) -> dict:
        """JSON-ready description, angles in degrees as well."""
        return {
            "robot": self.robot,
            "q0_rad": list(self.q0),
            "q0_deg": np.degrees(self.q0).round(9).tolist(),
            "direction": (np.asarray(self.direction) / np.linalg.norm(self.direction)).tolist(),
            "accel": self.accel,
            "durations": dict(zip(MOVEMENTS, self.durations)),
            "torque_limit": list(self.torque_limit),
            "weight": self.weight.tolist(),
            "dt": self.dt,
            "gravity": False,
        }


#: The paper's scenario as torqueopt reproduces it.
PAPER = PaperScenario()
