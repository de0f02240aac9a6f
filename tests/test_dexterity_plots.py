"""Dexterity in figures: the run panel, ellipses on stick figures (checked against the measures), ``torqueopt plot``."""

import numpy as np
import pytest

import torqueopt
from torqueopt import plots
from torqueopt.cli import main
from torqueopt.dexterity import dexterity
from torqueopt.errors import InvalidInput

from .conftest import PAPER_Q0

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def run(planar3):
    return torqueopt.simulate(
        planar3, "pinv", torqueopt.StraightLine((1.0, 1.0), duration=0.3), PAPER_Q0, dexterity=True
    )


@pytest.mark.slow
def test_the_run_figure_has_a_dexterity_panel_when_the_run_has_measures(tmp_path, run, saved_figures):
    plots.plot_run(run, tmp_path / "with.png")
    plain = torqueopt.simulate(
        torqueopt.load_robot("planar3"), "pinv", torqueopt.StraightLine((1, 1), duration=0.3), PAPER_Q0
    )
    plots.plot_run(plain, tmp_path / "without.png")
    with_panel, without_panel = saved_figures
    assert len(with_panel.axes) == len(without_panel.axes) + 1
    panel = with_panel.axes[-1]
    assert panel.get_title(loc="left") == "dexterity, as a ratio to its start value"
    lines = {line.get_label().split(" (start")[0]: line for line in panel.get_lines()}
    for label, measure in (("w, Eq. (6)", "manipulability"), ("σ_min(J)", "min_singular_value"),
                           ("dynamic w, Eq. (25)", "dynamic_manipulability")):  # fmt: skip
        values = run.dexterity[measure]
        np.testing.assert_array_equal(lines[label].get_xdata(), run.t)
        np.testing.assert_allclose(lines[label].get_ydata(), values / values[0], rtol=1e-15)
    # σ_min of the planar Jacobian, closed form, at the last sample
    absolute = np.cumsum(run.joint_angles[-1])
    jacobian = np.array(
        [[-np.sin(absolute[j:]).sum() for j in range(3)], [np.cos(absolute[j:]).sum() for j in range(3)]]
    )
    assert run.dexterity["min_singular_value"][-1] == pytest.approx(np.linalg.svd(jacobian)[1][-1], rel=1e-12)
    assert (tmp_path / "with.png").read_bytes()[:8] == PNG


# The velocity ellipses in the quick selection (-m "not slow"), both kinds in the full suite.
@pytest.mark.parametrize("kind", ["velocity", pytest.param("acceleration", marks=pytest.mark.slow)])
def test_stick_figure_ellipses_are_the_dexterity_ellipses_at_the_tip(tmp_path, planar3, run, kind, saved_figures):
    plots.plot_stick_strip(planar3, run, tmp_path / "stick.png", title="t", snapshots=3, ellipse=kind)
    figure = saved_figures[-1]
    rows = plots.stick._snapshot_rows(run, 3)
    patches = [patch for ax in figure.axes for patch in ax.patches]
    assert len(patches) == len(rows)
    shapes = []
    for patch, row in zip(patches, rows):
        outline = np.unique(patch.get_xy().round(12), axis=0)  # the closed polygon repeats its first point
        tip = run.x[row]
        np.testing.assert_allclose(outline.mean(axis=0), tip, atol=1e-3)
        measured = dexterity(planar3, run.q[row])
        ellipsoid = measured.velocity_ellipsoid if kind == "velocity" else measured.acceleration_ellipsoid
        # Half the widest extent along the major axis is the scaled largest radius.
        extent = np.abs((outline - tip) @ ellipsoid.axes[:, 0]).max()
        shapes.append(extent / ellipsoid.radii[0])
        minor = np.abs((outline - tip) @ ellipsoid.axes[:, 1]).max()
        assert minor / extent == pytest.approx(ellipsoid.radii[1] / ellipsoid.radii[0], rel=1e-3)
    # One scale for every snapshot.
    np.testing.assert_allclose(shapes, shapes[0], rtol=1e-3)


def test_a_bad_ellipse_kind_is_refused(tmp_path, planar3, run):
    with pytest.raises(InvalidInput, match="^ellipse='force' is not one of velocity, acceleration"):
        plots.plot_stick_strip(planar3, run, tmp_path / "x.png", title="x", ellipse="force")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.slow
def test_plot_command_draws_stick_figures_with_ellipses(tmp_path, run, capsys):
    saved = run.to_csv(tmp_path / "run.csv")
    assert main(["plot", str(saved), "--stick-figures", "--ellipse", "acceleration", "--snapshots", "4"]) == 0
    assert capsys.readouterr().out == f"wrote {tmp_path / 'run.png'}\nwrote {tmp_path / 'run-stick.png'}\n"
    assert (tmp_path / "run-stick.png").read_bytes()[:8] == PNG


@pytest.mark.parametrize(
    "options, message",
    [
        (["--snapshots", "30"], "argument --snapshots: 30 must be from 2 to 24"),
        (["--ellipse", "force"], "argument --ellipse: invalid choice: 'force'"),
        (["--robot", "nobot"], "unknown robot 'nobot'"),
    ],
)
def test_plot_command_bad_stick_options_write_nothing(tmp_path, run, capsys, options, message):
    saved = run.to_csv(tmp_path / "run.npz")
    code = None
    try:
        code = main(["plot", str(saved), "--stick-figures", *options])
    except SystemExit as stop:
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not list(tmp_path.glob("*.png"))
