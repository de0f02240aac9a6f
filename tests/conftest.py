"""Shared fixtures: robots are loaded once per session (loading parses URDFs).

Session robots are shared by every test that asks for them: a test that
changes a robot (torque limits, gravity) loads its own. Random draws are
seeded: numpy generators from :func:`rng`, Pinocchio's ``randomConfiguration``
after ``pin.seed``.

The README's test command runs the suite on every core (pytest-xdist, ``-n auto --dist loadfile``): each
test file runs whole on one worker, in file order, so a module-scoped fixture is computed once and a test
that reads what an earlier one of its file wrote (tests/test_readme.py's page commands) still finds it.
Session fixtures are computed once per worker that needs them.
"""

import os

import numpy as np
import pytest

import torqueopt
from torqueopt.paper import PAPER, run_paper

# Work that takes more than a second says so on stderr (torqueopt.progress.said_if_slow): a loaded machine
# would then add lines to what the tests compare. Never here, and in no subprocess of a test, unless the test
# asks for it (tests/test_progress.py).
os.environ["TORQUEOPT_SLOW_SECONDS"] = "3600"

#: The paper's start configuration, q0 = (-45°, 135°, -135°) [rad].
PAPER_Q0 = np.array(PAPER.q0)


@pytest.fixture(scope="session")
def planar3():
    """The paper's arm as the catalogue loads it: limits 54, 24, 6 N·m from its URDF, gravity off."""
    return torqueopt.load_robot("planar3")


@pytest.fixture(scope="session")
def paper():
    """Every run of the paper's experiment (:func:`torqueopt.paper.run_paper` on :data:`PAPER`), computed once."""
    return run_paper()


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
def saved_figures(monkeypatch):
    """Every matplotlib figure saved during the test, in the order saved: their artists hold what was drawn."""
    import matplotlib.figure

    figures = []
    original = matplotlib.figure.Figure.savefig

    def spy(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    return figures


@pytest.fixture(scope="session")
def chromium():
    """The headless Chromium the browser tests drive; the test skips, saying why, where none is found."""
    from torqueopt import viewer
    from torqueopt.errors import MissingDependency

    try:
        return viewer.find_browser()
    except MissingDependency as missing:
        pytest.skip(f"headless browser test needs Chromium: {missing}")


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)
