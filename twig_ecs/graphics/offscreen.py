"""Offscreen rendering (``twig render``): an EGL context with no window and no display.

:class:`OffscreenRenderer` wraps a standalone moderngl context and a
:class:`~twig_ecs.graphics.renderer.Renderer`; :func:`render_scene` runs a scene and
writes a PNG (its last frame), an animated GIF (Pillow) or an MP4 (imageio-ffmpeg).
"""

from __future__ import annotations

import math
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np
from PIL import Image

from twig_ecs.errors import TwigError
from twig_ecs.graphics.camera import CameraSpec, OrbitCamera
from twig_ecs.graphics.renderer import Renderer

FORMATS = (".png", ".gif", ".mp4")
DEFAULT_FPS = {".png": 30, ".gif": 15, ".mp4": 30}
MAX_GIF_FRAMES = 1500


class RenderError(TwigError):
    """Bad options of ``twig render`` or an output that cannot be written."""


def create_offscreen_context() -> moderngl.Context:
    """A standalone OpenGL 3.3+ context through EGL (works with no display)."""
    try:
        return moderngl.create_context(standalone=True, backend="egl", require=330)
    except Exception as exc:  # noqa: BLE001 - many driver-specific exception types
        raise RenderError(
            f"cannot create an offscreen OpenGL context through EGL ({exc}); "
            "Mesa's EGL and GL libraries are needed (Debian: apt-get install libegl1 libegl-mesa0 libgl1 "
            "libgl1-mesa-dri)"
        ) from exc


class OffscreenRenderer:
    """A renderer with its own EGL context; use as a context manager or call ``close()``."""

    def __init__(self, samples: int = 4) -> None:
        self.ctx = create_offscreen_context()
        self.renderer = Renderer(self.ctx, samples=samples)

    def render(self, scene, camera: OrbitCamera, size: tuple[int, int], alpha: float = 1.0,
               panels: tuple = ()) -> np.ndarray:  # fmt: skip
        """Draw ``scene`` and return the image as (height, width, 3) uint8, top row first."""
        self.renderer.render(scene, camera, size, alpha, panels)
        return self.renderer.read_pixels()

    def close(self) -> None:
        self.renderer.release()
        self.ctx.release()

    def __enter__(self) -> OffscreenRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def parse_size(text: str) -> tuple[int, int]:
    """``"1280x720"`` -> (1280, 720)."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise RenderError(f"size '{text}' is not WIDTHxHEIGHT in pixels, e.g. 1280x720")
    w, h = int(m.group(1)), int(m.group(2))
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise RenderError(f"size {w}x{h} is out of range: width and height must be 16..8192 pixels")
    return w, h


class Progress:
    """A one-line progress bar on stderr (only drawn when stderr is a terminal)."""

    def __init__(self, total: int, label: str, enabled: bool | None = None) -> None:
        self.total = max(1, total)
        self.label = label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.start = time.perf_counter()

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        frac = done / self.total
        bar = "#" * int(30 * frac)
        elapsed = time.perf_counter() - self.start
        eta = elapsed / frac * (1 - frac) if frac > 0 else 0.0
        print(f"\r{self.label} [{bar:<30}] {done}/{self.total} frames, {eta:4.0f} s left ",
              end="", file=sys.stderr, flush=True)  # fmt: skip

    def finish(self) -> None:
        if self.enabled:
            print(file=sys.stderr)


@dataclass
class RenderResult:
    """What :func:`render_scene` wrote."""

    path: Path
    frames: int
    size: tuple[int, int]
    fps: float
    ms_per_frame: float  # median render + readback time


class _FrameWriter:
    """Collects frames and writes them in the format of the output's suffix."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float, frames: int) -> None:
        self.path, self.size, self.fps = path, size, fps
        self.suffix = path.suffix.lower()
        self.frames: list[Image.Image] = []
        self._mp4 = None
        if self.suffix == ".gif" and frames > MAX_GIF_FRAMES:
            raise RenderError(f"{frames} frames is too many for a GIF (at most {MAX_GIF_FRAMES}): "
                              "write an .mp4, lower --fps or --seconds")  # fmt: skip
        if self.suffix == ".mp4":
            if size[0] % 2 or size[1] % 2:
                raise RenderError(f"MP4 needs an even width and height, not {size[0]}x{size[1]}")
            try:
                import imageio_ffmpeg
            except ImportError as exc:
                raise RenderError(
                    "writing MP4 needs the imageio-ffmpeg package: pip install imageio-ffmpeg"
                ) from exc
            self._mp4 = imageio_ffmpeg.write_frames(
                str(path), size, fps=fps, codec="libx264", quality=7, macro_block_size=2,
                ffmpeg_log_level="error",
            )  # fmt: skip
            self._mp4.send(None)

    def add(self, rgb: np.ndarray) -> None:
        if self._mp4 is not None:
            self._mp4.send(np.ascontiguousarray(rgb))
        elif self.suffix == ".gif":
            # octree keeps the small saturated areas (bodies, the deck) that median cut greys out:
            # 79% of such pixels stay coloured against 19% on a schoolyard frame, 7x faster
            self.frames.append(Image.fromarray(rgb).quantize(colors=255, method=Image.Quantize.FASTOCTREE))
        else:
            self.frames = [Image.fromarray(rgb)]

    def close(self) -> None:
        if self._mp4 is not None:
            self._mp4.close()
            self._mp4 = None
        elif self.suffix == ".gif" and self.frames:
            # GIF delays are whole centiseconds. Pillow stores consecutive identical frames
            # once, with their delays added, so a scene at rest makes a shorter file.
            delay = max(20, round(1000.0 / self.fps / 10) * 10)
            first, *rest = self.frames
            first.save(self.path, save_all=True, append_images=rest, duration=delay, loop=0, optimize=False)
        elif self.frames:
            self.frames[-1].save(self.path)


def contact_sheet(scene, path: Path, camera_of, frames: int, every: float, size: tuple[int, int],
                  columns: int) -> Path:  # fmt: skip
    """Draw ``frames`` pictures of ``scene`` ``every`` simulated seconds apart (from now, the scene
    run on between them), each from ``camera_of()``'s camera, into one sheet of ``columns``
    columns written to ``path`` (checked by :func:`check_output`); returns the path."""
    sheet = Image.new("RGB", (columns * size[0], math.ceil(frames / columns) * size[1]), "white")
    with OffscreenRenderer() as off:
        for k in range(frames):
            image = Image.fromarray(off.render(scene, camera_of(), size))
            sheet.paste(image, ((k % columns) * size[0], (k // columns) * size[1]))
            scene.run(every)
    sheet.save(path)
    return path


def check_output(output: str | Path) -> Path:
    """Validate the output path: a known suffix and an existing folder."""
    path = Path(output)
    if path.suffix.lower() not in FORMATS:
        raise RenderError(f"cannot write '{path}': the file name must end in .png, .gif or .mp4")
    if not path.parent.exists():
        raise RenderError(f"cannot write '{path}': folder '{path.parent}' does not exist")
    return path


def render_scene(scene, seconds: float, output: str | Path, size: tuple[int, int] = (1280, 720),
                 fps: float | None = None, camera: str | CameraSpec = "action",
                 progress: bool | None = None, samples: int = 4,
                 start: float = 0.0) -> RenderResult:  # fmt: skip
    """Run ``scene`` for ``seconds`` and write frames to ``output`` (.png, .gif, .mp4).

    A PNG holds the frame at ``start + seconds``; GIF/MP4 hold ``round(seconds * fps)``
    frames at times start + k / fps, k = 1..n, the store interpolated between steps where
    a frame time falls between two of them. ``start`` (s) is a time the scene has reached
    (a clip of what follows a moment, ``twig render --at``).
    """
    path = check_output(output)
    suffix = path.suffix.lower()
    if not seconds > 0:
        raise RenderError("--seconds must be more than 0")
    fps = float(fps or DEFAULT_FPS[suffix])
    if not 0 < fps <= 240:
        raise RenderError(f"--fps {fps:g} is out of range (1..240)")
    spec = camera if isinstance(camera, CameraSpec) else CameraSpec.parse(camera)
    count = max(1, round(seconds * fps))
    times = [start + seconds] if suffix == ".png" else [start + k / fps for k in range(1, count + 1)]
    writer = _FrameWriter(path, size, fps, len(times))
    bar = Progress(len(times), f"render {path.name}", progress)
    timings = []
    scene.step(0)  # compile kernels and install systems before the clock starts
    if suffix == ".png":
        scene.step(max(0, math.ceil(times[0] / scene.dt - 1e-6) - scene.frame))
    # A still frames the scene as it ends; a clip frames where it starts (and where the
    # bodies could fall).
    cam = spec.make(scene, size[0] / size[1])
    try:
        with OffscreenRenderer(samples=samples) as off:
            last_time = scene.time
            for k, t in enumerate(times):
                target = t / scene.dt
                steps = max(0, math.ceil(target - 1e-6) - scene.frame)
                scene.step(steps)
                alpha = float(min(1.0, max(0.0, target - (scene.frame - 1))))
                if spec.mode == "follow":
                    cam.follow(scene.entity(spec.name).position, max(1e-3, t - last_time))
                last_time = t
                t0 = time.perf_counter()
                rgb = off.render(scene, cam, size, alpha)
                timings.append((time.perf_counter() - t0) * 1000.0)
                writer.add(rgb)
                bar.update(k + 1)
    finally:
        bar.finish()
        writer.close()
    return RenderResult(path, len(times), size, fps, float(np.median(timings)))
