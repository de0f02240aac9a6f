"""Geometry for the scene: tubes along paths and the transforms meshcat takes."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..result import SimResult

__all__ = ["decimate", "quaternion", "reach", "reference_positions", "scaled", "translation", "tube_mesh"]


def reference_positions(result: SimResult, start: np.ndarray) -> np.ndarray:
    """Reference tip positions in 3-D [m]: the task's linear rows, the start's value elsewhere (z for ``xy``)."""
    linear = min(result.x_ref.shape[1], 3)
    positions = np.tile(start, (len(result.t), 1))
    positions[:, :linear] = result.x_ref[:, :linear]
    return positions


def reach(joint_positions: np.ndarray, tip: np.ndarray) -> float:
    """Length of the polyline base joint → ... → tip [m], the arm's size."""
    points = np.vstack([joint_positions, tip])
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def decimate(points: np.ndarray, most: int) -> np.ndarray:
    """At most ``most`` of the points, evenly spread, first and last kept."""
    if len(points) <= most:
        return points
    return points[np.unique(np.linspace(0, len(points) - 1, most).round().astype(int))]


def tube_mesh(geometry, points: np.ndarray, radius: float, sides: int = 8):
    """A thin tube along a polyline, or None when the points do not move.

    WebGL draws lines one pixel wide whatever their width, too thin to see
    on a screenshot, hence tubes. The cross-section is carried along the
    path by parallel transport, so it does not twist.
    """
    points = np.asarray(points, dtype=float)
    moved = np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-6 * max(radius, 1e-9)
    points = points[np.r_[True, moved]]
    if len(points) < 2:
        return None
    steps = np.diff(points, axis=0)
    steps /= np.linalg.norm(steps, axis=1, keepdims=True)
    # At a vertex, the mean of the two steps' directions; where the path
    # turns back on itself that mean vanishes and the step ahead serves.
    tangents = np.vstack([steps[:1], steps[:-1] + steps[1:], steps[-1:]])
    lengths = np.linalg.norm(tangents, axis=1)
    reversed_here = lengths < 1e-6
    tangents[reversed_here] = np.vstack([steps, steps[-1:]])[reversed_here]
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    axis = np.eye(3)[np.argmin(np.abs(tangents[0]))]
    normal = np.cross(tangents[0], axis)
    rings = []
    angles = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    for point, tangent in zip(points, tangents):
        transported = normal - normal.dot(tangent) * tangent
        if np.linalg.norm(transported) > 1e-6:
            normal = transported
        normal = normal / np.linalg.norm(normal)
        binormal = np.cross(tangent, normal)
        rings.append(point + radius * (np.outer(np.cos(angles), normal) + np.outer(np.sin(angles), binormal)))
    vertices = np.vstack(rings)
    ring = np.arange(sides)
    following = (ring + 1) % sides
    faces = []
    for index in range(len(points) - 1):
        here, there = index * sides, (index + 1) * sides
        faces.append(np.column_stack([here + ring, here + following, there + following]))
        faces.append(np.column_stack([here + ring, there + following, there + ring]))
    return geometry.TriangularMeshGeometry(vertices, np.vstack(faces))


def scaled(placement: pin.SE3, scale: np.ndarray) -> np.ndarray:
    matrix = placement.homogeneous.copy()
    matrix[:3, :3] = matrix[:3, :3] @ np.diag(scale)
    return matrix


def translation(position: np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = position
    return matrix


def quaternion(placement: pin.SE3) -> list[float]:
    """Rotation as three.js wants it: [x, y, z, w]."""
    return pin.Quaternion(placement.rotation).coeffs().tolist()
