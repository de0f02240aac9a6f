r"""A plug-in resolver: null-space velocity damping, written as a user would, outside torqueopt."""

import numpy as np

import torqueopt
from torqueopt.resolvers.options import number


class SelfMotionBrake(torqueopt.NullSpaceResolver):
    r"""Brakes the self-motion: y = −k Zᵀq̇, the least ‖(I − J⁺J)(q̈ + k q̇)‖².

    The same law as the built-in ``self-motion-damping`` (whose runs it must equal), from outside the package.
    """

    name = "self-motion-brake"
    options = (
        torqueopt.Option(
            name="gain",
            kind="number >= 0",
            unit="1/s",
            default=4.0,
            meaning="k: the rate at which the self-motion velocity decays",
            convert=number(0.0, unit="1/s"),
        ),
    )

    def null_space_function(self, robot):
        gain = self.gain

        def coordinates(terms, null_space_basis, particular):
            return -gain * null_space_basis.T @ terms.joint_velocity

        return coordinates

    def objective_function(self, robot):
        gain = self.gain

        def braked(terms, torque):
            jacobian = terms.jacobian
            projector = np.eye(jacobian.shape[1]) - np.linalg.pinv(jacobian) @ jacobian
            acceleration = np.linalg.solve(terms.inertia, torque - terms.bias_torque)
            rest = projector @ (acceleration + gain * terms.joint_velocity)
            return float(rest @ rest)

        return braked
