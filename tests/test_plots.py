"""Figures: the arm's stick points against closed-form kinematics, every figure kind, and ``torqueopt plot``."""

import math

import matplotlib.figure
import numpy as np
import pytest

import torqueopt
from torqueopt import plots
from torqueopt.cli import main
from torqueopt.errors import InvalidInput

PNG = b"\x89PNG\r\n\x1a\n"
PAPER_Q0 = np.radians([-45.0, 135.0, -135.0])


@pytest.fixture(scope="module")
def planar3():
    return torqueopt.load_robot("planar3")


@pytest.fixture(scope="module")
def short_runs(planar3):
    line = torqueopt.StraightLine((1.0, 1.0), duration=0.5)
    return [torqueopt.simulate(planar3, name, line, PAPER_Q0) for name in ("pinv", "null-space")]


@pytest.fixture(scope="module")
def stopped_run(planar3):
    # The long null-space movement, stopped by a low speed ceiling in the middle of its whip.
    line = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
    return torqueopt.simulate(planar3, "null-space", line, PAPER_Q0, max_joint_speed=5.0)


@pytest.fixture
def titles(monkeypatch):
    """Every figure title drawn during the test."""
    drawn = []
    original = matplotlib.figure.Figure.suptitle

    def spy(self, text, **kwargs):
        drawn.append(text)
        return original(self, text, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "suptitle", spy)
    return drawn


def assert_png(path):
    assert path.read_bytes()[:8] == PNG
    assert not list(path.parent.glob(".*.part")), "a temporary file was left behind"


def test_arm_points_are_the_planar_forward_kinematics(planar3, rng):
    for angles in [PAPER_Q0, *rng.uniform(-math.pi, math.pi, (5, 3))]:
        absolute = np.cumsum(angles)
        joints = np.vstack([[0.0, 0.0], np.cumsum(np.column_stack([np.cos(absolute), np.sin(absolute)]), axis=0)])
        points = plots.arm_points(planar3, angles)
        np.testing.assert_allclose(points[:, :2], joints, atol=1e-12)
        np.testing.assert_allclose(points[:, 2], 0.0, atol=1e-12)


def test_arm_points_end_at_the_task_frame_of_a_3d_arm(panda):
    q = panda.default_configuration
    points = plots.arm_points(panda, panda.joint_angles(q))
    assert points.shape == (panda.nv + 1, 3)
    np.testing.assert_allclose(points[-1], panda.frame_placement(q).translation, atol=1e-12)


@pytest.mark.slow
def test_torque_motion_and_tip_figures(tmp_path, short_runs, titles):
    torques = plots.plot_torques(short_runs, tmp_path / "torques.png", title="short", instability_times={"pinv": 0.2})
    motion = plots.plot_motion(short_runs[1], tmp_path / "motion.png", title="motion", events={"event": 0.25})
    tip = plots.plot_tip_path(short_runs, tmp_path / "tip.png", title="tip")
    for path in (torques, motion, tip):
        assert_png(path)
    assert titles == ["short", "motion", "tip"]


def test_stick_strips_for_the_planar_arm_and_a_3d_arm(tmp_path, planar3, short_runs, panda):
    assert_png(plots.plot_stick_strip(planar3, short_runs[1], tmp_path / "planar.png", title="planar", snapshots=6))
    line = torqueopt.StraightLine((0.0, 1.0, 0.0), accel=0.2, duration=0.2)
    run = torqueopt.simulate(panda, "pinv", line, panda.default_configuration)
    assert_png(plots.plot_stick_strip(panda, run, tmp_path / "panda.png", title="panda", snapshots=4))


def test_snapshots_crowd_where_the_joints_move_fast(stopped_run):
    rows = plots.stick._snapshot_rows(stopped_run, 8)
    assert rows[0] == 0 and rows[-1] == len(stopped_run.t) - 1
    # The run's second half (from 0.7 s) holds most of its joint motion, so most snapshots.
    assert sum(stopped_run.t[rows] > 0.7) >= 4


@pytest.mark.slow
def test_a_stopped_run_is_drawn_up_to_its_stop_and_says_so(tmp_path, stopped_run, titles):
    assert not stopped_run.completed and 1.0 < stopped_run.stop_time < 2.0
    assert_png(plots.plot_run(stopped_run, tmp_path / "run.png"))
    assert titles[-1].startswith(
        "planar3: resolver null-space, task xy at 'tip', 2 s\nnull-space STOPPED EARLY at t = "
    )
    assert "speed of joint" in titles[-1] and "(drawn up to there)" in titles[-1]


@pytest.mark.parametrize("snapshots", [1, 25, 2.5])
def test_bad_snapshot_counts(tmp_path, planar3, short_runs, snapshots):
    with pytest.raises(InvalidInput, match=rf"^snapshots={snapshots!r} must be a whole number from 2 to 24$"):
        plots.plot_stick_strip(planar3, short_runs[0], tmp_path / "x.png", title="x", snapshots=snapshots)


def test_no_runs_to_plot(tmp_path):
    with pytest.raises(InvalidInput, match=r"^no runs to plot: give at least one SimResult$"):
        plots.plot_torques([], tmp_path / "x.png", title="x")


# -- torqueopt plot ------------------------------------------------------------
@pytest.fixture(scope="module")
def saved_runs(tmp_path_factory, short_runs, stopped_run):
    folder = tmp_path_factory.mktemp("runs")
    short_runs[0].to_csv(folder / "short.csv")
    short_runs[0].to_csv(folder / "short.npz")
    stopped_run.to_csv(folder / "stopped.csv")
    return folder


@pytest.mark.slow
def test_plot_command_writes_the_figure_beside_the_run(saved_runs, capsys):
    assert main(["plot", str(saved_runs / "short.csv")]) == 0
    assert capsys.readouterr().out == f"wrote {saved_runs / 'short.png'}\n"
    assert_png(saved_runs / "short.png")


@pytest.mark.slow
def test_plot_command_reads_npz_and_takes_out_and_title(saved_runs, tmp_path, capsys, titles):
    out = tmp_path / "figures" / "mine.png"
    assert main(["plot", str(saved_runs / "short.npz"), "--out", str(out), "--title", "my run"]) == 0
    assert_png(out)
    assert titles == ["my run"]


def test_plot_command_on_a_stopped_run(saved_runs, tmp_path, capsys):
    out = tmp_path / "stopped.png"
    assert main(["plot", str(saved_runs / "stopped.csv"), "--out", str(out)]) == 0
    stop = torqueopt.load_result(saved_runs / "stopped.csv").stop_time
    assert capsys.readouterr().out == f"wrote {out} (the run stopped early at t = {stop:.3f} s)\n"
    assert_png(out)


def malformed_runs(folder):
    """(file, the error it should give) for run files that cannot be read."""
    good = (folder / "short.csv").read_text()
    sidecar = (folder / "short.csv.json").read_text()
    cases = []
    path = folder / "garbage.csv"
    path.write_text("t,q1\nnot,numbers\n")
    (folder / "garbage.csv.json").write_text(sidecar)
    cases.append((path, f"run file '{path}' is malformed (could not convert string 'not' to float64"))
    path = folder / "no-sidecar.csv"
    path.write_text(good)
    cases.append((path, f"run file '{path}' has no sidecar '{path}.json'; write runs with torqueopt run --out"))
    path = folder / "bad-sidecar.csv"
    path.write_text(good)
    (folder / "bad-sidecar.csv.json").write_text("{not json")
    cases.append((path, (f"run file '{path}' is malformed (Expecting property name enclosed in double quotes: line 1 "
                        "column 2 (char 1)); write runs with torqueopt run --out")))  # fmt: skip
    path = folder / "thin-sidecar.csv"
    path.write_text(good)
    (folder / "thin-sidecar.csv.json").write_text("{}")
    cases.append((path, (f"run file '{path}' is malformed (missing field 'joint_names'); write runs with torqueopt "
                        "run --out")))  # fmt: skip
    path = folder / "broken.npz"
    path.write_bytes(b"PK\x03\x04 this is no zip archive")
    cases.append((path, f"run file '{path}' is malformed ("))
    return cases


def test_plot_command_refuses_missing_and_malformed_files(saved_runs, tmp_path, capsys):
    missing = tmp_path / "nowhere.csv"
    assert main(["plot", str(missing)]) == 2
    assert capsys.readouterr().err == f"torqueopt plot: error: run file '{missing}' does not exist\n"
    for path, message in malformed_runs(saved_runs):
        assert main(["plot", str(path)]) == 2, path
        err = capsys.readouterr().err
        assert err.startswith(f"torqueopt plot: error: {message}"), err
        assert err.count("\n") == 1, err
        assert not path.with_suffix(".png").exists()
