"""The scene at full speed: the window's frames step and draw its :class:`~twig_ecs.graphics.viewer.Viewer`,
and the keys and mouse go to it."""

from __future__ import annotations

import time

from twig_ecs.graphics.view import View


class PlayView(View):
    """Steps the viewer's scene by the wall clock, draws it, and hands it the input."""

    def __init__(self, viewer) -> None:
        self.viewer = viewer

    def on_show_view(self) -> None:
        self.viewer.bind_keys(self.window.keys)
        self.window.set_caption(f"twig - {self.viewer.scene.name}")

    def on_update(self, elapsed: float) -> None:
        # fps from the wall clock even when frame(elapsed) fakes the simulated time
        self.viewer.stats.add_frame(self.window.wall_gap * 1000.0)
        if self.viewer.advance(elapsed) and self.window.first_step is None:
            self.window.first_step = time.perf_counter()

    def on_draw(self) -> None:
        window = self.window
        size, scale = window.framebuffer()
        self.viewer.window_size = (window.width, window.height)
        self.viewer.draw(window.renderer, size, scale)

    def on_close(self) -> None:
        self.viewer.close()

    # -- input: the viewer's ------------------------------------------------------------

    def on_key_press(self, symbol: int, modifiers: int) -> None:
        if self.viewer.key_press(symbol, modifiers) == "quit":
            self.window.close()

    def on_key_release(self, symbol: int, modifiers: int) -> None:
        self.viewer.key_release(symbol)

    def on_mouse_press(self, x, y, button, modifiers) -> None:
        self.viewer.window_size = (self.window.width, self.window.height)
        self.viewer.mouse_press(x, y, button, modifiers, self.window.mouse)

    def on_mouse_release(self, x, y, button, modifiers) -> None:
        self.viewer.mouse_release(x, y, button, modifiers, self.window.mouse)

    def on_mouse_drag(self, x, y, dx, dy, buttons, modifiers) -> None:
        self.viewer.window_size = (self.window.width, self.window.height)
        self.viewer.mouse_drag(x, y, dx, dy, buttons, modifiers, self.window.height, self.window.mouse)

    def on_mouse_scroll(self, x, y, scroll_x, scroll_y) -> None:
        self.viewer.scroll(scroll_y, x, y)

    def on_mouse_motion(self, x, y, dx, dy) -> None:
        self.viewer.window_size = (self.window.width, self.window.height)
        self.viewer.mouse_motion(x, y)
