"""F1: the inspector, an overlay of the play view.

With imgui-bundle installed it is three Dear ImGui windows (:mod:`inspector_ui`): the
characters' table, their last minute plotted, and a slider for every behaviour parameter;
a mouse press that lands on one of them (and the drag and release after it) is the
inspector's, everything else goes to the scene. Without imgui-bundle it is a text panel.
"""

from __future__ import annotations

from twig_ecs.graphics.inspector_ui import History, imgui_available
from twig_ecs.graphics.overlay import inspector_lines, text_panel


class Inspector:
    """Whether the inspector is shown, its ImGui windows (made at the first F1), and its mouse."""

    def __init__(self) -> None:
        self.shown = False
        #: the ImGui inspector (made at the first draw while shown, when imgui-bundle is installed)
        self.ui = None
        self.held = False  # the mouse button now held went down on the inspector
        #: the characters' last minute (the plots), kept whether or not the inspector is shown
        self.history = History()

    def active(self) -> bool:
        """Are the ImGui windows up (and so taking the mouse where they are)?"""
        return self.shown and self.ui is not None

    # -- the mouse: each returns True when the event was the inspector's ---------------------

    def mouse_motion(self, x: float, y: float, height: int) -> None:
        """The cursor moved with no button down: the inspector follows it (hover, scrolling)."""
        if self.active():
            self.ui.mouse_move(x, y, height)

    def mouse_press(self, x: float, y: float, height: int, button_index: int) -> bool:
        if self.active() and self.ui.covers(x, y, height):
            self.held = True
            self.ui.mouse_button(x, y, height, True, button_index)
            return True
        return False

    def mouse_release(self, x: float, y: float, height: int, button_index: int) -> bool:
        if self.held:
            self.held = False
            self.ui.mouse_button(x, y, height, False, button_index)
            return True
        return False

    def mouse_drag(self, x: float, y: float, height: int) -> bool:
        if self.held:
            self.ui.mouse_move(x, y, height)
            return True
        return False

    def scroll(self, amount: float, x: float | None, y: float | None, height: int) -> bool:
        if self.active() and x is not None and self.ui.covers(x, y, height):
            self.ui.mouse_move(x, y, height)
            self.ui.scroll(amount)
            return True
        return False

    # -- drawing ------------------------------------------------------------------------

    def text_panel(self, viewer, scale: float, width: int, margin: int):
        """The text inspector's panel (without imgui-bundle), or None."""
        if not self.shown or self.ui is not None:
            return None
        lines = tuple(inspector_lines(viewer.scene, viewer.selected))
        fits = width - 2 * margin
        return viewer._panel(
            "inspector",
            (scale, lines, width),
            lambda: text_panel(lines, scale, title="inspector", max_width=fits),
        )

    def prepare(self, renderer) -> None:
        """Make the ImGui windows at the first frame they show (they need the GL context)."""
        if self.shown and self.ui is None and imgui_available():
            from twig_ecs.graphics.inspector_ui import InspectorUI

            self.ui = InspectorUI(renderer.ctx)

    def draw(
        self, viewer, renderer, size: tuple[int, int], window_size: tuple[int, int], elapsed: float
    ) -> None:
        """Draw the ImGui windows over the frame just rendered."""
        if self.active():
            self.ui.draw(viewer, renderer.frame, size, window_size, elapsed)

    def release(self) -> None:
        if self.ui is not None:
            self.ui.release()
            self.ui = None
