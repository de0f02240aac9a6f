"""The forest's CRBA pass, which the kinetic-energy stack takes for its H instead of ``computeMinverse``'s H⁻¹.

CRBA in the WORLD convention computes the world-frame joint Jacobians and placements on its way: the forest reads
J and the tip from that pass, so they must be bit for bit those of the plain Jacobian pass. Its H per row must be
the robot's own CRBA H, and the inverse the stack takes of it (``stacked_symmetric_inverse``) the robot's own
``computeMinverse``.
"""

import numpy as np
import pinocchio as pin
import pytest

from torqueopt.resolvers.velocity.pseudoinverse import stacked_symmetric_inverse
from torqueopt.robot_copies import RobotForest


def _states(robot, count, seed):
    rng = np.random.default_rng(seed)
    low = np.maximum(robot.model.lowerPositionLimit, -3.0)
    high = np.minimum(robot.model.upperPositionLimit, 3.0)
    return rng.uniform(low, high, (count, robot.nv))


def _relative(ours, theirs):
    return np.max(np.abs(ours - theirs)) / (1.0 + np.max(np.abs(theirs)))


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_inertia_pass_gives_the_plain_passes_kinematics(name, planar3, panda):
    robot = {"planar3": planar3, "panda": panda}[name]
    q = _states(robot, 13, seed=5)
    plain = RobotForest(robot, copies=5).kinematics(q, joints=True)
    with_inertia = RobotForest(robot, copies=5).kinematics(q, inertia=True, joints=True)
    assert np.array_equal(with_inertia.jacobian, plain.jacobian) and np.array_equal(with_inertia.tip, plain.tip)
    for field in ("jacobian", "origins", "rotations"):
        assert np.array_equal(getattr(with_inertia.joints, field), getattr(plain.joints, field)), field
    assert plain.inertia is None and with_inertia.inverse_inertia is None and with_inertia.rate is None
    with pytest.raises(ValueError):
        RobotForest(robot, copies=5).kinematics(q, np.zeros_like(q), inertia=True)
    with pytest.raises(ValueError):
        RobotForest(robot, copies=5).kinematics(q, inertia=True, inverse_inertia=True)


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_inertia_pass_gives_each_robots_inertia_and_its_inverse_computeminverses(name, planar3, panda):
    """13 states through a forest of 5 copies (three passes, the last partly filled): H against the robot's own
    CRBA (made whole from its upper triangle), H⁻¹ of the stacked inverse against its own ``computeMinverse``."""
    robot = {"planar3": planar3, "panda": panda}[name]
    q = _states(robot, 13, seed=9)
    inertia = RobotForest(robot, copies=5).kinematics(q, inertia=True).inertia
    inverse = stacked_symmetric_inverse(inertia)
    model, data = robot.model, robot.model.createData()
    for i in range(len(q)):
        upper = pin.crba(model, data, q[i])
        assert _relative(inertia[i], np.triu(upper) + np.triu(upper, 1).T) < 1e-13
        assert _relative(inverse[i], pin.computeMinverse(model, data, q[i])) < 1e-13


def test_the_stacked_symmetric_inverse_of_three_by_three_matrices_is_lapacks():
    """The cofactor form for n = 3 on random symmetric positive-definite stacks, against numpy's inverse."""
    rng = np.random.default_rng(2)
    factors = rng.normal(size=(50, 3, 3))
    matrices = factors @ np.swapaxes(factors, 1, 2) + 0.1 * np.eye(3)
    assert _relative(stacked_symmetric_inverse(matrices), np.linalg.inv(matrices)) < 1e-12
    assert np.allclose(stacked_symmetric_inverse(matrices) @ matrices, np.eye(3), atol=1e-10)
