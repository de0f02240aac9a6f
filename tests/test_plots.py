"""Figures: the arm's stick points against closed-form kinematics, every figure kind, and ``torqueopt plot``."""

import math

import matplotlib.figure
import numpy as np
import pytest

import torqueopt
from torqueopt import plots
from torqueopt.cli import main
from torqueopt.errors import InvalidInput

from .drawn import data, horizontal_levels, labelled, vertical_marks, vertical_times

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


#: planar3's torque limits from its URDF, the paper's 54, 24 and 6 N·m.
PAPER_LIMITS = (54.0, 24.0, 6.0)


def planar_joint_points(angles):
    """Closed-form positions [m] of planar3's joint origins and tip (unit links), shape (4, 2)."""
    absolute = np.cumsum(angles)
    return np.vstack([[0.0, 0.0], np.cumsum(np.column_stack([np.cos(absolute), np.sin(absolute)]), axis=0)])


def test_the_torque_figure_draws_each_run_its_limits_and_the_instability(tmp_path, short_runs, saved_figures, titles):
    assert_png(plots.plot_torques(short_runs, tmp_path / "torques.png", title="short", instability_times={"pinv": 0.2}))
    assert titles == ["short"]
    (figure,) = saved_figures
    assert len(figure.axes) == 3
    for joint, ax in enumerate(figure.axes):
        for run in short_runs:
            t, tau = data(ax, run.resolver)
            np.testing.assert_array_equal(t, run.t)
            np.testing.assert_array_equal(tau, run.tau[:, joint])
        assert horizontal_levels(ax) == [-PAPER_LIMITS[joint], PAPER_LIMITS[joint]]
        assert vertical_marks(ax) == {"pinv unstable from 0.20 s": 0.2}
        assert f"limit ±{PAPER_LIMITS[joint]:g} N·m" in ax.get_title(loc="left")


def test_the_motion_figure_draws_the_joint_velocities_accelerations_and_events(tmp_path, short_runs, saved_figures):
    run = short_runs[1]
    assert_png(plots.plot_motion(run, tmp_path / "motion.png", title="motion", events={"event": 0.25}))
    (figure,) = saved_figures
    speed_ax, accel_ax = figure.axes
    for joint, name in enumerate(run.joint_names):
        np.testing.assert_array_equal(data(speed_ax, name)[0], run.t)
        np.testing.assert_array_equal(data(speed_ax, name)[1], run.v[:, joint])
        np.testing.assert_array_equal(data(accel_ax, name)[1], run.acceleration[:, joint])
    for ax in (speed_ax, accel_ax):
        assert vertical_marks(ax) == {"event (0.250 s)": 0.25}


def test_the_tip_figure_draws_the_deviation_across_the_line_and_the_tip_error(tmp_path, short_runs, saved_figures):
    assert_png(plots.plot_tip_path(short_runs, tmp_path / "tip.png", title="tip"))
    (figure,) = saved_figures
    path_ax, error_ax = figure.axes
    along_line = np.array([1.0, 1.0]) / math.sqrt(2.0)
    to_its_left = np.array([-1.0, 1.0]) / math.sqrt(2.0)
    assert horizontal_levels(path_ax) == [0.0]  # the reference line
    for run in short_runs:
        offset = run.x - run.x_ref[0]
        along, across = data(path_ax, f"{run.resolver} tip")
        np.testing.assert_allclose(along, offset @ along_line, atol=1e-12)
        np.testing.assert_allclose(across, 1e3 * (offset @ to_its_left), atol=1e-9)
        t, error = data(error_ax, f"{run.resolver} tip")
        np.testing.assert_array_equal(t, run.t)
        np.testing.assert_allclose(error, 1e3 * np.linalg.norm(run.x - run.x_ref, axis=1), atol=1e-9)
    # 0.5 m along the line in 0.5 s, the tip within a millimetre of it
    assert along[-1] == pytest.approx(np.linalg.norm(short_runs[0].x_ref[-1] - short_runs[0].x_ref[0]), abs=1e-3)


def stick_panels(figure):
    """(panel axes, the run's row it shows) of a stick strip; the tip path so far ends at that row."""
    panels = [ax for ax in figure.axes if any(line.get_label() == "tip path so far" for line in ax.get_lines())]
    return [(ax, len(labelled(ax, "tip path so far").get_xdata()) - 1) for ax in panels]


def test_the_planar_stick_strip_draws_the_arm_at_each_snapshot_over_the_joint_speeds(
    tmp_path, planar3, short_runs, saved_figures
):
    run = short_runs[1]
    assert_png(plots.plot_stick_strip(planar3, run, tmp_path / "planar.png", title="planar", snapshots=6))
    (figure,) = saved_figures
    panels = stick_panels(figure)
    rows = [row for _, row in panels]
    assert len(panels) == 6 and rows[0] == 0 and rows[-1] == len(run.t) - 1 and rows == sorted(set(rows))
    for ax, row in panels:
        joints = planar_joint_points(run.joint_angles[row])
        np.testing.assert_allclose(np.column_stack(data(ax, "arm (joints as dots)")), joints, atol=1e-12)
        np.testing.assert_allclose(np.column_stack(data(ax, "tip")), joints[-1:], atol=1e-12)
        np.testing.assert_allclose(np.column_stack(data(ax, "tip path so far")), run.x[: row + 1], atol=1e-12)
        np.testing.assert_allclose(np.column_stack(data(ax, "reference path")), run.x_ref, atol=1e-12)
        assert f"t = {run.t[row]:.3f} s" in [text.get_text() for text in ax.texts]
    speed_ax = figure.axes[-1]
    for joint, name in enumerate(run.joint_names):
        np.testing.assert_array_equal(data(speed_ax, f"{name} velocity")[1], run.v[:, joint])
    assert vertical_times(speed_ax) == run.t[rows].tolist()


def test_the_stick_strip_of_a_3d_arm_projects_its_pinocchio_points(tmp_path, panda, saved_figures):
    line = torqueopt.StraightLine((0.0, 1.0, 0.0), accel=0.2, duration=0.2)
    run = torqueopt.simulate(panda, "pinv", line, panda.default_configuration)
    assert_png(plots.plot_stick_strip(panda, run, tmp_path / "panda.png", title="panda", snapshots=4))
    (figure,) = saved_figures
    for ax, row in stick_panels(figure):
        drawn = np.column_stack(data(ax, "arm (joints as dots)"))
        points = plots.arm_points(panda, run.joint_angles[row])
        assert drawn.shape == (panda.nv + 1, 2)
        # An orthogonal projection on a plane: no segment drawn longer than it is, the tip where the task frame is.
        drawn_lengths = np.linalg.norm(np.diff(drawn, axis=0), axis=1)
        assert (drawn_lengths <= np.linalg.norm(np.diff(points, axis=0), axis=1) + 1e-12).all()
        np.testing.assert_allclose(data(ax, "tip path so far")[0][-1], drawn[-1, 0], atol=1e-12)
        np.testing.assert_allclose(data(ax, "tip path so far")[1][-1], drawn[-1, 1], atol=1e-12)


def test_snapshots_crowd_where_the_joints_move_fast(stopped_run):
    rows = plots.stick._snapshot_rows(stopped_run, 8)
    assert rows[0] == 0 and rows[-1] == len(stopped_run.t) - 1
    # The run's second half (from 0.7 s) holds most of its joint motion, so most snapshots.
    assert sum(stopped_run.t[rows] > 0.7) >= 4


def test_the_run_figure_draws_a_stopped_run_up_to_its_stop_and_says_so(tmp_path, stopped_run, titles, saved_figures):
    run = stopped_run
    assert not run.completed and 1.0 < run.stop_time < 2.0
    assert_png(plots.plot_run(run, tmp_path / "run.png"))
    assert titles[-1].startswith(
        "planar3: resolver null-space, task xy at 'tip', 2 s\nnull-space STOPPED EARLY at t = "
    )
    assert "speed of joint" in titles[-1] and "(drawn up to there)" in titles[-1]
    (figure,) = saved_figures
    *torque_axes, speed_ax, path_ax, error_ax = figure.axes
    assert len(torque_axes) == 3
    stop = {"null-space stopped early": run.stop_time}
    for joint, ax in enumerate(torque_axes):
        t, tau = data(ax, "torque")
        np.testing.assert_array_equal(t, run.t)
        np.testing.assert_array_equal(tau, run.tau[:, joint])
        assert horizontal_levels(ax) == [-PAPER_LIMITS[joint], PAPER_LIMITS[joint]]
        assert vertical_marks(ax) == stop
    for joint, name in enumerate(run.joint_names):
        np.testing.assert_array_equal(data(speed_ax, name)[1], run.v[:, joint])
    assert vertical_marks(speed_ax) == stop
    offset = run.x - run.x_ref[0]
    np.testing.assert_allclose(data(path_ax, "tip")[0], offset @ (np.array([1.0, 1.0]) / math.sqrt(2.0)), atol=1e-12)
    (error_line,) = [line for line in error_ax.get_lines() if len(line.get_xdata()) == len(run.t)]
    np.testing.assert_allclose(error_line.get_ydata(), 1e3 * np.linalg.norm(run.x - run.x_ref, axis=1), atol=1e-9)
    assert vertical_times(error_ax) == [run.stop_time]


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
def test_plot_command_reads_npz_and_takes_out_and_title(
    saved_runs, short_runs, tmp_path, capsys, titles, saved_figures
):
    out = tmp_path / "figures" / "mine.png"
    assert main(["plot", str(saved_runs / "short.npz"), "--out", str(out), "--title", "my run"]) == 0
    assert_png(out)
    assert titles == ["my run"]
    (figure,) = saved_figures
    for joint in range(3):
        np.testing.assert_array_equal(data(figure.axes[joint], "torque")[1], short_runs[0].tau[:, joint])


def test_plot_command_on_a_stopped_run(saved_runs, stopped_run, tmp_path, capsys, saved_figures):
    out = tmp_path / "stopped.png"
    assert main(["plot", str(saved_runs / "stopped.csv"), "--out", str(out)]) == 0
    stop = torqueopt.load_result(saved_runs / "stopped.csv").stop_time
    assert capsys.readouterr().out == f"wrote {out} (the run stopped early at t = {stop:.3f} s)\n"
    assert_png(out)
    (figure,) = saved_figures
    for joint in range(3):
        t, tau = data(figure.axes[joint], "torque")
        # the CSV keeps 10 significant digits
        np.testing.assert_allclose(t, stopped_run.t, rtol=1e-9)
        np.testing.assert_allclose(tau, stopped_run.tau[:, joint], rtol=1e-9)


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


def test_plot_command_refuses_hostile_files_and_values_in_one_line(saved_runs, tmp_path, capsys):
    """A header without rows (was IndexError), an inf torque (was OverflowError), --dpi 1e6 and a title that is
    bad mathtext (were tracebacks): one line each, exit 2, no figure."""
    good = (saved_runs / "short.csv").read_text().splitlines()
    sidecar = (saved_runs / "short.csv.json").read_text()
    empty = tmp_path / "empty.csv"
    empty.write_text(good[0] + "\n")
    (tmp_path / "empty.csv.json").write_text(sidecar)
    header = good[0].split(",")
    column = next(i for i, name in enumerate(header) if name.startswith("tau"))
    row = good[5].split(",")
    row[column] = "inf"
    infinite = tmp_path / "inf.csv"
    infinite.write_text("\n".join([*good[:5], ",".join(row), *good[6:]]) + "\n")
    (tmp_path / "inf.csv.json").write_text(sidecar)
    cases = [
        ([str(empty)], f"run file '{empty}' has no rows: nothing to plot"),
        ([str(infinite)], f"run file '{infinite}' holds an infinite torque (inf N·m at t = 0.004 s, joint "
         f"joint{header[column][3:]}): nothing to plot"),
        ([str(saved_runs / "short.csv"), "--out", str(tmp_path / "d.png"), "--dpi", "1e6"],
         "--dpi: 1e6 must be a number in (0, 1200]"),
        ([str(saved_runs / "short.csv"), "--out", str(tmp_path / "t.png"), "--title", "$\\frac{1}{$"],
         "--title '$\\frac{1}{$' is not valid mathtext (put math between $...$, or escape a literal $ as \\$)"),
    ]  # fmt: skip
    for arguments, message in cases:
        assert main(["plot", *arguments]) == 2, arguments
        assert capsys.readouterr().err == f"torqueopt plot: error: {message}\n"
    assert not list(tmp_path.glob("*.png"))


@pytest.mark.parametrize("option, value", [("--ellipse", "acceleration"), ("--snapshots", "4")])
def test_a_stick_figure_option_without_stick_figures_is_refused(saved_runs, tmp_path, capsys, option, value):
    """--ellipse without --stick-figures was silently ignored."""
    out = tmp_path / "fig.png"
    assert main(["plot", str(saved_runs / "short.csv"), "--out", str(out), option, value]) == 2
    assert capsys.readouterr().err == (
        f"torqueopt plot: error: {option} {value} shapes the stick figures, which are not drawn: add --stick-figures\n"
    )
    assert not out.exists()


def test_plot_of_a_run_without_rows_is_one_line_in_a_process_too(saved_runs, tmp_path):
    """numpy's "loadtxt: input contained no data" warning came before the error line."""
    import subprocess
    import sys
    from pathlib import Path

    empty = tmp_path / "empty.csv"
    empty.write_text((saved_runs / "short.csv").read_text().splitlines()[0] + "\n")
    (tmp_path / "empty.csv.json").write_text((saved_runs / "short.csv.json").read_text())
    root = Path(__file__).resolve().parent.parent
    process = subprocess.run([sys.executable, "-m", "torqueopt", "plot", str(empty)], capture_output=True, text=True,
                             env={**__import__("os").environ, "PYTHONPATH": str(root)}, timeout=120, check=False)  # fmt: skip
    assert process.returncode == 2
    assert process.stderr == f"torqueopt plot: error: run file '{empty}' has no rows: nothing to plot\n"


def test_plot_of_an_unstable_run_marks_when_it_went_unstable(planar3, tmp_path, saved_figures, capsys):
    """`torqueopt plot` drew the paper's long null-space run without marking its instability at 1.389 s."""
    from torqueopt.whiplash import detect_whiplash

    run = torqueopt.simulate(planar3, "null-space", torqueopt.StraightLine((1.0, 1.0), duration=2.0), PAPER_Q0)
    run.to_csv(tmp_path / "long.csv")
    report = detect_whiplash(run)
    assert report.unstable
    assert main(["plot", str(tmp_path / "long.csv"), "--out", str(tmp_path / "long.png")]) == 0
    (figure,) = saved_figures
    label = f"unstable by the whiplash detector ({report.time:.3f} s)"
    marked = [ax for ax in figure.axes if label in vertical_marks(ax)]
    assert len(marked) >= run.n + 1  # every torque panel and the velocity panel
    for ax in marked:
        assert vertical_marks(ax)[label] == pytest.approx(report.time)


def test_pinv_and_velocity_pinv_are_told_apart_by_colour():
    """kinematic_vs_kinetic_torques.png drew pinv and velocity-pinv in near-identical blues."""
    import matplotlib.colors

    from torqueopt.plots import RESOLVER_COLORS

    rgb = {name: np.array(matplotlib.colors.to_rgb(colour)) for name, colour in RESOLVER_COLORS.items()}
    assert np.linalg.norm(rgb["pinv"] - rgb["velocity-pinv"]) > 0.5
    assert len(set(RESOLVER_COLORS.values())) == len(RESOLVER_COLORS)


def curves_under_legends(figure) -> list[tuple[str, str, int]]:
    """(panel title, curve label, points) for every curve drawn in data coordinates with points under its own
    panel's legend: a legend that hides what it names."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    covered = []
    for ax in figure.axes:
        if ax.get_legend() is None:
            continue
        box = ax.get_legend().get_window_extent(canvas.get_renderer())
        for curve in ax.get_lines():
            if curve.get_transform() != ax.transData:
                continue  # a limit or an event line spans the whole panel
            points = ax.transData.transform(np.column_stack([curve.get_xdata(), curve.get_ydata()]))
            inside = (points[:, 0] > box.x0) & (points[:, 0] < box.x1) & (points[:, 1] > box.y0)
            inside &= points[:, 1] < box.y1
            if inside.any():
                covered.append((ax.get_title(loc="left"), curve.get_label(), int(inside.sum())))
    return covered


def test_the_velocity_legend_covers_no_curve_of_a_7_joint_arm(panda, tmp_path, saved_figures):
    """The panda plot's velocity legend (7 joints) sat on top of the curves."""
    line = torqueopt.StraightLine((0.0, 1.0, 0.0), accel=0.5, duration=0.4)
    run = torqueopt.simulate(panda, "pinv", line, panda.default_configuration)
    plots.plot_run(run, tmp_path / "panda.png")
    (figure,) = saved_figures
    assert curves_under_legends(figure) == []


def test_the_run_figure_of_an_arm_leaving_its_limits_keeps_every_title_inside_it(panda, tmp_path, saved_figures):
    """panda's joint 7 leaves its velocity limit at 3 ms and its position limit at 65 ms (null-space, 0.4 s along
    y): the velocity panel's title named both on one line, which ran off the figure's right edge."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    line = torqueopt.StraightLine((0.0, 1.0, 0.0), duration=0.4)
    run = torqueopt.simulate(panda, "null-space", line, panda.default_configuration)
    assert run.first_position_violation[:2] == (0.065, "panda_joint7")
    assert run.first_velocity_violation[:2] == (0.003, "panda_joint7")
    plots.plot_run(run, tmp_path / "panda.png")
    (figure,) = saved_figures
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    speed_title = next(ax for ax in figure.axes if ax.get_title(loc="left").startswith("joint velocities"))
    assert speed_title.get_title(loc="left").splitlines()[1:] == [
        "position limit left at 0.065 s (panda_joint7)",
        "velocity limit left at 0.003 s (panda_joint7)",
    ]
    for ax in figure.axes:
        box = ax._left_title.get_window_extent(canvas.get_renderer())
        assert box.x0 >= 0.0 and box.x1 <= figure.bbox.width, ax.get_title(loc="left")
    assert curves_under_legends(figure) == []


def test_no_legend_of_a_circle_run_covers_its_curves(planar3, tmp_path, saved_figures):
    """On a circle that null-space loses (unstable at 0.57 s, stopped at 1.16 s) the dexterity ratios fill their
    panel: its legend, kept at the upper left with head room above the curves, covered hundreds of points of
    each of the three."""
    circle = torqueopt.Circle(0.3, 2.0)
    run = torqueopt.simulate(planar3, "null-space", circle, np.radians([-45, 135, -135]), dexterity=True)
    assert run.stop_reason and run.dexterity
    plots.plot_run(run, tmp_path / "circle.png")
    (figure,) = saved_figures
    titles = [ax.get_title(loc="left") for ax in figure.axes if ax.get_legend() is not None]
    assert any(title.startswith("dexterity") for title in titles) and "tip path" in titles
    assert curves_under_legends(figure) == []


def test_torque_panel_titles_of_six_runs_stay_inside_the_figure(planar3, tmp_path, saved_figures):
    """kinematic_vs_kinetic_torques.png compares six runs: its panel titles ran off the right edge."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    line = torqueopt.StraightLine([1, 1], accel=np.sqrt(2), duration=0.3)
    names = ("pinv", "inertia-pinv", "null-space", "weighted-null-space", "damped-null-space", "self-motion-damping")
    runs = [torqueopt.simulate(planar3, name, line, np.radians([-45, 135, -135])) for name in names]
    plots.plot_torques(runs, tmp_path / "six.png", title="six runs")
    (figure,) = saved_figures
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    width = figure.bbox.width
    for ax in figure.axes:
        title = ax.title if ax.title.get_text() else ax._left_title
        assert title.get_text()
        box = title.get_window_extent(canvas.get_renderer())
        assert box.x0 >= 0.0 and box.x1 <= width, (title.get_text(), box.x1, width)
        assert all(name in title.get_text() for name in names)  # every run's peak is still named


def _stretched(result, rows):
    """``result`` with ``rows`` rows: its arrays repeated along time, its times evenly spaced (a long run's shapes)."""
    import dataclasses

    def stretch(value):
        if isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) == len(result.t):
            return np.resize(value, (rows, *value.shape[1:]))
        return value

    changes = {f.name: stretch(getattr(result, f.name)) for f in dataclasses.fields(result) if f.init}
    changes["t"] = np.arange(rows) * result.dt
    changes["duration"] = float(changes["t"][-1])
    changes["dexterity"] = {key: stretch(value) for key, value in (result.dexterity or {}).items()} or result.dexterity
    return dataclasses.replace(result, **changes)


@pytest.mark.slow
def test_the_run_figure_of_100000_rows_takes_memory_linear_in_the_rows(short_runs, tmp_path):
    # A 16 s run took 4.1 GB: the tip panel's full SVD of the N×3 reference built an N×N matrix (80 GB at
    # 100,000 rows). It peaks at about 32 MB (the run's arrays and the drawn lines); N² of anything is 80 GB.
    import tracemalloc

    long_run = _stretched(short_runs[1], 100_000)
    tracemalloc.start()
    try:
        plots.plot_run(long_run, tmp_path / "long.png")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert_png(tmp_path / "long.png")
    assert peak < 400e6, f"plotting 100,000 rows peaked at {peak / 1e6:.0f} MB"
