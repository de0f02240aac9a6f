"""Every file torqueopt writes, it reads back: also a run that stopped at its first sample."""

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.cli import main
from torqueopt.whiplash import detect_whiplash


@pytest.fixture(scope="module")
def stopped_at_start(planar3):
    # Stretched out along x, the arm's Jacobian has rank 1: singular at t = 0.
    return torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), [0.0, 0.0, 0.0])


def test_a_run_stopped_at_its_first_sample_keeps_that_state(stopped_at_start):
    result = stopped_at_start
    assert not result.completed and result.stop_time == 0.0
    assert len(result.t) == 1 and np.isnan(result.tau).all()
    np.testing.assert_allclose(result.x[0], [3.0, 0.0], atol=1e-12)
    assert result.jacobian_inverse_condition[0] == pytest.approx(0.0, abs=1e-12)
    report = detect_whiplash(result)
    assert not report.unstable and "applied no torque" in report.reason


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_it_writes_a_file_that_plot_and_play_read_back(stopped_at_start, tmp_path, suffix, capsys):
    path = stopped_at_start.to_csv(tmp_path / f"run{suffix}")
    back = torqueopt.load_result(path)
    assert len(back.t) == 1 and back.stop_reason == stopped_at_start.stop_reason
    np.testing.assert_allclose(back.x, stopped_at_start.x)
    assert main(["plot", str(path), "--out", str(tmp_path / "fig.png")]) == 0
    assert (tmp_path / "fig.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["play", str(path), "--html", str(tmp_path / "run.html")]) == 0
    assert "1 frame over" in capsys.readouterr().out
