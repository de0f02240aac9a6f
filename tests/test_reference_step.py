r"""The plain reference of a torque run, step by step as the paper's Section 3 says it (the oracle of the engine).

A run of :func:`torqueopt.simulate` is, at each step start :math:`t_k`: the task terms of the state
(Pinocchio's ``computeAllTerms`` and frame calls, ``Robot.terms``), the command
:math:`\ddot x = \ddot x_{ref} + K_D(\dot x_{ref} - J\dot q) + K_P(x_{ref} - x)`, the resolver's torque, the row
(t, q, q̇, q̈, τ, x), the torque ceiling, then RK4 of ABA with the torque held (the textbook stages of
``test_integrator.rk4_reference_step``) and the speed ceiling; at t = T the state alone. The loop below writes
that out with none of the engine's machinery (no lanes, blocks, stacks or plants), and the tests hold the
library's runs to it: the same rows, the same stop at the same row.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import torqueopt
from tests.test_integrator import rk4_reference_step


def reference_run(robot, resolver, trajectory, q0, dt, *, feedback=(0.0, 0.0), max_torque_ratio=1e3, max_speed=1e3):
    """(rows, stop): rows of (t, q, v, q̈, τ, x) per step start, and why the run stopped (None at t = T)."""
    step = torqueopt.get_resolver(resolver).solver(robot)
    kp, kd = feedback
    q, v = robot.configuration(q0), np.zeros(robot.nv)
    if trajectory.start is None:
        trajectory = trajectory.anchored(robot.frame_placement(q).translation[: trajectory.dimension])
    steps = round(trajectory.duration / dt)
    rows = []
    for k in range(steps + 1):
        t = k * dt
        terms = robot.terms(q, v)
        x = terms.placement.translation[robot.task_rows]
        if k == steps:
            rows.append((t, q, v, np.full(robot.nv, np.nan), np.full(robot.nv, np.nan), x))
            return rows, None
        reference = trajectory.sample(np.array([t]))
        command = reference.acceleration[0] + kd * (reference.velocity[0] - terms.jacobian @ v)
        command = command + kp * (reference.position[0] - x)
        resolution = step(terms, command)
        rows.append((t, q, v, resolution.joint_acceleration, resolution.torque, x))
        if np.any(np.abs(resolution.torque) > max_torque_ratio * robot.torque_upper):
            return rows, "torque"
        q, v = rk4_reference_step(robot, q, v, resolution.torque, dt)
        if np.any(np.abs(v) > max_speed):
            return rows, "speed"
    raise AssertionError("unreachable")


Q0 = (-math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4)


def assert_run_is_the_reference(result, rows):
    assert len(result.t) == len(rows)
    columns = [np.array(column) for column in zip(*rows)]
    for name, expected in zip(("t", "q", "v", "acceleration", "tau", "x"), columns):
        got = getattr(result, name)
        scale = 1.0 + np.nanmax(np.abs(expected))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * scale, equal_nan=True, err_msg=name)


@pytest.mark.parametrize(
    ("resolver", "feedback"), [("null-space", None), ("inertia-pinv", (400.0, 40.0)), ("damped-null-space", None)]
)
def test_a_run_is_the_reference_loop_step_by_step(planar3, resolver, feedback):
    line = torqueopt.StraightLine((1.0, 1.0), accel=math.sqrt(2), duration=0.3)
    result = torqueopt.simulate(planar3, resolver, line, Q0, feedback=feedback)
    rows, stop = reference_run(planar3, resolver, line, Q0, 1e-3, feedback=feedback or (0.0, 0.0))
    assert stop is None and result.stop_reason is None
    assert_run_is_the_reference(result, rows)


def test_a_run_stops_where_the_reference_loop_does(planar3):
    """A torque ceiling of 0.9 times the limits is passed mid-movement: the same last row, the torque kept."""
    line = torqueopt.StraightLine((1.0, 1.0), accel=4.0, duration=1.0)
    result = torqueopt.simulate(planar3, "null-space", line, Q0, max_torque_ratio=0.9)
    rows, stop = reference_run(planar3, "null-space", line, Q0, 1e-3, max_torque_ratio=0.9)
    assert stop == "torque" and result.stop_reason.startswith("torque of joint")
    assert np.all(np.isfinite(result.tau[-1]))
    assert_run_is_the_reference(result, rows)


def test_a_position_run_on_panda_is_the_reference_loop(panda):
    line = torqueopt.StraightLine((1.0, 0.0, 0.0), accel=0.2, duration=0.1)
    q0 = panda.default_configuration
    result = torqueopt.simulate(panda, "null-space", line, q0)
    rows, stop = reference_run(panda, "null-space", line, q0, 1e-3)
    assert stop is None
    assert_run_is_the_reference(result, rows)
