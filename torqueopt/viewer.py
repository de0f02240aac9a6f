r"""Meshcat playback of a run: live in a browser, or as one self-contained HTML file.

A :class:`Playback` pairs a :class:`~torqueopt.result.SimResult` with the
robot that made it and draws, in a meshcat scene,

* the arm with its URDF visuals (meshes, or the cylinders of ``planar3``),
  loaded on the full model and reduced as the dynamic model is, the joints
  outside the task chain locked at the robot's reference configuration;
* the reference path of the tip (a translucent green tube) and the tip's
  trace (an orange tube inside it), which grows as the arm moves;
* a red sphere at every joint whose torque is over its limit,
  :math:`|\tau_i| > \tau_i^+` (or below :math:`\tau_i^-`), shown while it is.

The run is sampled at ``fps`` display frames per second of playback; a
playback at ``speed`` s of simulated time per second of wall time shows the
row at simulated time :math:`t` at wall time :math:`t/\text{speed}`. A joint
is highlighted at a frame when its torque was over the limit at any row since
the previous frame, so that subsampling never hides a short violation.

Live playback (:class:`LiveViewer`) runs meshcat's server in a subprocess
bound to 127.0.0.1 only: meshcat 0.3's own server binds its web port on every
interface. The static export (:func:`export_html`) needs no server: the scene
commands are recorded in-process and written into one HTML file with
meshcat's viewer script, with the run as a meshcat animation that plays when
the file opens. :func:`screenshot_html` renders such a file in headless
Chromium.

meshcat, and a browser for screenshots, are optional: they are imported or
looked for only here, and their absence raises
:class:`~torqueopt.errors.MissingDependency` naming what to install.
"""

from __future__ import annotations

import base64
import contextlib
import io
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .checks import positive_number
from .errors import InvalidInput, MissingDependency, TorqueoptError
from .result import SimResult, atomic_write
from .robot import Robot

__all__ = [
    "DEFAULT_FPS",
    "HIGHLIGHT_COLOR",
    "LOCALHOST",
    "LiveViewer",
    "Playback",
    "PlaybackFrames",
    "check_run_matches",
    "export_html",
    "find_browser",
    "over_limit",
    "require_meshcat",
    "sample_frames",
    "screenshot_html",
    "visual_model",
]

#: Display frames per second of playback (wall time), live and in HTML files.
DEFAULT_FPS = 30.0
#: The only address the live server listens on.
LOCALHOST = "127.0.0.1"
#: Colour of the sphere marking a joint over its torque limit (0xRRGGBB).
HIGHLIGHT_COLOR = 0xE41A1C
REFERENCE_COLOR = 0x2CA02C
TRACE_COLOR = 0xFF7F0E
#: Background gradient, RGB in [0, 1].
BACKGROUND_TOP = [0.98, 0.98, 0.98]
BACKGROUND_BOTTOM = [0.78, 0.78, 0.8]
#: Browsers :func:`find_browser` looks for, in this order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

_ROOT = "torqueopt"
_ROBOT_NODE = f"{_ROOT}/robot"
_MARKER_NODE = f"{_ROOT}/torque_limit"
_TRACE_NODE = f"{_ROOT}/tip_trace"
_REFERENCE_NODE = f"{_ROOT}/reference_path"
_CAMERA_NODE = "/Cameras/default/rotated/<object>"
#: Vertical field of view of the camera [deg]; narrower than meshcat's 75 so that links keep their shape.
_CAMERA_FOV = 40.0


def require_meshcat():
    """meshcat and its submodules, or MissingDependency saying how to install it."""
    try:
        import meshcat
        import meshcat.animation
        import meshcat.geometry
    except ImportError:
        raise MissingDependency(
            "meshcat playback needs the 'meshcat' package, which is not installed: pip install meshcat"
        ) from None
    return meshcat


# -- what to show at each frame ------------------------------------------------


@dataclass(frozen=True)
class PlaybackFrames:
    """The rows of a run shown as display frames.

    Attributes:
        rows: index of the run's row shown at each frame, increasing, (K,).
        time: wall time of each frame from the start of playback [s], (K,).
        over_limit: per frame and joint, True when the joint's torque was over
            its limit at some row since the previous frame (at row 0 for the
            first frame), (K, n).
    """

    rows: np.ndarray
    time: np.ndarray
    over_limit: np.ndarray

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def duration(self) -> float:
        """Wall time of the playback [s]."""
        return float(self.time[-1])


def over_limit(result: SimResult) -> np.ndarray:
    """Per row and joint, True where the torque is beyond its limit (N, n); unbounded joints never are."""
    return result.torque_ratio > 1.0


def sample_frames(result: SimResult, fps: float = DEFAULT_FPS, speed: float = 1.0) -> PlaybackFrames:
    """Pick the rows of ``result`` to show at ``fps`` frames per wall-clock second.

    Args:
        fps: display frames per second of playback [1/s].
        speed: simulated seconds per wall-clock second (1 real time, 0.25 four times slower).

    The first and the last row are always shown; a row is never shown twice.
    """
    fps = positive_number(fps, "fps")
    speed = positive_number(speed, "speed")
    times = np.asarray(result.t, dtype=float)
    if times.size == 0:
        raise InvalidInput("the run has no rows to play (it stopped before its first step)")
    elapsed = times - times[0]
    frame_count = math.floor(elapsed[-1] / speed * fps + 1e-9) + 1
    wanted = np.arange(frame_count) * (speed / fps)
    # The row at or just before each frame's simulated time.
    rows = np.searchsorted(elapsed, wanted + 1e-9 * max(1.0, elapsed[-1]), side="right") - 1
    rows = np.unique(np.append(np.clip(rows, 0, times.size - 1), times.size - 1))

    over = over_limit(result)
    counts = np.cumsum(over, axis=0)
    since_previous = counts[rows].copy()
    since_previous[1:] -= counts[rows[:-1]]
    return PlaybackFrames(rows=rows, time=elapsed[rows] / speed, over_limit=since_previous > 0)


# -- the robot's visuals ---------------------------------------------------------


def visual_model(robot: Robot) -> tuple[pin.Model, pin.GeometryModel]:
    """Kinematic model and visual geometry of the robot's moving chain.

    The URDF's visuals are loaded on the full model (mesh URIs resolved
    through ``robot.source.package_dirs``), then both are reduced by locking
    the joints :attr:`Robot.locked_joints` at :attr:`Robot.locked_configuration`,
    as :func:`torqueopt.load_robot` reduced the dynamic model; the result has
    the same joints, in the same order, as ``robot.model``.
    """
    if robot.source is None:
        raise InvalidInput(f"robot '{robot.name}' was not loaded from a URDF, so it has no visuals to show")
    full_model = robot.full_model
    package_dirs = [str(path) for path in robot.source.package_dirs]
    try:
        geometry = pin.buildGeomFromUrdf(
            full_model, str(robot.source.urdf), pin.GeometryType.VISUAL, package_dirs=package_dirs
        )
    except (RuntimeError, ValueError) as error:
        raise TorqueoptError(f"cannot load the visuals of '{robot.source.urdf}': {error}") from None
    locked_ids = [full_model.getJointId(name) for name in robot.locked_joints]
    if locked_ids:
        model, geometry = pin.buildReducedModel(full_model, geometry, locked_ids, robot.locked_configuration)
    else:
        model = full_model
    if list(model.names) != list(robot.model.names):
        raise TorqueoptError(
            f"the visual model of '{robot.name}' has joints {list(model.names)[1:]}, "
            f"not the robot's {list(robot.model.names)[1:]}"
        )
    return model, geometry


# -- the playback ------------------------------------------------------------------


class Playback:
    """A run and the robot that made it, ready to draw in a meshcat visualizer.

    Args:
        robot: the robot of the run (same joints, same order).
        result: the run, e.g. from :func:`torqueopt.simulate` or :func:`torqueopt.load_result`.
        speed: simulated seconds per wall-clock second (0.25: four times slower).
        fps: display frames per second of playback.

    Raises:
        InvalidInput: the run's joints are not the robot's, or speed/fps are not positive.
    """

    def __init__(self, robot: Robot, result: SimResult, *, speed: float = 1.0, fps: float = DEFAULT_FPS):
        check_run_matches(robot, result)
        self.robot = robot
        self.result = result
        self.speed = positive_number(speed, "speed")
        self.frames = sample_frames(result, fps, speed)
        self.fps = float(fps)
        self.model, self.geometry = visual_model(robot)
        self._data = self.model.createData()
        self._geometry_data = self.geometry.createData()

        self.configurations = np.array([robot.configuration(angles) for angles in result.joint_angles])
        self.tip_positions = np.array([robot.frame_placement(q).translation for q in self.configurations])
        self.reference_positions = _reference_positions(result, self.tip_positions[0])
        self.joint_ids = [self.model.getJointId(name) for name in robot.joint_names]

        self._frame_visuals = []
        self._frame_joints = []
        for row in self.frames.rows:
            visuals, joints = self._placements(self.configurations[row])
            self._frame_visuals.append(visuals)
            self._frame_joints.append(joints)
        self.marker_radius = max(0.08, 0.03 * _reach(self._frame_joints[0], self.tip_positions[0]))
        self._path_radius = 0.25 * self.marker_radius
        self._centre, self._half_extent = self._bounds()

    # -- geometry at a configuration ------------------------------------------
    def _placements(self, q: np.ndarray) -> tuple[list[pin.SE3], np.ndarray]:
        """World placements of the visuals and positions of the joints at q."""
        pin.forwardKinematics(self.model, self._data, q)
        pin.updateGeometryPlacements(self.model, self._data, self.geometry, self._geometry_data)
        visuals = [placement.copy() for placement in self._geometry_data.oMg]
        joints = np.array([self._data.oMi[j].translation for j in self.joint_ids])
        return visuals, joints

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre and half-extents [m] of a box around the base, the paths and every joint at every frame."""
        points = np.vstack([np.zeros((1, 3)), self.tip_positions, self.reference_positions, *self._frame_joints])
        low, high = points.min(axis=0), points.max(axis=0)
        # Links and meshes stick out of their joints by about a marker.
        return 0.5 * (low + high), 0.5 * (high - low) + 1.5 * self.marker_radius

    def _visual_node(self, index: int) -> str:
        return f"{_ROBOT_NODE}/visuals/{self.geometry.geometryObjects[index].name}"

    def _marker_node(self, joint: int) -> str:
        return f"{_MARKER_NODE}/{self.robot.joint_names[joint]}"

    def highlighted_joints(self, frame: int) -> list[str]:
        """Names of the joints highlighted at display frame ``frame``."""
        return [name for name, over in zip(self.robot.joint_names, self.frames.over_limit[frame]) if over]

    # -- drawing ----------------------------------------------------------------
    def draw_scene(self, vis) -> None:
        """Set up background, camera, robot visuals, reference path and markers; show frame 0."""
        meshcat = require_meshcat()
        from pinocchio.visualize import MeshcatVisualizer

        geometry = meshcat.geometry
        vis["/Background"].set_property("top_color", BACKGROUND_TOP)
        vis["/Background"].set_property("bottom_color", BACKGROUND_BOTTOM)
        vis["/Axes"].set_property("visible", False)
        # meshcat's orbit controls always aim at the scene origin, so the
        # scene is shifted to put the middle of the motion there.
        shift = np.eye(4)
        shift[:3, 3] = -self._centre
        vis[_ROOT].set_transform(shift)
        vis["/Grid"].set_transform(shift)
        vis[_CAMERA_NODE].set_property("fov", _CAMERA_FOV)
        vis[_CAMERA_NODE].set_property("position", self._camera_position().tolist())

        pinocchio_viewer = MeshcatVisualizer(self.model, None, self.geometry)
        pinocchio_viewer.initViewer(viewer=vis)
        pinocchio_viewer.loadViewerModel(rootNodeName=_ROBOT_NODE)

        reference = _tube(geometry, _decimate(self.reference_positions, 400), self._path_radius)
        if reference is not None:
            vis[_REFERENCE_NODE].set_object(
                reference, geometry.MeshLambertMaterial(color=REFERENCE_COLOR, opacity=0.45)
            )
        marker = geometry.MeshLambertMaterial(color=HIGHLIGHT_COLOR)
        for joint in range(len(self.joint_ids)):
            vis[self._marker_node(joint)].set_object(geometry.Sphere(self.marker_radius), marker)
        vis[_TRACE_NODE].delete()
        self.show_frame(vis, 0)

    def _camera_position(self) -> np.ndarray:
        """Camera position in meshcat's camera frame (three.js axes, y up) with the scene's centre at the origin.

        Motion in a horizontal plane (the paper's arm) is seen from above,
        tilted a little; anything else from the front-right, above.
        """
        half = self._half_extent
        pad = 1.5 * self.marker_radius
        if half[2] - pad < 0.05 * (half.max() - pad):
            direction = np.array([0.0, -0.2, 1.0])
            # A window wider than high: the height of the picture limits the view.
            visible_half = max(half[1], half[0] / 1.5)
        else:
            direction = np.array([1.0, -1.0, 0.6])
            visible_half = float(np.linalg.norm(half))
        direction /= np.linalg.norm(direction)
        distance = 1.1 * visible_half / math.tan(math.radians(_CAMERA_FOV) / 2)
        x, y, z = distance * direction
        return np.array([x, z, -y])

    def show_frame(self, vis, frame: int, previous_frame: int | None = None) -> None:
        """Move the arm and the markers to display frame ``frame``.

        With ``previous_frame``, the frame last shown, the trace grows by the
        rows between the two, and a joint is highlighted when it was over its
        limit at any frame after ``previous_frame`` up to ``frame``.
        """
        first = frame if previous_frame is None else previous_frame + 1
        highlighted = self.frames.over_limit[first : frame + 1].any(axis=0)
        for index, placement in enumerate(self._frame_visuals[frame]):
            vis[self._visual_node(index)].set_transform(
                _scaled(placement, self.geometry.geometryObjects[index].meshScale)
            )
        for joint, position in enumerate(self._frame_joints[frame]):
            node = vis[self._marker_node(joint)]
            node.set_transform(_translation(position))
            node.set_property("visible", bool(highlighted[joint]))
        if previous_frame is not None:
            self._draw_trace_segment(vis, previous_frame, frame)

    def _draw_trace_segment(self, vis, first_frame: int, last_frame: int) -> None:
        """The tip's trace from one frame to another, as the node ``tip_trace/<last_frame>``."""
        geometry = require_meshcat().geometry
        first, last = self.frames.rows[first_frame], self.frames.rows[last_frame]
        tube = _tube(geometry, _decimate(self.tip_positions[first : last + 1], 12), 0.6 * self._path_radius)
        if tube is not None:
            vis[f"{_TRACE_NODE}/{last_frame}"].set_object(tube, geometry.MeshLambertMaterial(color=TRACE_COLOR))

    def play(self, vis, sleep=time.sleep, clock=time.perf_counter) -> int:
        """Play the run in a live visualizer at :attr:`speed`; returns the number of frames drawn.

        When drawing falls behind the clock, frames are skipped (the trace
        and the highlights still cover the rows skipped).
        """
        vis[_TRACE_NODE].delete()
        self.show_frame(vis, 0)
        start = clock()
        drawn, previous = 1, 0
        last = len(self.frames) - 1
        while previous < last:
            elapsed = clock() - start
            due = int(np.searchsorted(self.frames.time, elapsed, side="right")) - 1
            if due <= previous:
                sleep(self.frames.time[previous + 1] - elapsed)
                continue
            frame = min(due, last)
            self.show_frame(vis, frame, previous)
            previous = frame
            drawn += 1
        return drawn

    def animation(self, vis):
        """The run as a meshcat Animation for the scene drawn in ``vis``.

        Tracks: the visuals' positions and orientations and the markers'
        positions at every frame, the markers' visibility where it changes,
        and the visibility of each trace segment from its frame on. Every
        track has a key at the last frame, so that all of them last as long
        as the playback and hold their last value when it ends.
        """
        meshcat = require_meshcat()
        animation = meshcat.animation.Animation(default_framerate=self.fps)
        for frame, wall_time in enumerate(self.frames.time):
            key = wall_time * self.fps
            with animation.at_frame(vis, key) as at:
                for index, placement in enumerate(self._frame_visuals[frame]):
                    node = at[self._visual_node(index)]
                    node.set_property("position", "vector3", placement.translation.tolist())
                    node.set_property("quaternion", "quaternion", _quaternion(placement))
                for joint, position in enumerate(self._frame_joints[frame]):
                    at[self._marker_node(joint)].set_property("position", "vector3", position.tolist())
        last = len(self.frames) - 1
        for joint in range(len(self.joint_ids)):
            over = self.frames.over_limit[:, joint]
            changes = np.flatnonzero(np.diff(over.astype(int))) + 1
            for frame in sorted({0, *changes.tolist(), last}):
                with animation.at_frame(vis, self.frames.time[frame] * self.fps) as at:
                    at[self._marker_node(joint)].set_property("visible", "boolean", bool(over[frame]))
        for frame in range(1, len(self.frames)):
            for key_frame, shown in sorted({(0, False), (frame, True), (last, True)}):
                with animation.at_frame(vis, self.frames.time[key_frame] * self.fps) as at:
                    at[f"{_TRACE_NODE}/{frame}"].set_property("visible", "boolean", shown)
        return animation

    def html(self) -> str:
        """A self-contained HTML page that plays the run once when opened (no server, works offline).

        Opened with ``#t=SECONDS`` after its address, the page shows the run
        paused at that simulated time instead (``#t=end``: at its end).
        """
        meshcat = require_meshcat()
        vis = meshcat.Visualizer(window=_RecordingWindow(speed=self.speed))
        self.draw_scene(vis)
        for frame in range(1, len(self.frames)):
            self._draw_trace_segment(vis, frame - 1, frame)
            vis[f"{_TRACE_NODE}/{frame}"].set_property("visible", False)
        vis.set_animation(self.animation(vis), play=True, repetitions=1)
        return vis.static_html()


def check_run_matches(robot: Robot, result: SimResult) -> None:
    """Raise InvalidInput unless the run moved exactly the robot's joints, in order."""
    run_joints, robot_joints = list(result.joint_names), list(robot.joint_names)
    if run_joints == robot_joints and result.joint_angles.shape[1:] == (robot.nv,):
        return
    raise InvalidInput(
        f"the run moves {len(run_joints)} joints ({', '.join(run_joints)}) but robot '{robot.name}' with frame "
        f"'{robot.frame}' moves {len(robot_joints)} ({', '.join(robot_joints)}); give the robot the run was made "
        f"with (robot '{result.robot}', frame '{result.frame}')"
    )


def export_html(playback: Playback, path: str | Path) -> Path:
    """Write ``playback`` as a self-contained HTML file, atomically; returns the path."""
    path = Path(path)
    page = playback.html().encode("utf-8")
    atomic_write(path, lambda handle: handle.write(page))
    return path


# -- static HTML ----------------------------------------------------------------------


class _RecordingWindow:
    """Stands in for meshcat's ViewerWindow: keeps the scene commands in order, no server.

    ``get_scene`` returns the page that meshcat's server would give for
    ``static_html()``, except that the commands run synchronously and in
    the order they were sent, and that ``#t=SECONDS`` in the page's address
    pauses the animation at that simulated time (``speed`` converts it to
    the animation's time).
    """

    def __init__(self, speed: float = 1.0):
        self.commands: list[bytes] = []
        self.speed = speed

    def send(self, command) -> None:
        import umsgpack

        self.commands.append(umsgpack.packb(command.lower()))

    def get_scene(self) -> str:
        meshcat = require_meshcat()
        viewer_script = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        script = viewer_script.read_text(encoding="utf-8")
        encoded = ",\n".join(f'"{base64.b64encode(command).decode("ascii")}"' for command in self.commands)
        return _PAGE.format(viewer_script=script, commands=encoded, speed=repr(float(self.speed)))


_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>torqueopt playback</title>
<style>body {{ margin: 0; }} #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}</style>
</head>
<body>
<div id="meshcat-pane"></div>
<script>
{viewer_script}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
var commands = [
{commands}
];
for (const command of commands) {{
    const text = atob(command);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) {{ bytes[i] = text.charCodeAt(i); }}
    viewer.handle_command_bytearray(bytes);
}}
// Simulated seconds per second of animation.
const speed = {speed};
const shown = /[#&]t=(end|[0-9.eE+-]+)/.exec(location.hash);
if (shown !== null) {{
    viewer.animator.pause();
    viewer.animator.seek(shown[1] === "end" ? viewer.animator.duration : parseFloat(shown[1]) / speed);
}}
document.title = "torqueopt playback (loaded)";
</script>
</body>
</html>
"""


# -- live server ------------------------------------------------------------------------


def _serve_localhost() -> None:
    """Body of the server subprocess: meshcat's ZMQ/websocket bridge, every socket on 127.0.0.1."""
    import tornado.web
    from meshcat.servers import zmqserver

    class LocalhostApplication(tornado.web.Application):
        def listen(self, port, address=None, **kwargs):
            return super().listen(port, LOCALHOST, **kwargs)

    class LocalhostBridge(zmqserver.ZMQWebSocketBridge):
        def make_app(self):
            return LocalhostApplication(
                [
                    (
                        r"/static/(.*)",
                        zmqserver.StaticFileHandlerNoCache,
                        {"path": zmqserver.VIEWER_ROOT, "default_filename": zmqserver.VIEWER_HTML},
                    ),
                    (r"/", zmqserver.WebSocketHandler, {"bridge": self}),
                ]
            )

        def wait_for_websockets(self):
            # meshcat answers "wait" on the raw socket from a timer, outside its
            # ZMQStream's handler, and the stream then misses every later
            # command; answering through the stream keeps it polling.
            if self.websocket_pool:
                self.zmq_stream.send(b"ok")
            else:
                self.ioloop.call_later(0.1, self.wait_for_websockets)

    def exit_with_parent():
        # The parent holds the other end of stdin: EOF means it has gone,
        # even when killed without the chance to stop this server.
        sys.stdin.buffer.read()
        os._exit(0)

    threading.Thread(target=exit_with_parent, daemon=True).start()
    bridge = LocalhostBridge(zmq_url=None, host=LOCALHOST)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    bridge.run()


class LiveViewer:
    """A meshcat server on 127.0.0.1 in a subprocess, and a visualizer connected to it.

    Use it as a context manager; leaving it stops the server::

        with LiveViewer() as live:
            print(live.url)
            playback.draw_scene(live.visualizer)
            live.wait_for_browser()
            playback.play(live.visualizer)
    """

    def __init__(self, startup_timeout: float = 30.0):
        meshcat = require_meshcat()
        self._process = subprocess.Popen(
            [sys.executable, "-u", "-c", "from torqueopt.viewer import _serve_localhost; _serve_localhost()"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            urls = self._read_urls(startup_timeout)
            self.zmq_url, self.url = urls["zmq_url"], urls["web_url"]
            # meshcat prints the URL itself; the caller says it in its own words.
            with contextlib.redirect_stdout(io.StringIO()):
                self.visualizer = meshcat.Visualizer(zmq_url=self.zmq_url)
        except BaseException:
            self.close()
            raise

    @property
    def pid(self) -> int:
        """Process id of the server."""
        return self._process.pid

    def _read_urls(self, timeout: float) -> dict[str, str]:
        urls: dict[str, str] = {}
        stdout = self._process.stdout

        def read():
            for line in stdout:
                key, _, value = line.decode("utf-8", "replace").strip().partition("=")
                urls[key] = value
                if "web_url" in urls:
                    break

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        reader.join(timeout)
        if "zmq_url" not in urls or "web_url" not in urls:
            raise TorqueoptError(f"the meshcat server did not start within {timeout:g} s")
        # Keep draining the pipe so that the server never blocks on a full one.
        threading.Thread(target=lambda: stdout.read(), daemon=True).start()
        return urls

    def wait_for_browser(self, timeout: float | None = None, poll: float = 0.5) -> None:
        """Block until a browser has opened :attr:`url`, or ``timeout`` seconds (then close the viewer)."""
        socket = self.visualizer.window.zmq_socket
        socket.send(b"wait")
        deadline = None if timeout is None else time.monotonic() + timeout
        while not socket.poll(int(poll * 1000)):
            if self._process.poll() is not None:
                raise TorqueoptError(f"the meshcat server stopped (exit code {self._process.returncode})")
            if deadline is not None and time.monotonic() > deadline:
                raise TorqueoptError(f"no browser opened {self.url} within {timeout:g} s")
        socket.recv()

    def close(self) -> None:
        """Stop the server and close the connection to it."""
        visualizer = getattr(self, "visualizer", None)
        if visualizer is not None:
            visualizer.window.zmq_socket.close(linger=0)
        if self._process.stdin is not None:
            self._process.stdin.close()
        if self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        if self._process.stdout is not None:
            self._process.stdout.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


# -- headless screenshots ------------------------------------------------------------------


def find_browser(browser: str | None = None) -> str:
    """Path of a Chromium-family browser: ``browser`` if given, else the first of :data:`BROWSERS` on PATH."""
    candidates = (browser,) if browser else BROWSERS
    for name in candidates:
        found = shutil.which(name)
        if found:
            return found
    raise MissingDependency(
        f"no headless browser found (looked for {', '.join(candidates)}): install Chromium, "
        "e.g. apt-get install chromium"
    )


def screenshot_html(
    html_path: str | Path,
    png_path: str | Path,
    *,
    at: float | None = None,
    wait: float = 1.0,
    width: int = 1280,
    height: int = 800,
    browser: str | None = None,
    timeout: float = 120.0,
) -> Path:
    """Render a playback page in headless Chromium and save a PNG screenshot, atomically.

    Args:
        at: simulated time [s] at which the page pauses the run (see
            :meth:`Playback.html`); None for the end of the run.
        wait: virtual time [s] the page gets to load and draw. Playing the
            animation under virtual time is slow and erratic in software
            WebGL, hence the pause.
        width, height: window size [pixels].
        browser: browser executable; see :func:`find_browser`.

    The browser runs without sandbox, GPU (WebGL falls back to SwiftShader),
    network services, sync or first-run setup, with a fresh profile.
    """
    executable = find_browser(browser)
    html_path, png_path = Path(html_path).resolve(), Path(png_path)
    if not html_path.is_file():
        raise InvalidInput(f"HTML file '{html_path}' does not exist")
    with tempfile.TemporaryDirectory(prefix="torqueopt-chromium-") as scratch:
        shot = Path(scratch) / "screenshot.png"
        command = [
            executable,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            # Chromium only falls back to software WebGL when told that is fine.
            "--enable-unsafe-swiftshader",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-extensions",
            "--disable-crash-reporter",
            "--no-first-run",
            "--no-default-browser-check",
            "--hide-scrollbars",
            "--mute-audio",
            f"--user-data-dir={Path(scratch) / 'profile'}",
            f"--window-size={int(width)},{int(height)}",
            f"--virtual-time-budget={int(wait * 1000)}",
            f"--screenshot={shot}",
            f"{html_path.as_uri()}#t={'end' if at is None else repr(float(at))}",
        ]
        try:
            completed = subprocess.run(
                command, check=False, capture_output=True, timeout=timeout, stdin=subprocess.DEVNULL
            )
        except subprocess.TimeoutExpired:
            raise TorqueoptError(
                f"{executable} did not finish the screenshot of '{html_path}' within {timeout:g} s"
            ) from None
        if not shot.is_file():
            detail = completed.stderr.decode("utf-8", "replace").strip().splitlines()[-1:] or ["no output"]
            raise TorqueoptError(f"{executable} wrote no screenshot (exit code {completed.returncode}): {detail[0]}")
        image = shot.read_bytes()
    atomic_write(png_path, lambda handle: handle.write(image))
    return png_path


# -- helpers ---------------------------------------------------------------------------------


def _reference_positions(result: SimResult, start: np.ndarray) -> np.ndarray:
    """Reference tip positions in 3-D [m]: the task's linear rows, the start's value elsewhere (z for ``xy``)."""
    linear = min(result.x_ref.shape[1], 3)
    positions = np.tile(start, (len(result.t), 1))
    positions[:, :linear] = result.x_ref[:, :linear]
    return positions


def _reach(joint_positions: np.ndarray, tip: np.ndarray) -> float:
    """Length of the polyline base joint → ... → tip [m], the arm's size."""
    points = np.vstack([joint_positions, tip])
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _decimate(points: np.ndarray, most: int) -> np.ndarray:
    """At most ``most`` of the points, evenly spread, first and last kept."""
    if len(points) <= most:
        return points
    return points[np.unique(np.linspace(0, len(points) - 1, most).round().astype(int))]


def _tube(geometry, points: np.ndarray, radius: float, sides: int = 8):
    """A thin tube along a polyline, or None when the points do not move.

    WebGL draws lines one pixel wide whatever their width, too thin to see
    on a screenshot, hence tubes. The cross-section is carried along the
    path by parallel transport, so it does not twist.
    """
    points = np.asarray(points, dtype=float)
    moved = np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-6 * max(radius, 1e-9)
    points = points[np.r_[True, moved]]
    if len(points) < 2:
        return None
    steps = np.diff(points, axis=0)
    steps /= np.linalg.norm(steps, axis=1, keepdims=True)
    # At a vertex, the mean of the two steps' directions; where the path
    # turns back on itself that mean vanishes and the step ahead serves.
    tangents = np.vstack([steps[:1], steps[:-1] + steps[1:], steps[-1:]])
    lengths = np.linalg.norm(tangents, axis=1)
    reversed_here = lengths < 1e-6
    tangents[reversed_here] = np.vstack([steps, steps[-1:]])[reversed_here]
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    axis = np.eye(3)[np.argmin(np.abs(tangents[0]))]
    normal = np.cross(tangents[0], axis)
    rings = []
    angles = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    for point, tangent in zip(points, tangents):
        transported = normal - normal.dot(tangent) * tangent
        if np.linalg.norm(transported) > 1e-6:
            normal = transported
        normal = normal / np.linalg.norm(normal)
        binormal = np.cross(tangent, normal)
        rings.append(point + radius * (np.outer(np.cos(angles), normal) + np.outer(np.sin(angles), binormal)))
    vertices = np.vstack(rings)
    ring = np.arange(sides)
    following = (ring + 1) % sides
    faces = []
    for index in range(len(points) - 1):
        here, there = index * sides, (index + 1) * sides
        faces.append(np.column_stack([here + ring, here + following, there + following]))
        faces.append(np.column_stack([here + ring, there + following, there + ring]))
    return geometry.TriangularMeshGeometry(vertices, np.vstack(faces))


def _scaled(placement: pin.SE3, scale: np.ndarray) -> np.ndarray:
    matrix = placement.homogeneous.copy()
    matrix[:3, :3] = matrix[:3, :3] @ np.diag(scale)
    return matrix


def _translation(position: np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = position
    return matrix


def _quaternion(placement: pin.SE3) -> list[float]:
    """Rotation as three.js wants it: [x, y, z, w]."""
    return pin.Quaternion(placement.rotation).coeffs().tolist()
