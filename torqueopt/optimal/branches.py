"""Warm starts on other branches of the self-motion: the path's end reached in other inverse-kinematics solutions.

Every resolver's run from q0 follows the self-motion branch it starts on. Where that branch leaves the joint limits
before the path ends, a motion within the limits may still exist on another: on panda line 13 of the atlas's
population (2 s, torque bounds and joint limits) phase-1 found a least excess of 0.21 from pinv's and bounded-torque's
runs (joints 1 and 2 past their limits at T) and 0.018 from damped-null-space's, yet from the end configuration with
joints 1 and 3 at -2.8 rad (the other one found has both at 0.3 rad) it found a motion within every limit, and the
solve from it converged.

:func:`branch_starts` makes such starts: each is a decision vector of the shooting program whose knots follow the path
from q0 to one inverse-kinematics solution at the path's end. They are starts for the phase-1 problem
(:func:`~torqueopt.optimal.shooting.least_excess`), which restores the dynamics, limits and rest at both ends.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pinocchio as pin

from ..atlas.population import _inverse_kinematics

__all__ = ["END_MARGIN", "branch_starts", "end_configurations"]

#: How far inside every joint position limit an end configuration must be [rad, m], and how far apart two must be
#: (the largest joint difference) to count as two branches.
END_MARGIN = 0.02
_DISTINCT = 0.3
#: Random postures tried per start asked for.
_TRIES_PER_START = 40


def end_configurations(problem, count: int, seed: int = 0) -> list[np.ndarray]:
    """Up to ``count`` joint-angle vectors putting the task frame at the path's end, each :data:`END_MARGIN` inside the
    limits: inverse kinematics from random postures, pulled in the null space toward the middle of the joint ranges
    (so the solutions found are the middles of the branches reached, and distinct ones are distinct branches)."""
    robot = problem.robot
    lower, upper, _ = robot.joint_limits
    lower = np.where(np.isfinite(lower), lower, -np.pi)
    upper = np.where(np.isfinite(upper), upper, np.pi)
    middle = 0.5 * (lower + upper)
    data = robot.model.createData()
    generator = np.random.default_rng(seed)
    found = []
    for _ in range(_TRIES_PER_START * count):
        posture = lower + (upper - lower) * generator.uniform(0.1, 0.9, size=robot.nv)
        angles = _pulled(robot, data, problem.reference[-1], posture, middle)
        if angles is None or np.any(angles < lower + END_MARGIN) or np.any(angles > upper - END_MARGIN):
            continue
        if any(np.max(np.abs(angles - other)) < _DISTINCT for other in found):
            continue
        found.append(angles)
        if len(found) == count:
            break
    return found


def _pulled(robot, data, target, angles, toward, iterations: int = 300):
    """From ``angles``, ``iterations`` steps to the task frame at ``target`` and along the self-motion toward
    ``toward``, then inverse kinematics to 1e-11 m without the pull; None when that does not converge."""
    dimension = target.size
    for _ in range(iterations):
        q = robot.configuration(angles)
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, pin.LOCAL_WORLD_ALIGNED)[:dimension]
        pin.updateFramePlacements(robot.model, data)
        error = target - data.oMf[robot.frame_id].translation[:dimension]
        pseudo_inverse = np.linalg.pinv(jacobian, rcond=1e-8)
        step = pseudo_inverse @ error + 0.2 * (np.eye(robot.nv) - pseudo_inverse @ jacobian) @ (toward - angles)
        angles = angles + min(1.0, 0.5 / max(np.linalg.norm(step), 1e-300)) * step
    return _inverse_kinematics(robot, data, target, angles, iterations=50)


def branch_starts(problem, count: int = 4, seed: int = 0) -> Iterator[tuple[str, np.ndarray]]:
    """Up to ``count`` (name, decision vector) starts, one per end configuration (:func:`end_configurations`), each
    made when asked for.

    Each: the path tracked backward from its end configuration knot by knot (inverse kinematics from the next knot's
    angles, pulled toward q0 in the null space), then blended into q0 over the first half of the movement (the
    offset q0 minus the backward track's first knot, faded by a half cosine, each knot put back on the path), the
    velocities by central differences (zero at both ends), the held accelerations from successive velocities.
    """
    robot, nodes = problem.robot, problem.times
    data = robot.model.createData()
    first = problem.q0  # the start's angles
    half = 0.5 * nodes[-1]
    fade = 0.5 - 0.5 * np.cos(np.pi * np.clip(nodes / half, 0.0, 1.0))  # 0 at t = 0, 1 from T/2 on
    for number, end in enumerate(end_configurations(problem, count, seed), start=1):
        track = [end]
        for target in problem.reference[-2::-1]:
            angles = _pulled(robot, data, target, track[-1], first, iterations=5)
            if angles is None:
                break
            track.append(angles)
        if len(track) < len(nodes):
            continue
        track = np.array(track[::-1])
        offset = first - track[0]
        knots = [first]
        for k in range(1, len(nodes)):
            angles = _inverse_kinematics(robot, data, problem.reference[k], track[k] + (1.0 - fade[k]) * offset, 50)
            if angles is None:
                break
            knots.append(angles)
        if len(knots) < len(nodes):
            continue
        knots = np.array(knots)
        velocity = np.gradient(knots, nodes, axis=0)
        velocity[0] = velocity[-1] = 0.0
        acceleration = (velocity[1:] - velocity[:-1]) / problem.h
        yield f"end branch {number}", problem.join(knots, velocity, acceleration)
