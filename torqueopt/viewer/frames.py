r"""Which rows of a run a playback shows, and when.

The run is sampled at ``fps`` display frames per second of playback; a
playback at ``speed`` s of simulated time per second of wall time shows the
row at simulated time :math:`t` at wall time :math:`t/\text{speed}`. A joint
is highlighted at a frame when its torque was over the limit at any row since
the previous frame, so that subsampling never hides a short violation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import bounded_count, positive_number, show_number
from ..errors import InvalidInput
from ..result import SimResult

__all__ = ["DEFAULT_FPS", "DEFAULT_MAX_FRAMES", "PlaybackFrames", "frame_count", "over_limit", "sample_frames"]

#: Display frames per second of playback (wall time), live and in HTML files.
DEFAULT_FPS = 30.0
#: Most display frames one playback may have (about 55 min at 30 fps); ``max_frames`` raises it.
DEFAULT_MAX_FRAMES = 100_000


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


def frame_count(
    simulated_time: float, speed: float, fps: float, max_frames: int = DEFAULT_MAX_FRAMES, option: str = "max_frames"
) -> int:
    """Display frames of a playback of ``simulated_time`` [s] at ``speed`` and ``fps``, bounded by ``max_frames``.

    Raises:
        InvalidInput: not positive speed or fps, or more frames than
            ``max_frames`` (the message names ``option``, the option that raises it).
    """
    fps = positive_number(fps, "fps")
    speed = positive_number(speed, "speed")
    frames = simulated_time / speed * fps  # inf past the float range: refused below, not converted
    count = math.floor(frames + 1e-9) + 1 if math.isfinite(frames) else frames
    return bounded_count(
        count,
        max_frames,
        f"playing {show_number(simulated_time)} s of simulated time at speed {show_number(speed)} and "
        f"fps {show_number(fps)}",
        "frames",
        option,
        remedy="or give a larger speed or a smaller fps",
    )


def sample_frames(
    result: SimResult, fps: float = DEFAULT_FPS, speed: float = 1.0, max_frames: int = DEFAULT_MAX_FRAMES
) -> PlaybackFrames:
    """Pick the rows of ``result`` to show at ``fps`` frames per wall-clock second.

    Args:
        fps: display frames per second of playback [1/s].
        speed: simulated seconds per wall-clock second (1 real time, 0.25 four times slower).
        max_frames: the most display frames the playback may have (see :func:`frame_count`).

    The first and the last row are always shown; a row is never shown twice.
    """
    fps = positive_number(fps, "fps")
    speed = positive_number(speed, "speed")
    times = np.asarray(result.t, dtype=float)
    if times.size == 0:
        raise InvalidInput("the run has no rows to play (it stopped before its first step)")
    elapsed = times - times[0]
    frames = frame_count(float(elapsed[-1]), speed, fps, max_frames)
    wanted = np.arange(frames) * (speed / fps)
    # The row at or just before each frame's simulated time.
    rows = np.searchsorted(elapsed, wanted + 1e-9 * max(1.0, elapsed[-1]), side="right") - 1
    rows = np.unique(np.append(np.clip(rows, 0, times.size - 1), times.size - 1))

    over = over_limit(result)
    counts = np.cumsum(over, axis=0)
    since_previous = counts[rows].copy()
    since_previous[1:] -= counts[rows[:-1]]
    return PlaybackFrames(rows=rows, time=elapsed[rows] / speed, over_limit=since_previous > 0)
