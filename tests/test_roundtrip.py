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


@pytest.mark.slow
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


@pytest.fixture(scope="module")
def short_run(planar3):
    return torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.05), np.radians([-45.0, 135.0, -135.0]))


def _rewrite_columns(path, order=None, rename=None):
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:]]
    if order is not None:
        header = [header[i] for i in order]
        rows = [[row[i] for i in order] for row in rows]
    if rename is not None:
        header = [rename.get(name, name) for name in header]
    path.write_text("\n".join(",".join(row) for row in [header, *rows]) + "\n")


def test_the_csv_loader_reads_columns_by_name(short_run, tmp_path):
    path = short_run.to_csv(tmp_path / "run.csv")
    columns = path.read_text().splitlines()[0].split(",")
    _rewrite_columns(path, order=list(reversed(range(len(columns)))))
    back = torqueopt.load_result(path)
    np.testing.assert_allclose(back.tau, short_run.tau, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(back.joint_angles, short_run.joint_angles, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(back.x_ref, short_run.x_ref, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(
    "rename, message",
    [
        ({"tau2": "torque2"}, "has no column tau2; a run of 3 joints has t, q1..q3"),
        ({"tau2": "tau1"}, "names column 'tau1' twice"),
        ({"xref2": "x3"}, "has no column xref2"),
    ],
)
def test_the_csv_loader_refuses_a_header_off_the_contract(short_run, tmp_path, rename, message):
    path = short_run.to_csv(tmp_path / "run.csv")
    _rewrite_columns(path, rename=rename)
    with pytest.raises(torqueopt.InvalidInput, match=f"run file '.*run.csv' is malformed \\(its header {message}"):
        torqueopt.load_result(path)


def test_the_csv_loader_refuses_an_unknown_column(short_run, tmp_path):
    path = short_run.to_csv(tmp_path / "run.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0] + ",bonus", *(line + ",1" for line in lines[1:])]) + "\n")
    with pytest.raises(torqueopt.InvalidInput, match="its header has unknown column 'bonus'"):
        torqueopt.load_result(path)
