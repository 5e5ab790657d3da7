"""Recording the window: what it shows, as an H.264 MP4 at a steady frame rate.

The window draws at whatever rate the machine allows; a video plays at a fixed one. So
the recorder keeps a clock of its own, the video's, advanced by the seconds each drawn
frame stands for, and writes each frame as many times as video frames fell due meanwhile
(a slow window repeats frames, a fast one skips some). The window advances that clock
by the simulated time each frame moved the scene on (at the time scale chosen: see
:meth:`~twig_ecs.graphics.app.Viewer.video_seconds`), so a window that cannot keep up
with real time still records a video that plays at real speed: its frame count is 30
per simulated second.

The encoder is imageio-ffmpeg's (already a dependency of ``twig render``): its wheels
carry their own ffmpeg binary, so no system ffmpeg is needed.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from twig_ecs.errors import TwigError

#: Video frames per second of a recording.
RECORD_FPS = 30.0
#: The most copies of one drawn frame (a window stalled for seconds does not write a long still).
MAX_REPEATS = 15


class RecordingError(TwigError):
    """A recording could not be started or written."""


class Recorder:
    """Writes drawn frames (RGB arrays, top row first) to ``path`` as an MP4."""

    def __init__(self, path: str | Path, size: tuple[int, int], fps: float = RECORD_FPS) -> None:
        try:
            import imageio_ffmpeg
        except ImportError as exc:
            raise RecordingError("recording needs the imageio-ffmpeg package: "
                                 "pip install imageio-ffmpeg") from exc  # fmt: skip
        self.path = Path(path)
        # H.264 in yuv420p needs even sides: the odd last row or column is left out
        self.size = (size[0] - size[0] % 2, size[1] - size[1] % 2)
        if min(self.size) < 2:
            raise RecordingError(f"cannot record a {size[0]}x{size[1]} window")
        self.fps = fps
        self.frames = 0  # video frames written
        self.clock = 0.0  # seconds of video recorded
        self._writer = imageio_ffmpeg.write_frames(str(self.path), self.size, fps=fps, codec="libx264",
                                                   quality=7, macro_block_size=2,
                                                   ffmpeg_log_level="error")  # fmt: skip
        self._writer.send(None)

    def add(self, rgb: np.ndarray, seconds: float) -> int:
        """Add a frame that stands for ``seconds`` of video after the last one; returns video
        frames written (the first frame once, at time 0)."""
        if self._writer is None:
            raise RecordingError(f"the recording {self.path} is already closed")
        self.clock += max(0.0, seconds)
        due = max(1 if self.frames == 0 else 0, math.floor(self.clock * self.fps + 1e-6) + 1 - self.frames)
        due = min(due, MAX_REPEATS)
        width, height = self.size
        frame = np.ascontiguousarray(rgb[:height, :width])
        if frame.shape[:2] != (height, width):  # the window shrank while recording
            padded = np.zeros((height, width, 3), dtype=np.uint8)
            padded[: frame.shape[0], : frame.shape[1]] = frame
            frame = padded
        for _ in range(due):
            self._writer.send(frame)
        self.frames += due
        return due

    def close(self) -> Path:
        """Finish the file; returns its path."""
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        return self.path
