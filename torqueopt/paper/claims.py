"""The paper's six claims, each checked on the runs of :func:`~torqueopt.paper.run_paper`.

The thresholds that turn the paper's words ("a small fraction", "much
smaller", "high joint speed") into numbers are the module constants.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..result import SimResult
from .alignment import alignment_times

if TYPE_CHECKING:
    from .runner import PaperResults

__all__ = [
    "Claim",
    "check_claims",
    "SMALL_FRACTION",
    "PULLED_AWAY",
    "MUCH_SMALLER",
    "HIGH_SPEED",
    "NEAR_ALIGNMENT",
]


@dataclass(frozen=True)
class Claim:
    """One of the paper's claims, checked on the runs.

    Attributes:
        number: 1 to 6, in the order of Section 3 (short, medium and long movements, weighting, free swing).
        statement: the claim in words.
        holds: whether the numbers bear it out.
        evidence: the numbers the verdict was made of beside the runs' own, by name, with the thresholds used:
            times [s], speeds [rad/s], gravity [m/s²]; fractions and ratios to a limit dimensionless.
            docs/paper.md says them in words.
    """

    number: int
    statement: str
    holds: bool
    evidence: dict


#: What the words of the claims are taken to mean, in numbers.
SMALL_FRACTION = 0.25  # claim 1: "a small fraction": at most a quarter
PULLED_AWAY = 0.10  # claim 1: joint 3's peak drops by at least 10 % of its limit
MUCH_SMALLER = 0.75  # claim 4: "much smaller": at most three quarters
HIGH_SPEED = 3.0  # claims 3, 6: "high joint speed": 3 times pinv's fastest joint on the long movement
NEAR_ALIGNMENT = 0.1  # claims 3, 6: a speed peak "as links 2 and 3 straighten": within 0.1 s [s]


def check_claims(results: PaperResults) -> list[Claim]:
    """The paper's six claims about its Figures 2-7, each with its verdict and numbers.

    The thresholds that turn the paper's words into numbers are the module
    constants ``SMALL_FRACTION``, ``PULLED_AWAY``, ``MUCH_SMALLER``,
    ``HIGH_SPEED`` and ``NEAR_ALIGNMENT``.
    """
    # A run that stopped at its first step has no rows: its peaks are 0 and
    # ratios of them nan, which every comparison below counts as "does not hold".
    with np.errstate(divide="ignore", invalid="ignore"):
        return _check_claims(results)


def _check_claims(results: PaperResults) -> list[Claim]:
    pinv_speed = float(np.abs(results.runs["long", "pinv"].v).max(initial=0.0))  # the long movement's fastest joint
    return [
        _claim_1(results.runs, np.asarray(results.scenario.torque_limit)),
        _claim_2(results.runs),
        _claim_3(results, pinv_speed),
        _claim_4(results.runs),
        _claim_5(results),
        _claim_6(results.free_swing, pinv_speed),
    ]


def _peak(runs, movement: str, name: str) -> np.ndarray:
    return runs[movement, name].peak_torque


def _within(runs, movement: str, name: str) -> bool:
    return runs[movement, name].first_limit_violation is None and runs[movement, name].completed


def _claim_1(runs, limit: np.ndarray) -> Claim:
    pinv, null = _peak(runs, "short", "pinv"), _peak(runs, "short", "null-space")
    fraction = null[0] / pinv[0]
    pulled = (pinv[2] - null[2]) / limit[2]
    return Claim(
        1,
        "short: null-space cuts the peak joint-1 torque to a small fraction of pinv's and pulls joint 3 "
        "away from its 6 N·m limit",
        bool(fraction <= SMALL_FRACTION and pulled >= PULLED_AWAY),
        {
            "joint_1_fraction_of_pinv": fraction,
            "small_fraction": SMALL_FRACTION,
            "joint_3_pulled_away": pulled,
            "pulled_away": PULLED_AWAY,
        },
    )


def _claim_2(runs) -> Claim:
    pinv, null = _peak(runs, "medium", "pinv"), _peak(runs, "medium", "null-space")
    return Claim(
        2,
        "medium: null-space still needs less peak torque than pinv at joints 1 and 3 and stays within all "
        "limits, though joint 2 is larger",
        bool(null[0] < pinv[0] and null[2] < pinv[2] and _within(runs, "medium", "null-space") and null[1] > pinv[1]),
        {"null_space_first_limit_violation": runs["medium", "null-space"].first_limit_violation},
    )


def _claim_3(results: PaperResults, pinv_speed: float) -> Claim:
    runs, judged = results.runs, results.whiplash
    long_null, verdict = runs["long", "null-space"], judged["long", "null-space"]
    aligned = [t for t in alignment_times(long_null) if verdict.time is not None and t >= verdict.time - NEAR_ALIGNMENT]
    speed_at = [_speed_at(long_null, t) for t in aligned]
    fast = [pinv_speed > 0 and s >= HIGH_SPEED * pinv_speed for s in speed_at]
    late = bool(verdict.unstable and verdict.time > 0.5 * long_null.duration)
    return Claim(
        3,
        "long: pinv stays within all limits; null-space goes unstable late in the movement, with links 2 and 3 "
        "passing through alignment at high joint speeds",
        bool(_within(runs, "long", "pinv") and not judged["long", "pinv"].unstable and late and any(fast)),
        {
            "pinv_fastest_joint_speed": pinv_speed,
            "alignment_times": aligned,
            "fastest_joint_speed_at": speed_at,
            "high_speed": HIGH_SPEED,
            "near_alignment": NEAR_ALIGNMENT,
        },
    )


def _claim_4(runs) -> Claim:
    weighted, null = _peak(runs, "short", "weighted-null-space"), _peak(runs, "short", "null-space")
    ratio = weighted[2] / null[2]
    return Claim(
        4,
        "short: weighted-null-space makes joint 3's torque much smaller than null-space's at the expense of "
        "joints 1 and 2, all within limits",
        bool(
            ratio <= MUCH_SMALLER
            and weighted[0] > null[0]
            and weighted[1] > null[1]
            and _within(runs, "short", "weighted-null-space")
        ),
        {"joint_3_fraction_of_null_space": ratio, "much_smaller": MUCH_SMALLER},
    )


def _claim_5(results: PaperResults) -> Claim:
    runs = results.runs
    inertia, pinv = _peak(runs, "short", "inertia-pinv"), _peak(runs, "short", "pinv")
    null = _peak(runs, "short", "null-space")
    between = [min(p, z) <= i <= max(p, z) for i, p, z in zip(inertia, pinv, null)]
    unstable_long = [results.whiplash["long", name].unstable for name in ("weighted-null-space", "inertia-pinv")]
    return Claim(
        5,
        "long: weighted-null-space and inertia-pinv go unstable too; inertia-pinv's torques in the short "
        "movement lie between those of pinv and null-space for most joints",
        bool(all(unstable_long) and sum(between) > len(between) / 2),
        {"joints_between": [i + 1 for i, b in enumerate(between) if b]},
    )


def _claim_6(swing: SimResult, pinv_speed: float) -> Claim:
    speed = np.abs(swing.v).max(axis=1, initial=0.0)
    peak_row = int(np.argmax(speed))
    peak_time, peak_speed = float(swing.t[peak_row]), float(speed[peak_row])
    swing_aligned = alignment_times(swing)
    nearest = min(swing_aligned, key=lambda t: abs(t - peak_time)) if swing_aligned else None
    return Claim(
        6,
        "the free-swinging arm shows the same whip: a joint-speed peak as links 2 and 3 straighten",
        bool(
            nearest is not None
            and abs(nearest - peak_time) <= NEAR_ALIGNMENT
            and pinv_speed > 0
            and peak_speed >= HIGH_SPEED * pinv_speed
        ),
        {
            "fastest_joint": swing.joint_names[int(np.argmax(np.abs(swing.v[peak_row])))],
            "peak_speed": peak_speed,
            "peak_time": peak_time,
            "pinv_fastest_joint_speed": pinv_speed,
            "high_speed": HIGH_SPEED,
            "near_alignment": NEAR_ALIGNMENT,
        },
    )


def _speed_at(result: SimResult, time: float) -> float:
    row = int(np.clip(np.searchsorted(result.t, time), 0, len(result.t) - 1))
    return float(np.abs(result.v[row]).max())
