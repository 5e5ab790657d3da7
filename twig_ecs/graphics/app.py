"""``twig play``: open the play window on a scene and run it.

The window (:class:`~twig_ecs.graphics.window.PlayWindow`) shows one view at a time
(:mod:`twig_ecs.graphics.view`): on a first run the compile's progress
(:mod:`~twig_ecs.graphics.loading_view`), then the scene in slow motion while the
compile ends (:mod:`~twig_ecs.graphics.slow_motion_view`), then the scene at full speed
(:mod:`~twig_ecs.graphics.play_view`), whose model, the scene with its camera, clock and
input, is the :class:`~twig_ecs.graphics.viewer.Viewer`. The inspector (F1) is an overlay
of the play view (:mod:`~twig_ecs.graphics.inspector`). Tests drive the window frame by
frame with :meth:`PlayWindow.frame`.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pyglet

from twig_ecs.graphics.camera import CameraSpec
from twig_ecs.graphics.display import WindowError, load_pyglet_window  # noqa: F401 - public here as before
from twig_ecs.graphics.loading import Loading  # noqa: F401 - public here as before
from twig_ecs.graphics.viewer import MAX_STEPS_PER_FRAME, TIME_SCALES, Viewer  # noqa: F401 - as before


def _window_class(window_module):
    """The play window class (:class:`~twig_ecs.graphics.window.PlayWindow`), importable once
    ``window_module`` (pyglet.window, from :func:`load_pyglet_window`) has been imported."""
    assert window_module is sys.modules.get("pyglet.window"), "load_pyglet_window() first"
    from twig_ecs.graphics.window import PlayWindow

    return PlayWindow


def open_window(source: str = "schoolyard", seed: int = 0, content: tuple | list = (),
                size: tuple[int, int] = (1280, 720), camera: CameraSpec | None = None,
                paused: bool = False, headless: bool = False, screenshot_dir: str | Path = ".",
                visible: bool = True, parameters: dict | None = None):  # fmt: skip
    """Open a play window (a :class:`PlayWindow`, a ``pyglet.window.Window``) on a scene."""
    from twig_ecs import kernels

    window_class = _window_class(load_pyglet_window(headless))

    def make_viewer() -> Viewer:
        return Viewer(source, seed, content, camera, paused, screenshot_dir, parameters)

    if kernels.needs_build():  # a first run: open at once and show the compile's progress
        loading = Loading(kernels.KernelBuild(source, seed, content, parameters), make_viewer,
                          f"twig - {Path(str(source)).stem}", interim=True)  # fmt: skip
        try:
            return window_class(None, size, visible=visible and not headless, loading=loading)
        except BaseException:
            loading.build.cancel()
            raise
    viewer = make_viewer()
    try:
        return window_class(viewer, size, visible=visible and not headless)
    except BaseException:
        viewer.close()
        raise


def play(
    source: str = "schoolyard",
    seed: int = 0,
    content: tuple | list = (),
    size: tuple[int, int] = (1280, 720),
    camera: CameraSpec | None = None,
    paused: bool = False,
    max_frames: int | None = None,
    headless: bool = False,
    screenshot_dir: str | Path = ".",
    parameters: dict | None = None,
) -> int:
    """Open the window and run until it closes (or ``max_frames`` scene frames are drawn).

    Returns the scene frames drawn. On a first run the window opens at once and shows the
    kernels compiling, soon over the scene running in slow motion; those frames do not
    count. With ``max_frames`` a line on stderr says when the first frame was drawn, when
    the scene first stepped and when it ran at full speed (seconds since the call).
    """
    start = time.perf_counter()
    window = open_window(source, seed, content, size, camera, paused, headless, screenshot_dir,
                         parameters=parameters)  # fmt: skip
    if max_frames is None and not headless:
        pyglet.app.run(interval=1 / 120)
        return window.viewer.frames if window.viewer is not None else 0
    limit = max_frames if max_frames is not None else 600
    first = None
    try:
        while not window.closed and (window.loading is not None or window.viewer.frames < limit):
            window.frame()
            if first is None:
                first = time.perf_counter() - start
                if max_frames is not None:
                    print("twig play: first frame drawn", file=sys.stderr, flush=True)
        drawn = window.viewer.frames if window.viewer is not None else 0
    finally:
        window.close()
    if max_frames is not None:

        def since(moment: float | None) -> str:
            return f"{moment - start:.2f} s" if moment else "never"

        print(f"twig play: first frame after {first:.2f} s, first step after "
              f"{since(window.first_step)}, at full speed after {since(window.full_speed)}",
              file=sys.stderr)  # fmt: skip
    return drawn
