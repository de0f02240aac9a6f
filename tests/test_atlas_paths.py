"""The atlas's paths beyond the paper's line (``--path min-jerk|circle``) and the acceleration sized per arm.

The geometry is checked independently of the code that draws it: the circle's centre, plane and radius are
refitted (circumcircle of three points) from the reference a pinv run tracked, which its tip (Pinocchio's
forward kinematics of the simulated joint angles) follows, and every sampled point of every path is
measured against the reach.
"""

# ruff: noqa: E402

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pinocchio as pin
import pytest

pandas = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")
pytest.importorskip("tqdm")
if importlib.util.find_spec("distributed") is None:
    pytest.skip("the atlas needs dask[distributed]", allow_module_level=True)

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population, run_atlas
from torqueopt.atlas.population import arm_reach, default_accel, movement_trajectory
from torqueopt.cli import main
from torqueopt.errors import InvalidInput

TINY = {"workers": 0, "progress": False, "figures": False, "resolvers": ["pinv"]}


def _circumcircle(a, b, c):
    """Centre, radius and unit normal of the circle through three points in 3-D."""
    ab, ac = b - a, c - a
    normal = np.cross(ab, ac)
    centre = a + (np.dot(ac, ac) * np.cross(normal, ab) + np.dot(ab, ab) * np.cross(ac, normal)) / (
        2.0 * np.dot(normal, normal)
    )
    return centre, float(np.linalg.norm(a - centre)), normal / np.linalg.norm(normal)


@pytest.mark.parametrize("kind", ["min-jerk", "circle"])
def test_populations_are_reproducible_with_a_seed(planar3, panda, kind):
    for robot in (planar3, panda):
        spec = PopulationSpec(paths=12, durations=(0.5, 1.0), seed=3, path=kind)
        first, again = draw_population(robot, spec), draw_population(robot, spec)
        other = draw_population(robot, PopulationSpec(paths=12, durations=(0.5, 1.0), seed=4, path=kind))
        assert [m.kind for m in first] == [kind] * 24
        for a, b in zip(first, again):
            assert np.array_equal(a.q0, b.q0) and np.array_equal(a.direction, b.direction)
            assert a.length == b.length and (kind != "circle" or np.array_equal(a.centre, b.centre))
        assert not np.allclose(first[0].q0, other[0].q0)
        # The lengths are drawn, not fixed: within 0.25..1 of a·T²/4, and not all alike.
        lengths = np.array([m.length / (m.accel * m.duration**2 / 4) for m in first])
        assert lengths.min() >= 0.25 and lengths.max() <= 1.0 and lengths.std() > 0.05


@pytest.mark.parametrize("kind", ["line", "min-jerk", "circle"])
def test_every_point_of_every_path_is_within_the_reach_and_starts_well_conditioned(panda, kind):
    spec = PopulationSpec(paths=25, durations=(1.0, 2.0), seed=5, path=kind, reach_fraction=0.7, min_condition=0.1)
    base, reach = arm_reach(panda)
    data = panda.model.createData()
    for movement in draw_population(panda, spec):
        trajectory = movement_trajectory(movement)
        points = trajectory.sample(np.linspace(0.0, movement.duration, 401)).position
        assert np.linalg.norm(points - base, axis=1).max() <= 0.7 * reach + 1e-12
        q = panda.configuration(movement.q0)
        assert np.allclose(panda.task_position(q), points[0], atol=1e-12)
        jacobian = pin.computeFrameJacobian(panda.model, data, q, panda.frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
        singular_values = np.linalg.svd(jacobian, compute_uv=False)
        assert singular_values[-1] / singular_values[0] >= 0.1
        if kind == "circle":
            assert np.allclose(points[-1], points[0], atol=1e-12)  # one whole turn, back at the start


def test_the_circle_is_where_the_rows_say(tmp_path, panda):
    """Centre, plane normal and radius in the rows equal the circle refitted from the tip positions of the
    pinv run (forward kinematics of its joint angles); the circumference and the direction of travel too."""
    result = run_atlas("panda", paths=3, durations=(1.0,), out=tmp_path, seed=2, path="circle", **TINY)
    table = result.table
    assert set(table["path_kind"]) == {"circle"}
    movements = {m.path: m for m in draw_population(panda, PopulationSpec(paths=3, durations=(1.0,), seed=2,
                                                                         path="circle"))}  # fmt: skip
    for _, row in table.iterrows():
        q0 = np.array([row[f"q0_{i}"] for i in range(1, 8)])
        run = torqueopt.simulate(panda, "pinv", movement_trajectory(movements[row["path"]]), q0)
        # The tip (forward kinematics of the run's joint angles) follows the run's reference to the row's
        # tip error (open loop, it drifts by a fraction of a millimetre); the reference is the circle.
        tips = np.array([panda.task_position(q) for q in run.q])
        assert np.linalg.norm(tips - run.x_ref, axis=1).max() == pytest.approx(row["max_tip_error"], rel=1e-6)
        tips = run.x_ref
        n = len(tips)
        centre, radius, normal = _circumcircle(tips[n // 5], tips[n // 2], tips[4 * n // 5])
        row_centre = np.array([row[f"centre_{i}"] for i in (1, 2, 3)])
        row_normal = np.array([row[f"normal_{i}"] for i in (1, 2, 3)])
        assert np.allclose(row_centre, centre, atol=1e-6)
        assert row["radius"] == pytest.approx(radius, rel=1e-4)
        # The tip turns counter-clockwise about the row's normal: the same normal, sign included.
        assert np.allclose(row_normal, normal, atol=1e-4)
        assert np.abs((tips - row_centre) @ row_normal).max() < 1e-6  # every tip point in the plane
        assert np.abs(np.linalg.norm(tips - row_centre, axis=1) - row["radius"]).max() < 1e-6
        assert row["path_length"] == pytest.approx(2 * math.pi * row["radius"])
        travel = tips[5] - tips[0]
        direction = np.array([row[f"direction_{i}"] for i in (1, 2, 3)])
        assert np.dot(travel / np.linalg.norm(travel), direction) > 0.999


def test_min_jerk_rows_give_the_length_and_direction_the_tip_covers(tmp_path, planar3):
    result = run_atlas("planar3", paths=3, durations=(1.0,), out=tmp_path, seed=1, path="min-jerk", **TINY)
    movements = draw_population(planar3, PopulationSpec(paths=3, durations=(1.0,), seed=1, path="min-jerk"))
    for _, row in result.table.iterrows():
        q0 = np.array([row[f"q0_{i}"] for i in (1, 2, 3)])
        run = torqueopt.simulate(planar3, "pinv", movement_trajectory(movements[row["path"]]), q0)
        covered = planar3.task_position(run.q[-1]) - planar3.task_position(run.q[0])
        assert np.linalg.norm(covered) == pytest.approx(row["path_length"], abs=2 * row["max_tip_error"] + 1e-12)
        assert np.allclose(covered / np.linalg.norm(covered), [row["direction_1"], row["direction_2"]], atol=1e-3)
        assert 0.25 * math.sqrt(2) / 4 <= row["path_length"] <= math.sqrt(2) / 4
    assert "path `min-jerk`" in (tmp_path / "atlas.md").read_text()


def test_the_default_acceleration_is_sized_to_the_arm(tmp_path, planar3, panda):
    """√2 m/s² x reach / 3 m: exactly the paper's √2 on planar3 (reach 3 m), 0.47 of the reach in 2 s on panda."""
    assert default_accel(arm_reach(planar3)[1]) == math.sqrt(2.0)
    reach = arm_reach(panda)[1]
    assert default_accel(reach) == pytest.approx(math.sqrt(2.0) * reach / 3.0)
    assert default_accel(reach) * 2.0**2 / 4 / reach == pytest.approx(math.sqrt(2) / 3)
    result = run_atlas("panda", paths=2, durations=(0.5,), out=tmp_path, **TINY)
    population = result.summary["config"]["population"]
    assert population["accel"] == pytest.approx(0.404, abs=5e-4) and result.summary["config"]["accel_from_reach"]
    assert np.allclose(result.table["path_length"], population["accel"] * 0.25 / 4)
    assert "this arm's default: √2 m/s² x reach 0.857 m / 3 m" in (tmp_path / "atlas.md").read_text()
    given = run_atlas("panda", paths=2, durations=(0.5,), out=tmp_path / "given", accel=1.0, **TINY)
    assert given.summary["config"]["population"]["accel"] == 1.0
    assert np.allclose(given.table["path_length"], 0.25 / 4)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"path": "square"}, "path 'square' is not a kind of path: choose one of line, min-jerk, circle"),
        ({"path": "circle", "mode": "grid"}, "the grid draws lines only: path 'circle' needs mode 'random'"),
        ({"length_range": (0.5, 0.2)}, r"length_range \[0.5, 0.2\] must be two fractions 0 < LOW <= HIGH <= 1"),
    ],
)
def test_bad_path_settings(kwargs, message):
    with pytest.raises(InvalidInput, match=message):
        PopulationSpec(**kwargs)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--path", "square"], "--path: 'square' is not a kind of path for the atlas; choose one of line, min-jerk, circle"),
        (["--path", "csv:x.csv"], "--path: 'csv:x.csv' is not a kind of path for the atlas"),
        (["--path", "circle", "--length-range", "0.5"], "--length-range"),
    ],
)  # fmt: skip
def test_cli_bad_path_is_one_line_and_exit_2(tmp_path, capsys, arguments, message):
    code = main(["atlas", "--paths", "2", "--workers", "0", "--no-progress", "--out", str(tmp_path / "a"), *arguments])
    error = capsys.readouterr().err
    assert code == 2 and message in error and error.count("\n") == 1
    assert not (tmp_path / "a").exists()
