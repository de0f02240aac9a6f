"""The trajectory protocol and its movements: derivatives, rest to rest, geometry, files, simulate and the CLI."""

import json
import math

import numpy as np
import pytest

import torqueopt
from torqueopt import Circle, InvalidInput, MinimumJerkLine, StraightLine, WaypointPath
from torqueopt.cli import main


def cross2(a, b):
    """z component of the cross product of planar vectors (rows)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


PAPER_Q0 = np.radians([-45.0, 135.0, -135.0])
WAYPOINTS_2D = (np.array([0.0, 0.4, 1.0, 1.5]), np.array([[0.0, 0.0], [0.1, 0.05], [0.15, -0.1], [0.3, 0.0]]))
WAYPOINTS_3D = (np.array([0.0, 0.3, 0.8]), np.array([[0.2, 0.1, 0.5], [0.25, 0.1, 0.55], [0.3, 0.0, 0.5]]))

SMOOTH = {
    "min-jerk 2-D": MinimumJerkLine([1.0, 2.0], length=0.7, duration=1.3).anchored([0.5, -0.2]),
    "min-jerk 3-D": MinimumJerkLine([0.0, 1.0, 1.0], length=0.2, duration=0.9).anchored([0.3, 0.0, 0.4]),
    "circle 2-D": Circle(0.25, 1.7).anchored([1.0, 0.5]),
    "circle 2 turns": Circle(0.1, 2.0, turns=2, centre_direction=[0.0, 1.0]).anchored([1.0, 0.5]),
    "circle 3-D tilted": Circle(0.15, 1.1, normal=[1.0, 0.0, 1.0]).anchored([0.4, 0.2, 0.6]),
    "waypoints 2-D": WaypointPath(*WAYPOINTS_2D).anchored([1.2, -0.3]),
    "waypoints 3-D": WaypointPath(*WAYPOINTS_3D, start=WAYPOINTS_3D[1][0]),
}


@pytest.mark.parametrize("name", SMOOTH)
def test_velocity_and_acceleration_are_the_derivatives_of_position(name):
    trajectory = SMOOTH[name]
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0.02, trajectory.duration - 0.02, 25))
    h = 1e-5
    before, here, after = trajectory.sample(t - h), trajectory.sample(t), trajectory.sample(t + h)
    scale = max(1.0, np.abs(here.acceleration).max())
    np.testing.assert_allclose((after.position - before.position) / (2 * h), here.velocity, atol=1e-7 * scale)
    np.testing.assert_allclose((after.velocity - before.velocity) / (2 * h), here.acceleration, atol=1e-6 * scale)


@pytest.mark.parametrize("name", SMOOTH)
def test_every_movement_is_rest_to_rest_and_rests_outside_its_duration(name):
    trajectory = SMOOTH[name]
    total = trajectory.duration
    edges = trajectory.sample(np.array([-0.5, 0.0, total, total + 0.5]))
    np.testing.assert_allclose(edges.velocity, 0.0, atol=1e-12)
    np.testing.assert_allclose(edges.acceleration, 0.0, atol=1e-9)
    np.testing.assert_allclose(edges.position[0], trajectory.start, atol=1e-12)
    np.testing.assert_allclose(edges.position[1], trajectory.start, atol=1e-12)
    np.testing.assert_allclose(edges.position[3], edges.position[2], atol=1e-12)
    np.testing.assert_allclose(trajectory.end, edges.position[2], atol=1e-12)
    # A scalar time gives vectors, an array of times a table.
    single = trajectory.sample(0.3 * total)
    assert single.position.shape == (trajectory.dimension,)
    np.testing.assert_allclose(single.velocity, trajectory.sample(np.array([0.3 * total])).velocity[0])
    # The record a result file keeps is plain JSON.
    record = json.loads(json.dumps(trajectory.describe()))
    assert record["duration"] == total and record["start"] == pytest.approx(list(trajectory.start))


def test_minimum_jerk_line_has_the_quintic_profile():
    line = MinimumJerkLine([3.0, 4.0], length=2.0, duration=1.5).anchored([1.0, -1.0])
    np.testing.assert_allclose(line.direction, [0.6, 0.8])
    t = np.linspace(0.0, 1.5, 15001)
    tau = t / 1.5
    sample = line.sample(t)
    arc = (sample.position - [1.0, -1.0]).dot(line.direction)
    np.testing.assert_allclose(arc, 2.0 * (10 * tau**3 - 15 * tau**4 + 6 * tau**5), atol=1e-12)
    # The path stays on the line.
    np.testing.assert_allclose(cross2(sample.position - [1.0, -1.0], line.direction), 0.0, atol=1e-12)
    np.testing.assert_allclose(line.end, [1.0 + 1.2, -1.0 + 1.6])
    speed = sample.velocity.dot(line.direction)
    assert speed.max() == pytest.approx(line.peak_speed, rel=1e-8) == pytest.approx(15 * 2.0 / (8 * 1.5))
    tangential = sample.acceleration.dot(line.direction)
    assert tangential.max() == pytest.approx(10 * math.sqrt(3) * 2.0 / (3 * 1.5**2), rel=1e-6)
    assert line.peak_acceleration == pytest.approx(tangential.max(), rel=1e-6)


def test_default_minimum_jerk_line_is_as_long_as_the_papers_long_movement():
    line, paper = MinimumJerkLine([1, 1]), StraightLine([1, 1])
    assert line.length == pytest.approx(paper.length) and line.duration == paper.duration


def test_circle_closes_on_itself_at_its_radius_turning_counter_clockwise():
    circle = Circle(0.3, 2.0).anchored([1.0, 1.0])
    t = np.linspace(0.0, 2.0, 2001)
    sample = circle.sample(t)
    # Default centre: towards the base (the world z axis), here towards the origin.
    np.testing.assert_allclose(circle.centre, np.array([1.0, 1.0]) * (1 - 0.3 / math.sqrt(2)))
    np.testing.assert_allclose(np.linalg.norm(sample.position - circle.centre, axis=1), 0.3, atol=1e-12)
    np.testing.assert_allclose(sample.position[-1], sample.position[0], atol=1e-12)
    radial = sample.position - circle.centre
    assert np.all(cross2(radial, sample.velocity)[1:-1] > 0)
    # The angle swept is one full turn.
    angle = np.unwrap(np.arctan2(radial[:, 1], radial[:, 0]))
    assert angle[-1] - angle[0] == pytest.approx(2 * math.pi)
    speed = np.linalg.norm(sample.velocity, axis=1)
    assert speed.max() == pytest.approx(circle.peak_speed, rel=1e-6) == pytest.approx(15 * math.pi * 0.3 / 8)


def test_two_turns_pass_the_start_half_way():
    circle = Circle(0.1, 2.0, turns=2).anchored([0.5, 0.0])
    middle = circle.sample(1.0)
    np.testing.assert_allclose(middle.position, [0.5, 0.0], atol=1e-12)
    assert np.linalg.norm(middle.velocity) == pytest.approx(circle.peak_speed)


def test_a_three_dimensional_circle_lies_in_its_plane():
    normal = np.array([0.0, 1.0, 1.0]) / math.sqrt(2)
    circle = Circle(0.2, 1.0, normal=[0.0, 1.0, 1.0], centre_direction=[1.0, 0.0, 0.0]).anchored([0.3, 0.1, 0.5])
    np.testing.assert_allclose(circle.centre, [0.5, 0.1, 0.5])
    sample = circle.sample(np.linspace(0.0, 1.0, 501))
    offsets = sample.position - circle.centre
    np.testing.assert_allclose(offsets.dot(normal), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(offsets, axis=1), 0.2, atol=1e-12)
    # Counter-clockwise about the normal.
    assert np.all(np.cross(offsets, sample.velocity)[1:-1].dot(normal) > 0)
    assert circle.dimension == 3


def test_default_centre_of_a_horizontal_circle_is_towards_the_vertical_axis():
    circle = Circle(0.1, 1.0).anchored([0.0, 0.4, 0.7])
    np.testing.assert_allclose(circle.centre, [0.0, 0.3, 0.7])
    on_axis = Circle(0.1, 1.0).anchored([0.0, 0.0, 0.7])
    np.testing.assert_allclose(on_axis.centre, [-0.1, 0.0, 0.7])


def test_waypoint_path_passes_through_its_waypoints():
    times, points = WAYPOINTS_2D
    path = WaypointPath(times, points).anchored([1.0, 2.0])
    np.testing.assert_allclose(path.sample(times).position, points + np.array([1.0, 2.0]), atol=1e-12)
    world = WaypointPath(*WAYPOINTS_3D, start=WAYPOINTS_3D[1][0])
    np.testing.assert_allclose(world.sample(WAYPOINTS_3D[0]).position, WAYPOINTS_3D[1], atol=1e-12)
    assert path.duration == 1.5 and path.dimension == 2


def test_two_waypoints_give_the_minimum_jerk_line():
    path = WaypointPath([0.0, 1.2], [[0.0, 0.0], [0.3, 0.4]]).anchored([0.1, 0.2])
    line = MinimumJerkLine([0.3, 0.4], length=0.5, duration=1.2).anchored([0.1, 0.2])
    t = np.linspace(0.0, 1.2, 97)
    for mine, theirs in zip(
        (path.sample(t).position, path.sample(t).velocity, path.sample(t).acceleration),
        (line.sample(t).position, line.sample(t).velocity, line.sample(t).acceleration),
    ):
        np.testing.assert_allclose(mine, theirs, atol=1e-10)


def test_waypoints_from_a_csv_file(tmp_path):
    path = tmp_path / "path.csv"
    path.write_text("t,x,y,z\n0,0.2,0.1,0.5\n0.3, 0.25,0.1,0.55\n\n0.8,0.3,0.0,0.5\n")
    relative = WaypointPath.from_csv(path)
    assert relative.start is None and relative.source == str(path) and relative.dimension == 3
    absolute = WaypointPath.from_csv(path, absolute=True)
    np.testing.assert_allclose(absolute.sample(WAYPOINTS_3D[0]).position, WAYPOINTS_3D[1], atol=1e-12)


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "is empty; give a header t,x,y or t,x,y,z"),
        ("time,x,y\n0,0,0\n1,1,1\n", "row 1: header 'time,x,y' must be t,x,y or t,x,y,z"),
        ("t,x,y\n0,0,0\n1,1\n", "row 3: 2 values, the header has 3"),
        ("t,x,y\n0,0,0\n1,abc,0\n", "row 3: '1,abc,0' is not all numbers"),
        ("t,x,y\n0,0,0\n1,nan,0\n", "row 3: '1,nan,0' has a non-finite value"),
        (
            "t,x,y\n0,0,0\n1,1,1\n1,2,2\n",
            "row 4: time 1 s is not after the previous row's 1 s; times must increase strictly",
        ),
        ("t,x,y\n0.5,0,0\n1,1,1\n", "row 2: the first time is 0.5 s, not 0"),
        ("t,x,y\n0,0,0\n", "has 1 waypoint rows; give at least 2"),
    ],
)
def test_bad_waypoint_files_name_the_row(text, message, tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InvalidInput, match="^waypoint file '.*bad.csv' ") as error:
        WaypointPath.from_csv(path)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_missing_waypoint_file_is_named(tmp_path):
    with pytest.raises(InvalidInput, match="waypoint file '.*none.csv' does not exist"):
        WaypointPath.from_csv(tmp_path / "none.csv")


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: MinimumJerkLine([0, 0]), r"direction \[0.0, 0.0\] is zero"),
        (lambda: MinimumJerkLine([1, 1], length=-1), r"length=-1 must be a positive finite number \[m\]"),
        (lambda: MinimumJerkLine([1, 1], start=[0, 0, 0]), "start .* must be 2 finite numbers like the direction"),
        (lambda: Circle(0, 1), r"radius=0 must be a positive finite number \[m\]"),
        (lambda: Circle(0.1, float("nan")), r"duration=nan must be a positive finite number \[s\]"),
        (lambda: Circle(0.1, 1, turns=0), "turns=0 must be a whole number >= 1"),
        (lambda: Circle(0.1, 1, turns=1.5), "turns=1.5 must be a whole number >= 1"),
        (lambda: Circle(0.1, 1, normal=[0, 0]), r"normal \[0.0, 0.0\] must be 3 finite numbers"),
        (lambda: Circle(0.1, 1, normal=[0, 0, 0]), "normal .* is zero"),
        (lambda: Circle(0.1, 1, centre_direction=[0, 0, 2]), "is zero or along the normal"),
        (
            lambda: Circle(0.1, 1, normal=[0, 0, 1], centre_direction=[1, 0]),
            "has 2 values but the normal makes the circle 3-D",
        ),
        (lambda: Circle(0.1, 1, centre_direction=[1, 0], start=[0, 0, 0]), "has 3 values but the circle is 2-D"),
        (lambda: WaypointPath([0, 1], [[0, 0, 0, 0], [1, 1, 1, 1]]), r"waypoints have shape \(2, 4\)"),
        (lambda: WaypointPath([0, 1, 2], [[0, 0], [1, 1]]), "3 waypoint times but 2 waypoints"),
        (
            lambda: WaypointPath([0, 2, 1], [[0, 0], [1, 1], [2, 2]]),
            "waypoint 3 time 1 s is not after the previous one, 2 s; times must increase strictly",
        ),
        (lambda: WaypointPath([1, 2], [[0, 0], [1, 1]]), "the first waypoint time is 1 s; times count from 0"),
        (lambda: Circle(0.1, 1).sample(0.5), "this Circle has no start point; use anchored"),
    ],
)
def test_bad_trajectories_are_rejected_with_the_value(make, message):
    with pytest.raises(InvalidInput, match=message):
        make()


# -- simulate takes any trajectory -------------------------------------------------


def test_simulate_follows_a_circle_and_records_it(planar3, tmp_path):
    circle = Circle(0.05, 1.0)
    result = torqueopt.simulate(planar3, "pinv", circle, PAPER_Q0)
    start = planar3.task_position(planar3.configuration(PAPER_Q0))
    reference = circle.anchored(start).sample(result.t).position
    np.testing.assert_allclose(result.x_ref, reference)
    np.testing.assert_allclose(result.x_ref[-1], result.x_ref[0], atol=1e-12)
    assert result.completed and result.max_tip_error < 0.01 * circle.radius
    assert result.trajectory["kind"] == "circle" and result.trajectory["radius"] == 0.05
    assert result.trajectory["start"] == pytest.approx(list(start))
    for name in ("run.npz", "run.csv"):
        loaded = torqueopt.load_result(result.to_csv(tmp_path / name))
        assert loaded.trajectory == result.trajectory


def test_simulate_takes_an_object_with_the_protocols_members(planar3):
    class Hold:
        duration, dimension, start = 0.05, 2, None

        def anchored(self, start):
            held = Hold()
            held.start = np.asarray(start)
            return held

        def sample(self, t):
            zeros = np.zeros((np.size(t), 2))
            return torqueopt.Reference(self.start + zeros, zeros, zeros)

    result = torqueopt.simulate(planar3, "null-space", Hold(), PAPER_Q0)
    assert result.completed and result.max_tip_error < 1e-9
    tip = planar3.task_position(planar3.configuration(PAPER_Q0))
    assert result.trajectory == {"kind": "Hold", "duration": 0.05, "start": pytest.approx(list(tip))}
    with pytest.raises(InvalidInput, match="trajectory object lacks sample, duration, dimension, start, anchored"):
        torqueopt.simulate(planar3, "pinv", object(), PAPER_Q0)


def test_a_trajectory_must_fit_the_task(planar3, panda):
    with pytest.raises(InvalidInput, match="trajectory Circle moves in 3 dimensions but task 'xy' moves the tip in 2"):
        torqueopt.simulate(planar3, "pinv", Circle(0.1, 0.5, normal=[0, 0, 1]), PAPER_Q0)
    with pytest.raises(InvalidInput, match="trajectory WaypointPath moves in 2 dimensions but task 'position'"):
        torqueopt.simulate(panda, "pinv", WaypointPath(*WAYPOINTS_2D), panda.default_configuration)


def test_a_waypoint_path_on_a_seven_joint_arm(panda):
    path = WaypointPath([0.0, 0.05], [[0.0, 0.0, 0.0], [0.0, 0.0, 0.002]])
    result = torqueopt.simulate(panda, "pinv", path, panda.default_configuration)
    assert result.completed and result.max_tip_error < 1e-4
    assert result.x_ref[-1] - result.x_ref[0] == pytest.approx([0.0, 0.0, 0.002], abs=1e-12)


# -- the CLI ------------------------------------------------------------------------

RUN = ["run", "--robot", "planar3", "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--resolver", "pinv"]


def test_cli_runs_each_path_and_records_it(tmp_path, capsys):
    waypoints = tmp_path / "w.csv"
    waypoints.write_text("t,x,y\n0,0,0\n0.1,0.01,0.005\n0.2,0.02,0\n")
    cases = {
        "line": ["--direction", "1,1", "--duration", "0.2"],
        "min-jerk": ["--direction", "1,0", "--duration", "0.2", "--length", "0.05"],
        "circle": ["--radius", "0.02", "--duration", "0.2", "--centre=0,-1"],
        f"csv:{waypoints}": [],
    }
    for path, options in cases.items():
        out = tmp_path / "run.csv"
        assert main([*RUN, "--path", path, *options, "--out", str(out)]) == 0
        record = json.loads((tmp_path / "run.csv.json").read_text())["trajectory"]
        assert record["kind"] == path.split(":")[0] and record["duration"] == pytest.approx(0.2)
    assert record["source"] == str(waypoints) and record["waypoints"] == 3
    capsys.readouterr()


def test_cli_min_jerk_line_defaults_to_the_lines_length(tmp_path):
    out = tmp_path / "run.npz"
    assert (
        main([*RUN, "--path", "min-jerk", "--direction", "1,1", "--duration", "0.1", "--accel", "2", "--out", str(out)])
        == 0
    )
    assert torqueopt.load_result(out).trajectory["length"] == pytest.approx(2 * 0.1**2 / 4)


@pytest.mark.parametrize(
    "options, message",
    [
        (["--path", "spiral"], "--path: 'spiral' is not a path; choose one of line, min-jerk, circle, csv:FILE"),
        (["--path", "csv:"], "--path: 'csv:' is not a path"),
        (["--path", "line:x", "--direction", "1,1"], "--path: 'line:x' is not a path"),
        ([], "--path line needs --direction (e.g. --direction 1,1)"),
        (
            ["--path", "circle", "--direction", "1,1"],
            "--direction applies to --path line or min-jerk, not to --path circle",
        ),
        (["--direction", "1,1", "--radius", "0.1"], "--radius applies to --path circle, not to --path line"),
        (
            ["--path", "csv:w.csv", "--duration", "1"],
            "--duration applies to --path line or min-jerk or circle, not to --path csv",
        ),
        (["--path", "circle", "--radius", "-1"], "--radius: -1 must be a positive finite number"),
        (["--path", "circle", "--turns", "2.5"], "--turns: 2.5 must be a whole number >= 1"),
        (["--path", "circle", "--turns", "0"], "--turns: 0 must be a whole number >= 1"),
        (
            ["--path", "circle", "--normal", "0,0,1"],
            "trajectory Circle moves in 3 dimensions but task 'xy' moves the tip in 2",
        ),
        (
            ["--path", "min-jerk", "--direction", "1,1", "--length", "1", "--accel", "1"],
            "--length and --accel both set",
        ),
        (["--path", "csv:nowhere.csv"], "waypoint file 'nowhere.csv' does not exist"),
    ],
)
def test_cli_bad_paths_are_one_line_exit_2(options, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "w.csv").write_text("t,x,y\n0,0,0\n1,0.1,0\n")
    out = tmp_path / "run.csv"
    assert main([*RUN, *options, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("torqueopt run: error: ") and message in err[0]
    assert not out.exists()


def test_cli_absolute_waypoints_are_world_coordinates(tmp_path, capsys):
    tip = (math.sqrt(2.0), 1.0 - math.sqrt(2.0))
    waypoints = tmp_path / "w.csv"
    waypoints.write_text(f"t,x,y\n0,{tip[0]!r},{tip[1]!r}\n0.2,{tip[0] + 0.01!r},{tip[1]!r}\n")
    out = tmp_path / "run.npz"
    assert main([*RUN, "--path", f"csv:{waypoints}", "--absolute", "--out", str(out)]) == 0
    result = torqueopt.load_result(out)
    np.testing.assert_allclose(result.x_ref[-1], [tip[0] + 0.01, tip[1]], atol=1e-12)
    assert result.trajectory["start"] == pytest.approx(list(tip))
    capsys.readouterr()


def test_a_spreadsheets_byte_order_mark_is_not_part_of_the_header(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_bytes("t,x,y\r\n0,0,0\r\n1,0.1,0.2\r\n".encode("utf-8-sig"))
    np.testing.assert_allclose(WaypointPath.from_csv(path, absolute=True).end, [0.1, 0.2], atol=1e-12)
