"""Opening pyglet's window module with the right platform options, and its display errors.

pyglet reads its platform options when ``pyglet.window`` is first imported, so that import
happens here, on demand, after ``headless`` (an EGL pbuffer "window" that needs no display)
has been decided; :mod:`twig_ecs.graphics.window` (which subclasses pyglet's window) is
imported after it.
"""

from __future__ import annotations

import importlib
import os
import sys

import pyglet

from twig_ecs.errors import TwigError


class WindowError(TwigError):
    """The window cannot be opened (no display, no OpenGL 3.3)."""


def load_pyglet_window(headless: bool = False):
    """Import ``pyglet.window`` with the right platform options and return the module."""
    if "pyglet.window" in sys.modules:
        if bool(pyglet.options["headless"]) != headless:
            mode = "headless" if headless else "with a display"
            raise WindowError(f"pyglet.window was already imported in this process, not {mode}")
        return importlib.import_module("pyglet.window")
    if not headless and sys.platform.startswith("linux"):
        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise WindowError(
                "a window needs a display and none is set (DISPLAY and WAYLAND_DISPLAY are empty). "
                "Use 'twig render' for images and videos, 'twig play --headless --frames N' for a "
                "scripted check, or 'twig serve' without --window to serve headless"
            )
    pyglet.options["shadow_window"] = False  # no hidden GLX window when there is no X server
    pyglet.options["headless"] = headless
    return importlib.import_module("pyglet.window")


def no_display_errors(window_module) -> tuple[type[BaseException], ...]:
    """pyglet's "cannot connect to the display" exceptions (pyglet.window and the X11 display
    module each define their own class of that name)."""
    found = [window_module.NoSuchDisplayException]
    try:
        from pyglet.display import xlib

        found.append(xlib.NoSuchDisplayException)
    except ImportError:  # not on X11 (Windows, macOS)
        pass
    return tuple(found)
