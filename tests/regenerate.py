"""Regression pins: the numbers torqueopt itself computes on fixed runs, and how to regenerate them.

These are not independent checks (those are the other test modules): they
pin torqueopt's own outputs so that an unintended change shows. After an
intended change of the numbers, regenerate the golden file from the
repository's root and say why in the commit::

    python -m tests.regenerate

which rewrites ``tests/golden/pins.json``. ``tests/test_regression.py``
compares a fresh computation against it with the tolerances given there.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt.paper import alignment_times, run_paper
from torqueopt.whiplash import detect_whiplash

from .test_whiplash import OTHER_STABLE, OTHER_UNSTABLE

GOLDEN = Path(__file__).parent / "golden" / "pins.json"

#: Runs off the paper's start, the whiplash tests' cases: (q0 [deg], direction [deg], duration [s], resolver).
OTHER_RUNS = OTHER_STABLE + OTHER_UNSTABLE


def case_id(case) -> str:
    q0, angle, duration, name = case
    return f"{name} {duration:g} s at {angle} deg from {list(q0)} deg"


def _time(value):
    return None if value is None else float(value)


def compute_pins(paper=None, planar3=None) -> dict:
    """Every pinned number, JSON-ready; ``paper`` and ``planar3`` are computed when not given."""
    paper = run_paper() if paper is None else paper
    planar3 = torqueopt.load_robot("planar3") if planar3 is None else planar3
    runs = {}
    for (movement, name), result in paper.runs.items():
        speed = np.abs(result.v)
        runs[f"{movement} {name}"] = {
            "peak_torque": result.peak_torque.tolist(),
            "peak_joint_speed": speed.max(axis=0).tolist(),
            "peak_joint_speed_time": result.t[speed.argmax(axis=0)].tolist(),
            "first_limit_violation": _time(result.first_limit_violation),
            "instability_time": _time(paper.whiplash[movement, name].time),
            "links_2_3_aligned": alignment_times(result),
            "max_tip_error": result.max_tip_error,
        }
    swing = paper.free_swing
    speed = np.abs(swing.v)
    free_swing = {
        "gravity": paper.free_swing_gravity.tolist(),
        "peak_joint_speed": speed.max(axis=0).tolist(),
        "peak_joint_speed_time": swing.t[speed.argmax(axis=0)].tolist(),
        "links_2_3_aligned": alignment_times(swing),
    }
    other = {}
    for case in OTHER_RUNS:
        q0, angle, duration, name = case
        direction = (math.cos(math.radians(angle)), math.sin(math.radians(angle)))
        line = torqueopt.StraightLine(direction, duration=duration)
        result = torqueopt.simulate(planar3, name, line, np.radians(q0))
        other[case_id(case)] = {
            "peak_torque_ratio": float(result.peak_torque_ratio.max()),
            "instability_time": _time(detect_whiplash(result).time),
        }
    return {"paper_runs": runs, "free_swing": free_swing, "other_runs": other}


def main() -> None:
    pins = compute_pins()
    GOLDEN.parent.mkdir(parents=True, exist_ok=True)
    GOLDEN.write_text(json.dumps(pins, indent=1) + "\n")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
