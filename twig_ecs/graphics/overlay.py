"""Text panels drawn over the 3D view: status line, help, inspector.

Panels are Pillow RGBA images that the renderer uploads as textures, so they look the
same in the window, in screenshots and offscreen. The inspector's columns are a
registry: a later feature adds one with :func:`add_inspector_field`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

_FONT_FILES = (
    "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf",
    "/usr/share/fonts/dejavu/DejaVuSansMono.ttf",
    "/Library/Fonts/Menlo.ttc",
    "C:/Windows/Fonts/consola.ttf",
)

HELP_LINES = (
    "Drag a body     pull it (spring) Release            throw it",
    "Click a body    select / target  1-7                command the selected",
    "Drag elsewhere  orbit            Right drag / WASD  pan",
    "Wheel           zoom             Q / E              turn",
    "Space           pause / run      .                  one step",
    "Tab             next character   F                  follow selected",
    "R               reload scene     L                  hidden links",
    "F1              inspector        F12                screenshot (PNG)",
    "[ / ]           slower / faster  V                  record MP4 (again: stop)",
    "Y               the whole scene in view (Y again: back)",
    "C               back to the automatic camera (the characters, followed)",
    "Backspace       clear selection  Esc                quit",
    "H               this help",
)


@lru_cache(maxsize=8)
def font(size: int) -> ImageFont.ImageFont | ImageFont.FreeTypeFont:
    """A monospaced font of ``size`` pixels (Pillow's built-in font when none is installed)."""
    for path in _FONT_FILES:
        if Path(path).exists():
            try:
                return ImageFont.truetype(path, size)
            except OSError:
                continue
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


#: The smallest font (pixels, before scaling) a panel shrinks to before it wraps its lines.
MIN_FONT_PX = 10


def text_panel(lines: Sequence[str], scale: float = 1.0, title: str | None = None,
               max_width: int | None = None) -> Image.Image:  # fmt: skip
    """A dark translucent box with ``lines`` of white text; ``scale`` follows the pixel ratio.

    With ``max_width`` (pixels) the panel never gets wider: the font shrinks (down to
    ``MIN_FONT_PX``) so a table keeps its columns, then over-long lines wrap.
    """
    all_lines = ([title] if title else []) + list(lines)
    size = max(9, round(14 * scale))
    pad = round(8 * scale)
    f = font(size)
    if max_width is not None:
        smallest = max(9, round(MIN_FONT_PX * scale))
        while size > smallest and _widest(f, all_lines) + 2 * pad > max_width:
            size -= 1
            f = font(size)
        if _widest(f, all_lines) + 2 * pad > max_width:
            all_lines = _wrap(all_lines, f, max_width - 2 * pad)
    line_h = round(size * 1.35)
    width = int(_widest(f, all_lines) + 2 * pad)
    height = int(line_h * len(all_lines) + 2 * pad)
    image = Image.new("RGBA", (max(width, 1), max(height, 1)), (20, 22, 28, 170))
    draw = ImageDraw.Draw(image)
    for k, line in enumerate(all_lines):
        color = (255, 220, 120, 255) if title and k == 0 else (235, 238, 242, 255)
        draw.text((pad, pad + k * line_h), line, font=f, fill=color)
    return image


def _widest(f, lines: Sequence[str]) -> int:
    return max((f.getbbox(line)[2] if line else 0 for line in lines), default=0)


def _wrap(lines: Sequence[str], f, width: int) -> list[str]:
    """Break lines wider than ``width`` pixels, at a space where there is one."""
    if width < 12 * max(1, f.getbbox("M")[2]):
        return list(lines)  # too narrow to wrap into anything readable
    out = []
    for line in lines:
        while line and f.getbbox(line)[2] > width:
            # the longest start of the line that fits (one character at least), by bisection:
            # a longer start is never narrower (the line grows to the right)
            cut, over = 1, len(line)  # line[:over] is too wide
            while over - cut > 1:
                mid = (cut + over) // 2
                if f.getbbox(line[:mid])[2] > width:
                    over = mid
                else:
                    cut = mid
            space = line.rfind(" ", 0, cut)
            cut = space if space > cut // 2 else cut
            out.append(line[:cut].rstrip())
            line = "    " + line[cut:].lstrip()
        out.append(line)
    return out


# -- inspector ------------------------------------------------------------------------

#: A column of the inspector: (scene, entity name) -> short text.
InspectorField = Callable[[object, str], str]


def _pain(scene, name: str) -> str:
    return f"{scene.entity(name).pain:6.2f}"


def _behaviour(scene, name: str) -> str:
    """The winning behaviour, once characters have one (a later issue); 'none' until then."""
    try:
        value = getattr(scene.entity(name), "behaviour", None)
    except Exception:  # noqa: BLE001 - the inspector must never take the window down
        value = None
    if value is None:
        return "none"
    return str(getattr(value, "name", value))


def _character_field(read: Callable[[object], str]) -> InspectorField:
    """A column that only characters fill ('-' for other bodies)."""

    def field(scene, name: str) -> str:
        handle = scene.entity(name)
        return read(handle) if hasattr(handle, "posture") else "-"

    return field


def _speed(handle) -> str:
    v = handle.velocity
    return f"{(v[0] ** 2 + v[2] ** 2) ** 0.5:4.1f}"


def _arms(handle) -> str:
    modes = handle.arm_modes
    return f"{modes['left']}/{modes['right']}"


def _goal(handle) -> str:
    goals = handle.goals
    if not goals:
        return "-"
    more = f" +{len(goals) - 1}" if len(goals) > 1 else ""
    return f"{goals[0].behavior}#{goals[0].id} {goals[0].status}{more}"


BAR_BLOCKS = " ▏▎▍▌▋▊▉█"


def activation_bar(value: float, width: int = 6) -> str:
    """A text bar of ``width`` cells for an activation (1.0 fills it)."""
    eighths = max(0, min(width * 8, round(value * width * 8)))
    full, rest = divmod(eighths, 8)
    return "█" * full + (BAR_BLOCKS[rest] if rest else "") + " " * (width - full - (1 if rest else 0))


def _activations(handle) -> str:
    last = handle.mind.last
    top = sorted(last.items(), key=lambda kv: -kv[1])[:3]
    return "  ".join(f"{name[:8]} {activation_bar(value)}" for name, value in top) or "-"


def _focus(handle) -> str:
    from twig_ecs.components import Memory

    memory = handle.world.try_component(handle.entity, Memory)
    return memory.focus if memory is not None and memory.focus else "-"


def _anxiety(handle) -> str:
    from twig_ecs.components import Attachment

    attachment = handle.world.try_component(handle.entity, Attachment)
    return f"{attachment.anxiety:4.2f}" if attachment is not None else "-"


#: Inspector columns after the name, in order. Add more with :func:`add_inspector_field`.
INSPECTOR_FIELDS: dict[str, InspectorField] = {
    "behaviour": _behaviour,
    "goal": _character_field(_goal),
    "activations": _character_field(_activations),
    "focus": _character_field(_focus),
    "anxiety": _character_field(_anxiety),
    "pain": _pain,
    "posture": _character_field(lambda h: h.posture),
    "m/s": _character_field(_speed),
    "arms": _character_field(_arms),
    "holds": _character_field(lambda h: ",".join(h.holding.values()) or "-"),
}


def add_inspector_field(title: str, field: InspectorField) -> None:
    """Add (or replace) an inspector column computed by ``field(scene, name)``."""
    INSPECTOR_FIELDS[title] = field


def inspector_rows(scene) -> list[dict[str, str]]:
    """One row per body with a pain sensor (the characters): name plus every field."""
    state = scene.state
    rows = []
    for name in scene.entity_names:
        try:
            body = scene.entity(name).body
            if not np.isfinite(state.bodies.pain_threshold[body.index]):
                continue
        except (KeyError, AttributeError):
            continue
        row = {"name": name}
        for title, field in INSPECTOR_FIELDS.items():
            try:
                row[title] = field(scene, name)
            except Exception as exc:  # noqa: BLE001 - show the problem in the cell instead
                row[title] = f"? {type(exc).__name__}"
        rows.append(row)
    return rows


def inspector_lines(scene, selected: str | None = None) -> list[str]:
    """The inspector as aligned text lines (a '>' marks the selected character)."""
    rows = inspector_rows(scene)
    if not rows:
        return ["no characters (bodies with a pain sensor)"]
    titles = list(rows[0])
    widths = {t: max(len(t), *(len(r[t]) for r in rows)) for t in titles}
    lines = ["  " + "  ".join(t.ljust(widths[t]) for t in titles)]
    for r in rows:
        mark = "> " if r["name"] == selected else "  "
        lines.append(mark + "  ".join(r[t].ljust(widths[t]) for t in titles))
    return lines
