"""One screen of the play window: what it draws, how it moves on, and the input it answers.

As arcade's ``View``: the window (:class:`~twig_ecs.graphics.window.PlayWindow`) shows one
view at a time (:meth:`~twig_ecs.graphics.window.PlayWindow.show_view`) and hands it
each frame (:meth:`View.on_update`, then :meth:`View.on_draw`) and each key and mouse
event. The views are

- :class:`~twig_ecs.graphics.loading_view.LoadingView`: the kernels' compile progress,
  before there is a scene;
- :class:`~twig_ecs.graphics.slow_motion_view.SlowMotionView`: the scene in slow motion,
  stepped in a thread of its own, while the compile finishes;
- :class:`~twig_ecs.graphics.play_view.PlayView`: the scene at full speed.

The inspector is an overlay of the play view (:mod:`twig_ecs.graphics.inspector`).
"""

from __future__ import annotations


class View:
    """A screen of the window; every handler does nothing unless a view says otherwise."""

    window = None  # the PlayWindow showing this view (set by show_view)

    def on_show_view(self) -> None:
        """The window has just made this its current view."""

    def on_hide_view(self) -> None:
        """Another view takes this one's place."""

    def on_update(self, elapsed: float) -> None:
        """Move on by ``elapsed`` wall seconds (before :meth:`on_draw`)."""

    def on_draw(self) -> None:
        """Draw into ``window.renderer.frame``; the window presents it."""

    def on_close(self) -> None:
        """The window is closing: stop and release what the view owns."""

    def on_key_press(self, symbol: int, modifiers: int) -> None:
        pass

    def on_key_release(self, symbol: int, modifiers: int) -> None:
        pass

    def on_mouse_press(self, x: float, y: float, button: int, modifiers: int) -> None:
        pass

    def on_mouse_release(self, x: float, y: float, button: int, modifiers: int) -> None:
        pass

    def on_mouse_drag(self, x: float, y: float, dx: float, dy: float, buttons: int, modifiers: int) -> None:
        pass

    def on_mouse_scroll(self, x: float, y: float, scroll_x: float, scroll_y: float) -> None:
        pass

    def on_mouse_motion(self, x: float, y: float, dx: float, dy: float) -> None:
        pass
