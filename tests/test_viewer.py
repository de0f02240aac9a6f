"""Meshcat playback: frame sampling, torque-limit highlights, the HTML export, the live
server, the play command, and the export rendered in headless Chromium."""

import asyncio
import base64
import re
import sys
import threading
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

import torqueopt
from torqueopt import viewer
from torqueopt.cli import main
from torqueopt.errors import InvalidInput, MissingDependency, OutputError

from .conftest import PAPER_Q0

umsgpack = pytest.importorskip("umsgpack", reason="meshcat (and its umsgpack) is not installed")

HIGHLIGHT_RGB = np.array([(viewer.HIGHLIGHT_COLOR >> shift) & 0xFF for shift in (16, 8, 0)]) / 255


def synthetic_run(robot, duration=2.0, dt=1e-3, violations=()):
    """A run of ``robot`` swinging its joints, zero torque except ``violations``.

    ``violations`` holds (joint index, first row, last row, torque as a
    multiple of the limit): those rows carry that torque, over the limit
    when the multiple's magnitude exceeds 1.
    """
    t = dt * np.arange(round(duration / dt) + 1)
    start = robot.joint_angles(robot.default_configuration)
    swing = 0.4 * np.sin(np.pi * t / duration)[:, None] * np.linspace(1.0, -1.0, robot.nv)
    angles = start + swing
    x = np.array([robot.task_position(robot.configuration(a)) for a in angles])
    tau = np.zeros_like(angles)
    for joint, first, last, multiple in violations:
        tau[first : last + 1, joint] = multiple * robot.torque_upper[joint]
    return torqueopt.SimResult(
        robot=robot.name, frame=robot.frame, task=robot.task, resolver="pinv",
        joint_names=list(robot.joint_names), dt=dt, t=t, q=np.array([robot.configuration(a) for a in angles]),
        joint_angles=angles, v=np.zeros_like(angles), acceleration=np.zeros_like(angles), tau=tau, x=x,
        x_ref=x.copy(), jacobian_inverse_condition=np.ones(len(t)), torque_upper=robot.torque_upper.copy(),
        torque_lower=robot.torque_lower.copy(), duration=duration,
    )  # fmt: skip


#: joint2 (index 1) over its limit for rows 500-700; joint3 over (negative) for 3 ms only, between frames.
VIOLATIONS = ((1, 500, 700, 1.25), (2, 1001, 1003, -1.2))


@pytest.fixture(scope="module")
def violating_run(planar3):
    return synthetic_run(planar3, violations=VIOLATIONS)


@pytest.fixture(scope="module")
def whiplash(planar3):
    """The paper's long movement with the null-space resolver: joints whip over their limits near the end."""
    return torqueopt.simulate(planar3, "null-space", torqueopt.StraightLine([1.0, 1.0], duration=2.0), PAPER_Q0)


def page_commands(html: str) -> list[dict]:
    """The meshcat commands a page built by Playback.html() runs, decoded."""
    block = html[html.index("var commands = [") : html.index("];", html.index("var commands = ["))]
    return [umsgpack.unpackb(base64.b64decode(text)) for text in re.findall(r'"([A-Za-z0-9+/=]+)"', block)]


# -- frames ------------------------------------------------------------------------


def test_frames_are_subsampled_at_fps_and_keep_first_and_last_row(violating_run):
    frames = viewer.sample_frames(violating_run, fps=30, speed=1.0)
    assert len(frames) == 61 and frames.rows[0] == 0 and frames.rows[-1] == 2000
    assert np.all(np.diff(frames.rows) > 0)
    np.testing.assert_allclose(frames.time, violating_run.t[frames.rows])
    slowed = viewer.sample_frames(violating_run, fps=30, speed=0.25)
    assert len(slowed) == 241 and slowed.duration == pytest.approx(8.0)
    # More frames than rows: every row once, never twice.
    every_row = viewer.sample_frames(violating_run, fps=5000, speed=1.0)
    np.testing.assert_array_equal(every_row.rows, np.arange(2001))


@pytest.mark.parametrize("fps, speed, message", [(0, 1, "fps=0 must be a positive"), (30, -1, "speed=-1 must be a positive"),
                                                 (float("nan"), 1, "fps=nan must be a positive")])  # fmt: skip
def test_bad_fps_or_speed(violating_run, fps, speed, message):
    with pytest.raises(InvalidInput, match=message):
        viewer.sample_frames(violating_run, fps=fps, speed=speed)


def test_a_joint_is_highlighted_exactly_while_over_its_limit(violating_run):
    frames = viewer.sample_frames(violating_run, fps=30)
    over = frames.over_limit
    rows = frames.rows
    assert not over[:, 0].any()
    # joint2: every frame whose span since the previous frame meets rows 500-700.
    previous = np.r_[-1, rows[:-1]]
    expected = (rows >= 500) & (previous < 700)
    np.testing.assert_array_equal(over[:, 1], expected)
    assert rows[over[:, 1]][0] >= 500 and rows[over[:, 1]][-1] <= 700 + 34
    # joint3's 3 ms violation falls between two frames and still shows, at one frame.
    assert not np.isin(np.arange(1001, 1004), rows).any()
    assert over[:, 2].sum() == 1 and previous[over[:, 2]][0] < 1001 <= rows[over[:, 2]][0]


def test_the_html_animation_shows_the_markers_at_those_frames_in_the_highlight_colour(planar3, violating_run):
    playback = viewer.Playback(planar3, violating_run, fps=30)
    commands = page_commands(playback.html())
    markers = {
        command["path"]: command for command in commands
        if command["type"] == "set_object" and "/torque_limit/" in command["path"]
    }  # fmt: skip
    assert sorted(markers) == [f"/meshcat/torqueopt/torque_limit/joint{i}" for i in (1, 2, 3)]
    for command in markers.values():
        assert command["object"]["materials"][0]["color"] == viewer.HIGHLIGHT_COLOR
    (animation,) = [command for command in commands if command["type"] == "set_animation"]
    assert animation["options"] == {"play": True, "repetitions": 1}
    clips = {entry["path"]: entry["clip"] for entry in animation["animations"]}
    for joint in range(3):
        clip = clips[f"/meshcat/torqueopt/torque_limit/joint{joint + 1}"]
        (visible,) = [track for track in clip["tracks"] if track["name"] == ".visible"]
        times = np.array([key["time"] for key in visible["keys"]]) / clip["fps"]
        values = [key["value"] for key in visible["keys"]]
        # The track's value at each frame (discrete: the last key at or before it).
        shown = [values[np.searchsorted(times, t + 1e-9, side="right") - 1] for t in playback.frames.time]
        np.testing.assert_array_equal(shown, playback.frames.over_limit[:, joint])
        assert times[-1] == pytest.approx(playback.frames.duration)


class RecordingVisualizer:
    """Enough of meshcat.Visualizer for Playback.play: records (path, method, arguments)."""

    def __init__(self, calls=None, path=""):
        self.calls = [] if calls is None else calls
        self.path = path

    def __getitem__(self, path):
        return RecordingVisualizer(self.calls, f"{self.path}/{path}")

    def __getattr__(self, method):
        return lambda *arguments: self.calls.append((self.path, method, arguments))


def test_live_playback_skips_frames_when_late_but_not_the_highlights(planar3, violating_run):
    playback = viewer.Playback(planar3, violating_run, fps=30)
    ticks = iter(np.arange(0.0, 10.0, 0.1))  # each look at the clock: 0.1 s later, three frames
    vis = RecordingVisualizer()
    drawn = playback.play(vis, sleep=lambda seconds: None, clock=lambda: next(ticks))
    assert drawn < len(playback.frames) / 2
    joint3 = [
        args for path, method, args in vis.calls if path.endswith("torque_limit/joint3") and method == "set_property"
    ]
    assert sum(shown for _, shown in joint3) == 1
    segments = [path for path, method, _ in vis.calls if "/tip_trace/" in path and method == "set_object"]
    assert len(segments) == drawn - 1


def test_the_run_must_move_the_robots_joints(panda, violating_run):
    with pytest.raises(InvalidInput, match=r"the run moves 3 joints \(joint1, joint2, joint3\) but robot 'panda'"):
        viewer.Playback(panda, violating_run)


# -- the HTML file -------------------------------------------------------------------


@pytest.mark.slow
def test_html_of_a_2s_planar3_run_is_small_and_subsampling_shrinks_it(planar3, whiplash, tmp_path):
    path = viewer.export_html(viewer.Playback(planar3, whiplash), tmp_path / "whiplash.html")
    size = path.stat().st_size
    assert size < 3e6
    every_row = viewer.export_html(viewer.Playback(planar3, whiplash, fps=1000), tmp_path / "full.html")
    assert size < every_row.stat().st_size < 10e6
    text = path.read_text()
    assert text.startswith("<!DOCTYPE html>") and "MeshCat.Viewer" in text
    assert "<script src" not in text and "<link" not in text  # self-contained: nothing to fetch


@pytest.mark.slow
def test_html_of_a_2s_panda_run_stays_under_30_mb(panda, tmp_path):
    run = synthetic_run(panda, violations=((3, 200, 400, 1.5),))
    path = viewer.export_html(viewer.Playback(panda, run), tmp_path / "panda.html")
    assert 1e6 < path.stat().st_size < 30e6
    commands = page_commands(path.read_text())
    meshes = [c for c in commands if c["type"] == "set_object" and "/robot/visuals/" in c["path"]]
    # Every visual of the arm and its hand, fingers locked in place.
    assert len(meshes) == len(viewer.visual_model(panda)[1].geometryObjects) == 11


def test_html_is_written_atomically(planar3, violating_run, tmp_path, monkeypatch):
    target = tmp_path / "run.html"
    target.write_text("previous export")
    playback = viewer.Playback(planar3, violating_run, fps=5)

    def full_disk(source, destination):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("os.replace", full_disk)
    with pytest.raises(OutputError, match="cannot write '.*run.html': No space left on device"):
        viewer.export_html(playback, target)
    monkeypatch.undo()
    assert target.read_text() == "previous export"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.html"]
    viewer.export_html(playback, target)
    assert target.read_text().startswith("<!DOCTYPE html>")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.html"]


@pytest.mark.slow
def test_visual_model_is_reduced_like_the_dynamic_model(panda, planar3):
    model, geometry = viewer.visual_model(panda)
    assert list(model.names) == list(panda.model.names)
    assert "panda_finger_joint1" in panda.locked_joints
    assert {g.name for g in geometry.geometryObjects} >= {"panda_leftfinger_0", "panda_hand_0"}
    assert all(Path(g.meshPath).is_file() for g in geometry.geometryObjects)
    _, cylinders = viewer.visual_model(planar3)
    assert len(cylinders.geometryObjects) == 5  # base, three links, tip


# -- the play command -------------------------------------------------------------------


@pytest.fixture(scope="module")
def run_csv(whiplash, tmp_path_factory):
    return whiplash.to_csv(tmp_path_factory.mktemp("run") / "whiplash.csv")


def test_play_writes_the_html(run_csv, tmp_path, capsys):
    out = tmp_path / "play.html"
    assert main(["play", str(run_csv), "--html", str(out), "--speed", "0.25", "--fps", "20"]) == 0
    printed = capsys.readouterr().out
    assert re.fullmatch(
        rf"wrote {re.escape(str(out))} \(\d\.\d MB\): 161 frames over 8\.00 s at speed 0\.25\n", printed
    )


PLAY_ERRORS = [
    (["MISSING.csv"], "run file 'MISSING.csv' does not exist"),
    (["RUN", "--robot", "panda"], ("the run moves 3 joints (joint1, joint2, joint3) but robot 'panda' with frame "
     "'panda_hand' moves 7 (panda_joint1, panda_joint2")),
    (["RUN", "--robot", "planar3", "--lock", "joint3"], ("the run moves 3 joints (joint1, joint2, joint3) but robot "
     "'planar3' with frame 'tip' moves 2 (joint1, joint2); give the robot the run was made with (robot 'planar3', frame 'tip')")),
    (["RUN", "--speed", "0"], "--speed: 0 must be a positive finite number"),
    (["RUN", "--fps", "many"], "--fps: 'many' is not a number"),
    # Frame counts past the float range (an OverflowError traceback before).
    (["RUN", "--fps", "1e308"], "needs infinitely many frames, more than the limit of"),
    (["RUN", "--speed", "1e-320"], "needs infinitely many frames, more than the limit of"),
    (["RUN", "--frame", "hand"], "robot 'planar3' has no frame 'hand'"),
]  # fmt: skip


@pytest.mark.parametrize("arguments, message", PLAY_ERRORS)
def test_play_bad_input_is_one_line_exit_2(arguments, message, run_csv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out.html"
    arguments = [str(run_csv) if a == "RUN" else a for a in arguments]
    assert main(["play", *arguments, "--html", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torqueopt play: error: ") and message in lines[0]
    assert not out.exists()


def _listing(folder):
    return sorted((p.name, p.is_symlink(), p.read_bytes() if p.is_file() else None) for p in folder.iterdir())


#: What is at the --html path before ``play``, and what play must do: write (through a link), or refuse in one line.
HTML_TARGETS = [
    ("the user's file", "replaced, keeping its mode"),
    ("a symbolic link", "written through"),
    ("a read-only file", "it is read-only"),
    ("a folder", "it is a folder"),
    ("a dangling link", "which does not exist"),
    ("a hard-linked file", "it has 2 hard links"),
    ("the run itself", "it is the file this command reads"),
    ("the run's sidecar", "it is the file this command reads"),
    ("a link to the run", "it is the file 'RUN' this command reads"),
]


@pytest.mark.parametrize("what, outcome", HTML_TARGETS, ids=[case[0] for case in HTML_TARGETS])
def test_play_html_follows_the_file_rules_and_checks_them_before_any_work(what, outcome, run_csv, tmp_path, capsys):
    """The rules of torqueopt.io for --html: a page written through a link, never over what is not a plain file of
    the user's, never over the run it shows (``play r.csv --html r.csv`` replaced the run by its own page), and
    nothing written when it refuses."""
    import os
    import shutil

    run = tmp_path / "run.csv"
    shutil.copy(run_csv, run)
    shutil.copy(f"{run_csv}.json", f"{run}.json")
    original = run.read_bytes()
    page = tmp_path / "page.html"
    if what == "the user's file":
        page.write_text("mine")
        page.chmod(0o640)
    elif what == "a symbolic link":
        (tmp_path / "target.html").write_text("mine")
        page.symlink_to("target.html")
    elif what == "a read-only file":
        page.write_text("mine")
        page.chmod(0o444)
    elif what == "a folder":
        page.mkdir()
    elif what == "a dangling link":
        page.symlink_to("nowhere.html")
    elif what == "a hard-linked file":
        page.write_text("mine")
        os.link(page, tmp_path / "other-name.html")
    elif what == "the run itself":
        page = run
    elif what == "the run's sidecar":
        page = Path(f"{run}.json")
    elif what == "a link to the run":
        page.symlink_to(run)
    before = _listing(tmp_path)
    code = main(["play", str(run), "--html", str(page), "--fps", "5"])
    captured = capsys.readouterr()
    assert run.read_bytes() == original
    if outcome in ("replaced, keeping its mode", "written through"):
        assert code == 0 and captured.err == ""
        written = tmp_path / ("target.html" if what == "a symbolic link" else "page.html")
        assert written.read_text().startswith("<!DOCTYPE html>")
        assert page.is_symlink() == (what == "a symbolic link")
        if what == "the user's file":
            assert (page.stat().st_mode & 0o777) == 0o640
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(name for name, *_ in before)  # no temporaries
        return
    message = outcome.replace("RUN", str(run))
    assert code == 2 and captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("torqueopt play: error: cannot write") and message in lines[0]
    assert _listing(tmp_path) == before  # nothing written, nothing left behind


@pytest.mark.parametrize("html", ["RUN", "RUN.json", "LINK"])
def test_run_refuses_an_html_page_at_its_own_run_file_before_simulating(html, tmp_path, capsys, monkeypatch):
    """``run --out a.csv --html a.csv`` said it wrote the run and its sidecar and left only the page in a.csv."""
    import torqueopt.cli.run as run_module

    monkeypatch.setattr(run_module, "simulate", lambda *args, **kwargs: pytest.fail("simulated before the check"))
    out = tmp_path / "a.csv"
    if html == "LINK":
        out.write_text("an earlier run")
        (tmp_path / "link.html").symlink_to("a.csv")
    page = {"RUN": str(out), "RUN.json": f"{out}.json", "LINK": str(tmp_path / "link.html")}[html]
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "0.1",
                 "--out", str(out), "--html", page])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err.startswith(f"torqueopt run: error: cannot write '{page}' as two of this command's files")
    assert captured.err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == (["a.csv", "link.html"] if html == "LINK" else [])
    if html == "LINK":
        assert out.read_text() == "an earlier run"


def test_without_meshcat_play_says_what_to_install_and_the_rest_works(run_csv, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "meshcat", None)  # import meshcat now raises ImportError
    expected = "meshcat playback needs the 'meshcat' package, which is not installed: pip install meshcat"
    assert main(["play", str(run_csv)]) == 2
    assert capsys.readouterr().err.strip() == f"torqueopt play: error: {expected}"
    # run --play refuses before simulating; run alone works.
    paper = ["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "0.1"]
    assert main([*paper, "--play"]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == f"torqueopt run: error: {expected}" and captured.out == ""
    assert main(paper) == 0
    with pytest.raises(MissingDependency, match="pip install meshcat"):
        viewer.require_meshcat()


def test_run_html_writes_the_run_and_its_animation(tmp_path, capsys):
    out = tmp_path / "run.html"
    code = main(["run", "--robot", "planar3", "--resolver", "pinv", "--direction", "1,1", "--duration", "0.3",
                 "--html", str(out), "--fps", "10"])  # fmt: skip
    assert code == 0 and "wrote" in capsys.readouterr().out and out.stat().st_size > 0


# -- the live server ----------------------------------------------------------------------


def listening_addresses(pid: int) -> list[str]:
    """Local addresses (hex, as in /proc/net/tcp) of the TCP sockets ``pid`` listens on."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        target = fd.readlink().as_posix() if fd.is_symlink() else ""
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    addresses = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                addresses.append(fields[1].split(":")[0])
    return addresses


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads listening sockets from Linux /proc")
def test_live_server_listens_on_localhost_only_and_plays_to_a_browser(planar3, whiplash):
    from tornado.websocket import websocket_connect

    playback = viewer.Playback(planar3, whiplash, speed=2.0)  # slow enough that a loaded host still draws frames
    received = []

    with viewer.LiveViewer() as live:
        assert live.url.startswith("http://127.0.0.1:")
        assert listening_addresses(live.pid) == ["0100007F", "0100007F"]  # 127.0.0.1: zmq and web

        playback.draw_scene(live.visualizer)
        socket_url = live.url.replace("http://", "ws://").split("/static")[0] + "/"

        async def browser():
            connection = await websocket_connect(socket_url)
            while (message := await connection.read_message()) is not None:
                received.append(umsgpack.unpackb(message))

        threading.Thread(target=lambda: asyncio.run(browser()), daemon=True).start()
        live.wait_for_browser(timeout=30)
        drawn = playback.play(live.visualizer)
        scene_size = len(received)
    assert drawn > 5
    kinds = {
        (command["type"], command["path"].split("/")[3] if command["path"].count("/") > 2 else "")
        for command in received
    }
    assert ("set_transform", "robot") in kinds and ("set_object", "tip_trace") in kinds
    assert scene_size > drawn


# -- in a real browser ------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.browser
def test_html_export_draws_the_arm_in_headless_chromium(chromium, planar3, whiplash, tmp_path):
    html = viewer.export_html(viewer.Playback(planar3, whiplash), tmp_path / "whiplash.html")
    # At 1.5 s all three joints are over their limits (the paper's whiplash).
    assert viewer.sample_frames(whiplash).over_limit[45].all()
    png = viewer.screenshot_html(html, tmp_path / "whiplash.png", at=1.5, width=800, height=500)
    image = matplotlib.image.imread(png)[:, :, :3]
    assert image.shape == (500, 800, 3)
    red, green, blue = image[:, :, 0], image[:, :, 1], image[:, :, 2]
    # planar3's links are rgb(0.2, 0.4, 0.8); lit, they stay clearly blue. The
    # background and the grid are grey, so a blank canvas has none of these.
    link_pixels = (blue > 0.45) & (blue - red > 0.25) & (blue - green > 0.15)
    highlight_pixels = np.all(np.abs(image - HIGHLIGHT_RGB) < 0.25, axis=2) & (red - green > 0.4)
    grey_pixels = np.ptp(image, axis=2) < 0.05
    assert link_pixels.sum() > 2000, "no arm drawn"
    assert highlight_pixels.sum() > 300, "no joint highlighted"
    assert grey_pixels.mean() > 0.5, "background missing"


@pytest.mark.slow
@pytest.mark.browser
def test_a_blank_page_fails_the_check(chromium, tmp_path):
    blank = tmp_path / "blank.html"
    blank.write_text("<!DOCTYPE html><html><body style='background:#eee'></body></html>")
    image = matplotlib.image.imread(viewer.screenshot_html(blank, tmp_path / "blank.png", width=400, height=300))
    red, green, blue = image[:, :, 0], image[:, :, 1], image[:, :, 2]
    assert not ((blue > 0.45) & (blue - red > 0.25) & (blue - green > 0.15)).any()
