r"""The stepping engine: one loop body that advances B movements of one robot and one resolver.

:func:`run_movements` is the only stepping loop of the package. Every run goes
through it: :func:`torqueopt.simulate` (B = 1), ``torqueopt.batch.simulate_batch``
(B movements side by side) and the velocity-level methods
(``torqueopt.kinematic.simulate_kinematic``). It fixes, once, what a step
is and in which order its parts come:

1. the task terms of the state (``torqueopt.terms``) and the task position x;
2. at the final sample, t = T, the state is recorded and, for a torque
   resolver, no torque is applied from it (a velocity-level method records
   the torque of its motion there too);
3. the command: the reference task acceleration of the sample (with task
   feedback when asked), or the commanded task velocity for a velocity-level
   method;
4. the resolver's step at the state (torque, q̈, σmin/σmax, what was given up);
5. the row is recorded and the stops that read it are applied: a resolver
   that could not resolve the state, a torque beyond its ceiling (and joint
   rates beyond theirs, at the velocity level);
6. the integrator advances the state over the step, and the stops that read
   the new state are applied (joint speeds beyond their ceiling, a
   velocity-level method undefined at a stage).

A movement that stops leaves the batch at once (its row of every stack is
dropped), so the others go on at the cost of those still running; the
reference is sampled a block of steps at a time, so memory follows the steps
taken.

What changes with B and with the level lives in a :class:`Lanes` object:
the data layout (one state as plain vectors for B = 1, (B, ...) stacks for
B > 1), the terms provider (Pinocchio on one data, or the forest), the
resolver's step (its single-state step, or its step on stacks), the
integrator (:mod:`torqueopt.integrators`) and the log. Their stop tests and
messages are those of ``torqueopt.stop_rules.StopRules``, and every run's
:class:`~torqueopt.SimResult` is made by ``torqueopt.run_records.build_result``.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

__all__ = ["Lanes", "run_movements"]


class Lanes(Protocol):
    """The movements a run advances, in the layout of its batch size, and the pieces that step them.

    ``q`` and ``v`` are the start state (one configuration and velocity for
    B = 1, (B, nq) and (B, n) stacks for B > 1); ``running`` is False once
    every movement stopped. ``j`` is a sample's index in the current block,
    ``t`` its time [s].
    """

    q: np.ndarray
    v: np.ndarray
    #: True when the resolver's step also runs at the final sample (velocity level), False when no torque is applied there.
    resolves_final: bool
    running: bool

    def block(self, start: int) -> list[float]:
        """Sample the reference from step ``start`` on; the times [s] of the block's steps."""

    def terms(self, q, v):
        """``(terms, x)``: the task terms of the state(s) and the task position(s)."""

    def command(self, j: int, terms, x):
        """The command of sample ``j``: the task acceleration (task velocity at the velocity level)."""

    def resolve(self, terms, command, j: int):
        """The resolver's step at the state(s); a failure is reported, never raised."""

    def record(self, j: int, t: float, q, v, x, terms, resolution) -> bool:
        """Record the row(s); True when a movement stopped at it (a failure or a ceiling)."""

    def record_final(self, j: int, q, v, x, terms) -> None:
        """Record the final state(s), where no torque is applied."""

    def compact(self, q, v, resolution):
        """``(q, v, resolution)`` without the movements that stopped."""

    def step(self, q, v, resolution, j: int, t: float):
        """``(q, v, stopped)``: the state(s) after the step, True when a movement stopped during it."""


def run_movements(lanes: Lanes, steps: int) -> None:
    """Advance every movement of ``lanes`` over ``steps`` steps, or until it stops: the one loop body.

    The lanes keep what the run recorded; the loop only orders the step's
    parts (see the module docstring) and drops the movements that stop.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # A diverging run overflows: the stop rules end it on the first non-finite torque or state and say so,
        # so numpy's floating-point warnings would only repeat it (and leak into a command's output).
        _run_movements(lanes, steps)


def _run_movements(lanes: Lanes, steps: int) -> None:
    q, v = lanes.q, lanes.v
    terms_at, command_at, resolve, record, advance = lanes.terms, lanes.command, lanes.resolve, lanes.record, lanes.step
    resolves_final = lanes.resolves_final
    start = 0
    while lanes.running and start <= steps:
        times = lanes.block(start)
        final = steps - start  # the block's index of the final state (past the block until the last one)
        for j, t in enumerate(times):
            terms, x = terms_at(q, v)
            if j == final and not resolves_final:
                # The final state: the movement is over, so no torque is applied from it.
                lanes.record_final(j, q, v, x, terms)
                break
            resolution = resolve(terms, command_at(j, terms, x), j)
            if record(j, t, q, v, x, terms, resolution):
                q, v, resolution = lanes.compact(q, v, resolution)
                if not lanes.running:
                    break
            if j == final:
                break
            q, v, stopped = advance(q, v, resolution, j, t)
            if stopped:
                q, v, _ = lanes.compact(q, v, None)
                if not lanes.running:
                    break
        start += len(times)
