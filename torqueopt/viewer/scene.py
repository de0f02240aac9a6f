r"""The meshcat scene of a run: the arm (its URDF visuals, reduced as the dynamic model is), the reference path
(a translucent green tube), the tip's growing trace (orange) and a red sphere at each joint while its torque is
over its limit, :math:`|\tau_i| > \tau_i^+` (or below :math:`\tau_i^-`).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pinocchio as pin

from ..checks import positive_number
from ..errors import InvalidInput
from ..result import SimResult
from ..robot import Robot
from .dependency import require_meshcat
from .frames import DEFAULT_FPS, DEFAULT_MAX_FRAMES, sample_frames
from .page import RecordingWindow
from .shapes import decimate, quaternion, reach, reference_positions, scaled, translation, tube_mesh
from .visual_model import visual_model

__all__ = [
    "BACKGROUND_BOTTOM",
    "BACKGROUND_TOP",
    "HIGHLIGHT_COLOR",
    "REFERENCE_COLOR",
    "TRACE_COLOR",
    "Playback",
    "check_run_matches",
]

#: Colour of the sphere marking a joint over its torque limit (0xRRGGBB).
HIGHLIGHT_COLOR = 0xE41A1C
REFERENCE_COLOR = 0x2CA02C
TRACE_COLOR = 0xFF7F0E
#: Background gradient, RGB in [0, 1].
BACKGROUND_TOP = [0.98, 0.98, 0.98]
BACKGROUND_BOTTOM = [0.78, 0.78, 0.8]

_ROOT = "torqueopt"
_ROBOT_NODE = f"{_ROOT}/robot"
_MARKER_NODE = f"{_ROOT}/torque_limit"
_TRACE_NODE = f"{_ROOT}/tip_trace"
_REFERENCE_NODE = f"{_ROOT}/reference_path"
_CAMERA_NODE = "/Cameras/default/rotated/<object>"
#: Vertical field of view of the camera [deg]; narrower than meshcat's 75 so that links keep their shape.
_CAMERA_FOV = 40.0


class Playback:
    """A run and the robot that made it, ready to draw in a meshcat visualizer.

    Args:
        robot: the robot of the run (same joints, same order).
        result: the run, e.g. from :func:`torqueopt.simulate` or :func:`torqueopt.load_result`.
        speed: simulated seconds per wall-clock second (0.25: four times slower).
        fps: display frames per second of playback.
        max_frames: the most display frames the playback may have.

    Raises:
        InvalidInput: the run's joints are not the robot's, or speed/fps are not positive.
    """

    def __init__(
        self,
        robot: Robot,
        result: SimResult,
        *,
        speed: float = 1.0,
        fps: float = DEFAULT_FPS,
        max_frames: int = DEFAULT_MAX_FRAMES,
    ):
        check_run_matches(robot, result)
        self.robot = robot
        self.result = result
        self.speed = positive_number(speed, "speed")
        self.frames = sample_frames(result, fps, speed, max_frames)
        self.fps = float(fps)
        self.model, self.geometry = visual_model(robot)
        self._data = self.model.createData()
        self._geometry_data = self.geometry.createData()

        self.configurations = np.array([robot.configuration(angles) for angles in result.joint_angles])
        robot_data = robot.model.createData()
        self.tip_positions = np.array([robot.frame_placement(q, robot_data).translation for q in self.configurations])
        self.reference_positions = reference_positions(result, self.tip_positions[0])
        self.joint_ids = [self.model.getJointId(name) for name in robot.joint_names]

        self._frame_visuals = []
        self._frame_joints = []
        for row in self.frames.rows:
            visuals, joints = self._placements(self.configurations[row])
            self._frame_visuals.append(visuals)
            self._frame_joints.append(joints)
        self.marker_radius = max(0.08, 0.03 * reach(self._frame_joints[0], self.tip_positions[0]))
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

        reference = tube_mesh(geometry, decimate(self.reference_positions, 400), self._path_radius)
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
                scaled(placement, self.geometry.geometryObjects[index].meshScale)
            )
        for joint, position in enumerate(self._frame_joints[frame]):
            node = vis[self._marker_node(joint)]
            node.set_transform(translation(position))
            node.set_property("visible", bool(highlighted[joint]))
        if previous_frame is not None:
            self._draw_trace_segment(vis, previous_frame, frame)

    def _draw_trace_segment(self, vis, first_frame: int, last_frame: int) -> None:
        """The tip's trace from one frame to another, as the node ``tip_trace/<last_frame>``."""
        geometry = require_meshcat().geometry
        first, last = self.frames.rows[first_frame], self.frames.rows[last_frame]
        trace = tube_mesh(geometry, decimate(self.tip_positions[first : last + 1], 12), 0.6 * self._path_radius)
        if trace is not None:
            vis[f"{_TRACE_NODE}/{last_frame}"].set_object(trace, geometry.MeshLambertMaterial(color=TRACE_COLOR))

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
                    node.set_property("quaternion", "quaternion", quaternion(placement))
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
        vis = meshcat.Visualizer(window=RecordingWindow(speed=self.speed))
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
