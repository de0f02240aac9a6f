"""Shared fixtures: robots are loaded once per session (loading parses URDFs)."""

import numpy as np
import pytest

import torqueopt

#: The paper's start configuration, q0 = (-45°, 135°, -135°).
PAPER_Q0 = np.radians([-45.0, 135.0, -135.0])


@pytest.fixture(scope="session")
def planar3():
    return torqueopt.load_robot("planar3")


@pytest.fixture(scope="session")
def panda():
    return torqueopt.load_robot("panda", task="position")


@pytest.fixture(scope="session")
def panda_pose():
    return torqueopt.load_robot("panda", task="pose")


@pytest.fixture(scope="session")
def xarm7():
    return torqueopt.load_robot("xarm7", task="position")


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)
