"""The first run's first screen: the kernels' compile progress, before there is a scene.

On a first run (no compiled kernels cached) the window opens at once on a
:class:`LoadingView`. Its frames draw the build's progress (what compiles, a bar, the
count of kernels still to compile) and rest between them, leaving the cores to the
compiling workers. With ``interim`` the scene is loaded meanwhile in a thread, with
every kernel as plain Python, and the window moves on to the
:class:`~twig_ecs.graphics.slow_motion_view.SlowMotionView`; without, it moves on to the
:class:`~twig_ecs.graphics.play_view.PlayView` once the build has finished.
"""

from __future__ import annotations

import threading
import time

from twig_ecs.graphics.loading import Loading, rest_after_frame
from twig_ecs.graphics.play_view import PlayView
from twig_ecs.graphics.slow_motion_view import SlowMotionView
from twig_ecs.graphics.view import View
from twig_ecs.trust import thread_trusting_as_now


class LoadingView(View):
    """Draws the compile's progress; makes the viewer (in a thread, with ``interim``) and moves on."""

    def __init__(self, loading: Loading) -> None:
        self.loading = loading
        self.frames = 0
        self._maker: threading.Thread | None = None  # makes the viewer with interim kernels
        self._made: list = []  # the viewer it made, or the exception it raised

    def on_update(self, elapsed: float) -> None:
        self.frames += 1
        loading, window = self.loading, self.window
        finished = loading.build.poll()
        if loading.interim and not finished and self.frames > 1 and self._maker is None:
            # the progress panel is up: now the scene, off the window's thread (imports, loading)
            self._maker = thread_trusting_as_now(self._make, name="twig-load-scene")
            self._maker.start()
        if self._maker is not None:
            if self._maker.is_alive():
                return
            made = self._made.pop()
            self._maker = None
            if isinstance(made, BaseException):
                raise made
            window.scene_started = time.perf_counter()
            window.show_view(SlowMotionView(loading, made))
            return
        if finished:
            window.show_view(PlayView(loading.make_viewer()))  # loads the kernels the workers just cached
            window.scene_started = window.full_speed = time.perf_counter()

    def _make(self) -> None:
        try:
            self._made.append(self.loading.start_interim())
        except BaseException as exc:  # noqa: BLE001 - raised again on the window's thread
            self._made.append(exc)

    def on_draw(self) -> None:
        began = time.perf_counter()
        window = self.window
        size, scale = window.framebuffer()
        image = self.loading.panel(scale)
        x, y = (size[0] - image.size[0]) // 2, (size[1] - image.size[1]) // 2
        window.renderer.render_panels(size, (("loading", image, x, y),))
        rest_after_frame(began)  # leave the cores to the compiling workers

    def on_key_press(self, symbol: int, modifiers: int) -> None:
        if symbol == self.window.keys.ESCAPE:  # nothing else to do yet
            self.window.close()

    def on_close(self) -> None:
        self.loading.build.cancel()
        if self._maker is not None:  # the window is already gone from the screen
            self._maker.join()
            made = self._made.pop()
            if not isinstance(made, BaseException):
                made.close()
        self.loading.end_interim()
