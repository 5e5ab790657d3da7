"""The play window: a pyglet window that shows one view at a time.

:class:`PlayWindow` owns what every view shares (the OpenGL context, the renderer, the
wall clock between frames) and hands each frame and each event to its current view
(:mod:`twig_ecs.graphics.view`), as arcade's ``Window.show_view`` does. Import this module
after :func:`~twig_ecs.graphics.display.load_pyglet_window`: pyglet reads its platform
options (a headless window or not) when ``pyglet.window`` is first imported.
"""

from __future__ import annotations

import os
import sys
import time

import moderngl
import numpy as np
import pyglet
import pyglet.window
from pyglet.window import key, mouse

from twig_ecs.graphics.display import WindowError, no_display_errors
from twig_ecs.graphics.loading import Loading
from twig_ecs.graphics.loading_view import LoadingView
from twig_ecs.graphics.play_view import PlayView
from twig_ecs.graphics.renderer import Renderer
from twig_ecs.graphics.view import View


class PlayWindow(pyglet.window.Window):
    """A resizable window that draws its current view; tests draw it frame by frame with :meth:`frame`.

    Opened on a viewer it shows the :class:`~twig_ecs.graphics.play_view.PlayView` at once;
    opened on a :class:`~twig_ecs.graphics.loading_view.Loading` (``viewer`` None) it shows
    the compile's progress first.
    """

    keys, mouse = key, mouse  # pyglet's key and mouse constants, for the views

    def __init__(
        self, viewer, size: tuple[int, int], visible: bool = True, loading: Loading | None = None
    ) -> None:
        config = pyglet.gl.Config(major_version=3, minor_version=3, forward_compatible=True,
                                  double_buffer=True)  # fmt: skip
        caption = loading.caption if viewer is None else f"twig - {viewer.scene.name}"
        try:
            super().__init__(size[0], size[1], caption=caption, resizable=True,
                             config=config, visible=visible, vsync=True)  # fmt: skip
        except (pyglet.window.NoSuchConfigException, pyglet.gl.ContextException) as exc:
            raise WindowError(f"cannot open an OpenGL 3.3 window: {exc}") from exc
        except no_display_errors(pyglet.window) as exc:  # DISPLAY names no X server now
            raise WindowError(
                f"cannot open a window: {exc} (DISPLAY={os.environ.get('DISPLAY', '')!r} is set but no "
                "display answers there; unset it or start the X server, or use 'twig render')"
            ) from None
        self.switch_to()
        moderngl.init_context()  # a context per window: create_context() would look for GLX
        self.ctx = moderngl.get_context()
        # Multisampling costs 2-3x on a software rasteriser: keep the window responsive there.
        software = any(s in self.ctx.info["GL_RENDERER"] for s in ("llvmpipe", "softpipe"))
        self.renderer = Renderer(self.ctx, samples=0 if software else 4)
        self._last = self._last_draw = time.perf_counter()
        #: wall seconds between the last two frames (what frame(elapsed) fakes is the simulated time)
        self.wall_gap = 0.0
        self.closed = False
        #: perf_counter() when the scene first drew (None before it exists)
        self.scene_started: float | None = None if viewer is None else time.perf_counter()
        #: perf_counter() when the scene first stepped at full speed, every kernel compiled
        self.full_speed: float | None = self.scene_started
        #: perf_counter() after the scene's first step (in slow motion or not)
        self.first_step: float | None = None
        self.current_view: View | None = None
        self.show_view(PlayView(viewer) if viewer is not None else LoadingView(loading))

    def show_view(self, view: View) -> None:
        """Make ``view`` the one that draws and takes the input from the next frame on."""
        if self.current_view is not None:
            self.current_view.on_hide_view()
        view.window = self
        self.current_view = view
        view.on_show_view()

    @property
    def viewer(self):
        """The scene's :class:`~twig_ecs.graphics.viewer.Viewer` (None while there is no scene yet)."""
        return getattr(self.current_view, "viewer", None)

    @property
    def loading(self) -> Loading | None:
        """The kernels' build while it runs (None once the scene runs at full speed)."""
        return getattr(self.current_view, "loading", None)

    def framebuffer(self) -> tuple[tuple[int, int], float]:
        """The framebuffer's size in pixels, and its pixels per window unit (HiDPI)."""
        size = self.get_framebuffer_size()
        return size, size[0] / max(1, self.width)

    # -- the loop -------------------------------------------------------------------------

    def on_draw(self) -> None:
        now = time.perf_counter()
        elapsed, self._last = now - self._last, now
        self.wall_gap, self._last_draw = now - self._last_draw, now
        view = self.current_view
        view.on_update(elapsed)
        while self.current_view is not view:  # it moved on: the new view starts from now
            view = self.current_view
            self._last = time.perf_counter()
            view.on_update(0.0)
        if self.closed:
            return
        view.on_draw()
        size, _ = self.framebuffer()
        self.renderer.present(self.ctx.screen, size)
        error = self.ctx.error  # read (and so clear) it: pyglet's GL checks would trip on it
        if error != "GL_NO_ERROR":
            print(f"twig play: OpenGL reported {error}", file=sys.stderr)

    def frame(self, elapsed: float | None = None) -> None:
        """Process events and draw one frame by hand (for tests and ``--frames``).

        ``elapsed`` overrides the wall time since the last frame (seconds)."""
        if elapsed is not None:
            self._last = time.perf_counter() - elapsed
        pyglet.clock.tick()
        self.switch_to()
        self.dispatch_events()  # queued input, synthetic events included
        if self.closed:
            return
        self.on_draw()  # directly: dispatch_event() would only queue it until the next frame
        if not self.closed:
            self.flip()

    def read_frame(self) -> np.ndarray:
        """The frame last drawn, (height, width, 3) uint8, top row first."""
        return self.renderer.read_pixels()

    # -- input: the current view's ------------------------------------------------------------

    def on_key_press(self, symbol: int, modifiers: int):
        self.current_view.on_key_press(symbol, modifiers)
        return True  # handled: keeps pyglet's default Esc handling out of the way

    def on_key_release(self, symbol: int, modifiers: int) -> None:
        self.current_view.on_key_release(symbol, modifiers)

    def on_mouse_press(self, x, y, button, modifiers) -> None:
        self.current_view.on_mouse_press(x, y, button, modifiers)

    def on_mouse_release(self, x, y, button, modifiers) -> None:
        self.current_view.on_mouse_release(x, y, button, modifiers)

    def on_mouse_drag(self, x, y, dx, dy, buttons, modifiers) -> None:
        self.current_view.on_mouse_drag(x, y, dx, dy, buttons, modifiers)

    def on_mouse_scroll(self, x, y, scroll_x, scroll_y) -> None:
        self.current_view.on_mouse_scroll(x, y, scroll_x, scroll_y)

    def on_mouse_motion(self, x, y, dx, dy) -> None:
        self.current_view.on_mouse_motion(x, y, dx, dy)

    def on_resize(self, width: int, height: int) -> None:
        pass  # the renderer follows get_framebuffer_size() every frame

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.set_visible(False)  # gone at once, even while a slow-motion step finishes
            self.switch_to()
            self.current_view.on_close()
            self.renderer.release()
        super().close()
