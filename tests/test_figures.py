"""Figures: the format the suffix names, the resolution asked for, and readable ticks."""

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


@pytest.mark.parametrize("suffix, magic", [(".pdf", b"%PDF-"), (".svg", b"<?xml"), (".png", b"\x89PNG")])
def test_plot_writes_the_format_its_suffix_names(saved_run, tmp_path, suffix, magic):
    out = tmp_path / f"fig{suffix}"
    assert main(["plot", str(saved_run), "--out", str(out)]) == 0
    content = out.read_bytes()
    assert content.startswith(magic)
    if suffix == ".svg":
        assert b"<svg" in content[:2000]


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
        (["--dpi", "0"], "--dpi: 0 must be a positive finite number"),
    ],
)
def test_an_unknown_format_or_bad_dpi_is_refused_before_work(saved_run, tmp_path, capsys, arguments, message):
    arguments = [a.replace("FIG", str(tmp_path / "fig")) for a in arguments]
    assert main(["plot", str(saved_run), *arguments]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(message, err[0])
    assert not list(tmp_path.glob("fig*"))


def test_no_tick_label_is_below_8_points(saved_run, tmp_path, monkeypatch):
    """Every figure goes through one save: look at the figure it saved."""
    import torqueopt.plots as plots

    saved = []
    original_save = plots._save

    def save(fig, path, dpi=None):
        saved.append(fig)
        return original_save(fig, path, dpi)

    monkeypatch.setattr(plots, "_save", save)
    plot_run(torqueopt.load_result(saved_run), tmp_path / "fig.png")
    sizes = [label.get_fontsize() for ax in saved[0].axes for label in (*ax.get_xticklabels(), *ax.get_yticklabels())]
    assert sizes and min(sizes) >= 8.0
