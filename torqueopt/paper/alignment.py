"""When two links of the arm pass through alignment: the geometry of the whip."""

from __future__ import annotations

import math

import numpy as np

from ..result import SimResult

__all__ = ["alignment_times"]


def alignment_times(result: SimResult, joint: int = 2) -> list[float]:
    """Times [s] at which ``joint`` (0-based; 2 is joint 3) passes through 0 mod 2π: its two links in line.

    Found as sign changes of the angle wrapped to (−π, π], interpolated
    linearly; wraps through ±π (links folded back) are not counted.
    """
    angle = np.angle(np.exp(1j * result.joint_angles[:, joint]))
    times = []
    for k in range(len(angle) - 1):
        a, b = angle[k], angle[k + 1]
        if (a == 0.0 or a * b < 0.0) and abs(a - b) < math.pi:
            fraction = 0.0 if a == b else a / (a - b)
            times.append(float(result.t[k] + fraction * (result.t[k + 1] - result.t[k])))
    return times
