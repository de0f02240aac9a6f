"""The columns of the atlas's table that describe a movement and its baseline, shared by every kind of row."""

from __future__ import annotations

import math

import numpy as np

from .population import Movement
from .verdicts import applied_rows

__all__ = ["movement_columns", "path_columns", "peak_applied_ratio", "start_columns"]


def movement_columns(movement: Movement, resolver: str) -> dict:
    """``path``, ``duration``, ``resolver``, ``q0_1..n`` and ``direction_1..d``."""
    row = {"path": int(movement.path), "duration": float(movement.duration), "resolver": resolver}
    for i, value in enumerate(movement.q0, start=1):
        row[f"q0_{i}"] = float(value)
    for i, value in enumerate(movement.direction, start=1):
        row[f"direction_{i}"] = float(value)
    return row


def path_columns(movement: Movement) -> dict:
    """The path's kind and parameters: length [m] (a·T²/4, L or 2πr) and, for a circle, radius, centre and normal."""
    row = {"path_kind": movement.kind, "path_length": float(movement.length)}
    if movement.kind == "line":
        row["path_accel"] = float(movement.accel)
    if movement.kind == "circle":
        row["radius"] = float(movement.radius)
        row.update({f"centre_{i}": float(value) for i, value in enumerate(movement.centre, start=1)})
        if movement.normal is not None:
            row.update({f"normal_{i}": float(value) for i, value in enumerate(movement.normal, start=1)})
    return row


def start_columns(movement: Movement) -> dict:
    """``start_1..d``: the tip's start [m]."""
    return {f"start_{i}": float(value) for i, value in enumerate(movement.start, start=1)}


def peak_applied_ratio(result) -> float:
    """The run's peak torque over its limit, over its applied torques and its limited joints (NaN when none is)."""
    applied = applied_rows(result)[0]
    limited = np.isfinite(applied.torque_upper)
    ratios = applied.torque_ratio[:, limited]
    if not ratios.size or np.isnan(ratios).all():
        return math.nan
    return float(np.nanmax(ratios))
