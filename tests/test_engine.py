"""The engine's one loop body (torqueopt.engine.run_movements): the order of a step's parts and the stops.

A scripted set of lanes records every call the loop makes; the expected
sequences are written out by hand from the loop's contract (terms, final
state, command, resolve, record, step), so a loop that records the final
state's torque, steps past a stop or skips the block boundary fails here.
The numbers of each lanes form are held to simulate elsewhere (test_batch's
registry tests, test_simulate, test_kinematic).
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

import torqueopt
from torqueopt.batch import simulate_batch
from torqueopt.engine import run_movements


class Scripted:
    """Lanes of one scalar 'movement' whose state counts the steps; ``stop_at`` = {(where, step): True}."""

    def __init__(self, block_size: int, resolves_final: bool = False, stop_at=None):
        self.q, self.v = 0, 0
        self.resolves_final, self.running = resolves_final, True
        self.block_size, self.stop_at, self.calls = block_size, stop_at or {}, []

    def block(self, start):
        self.start = start
        self.calls.append(("block", start))
        return [0.1 * (start + j) for j in range(self.block_size)]

    def terms(self, q, v):
        self.calls.append(("terms", q))
        return f"terms{q}", f"x{q}"

    def command(self, j, terms, x):
        return f"command{self.start + j}"

    def resolve(self, terms, command, j):
        self.calls.append(("resolve", command))
        return f"resolution{self.start + j}"

    def record(self, j, t, q, v, x, terms, resolution):
        self.calls.append(("record", resolution))
        return self.stop_at.get(("record", self.start + j), False)

    def record_final(self, j, q, v, x, terms):
        self.calls.append(("final", q))

    def compact(self, q, v, resolution):
        self.calls.append(("compact", q))
        self.running = False
        return q, v, resolution

    def step(self, q, v, resolution, j, t):
        self.calls.append(("step", resolution))
        return q + 1, v, self.stop_at.get(("step", self.start + j), False)


def test_the_final_state_applies_no_torque_at_the_torque_level():
    lanes = Scripted(block_size=2)
    run_movements(lanes, 3)
    assert lanes.calls == [
        ("block", 0),
        *[("terms", 0), ("resolve", "command0"), ("record", "resolution0"), ("step", "resolution0")],
        *[("terms", 1), ("resolve", "command1"), ("record", "resolution1"), ("step", "resolution1")],
        ("block", 2),
        *[("terms", 2), ("resolve", "command2"), ("record", "resolution2"), ("step", "resolution2")],
        *[("terms", 3), ("final", 3)],
    ]


def test_the_velocity_level_resolves_its_final_state_and_takes_no_step_from_it():
    lanes = Scripted(block_size=4, resolves_final=True)
    run_movements(lanes, 1)
    assert lanes.calls == [
        ("block", 0),
        *[("terms", 0), ("resolve", "command0"), ("record", "resolution0"), ("step", "resolution0")],
        *[("terms", 1), ("resolve", "command1"), ("record", "resolution1")],
    ]


@pytest.mark.parametrize("where", ["record", "step"])
def test_a_stop_ends_the_movement_where_it_happens(where):
    lanes = Scripted(block_size=8, stop_at={(where, 1): True})
    run_movements(lanes, 5)
    expected = [("block", 0), ("terms", 0), ("resolve", "command0"), ("record", "resolution0")]
    expected += [("step", "resolution0"), ("terms", 1), ("resolve", "command1"), ("record", "resolution1")]
    expected += [("compact", 1)] if where == "record" else [("step", "resolution1"), ("compact", 2)]
    assert lanes.calls == expected


def test_simulate_batch_and_the_kinematic_loop_all_run_on_the_one_loop_body(monkeypatch):
    """Every public loop advances its movements through run_movements (a counting stand-in sees each)."""
    seen = []

    def counting(lanes, steps):
        seen.append(type(lanes).__name__)
        run_movements(lanes, steps)

    for name in ("torqueopt.simulate", "torqueopt.batch", "torqueopt.kinematic"):
        monkeypatch.setattr(importlib.import_module(name), "run_movements", counting)
    robot = torqueopt.load_robot("planar3")
    q0 = (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4)
    line = torqueopt.StraightLine((1.0, 1.0), accel=math.sqrt(2), duration=0.05)
    single = torqueopt.simulate(robot, "null-space", line, q0)
    torqueopt.simulate(robot, "velocity-pinv", line, q0)
    (batched,) = simulate_batch(robot, "null-space", [line], [q0])
    assert seen == ["MovementStack", "KinematicMovement", "MovementStack"]
    assert np.allclose(batched.tau[:-1], single.tau[:-1], rtol=0, atol=1e-9)
