"""The window's immediate-mode inspector (Dear ImGui through imgui-bundle).

Three ImGui windows over the scene, drawn when F1 is on:

- *characters*: a table of every character (the columns of
  :data:`~twig_ecs.graphics.overlay.INSPECTOR_FIELDS`), scrolling both ways with the
  header row and name column frozen, so nothing is ever clipped; a click on a name
  selects that character;
- *history*: the selected character's anxiety, pain and behaviour activations over the
  last minute of simulated time, as line plots;
- *behaviour parameters*: a slider per behaviour parameter of each character
  (:mod:`twig_ecs.graphics.tuning`), applied at once, and a button that writes the moved
  ones into the scene's YAML (:mod:`twig_ecs.graphics.scene_writeback`).

imgui-bundle is optional (``pip install twig-ecs[window]``): :func:`imgui_available` says
whether it can be imported, and without it the window keeps its text-panel inspector.
Why imgui-bundle: it is a maintained binding of Dear ImGui with wheels for every
platform Python runs the window on, its tables scroll and resize, and it needs nothing
but an OpenGL context to draw into (:mod:`twig_ecs.graphics.imgui_gl` draws it with moderngl).
"""

from __future__ import annotations

import importlib
from collections import deque
from pathlib import Path

import numpy as np

from twig_ecs.errors import TwigError
from twig_ecs.graphics import tuning
from twig_ecs.graphics.overlay import inspector_rows
from twig_ecs.graphics.scene_writeback import WriteBackError, write_parameters

#: The history plot's span (simulated seconds) and sampling interval.
HISTORY_SECONDS = 60.0
HISTORY_EVERY = 0.1


def imgui_available() -> bool:
    """Can imgui-bundle be imported (the optional ``window`` extra)? Asked at the first F1 only."""
    try:
        importlib.import_module("imgui_bundle")
    except ImportError:
        return False
    return True


def _activations(scene, name: str) -> str:
    """A character's three strongest behaviour activations, as numbers."""
    mind = getattr(scene.entity(name), "mind", None)
    if mind is None:
        return "-"
    top = sorted(mind.last.items(), key=lambda kv: -kv[1])[:3]
    return "  ".join(f"{b} {a:.2f}" for b, a in top) or "-"


def write_moved(scene, tunables: list[tuning.Tunable]) -> str:
    """Write the sliders moved in ``scene`` into its YAML file; returns what happened, in words.

    A slider hands back float32 noise (2.34 comes as 2.3400001525878906), so each moved
    value is rounded to 6 significant digits and the running scene takes the rounded value:
    it then holds what the file says. The values go in by path, are read back and loaded
    before the file is replaced (:func:`~twig_ecs.graphics.scene_writeback.write_parameters`),
    or none is written and the message says which could not be and why.
    """
    for t in tunables:
        if t.value != t.initial:
            t.value = float(f"{t.value:.6g}")
    moved = [t for t in tunables if t.value != t.initial]
    if not moved:
        return "no parameter moved: nothing to write"
    source = scene.source
    if source is None or tuning.builtin_scene(source):
        return (f"'{scene.name}' is a built-in scene: copy its YAML and play the copy "
                "to write parameters into it")  # fmt: skip
    name = Path(str(source)).name
    values = {t.key: t.value for t in moved}
    try:
        count = write_parameters(source, values, library=scene.library, parameters=scene.parameters)
    except WriteBackError as exc:
        return f"not written ({name} unchanged): {exc.reason}"
    except (TwigError, OSError) as exc:
        return f"not written: {exc}"
    for t in moved:  # what the file now says is where the next change starts from
        t.initial = t.value
    plural = "" if count == 1 else "s"
    return f"wrote {count} parameter{plural} to {name} (read back: the scene loads with them)"


class History:
    """Samples of each character's anxiety, pain and activations, the last minute of them."""

    def __init__(self) -> None:
        self.samples: dict[str, deque] = {}
        self.last_time = -np.inf

    def sample(self, scene) -> None:
        """Record every character once per HISTORY_EVERY of simulated time."""
        now = scene.time
        if now < self.last_time:  # the scene was reloaded: time starts again
            self.samples.clear()
        elif now - self.last_time < HISTORY_EVERY - 1e-9:
            return
        self.last_time = now
        from twig_ecs.components import Attachment

        keep = int(round(HISTORY_SECONDS / HISTORY_EVERY))
        for name in scene.entity_names:
            handle = scene.entity(name)
            mind = getattr(handle, "mind", None)
            if mind is None:
                continue
            attachment = scene.world.try_component(handle.entity, Attachment)
            anxiety = attachment.anxiety if attachment is not None else 0.0
            row = (now, anxiety, handle.pain, dict(mind.last))
            self.samples.setdefault(name, deque(maxlen=keep)).append(row)

    def series(self, name: str) -> dict[str, np.ndarray]:
        """A character's recorded series by label: 'anxiety', 'pain', then each behaviour's activation."""
        rows = self.samples.get(name)
        if not rows:
            return {}
        out = {"anxiety": np.array([r[1] for r in rows], dtype=np.float32),
               "pain": np.array([r[2] for r in rows], dtype=np.float32)}  # fmt: skip
        behaviours = sorted({b for r in rows for b in r[3]})
        for b in behaviours:
            out[b] = np.array([r[3].get(b, 0.0) for r in rows], dtype=np.float32)
        return out


class InspectorUI:
    """The ImGui inspector of one window: its context, renderer, history and sliders."""

    def __init__(self, ctx) -> None:
        from imgui_bundle import imgui

        from twig_ecs.graphics.imgui_gl import ImguiRenderer

        self.imgui = imgui
        self.context = imgui.create_context()
        imgui.set_current_context(self.context)
        io = imgui.get_io()
        io.set_ini_filename(None)  # no imgui.ini written into the user's folder
        self.renderer = ImguiRenderer(ctx, imgui)
        self.tunables: list[tuning.Tunable] = []
        self._tunables_of = None  # the scene the sliders were made for
        self.rects: dict[str, tuple[float, float, float, float]] = {}  # widget label -> x0, y0, x1, y1
        self.windows: list[tuple[float, float, float, float]] = []  # the ImGui windows on screen
        self.message = ""

    # -- input (pyglet's window coordinates: y up from the bottom) -----------------

    def covers(self, x: float, y: float, height: int) -> bool:
        """Is window point (x, y) over one of the inspector's windows (as last drawn)?"""
        top = height - y
        return any(x0 <= x <= x1 and y0 <= top <= y1 for x0, y0, x1, y1 in self.windows)

    def mouse_move(self, x: float, y: float, height: int) -> None:
        self.imgui.set_current_context(self.context)
        self.imgui.get_io().add_mouse_pos_event(float(x), float(height - y))

    def mouse_button(self, x: float, y: float, height: int, down: bool, button: int = 0) -> None:
        self.mouse_move(x, y, height)
        self.imgui.get_io().add_mouse_button_event(button, down)

    def scroll(self, amount: float) -> None:
        self.imgui.set_current_context(self.context)
        self.imgui.get_io().add_mouse_wheel_event(0.0, float(amount))

    @property
    def active(self) -> bool:
        """Is a widget being used (a slider held)? Then mouse drags belong to the inspector."""
        self.imgui.set_current_context(self.context)
        return self.imgui.is_any_item_active()

    # -- one frame -----------------------------------------------------------------

    def draw(self, viewer, framebuffer, size: tuple[int, int], window_size: tuple[int, int],
             elapsed: float) -> None:  # fmt: skip
        """Build this frame's inspector for ``viewer`` and draw it over ``framebuffer``."""
        imgui = self.imgui
        imgui.set_current_context(self.context)
        io = imgui.get_io()
        io.display_size = (float(window_size[0]), float(window_size[1]))
        io.display_framebuffer_scale = (size[0] / max(1, window_size[0]), size[1] / max(1, window_size[1]))
        io.delta_time = max(1e-4, float(elapsed))
        scene = viewer.scene
        if self._tunables_of is not scene:
            self.tunables, self._tunables_of = tuning.find_tunables(scene), scene
        self.rects.clear()
        self.windows = []
        imgui.new_frame()
        width, height = window_size
        self._characters(viewer, width, height)
        self._history(viewer, width, height)
        self._parameters(viewer, width, height)
        imgui.render()
        self.renderer.render(imgui.get_draw_data(), framebuffer, size)

    def _begin(self, title: str, pos: tuple[float, float], size: tuple[float, float]) -> bool:
        imgui = self.imgui
        imgui.set_next_window_pos(pos, imgui.Cond_.first_use_ever)
        imgui.set_next_window_size(size, imgui.Cond_.first_use_ever)
        imgui.set_next_window_bg_alpha(0.85)
        return imgui.begin(title)[0]

    def _end(self) -> None:
        imgui = self.imgui
        p, s = imgui.get_window_pos(), imgui.get_window_size()
        self.windows.append((p.x, p.y, p.x + s.x, p.y + s.y))
        imgui.end()

    def _remember(self, label: str, width: float | None = None) -> None:
        """Keep the last widget's rectangle (``width``: only its first pixels, a slider's frame
        without its label), for tests that click it as a person would."""
        a, b = self.imgui.get_item_rect_min(), self.imgui.get_item_rect_max()
        self.rects[label] = (a.x, a.y, b.x if width is None else a.x + width, b.y)

    def _characters(self, viewer, width: int, height: int) -> None:
        imgui = self.imgui
        if self._begin("characters", (10, 10), (min(width - 20, 620), height * 0.32)):
            rows = inspector_rows(viewer.scene)
            titles = list(rows[0]) if rows else ["name"]
            flags = (imgui.TableFlags_.scroll_x | imgui.TableFlags_.scroll_y | imgui.TableFlags_.borders
                     | imgui.TableFlags_.resizable | imgui.TableFlags_.row_bg)  # fmt: skip
            if imgui.begin_table("characters table", len(titles), flags):
                imgui.table_setup_scroll_freeze(1, 1)  # the header row and the names stay in view
                for t in titles:
                    imgui.table_setup_column(t, imgui.TableColumnFlags_.width_fixed)
                imgui.table_headers_row()
                for row in rows:
                    imgui.table_next_row()
                    for k, t in enumerate(titles):
                        imgui.table_set_column_index(k)
                        if k == 0:
                            chosen = imgui.selectable(row[t], row[t] == viewer.selected)[0]
                            self._remember(f"row {row[t]}")
                            if chosen:
                                viewer.selected = row[t]
                        elif t == "activations":  # numbers: ImGui's font has no bar glyphs
                            imgui.text_unformatted(_activations(viewer.scene, row["name"]))
                        else:
                            imgui.text_unformatted(row[t])
                imgui.end_table()
        self._end()

    def _history(self, viewer, width: int, height: int) -> None:
        imgui = self.imgui
        name = viewer.selected
        title = f"history: {name or 'select a character'}###history"
        if self._begin(title, (10, 20 + height * 0.32), (min(width - 20, 420), height * 0.4)):
            series = viewer.history.series(name) if name else {}
            if not series:
                imgui.text_unformatted("click a character (or its name above) to plot it")
            else:
                n = len(series["anxiety"])
                imgui.text_unformatted(f"last {n * HISTORY_EVERY:4.1f} s of {HISTORY_SECONDS:.0f} s")
                for label, values in series.items():
                    top = 1.0 if label != "pain" else max(1.0, float(values.max()))
                    imgui.plot_lines(f"{label} {values[-1]:.2f}", values, scale_min=0.0, scale_max=top,
                                     graph_size=(imgui.get_content_region_avail().x * 0.6, 34))  # fmt: skip
                    self._remember(f"plot {label}")
        self._end()

    def _parameters(self, viewer, width: int, height: int) -> None:
        imgui = self.imgui
        if self._begin("behaviour parameters", (max(10, width - 370), 10), (360, height * 0.6)):
            # the button first: it stays in view however long the list below grows
            if imgui.button("write to scene file"):
                self.message = self.write_back(viewer)
                viewer.say(self.message, 5.0)
            self._remember("write")
            if self.message:
                imgui.text_wrapped(self.message)
            current = None
            imgui.push_item_width(imgui.get_content_region_avail().x * 0.45)
            for t in self.tunables:
                if t.entity != current:
                    current = t.entity
                    imgui.separator_text(t.entity)
                label = f"{t.behaviour}.{t.field}##{t.entity}"
                moved, value = imgui.slider_float(label, t.value, t.low, t.high, "%.4g")
                self._remember(f"{t.entity}.{t.behaviour}.{t.field}", imgui.calc_item_width())
                if moved:
                    t.value = value
            imgui.pop_item_width()
        self._end()

    def write_back(self, viewer) -> str:
        """Write the moved sliders' values into the scene's YAML; returns what happened, in words."""
        return write_moved(viewer.scene, self.tunables)

    def release(self) -> None:
        """Free the renderer's GPU objects and the ImGui context."""
        self.renderer.release()
        self.imgui.destroy_context(self.context)
