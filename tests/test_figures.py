"""Figures: the format the suffix names, the resolution asked for, and readable ticks."""

import itertools
import re
import struct

import numpy as np
import pytest

import torqueopt
from torqueopt import StraightLine
from torqueopt.cli import main
from torqueopt.plots import DEFAULT_DPI, plot_run


@pytest.fixture(scope="module")
def saved_run(planar3, tmp_path_factory):
    result = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.1), np.radians([-45.0, 135.0, -135.0]))
    return result.to_csv(tmp_path_factory.mktemp("run") / "run.csv")


def _png_size(path):
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", header[16:24])


# PDF runs in the quick selection (-m "not slow"); tests/test_plots.py writes PNGs there too.
@pytest.mark.parametrize(
    "suffix, magic",
    [
        (".pdf", b"%PDF-"),
        pytest.param(".svg", b"<?xml", marks=pytest.mark.slow),
        pytest.param(".png", b"\x89PNG", marks=pytest.mark.slow),
    ],
)
def test_plot_writes_the_format_its_suffix_names(saved_run, tmp_path, suffix, magic):
    out = tmp_path / f"fig{suffix}"
    assert main(["plot", str(saved_run), "--out", str(out)]) == 0
    content = out.read_bytes()
    assert content.startswith(magic)
    if suffix == ".svg":
        assert b"<svg" in content[:2000]


@pytest.mark.slow
def test_dpi_sets_the_png_resolution(saved_run, tmp_path):
    low, high = tmp_path / "low.png", tmp_path / "high.png"
    assert main(["plot", str(saved_run), "--out", str(low), "--dpi", "50"]) == 0
    assert main(["plot", str(saved_run), "--out", str(high)]) == 0
    (low_width, low_height), (high_width, high_height) = _png_size(low), _png_size(high)
    # Same figure size in inches: pixels scale with the dpi.
    assert high_width / low_width == pytest.approx(DEFAULT_DPI / 50, rel=0.02)
    assert high_height / low_height == pytest.approx(DEFAULT_DPI / 50, rel=0.02)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--out", "FIG.jpg"], "figure '.*fig.jpg' has '.jpg'; give a name ending in .png, .pdf, .svg"),
        (["--out", "FIG"], "has no suffix; give a name ending in .png, .pdf, .svg"),
        (["--dpi", "0"], r"--dpi: 0 must be a number in \(0, 1200\]"),
    ],
)
def test_an_unknown_format_or_bad_dpi_is_refused_before_work(saved_run, tmp_path, capsys, arguments, message):
    arguments = [a.replace("FIG", str(tmp_path / "fig")) for a in arguments]
    assert main(["plot", str(saved_run), *arguments]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(message, err[0])
    assert not list(tmp_path.glob("fig*"))


@pytest.mark.slow
def test_no_tick_label_is_below_8_points(saved_run, tmp_path, monkeypatch):
    """Every figure goes through one save: look at the figure it saved."""
    import torqueopt.plots.run as run_figure

    saved = []
    original_save = run_figure.save_figure

    def save(fig, path, dpi=None):
        saved.append(fig)
        return original_save(fig, path, dpi)

    monkeypatch.setattr(run_figure, "save_figure", save)
    plot_run(torqueopt.load_result(saved_run), tmp_path / "fig.png")
    sizes = [label.get_fontsize() for ax in saved[0].axes for label in (*ax.get_xticklabels(), *ax.get_yticklabels())]
    assert sizes and min(sizes) >= 8.0


def test_symlog_torque_ticks_do_not_overlap_and_come_more_than_once_a_decade():
    """Fig. 4's joint 1: limit 54 N·m, peak 510 N·m, on a panel of the paper's size."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from torqueopt.plots.canvas import symlog_scale

    fig = Figure(figsize=(9.0, 2.3), dpi=DEFAULT_DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 510, -40])
    symlog_scale(ax, 54.0, 510.0)
    fig.canvas.draw()
    ticks = sorted(ax.get_yticks())
    beyond = [tick for tick in ticks if tick > 54.0]
    assert len(beyond) >= 2 and ticks.count(54.0) == 1
    renderer = fig.canvas.get_renderer()
    boxes = sorted(
        (label.get_window_extent(renderer) for label in ax.get_yticklabels() if label.get_text()), key=lambda b: b.y0
    )
    for lower, upper in itertools.pairwise(boxes):
        assert upper.y0 >= lower.y1 - 0.5, "tick labels overlap"


def test_the_tip_panel_of_a_straight_3d_line_shows_the_deviation_in_mm():
    """A synthetic run: 0.3 m along z, with a known sideways drift of 2 mm · (t/T)²."""
    from matplotlib.figure import Figure

    from torqueopt.plots.panels import _draw_tip_path
    from torqueopt.result import SimResult

    t = np.linspace(0.0, 1.0, 101)
    start = np.array([0.3, 0.0, 0.5])
    x_ref = start + np.outer(0.3 * t, [0.0, 0.0, 1.0])
    x = x_ref + np.outer(2e-3 * t**2, [1.0, 0.0, 0.0])
    n = 2
    result = SimResult(
        robot="synthetic", frame="tip", task="position", resolver="pinv", joint_names=["a", "b"], dt=0.01,
        t=t, q=np.zeros((101, n)), joint_angles=np.zeros((101, n)), v=np.zeros((101, n)),
        acceleration=np.zeros((101, n)), tau=np.zeros((101, n)), x=x, x_ref=x_ref,
        jacobian_inverse_condition=np.ones(101), torque_upper=np.ones(n), torque_lower=-np.ones(n), duration=1.0,
    )  # fmt: skip
    ax = Figure().add_subplot()
    _draw_tip_path(ax, [result], single=True)
    tip = next(line for line in ax.get_lines() if line.get_label() == "tip")
    np.testing.assert_allclose(tip.get_xdata(), 0.3 * t, atol=1e-12)  # along the line [m], from 0
    np.testing.assert_allclose(tip.get_ydata(), 2.0 * t**2, atol=1e-9)  # off it [mm]
    assert "[mm]" in ax.get_ylabel()


def test_symlog_ticks_of_a_ratio_panel_keep_a_label_height_apart():
    """remedies_long.png: τ/τ⁺ panels (limit 1, weighted-null-space peaks at 81) about 1.5 in high, where the
    labels at ±1 and ±2 crowded."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from torqueopt.plots.canvas import symlog_scale

    fig = Figure(figsize=(9.0, 1.5), dpi=DEFAULT_DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 81.45, -30.0])
    symlog_scale(ax, 1.0, 81.45)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = sorted(
        (label.get_window_extent(renderer) for label in ax.get_yticklabels() if label.get_text()), key=lambda b: b.y0
    )
    height = boxes[0].height
    for lower, upper in itertools.pairwise(boxes):
        assert upper.y0 - lower.y1 >= 0.25 * height, "tick labels crowd"
