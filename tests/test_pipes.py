"""A result file never depends on stdout: a reader that goes away costs nothing."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import torqueopt

ROOT = Path(__file__).resolve().parent.parent
RUN = ["run", "--robot", "planar3", "--resolver", "pinv", "--q0=-0.785398,2.356194,-2.356194",
       "--direction", "1,1", "--duration", "0.5"]  # fmt: skip


def _environment(unbuffered: bool) -> dict:
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONUNBUFFERED"}
    environment["PYTHONPATH"] = str(ROOT)
    if unbuffered:
        environment["PYTHONUNBUFFERED"] = "1"
    return environment


# One case of each pipe test runs in the quick selection (-m "not slow"), the other in the full suite.
@pytest.mark.parametrize("unbuffered", [pytest.param(True, marks=pytest.mark.slow), False])
def test_a_reader_that_closed_before_the_first_line_costs_no_file(tmp_path, unbuffered):
    """The pipe's read end is closed before the command prints anything, so its
    first print fails with EPIPE: the run must still write the whole file and exit 0."""
    out = tmp_path / "run.csv"
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        process = subprocess.run(
            [sys.executable, "-m", "torqueopt", *RUN, "--out", str(out)],
            stdout=write_end, stderr=subprocess.PIPE, text=True, env=_environment(unbuffered), cwd=tmp_path,
            timeout=120, check=False,
        )  # fmt: skip
    finally:
        os.close(write_end)
    assert process.returncode == 0, process.stderr
    assert "Traceback" not in process.stderr and "BrokenPipe" not in process.stderr
    result = torqueopt.load_result(out)
    assert result.completed and len(result.t) == 501 and result.t[-1] == pytest.approx(0.5)


@pytest.mark.parametrize("unbuffered", [True, pytest.param(False, marks=pytest.mark.slow)])
def test_head_takes_one_line_and_the_file_is_complete(tmp_path, unbuffered):
    out = tmp_path / "run.csv"
    command = " ".join([f"'{sys.executable}'", "-m", "torqueopt", *RUN, "--out", str(out)])
    process = subprocess.run(
        ["bash", "-c", f'{command} | head -1; echo "status=${{PIPESTATUS[0]}}"'],
        capture_output=True, text=True, env=_environment(unbuffered), cwd=tmp_path, timeout=120, check=False,
    )  # fmt: skip
    lines = process.stdout.splitlines()
    assert lines[0].startswith("planar3: resolver pinv") and lines[-1] == "status=0", process.stdout + process.stderr
    assert "Traceback" not in process.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert len(table) == 501 and torqueopt.load_result(out).t[-1] == pytest.approx(0.5)


def test_a_stopped_run_keeps_its_exit_code_when_the_reader_is_gone(tmp_path):
    """Stretched out, planar3 is singular at its first sample: exit 3, and the
    one-row file (the state, with no torque) is written and reads back."""
    out = tmp_path / "run.csv"
    read_end, write_end = os.pipe()
    os.close(read_end)
    arguments = ["run", "--robot", "planar3", "--resolver", "pinv", "--q0=0,0,0", "--direction", "1,1"]
    try:
        process = subprocess.run(
            [sys.executable, "-m", "torqueopt", *arguments, "--out", str(out)],
            stdout=write_end, stderr=subprocess.PIPE, text=True, env=_environment(True), cwd=tmp_path,
            timeout=120, check=False,
        )  # fmt: skip
    finally:
        os.close(write_end)
    assert process.returncode == 3 and "Traceback" not in process.stderr
    result = torqueopt.load_result(out)
    assert len(result.t) == 1 and result.stop_time == 0.0 and np.isnan(result.tau).all()
