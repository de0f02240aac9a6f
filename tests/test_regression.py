"""Regression pins: torqueopt's own numbers on fixed runs against ``tests/golden/pins.json``.

These are not independent checks (those are the other modules: closed forms,
finite differences, optimality conditions, the paper's claims); they catch an
unintended change of the numbers. Regenerate the golden file after an
intended change with ``python -m tests.regenerate`` (see tests/regenerate.py).

Tolerances survive a change of linear solver or a reordered sum, which move
these numbers by about 1e-12 relative (measured: a 1e-13 relative change of
q0 moves the long runs' peaks by at most 1.4e-12), and still catch a change
of one step:

* torques, speeds, ratios, tip errors, gravity: 1e-6 relative;
* times on the step grid (first limit violation, instability, speed peaks):
  1e-6 relative, far below one step (1 ms in 1 s is 1e-3);
* interpolated alignment times: 1e-6 relative.
"""

import json

import numpy as np
import pytest

from .regenerate import GOLDEN, compute_pins

RTOL = 1e-6
#: Tip errors of the stable runs are a few µm; below 1 nm their digits are round-off.
TIP_ATOL = 1e-9


@pytest.fixture(scope="module")
def golden():
    return json.loads(GOLDEN.read_text())


@pytest.fixture(scope="module")
def pins(paper, planar3):
    return compute_pins(paper, planar3)


def assert_pinned(value, expected, what, atol=0.0):
    if expected is None or value is None:
        assert value == expected, f"{what}: {value} against golden {expected}"
        return
    np.testing.assert_allclose(value, expected, rtol=RTOL, atol=atol, err_msg=what)


def test_the_golden_file_covers_the_same_runs(pins, golden):
    assert {section: set(entries) for section, entries in pins.items()} == {
        section: set(entries) for section, entries in golden.items()
    }


@pytest.mark.parametrize(
    "field", ["peak_torque", "peak_joint_speed", "peak_joint_speed_time", "first_limit_violation",
              "instability_time", "links_2_3_aligned"]
)  # fmt: skip
def test_paper_runs(pins, golden, field):
    for key, expected in golden["paper_runs"].items():
        assert_pinned(pins["paper_runs"][key][field], expected[field], f"{key} {field}")


def test_paper_tip_errors(pins, golden):
    for key, expected in golden["paper_runs"].items():
        assert_pinned(pins["paper_runs"][key]["max_tip_error"], expected["max_tip_error"], key, atol=TIP_ATOL)


def test_free_swing(pins, golden):
    for field, expected in golden["free_swing"].items():
        assert_pinned(pins["free_swing"][field], expected, f"free swing {field}")


def test_runs_off_the_papers_start(pins, golden):
    for key, expected in golden["other_runs"].items():
        for field, value in expected.items():
            assert_pinned(pins["other_runs"][key][field], value, f"{key} {field}")
