"""``twig play``: a pyglet window that runs a scene and draws it with the shared renderer.

:class:`Viewer` holds everything that is not pyglet: the scene, the camera, the fixed-step
clock (a :class:`~twig_ecs.clock.FixedStepClock`: at most ``MAX_STEPS_PER_FRAME`` steps per
drawn frame, drawing interpolated by the leftover fraction), selection, overlays and the
key bindings.
:func:`open_window` wraps it in a pyglet window; tests drive that window frame by frame
with :meth:`PlayWindow.frame`.

pyglet reads its platform options when ``pyglet.window`` is first imported, so that import
happens here, on demand, after ``headless`` (an EGL pbuffer "window" that needs no display)
has been decided.
"""

from __future__ import annotations

import importlib
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np
import pyglet
from PIL import Image

from twig_ecs.clock import FixedStepClock
from twig_ecs.errors import TwigError
from twig_ecs.graphics import commands
from twig_ecs.graphics.camera import CameraSpec, OrbitCamera, action_point
from twig_ecs.graphics.eventlog import EventLog
from twig_ecs.graphics.inspector_ui import History, imgui_available
from twig_ecs.graphics.overlay import HELP_LINES, inspector_lines, text_panel
from twig_ecs.graphics.pace import PaceMeter
from twig_ecs.graphics.picking import Pick, cursor_ray, ground_point, is_fixed, near_miss, pick_node
from twig_ecs.graphics.recorder import Recorder, RecordingError
from twig_ecs.graphics.renderer import Renderer, solid_instances
from twig_ecs.perturb import MouseSpring

#: How fast the default camera catches up with the characters' centre (s to halve the gap).
ACTION_HALF_LIFE = 1.0
MAX_STEPS_PER_FRAME = 8  # a slower frame drops time instead of spiralling
MAX_FRAME_GAP = 0.25  # s: a longer gap between frames (a drag of the window) counts as this long
PAN_SPEED = 0.6  # WASD: distances per second
TURN_SPEED = 90.0  # Q/E: degrees per second
ORBIT_DEG_PER_PIXEL = 0.3
LOADING_FRAME_S = 0.05  # while the kernels compile, about 20 progress frames a second
#: While the kernels compile, the scene steps as plain Python at most once a frame, and those
#: frames take at most this share of one core (they rest in between): slow motion that leaves
#: most of the cores to the compiling workers (resting only 30 ms a frame, the compile took 40% longer).
INTERIM_SHARE = 0.3
#: The time scales [ and ] step through (simulated seconds per wall second).
TIME_SCALES = (0.25, 0.5, 1.0, 2.0, 4.0)
#: A left press that moves less than this (pixels) before release is a click, not a drag.
CLICK_PIXELS = 4
#: The mouse spring's line: radius (m), and the pull (N) at which it turns fully red.
SPRING_RADIUS = 0.012
SPRING_RED_AT = 200.0


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


def _no_display_errors(window_module) -> tuple[type[BaseException], ...]:
    """pyglet's "cannot connect to the display" exceptions (pyglet.window and the X11 display
    module each define their own class of that name)."""
    found = [window_module.NoSuchDisplayException]
    try:
        from pyglet.display import xlib

        found.append(xlib.NoSuchDisplayException)
    except ImportError:  # not on X11 (Windows, macOS)
        pass
    return tuple(found)


@dataclass
class Press:
    """A left mouse press: where (window pixels), the body part or ground point under it, and
    the movable part it just missed (``near``: a drag then is a missed grab, not an orbit)."""

    x: float
    y: float
    pick: Pick | None
    ground: np.ndarray | None
    near: Pick | None = None
    moved: bool = False
    told: bool = False  # the status line said why this drag does nothing


@dataclass
class Stats:
    """Smoothed timings for the status line."""

    frame_ms: float = 16.7
    step_ms: float = 0.0
    #: steps per second taken by someone else (``twig serve --window``: the server steps)
    external_rate: float = 0.0

    def add_frame(self, ms: float) -> None:
        self.frame_ms += 0.1 * (ms - self.frame_ms)

    def add_steps(self, ms: float, steps: int) -> None:
        if steps:
            self.step_ms += 0.2 * (ms / steps - self.step_ms)

    def add_external(self, steps: int, seconds: float) -> None:
        if seconds > 0:
            self.external_rate += 0.2 * (steps / seconds - self.external_rate)


class Viewer:
    """A scene, its camera and clock, and what the keys and mouse do to them."""

    def __init__(self, source: str, seed: int = 0, content: tuple | list = (),
                 camera: CameraSpec | None = None, paused: bool = False,
                 screenshot_dir: str | Path = ".", parameters: dict | None = None) -> None:  # fmt: skip
        from twig_ecs import Scene

        self.source, self.seed, self.content = source, seed, list(content)
        self.parameters = dict(parameters or {})
        self.scene = Scene.load(source, seed=seed, content=self.content, **self.parameters)
        self.scene.step(0)  # compile kernels and install systems now, not in the first frame
        self.camera_spec = camera or CameraSpec(mode="action")
        self.camera: OrbitCamera | None = None  # made at the first frame, when the aspect is known
        self.clock = FixedStepClock(self.scene.dt, max_steps=MAX_STEPS_PER_FRAME, max_elapsed=MAX_FRAME_GAP,
                                    paused=paused)  # fmt: skip
        self.alpha = 1.0
        self.restart_clock = True
        self.show_help = False
        self.show_inspector = False
        self.follow = self.camera_spec.mode == "follow"
        #: the camera keeps the characters' centre in view (the default), until a pan or follow
        self.follow_action = self.camera_spec.mode == "action"
        self._yard_view: OrbitCamera | None = None  # the action view to go back to, while Y shows the yard
        self.selected: str | None = self.camera_spec.name if self.follow else None
        self.screenshot_dir = Path(screenshot_dir)
        self.screenshot_requested = False
        self.record_requested = False
        self.last_screenshot: Path | None = None
        self.message = ""
        self.message_until = 0.0
        self.stats = Stats()
        self.frames = 0
        self._own_steps = 0  # steps this viewer took since the last draw
        self._seen = (self.scene.frame, time.perf_counter())  # scene frame and time at the last draw
        self.stepped_elsewhere = False  # set when the scene advances without us (a server steps it)
        self.keys_down: set[int] = set()
        self._status_cache: tuple[str, Image.Image] | None = None
        self._panel_cache: dict[str, tuple[tuple, Image.Image]] = {}
        #: a panel drawn at the top centre (the kernel compile's progress while it runs), or None
        self.notice: Image.Image | None = None
        self.window_size = (1280, 720)  # window units, for turning cursor positions into rays
        self.time_scale = 1.0
        self.recorder: Recorder | None = None
        self.last_recording: Path | None = None
        self._elapsed = 0.0  # wall seconds before the frame being drawn (the recorder's clock)
        self.command_target: commands.Target | None = None
        self.goal_log: list[str] = []  # goal events, newest last ("ann: hug done")
        #: the last few goal results and pains, with their times, for the panel over the view
        self.event_log = EventLog()
        #: the simulation's pace against the wall clock (the status line says when it falls behind)
        self.pace = PaceMeter()
        self._recorded_at: float | None = None  # the scene time of the last frame recorded
        self._press: Press | None = None
        self._grab_plane: tuple[np.ndarray, np.ndarray] | None = None
        #: the ImGui inspector (made at the first F1 when imgui-bundle is installed), and
        #: whether the mouse button now held went down on it
        self.ui = None
        self._ui_held = False
        #: the characters' last minute (the inspector's plots), kept whether or not it is shown
        self.history = History()
        self._attach(self.scene)

    def _attach(self, scene) -> None:
        """Give a (new) scene the mouse spring and report its goal results (status line and event
        log) and pains (event log)."""
        self.spring = scene.add_system(MouseSpring(), before="integrate")
        scene.on("goal.done", self._goal_ended)
        scene.on("goal.failed", self._goal_ended)
        scene.on("pain", self._hurt)
        self.event_log.clear()
        self.pace.reset()

    def _goal_ended(self, event) -> None:
        name = self.scene.name_of(event.character) or "?"
        why = f" ({event.reason})" if event.kind == "goal.failed" and event.reason else ""
        line = f"{name}: {event.behavior} {event.kind.split('.')[1]}{why}"
        self.goal_log.append(line)
        del self.goal_log[:-50]
        self.event_log.add(self.scene.time, line)
        self.say(line, 5.0)

    def _hurt(self, event) -> None:
        """A pain event: a line in the event log (one per body and cause while the blows go on)."""
        name = self.scene.name_of(event.body) or "?"
        if event.source_body == event.body:  # the mouse spring's yank reports the body itself
            cause = "yanked"
        else:
            cause = f"hit by {self.scene.name_of(event.source_body) or 'something'}"
        self.event_log.add(self.scene.time, f"{name} hurt: {cause} ({event.link}), pain {event.level:.2f}",
                           merge_key=("pain", event.body, event.source_body))  # fmt: skip

    # -- clock ------------------------------------------------------------------------

    @property
    def paused(self) -> bool:
        """Is the clock paused (Space)?"""
        return self.clock.paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self.clock.paused = bool(value)

    @property
    def accumulator(self) -> float:
        """Simulated seconds the clock owes (less than one step after :meth:`advance`)."""
        return self.clock.accumulator

    @accumulator.setter
    def accumulator(self, value: float) -> None:
        self.clock.accumulator = value

    def set_time_scale(self, scale: float) -> None:
        """Run at ``scale`` simulated seconds per wall second (one of TIME_SCALES from the keys)."""
        self.clock.scale = scale
        self.time_scale = self.clock.scale
        # fast forward needs more steps per frame; slow motion keeps the usual cap
        self.clock.max_steps = math.ceil(MAX_STEPS_PER_FRAME * max(1.0, self.time_scale))
        self.say(f"time x{self.time_scale:g}", 1.5)

    def change_time_scale(self, step: int) -> None:
        """Step to the next slower (-1) or faster (+1) of TIME_SCALES."""
        k = min(range(len(TIME_SCALES)), key=lambda i: abs(TIME_SCALES[i] - self.time_scale))
        self.set_time_scale(TIME_SCALES[min(len(TIME_SCALES) - 1, max(0, k + step))])

    def advance(self, elapsed: float) -> int:
        """Run as many fixed steps as ``elapsed`` seconds of wall time allow; return them."""
        if self.restart_clock:  # the time spent loading a scene is not simulated time
            elapsed, self.restart_clock = 0.0, False
        self._elapsed = elapsed
        self._move_camera(elapsed)
        steps = self.clock.advance(elapsed)
        if steps:
            t0 = time.perf_counter()
            self.scene.step(steps)
            self._own_steps += steps
            self.stats.add_steps((time.perf_counter() - t0) * 1000.0, steps)
        if self.paused or self.stepped_elsewhere:
            self.pace.reset()
        else:  # the uncapped wall time: a frame slower than MAX_FRAME_GAP is still behind
            self.pace.add(elapsed, steps * self.scene.dt)
        self.alpha = self.clock.fraction
        return steps

    def _move_camera(self, elapsed: float) -> None:
        if self.camera is None:
            return
        key = self._key
        dx = (key.D in self.keys_down) - (key.A in self.keys_down)
        dz = (key.W in self.keys_down) - (key.S in self.keys_down)
        if dx or dz:
            self.camera.pan(dx * PAN_SPEED * elapsed, dz * PAN_SPEED * elapsed)
            self.follow = self.follow_action = False
        turn = (key.E in self.keys_down) - (key.Q in self.keys_down)
        if turn:
            self.camera.orbit(turn * TURN_SPEED * elapsed, 0.0)
        if self.follow and self.scene.has_entity(self.selected):
            self.camera.follow(self.scene.entity(self.selected).position, max(elapsed, 1e-3))
        elif self.follow_action and self._yard_view is None:
            centre = action_point(self.scene)
            if centre is not None:  # slower than following one character: the centre jumps about
                self.camera.follow(centre, max(elapsed, 1e-3), half_life=ACTION_HALF_LIFE)

    def frame_action(self) -> None:
        """C: back to the automatic framing (the characters, followed), as the window started."""
        if self.camera is None:
            return
        aspect = self.window_size[0] / max(1, self.window_size[1])
        self.camera = CameraSpec(mode="action").make(self.scene, aspect)
        self._yard_view = None
        self.follow, self.follow_action = False, True
        self.say("camera: automatic framing", 1.5)

    def toggle_yard(self) -> None:
        """Y: the whole scene in view; again: back to the view before."""
        if self.camera is None:
            return
        if self._yard_view is not None:
            self.camera, self._yard_view = self._yard_view, None
            self.say("back to the action" if self.follow_action else "back", 1.5)
            return
        self._yard_view = self.camera
        aspect = self.window_size[0] / max(1, self.window_size[1])
        self.camera = CameraSpec(yaw=self.camera.yaw, pitch=self.camera.pitch).make(self.scene, aspect)
        self.say("the whole scene (Y: back)", 1.5)

    # -- characters -------------------------------------------------------------------

    def characters(self) -> list[str]:
        """Names Tab cycles through: bodies with a head, else every body."""
        names = []
        for name in self.scene.entity_names:
            if "head" in self.scene.entity(name).node_names:
                names.append(name)
        return names or self.scene.entity_names

    def cycle_selection(self, step: int = 1) -> None:
        names = self.characters()
        if not names:
            self.selected = None
            return
        k = names.index(self.selected) + step if self.selected in names else (0 if step > 0 else -1)
        self.selected = names[k % len(names)]
        self.say(f"selected {self.selected}")

    # -- actions ----------------------------------------------------------------------

    def say(self, text: str, seconds: float = 3.0) -> None:
        """Show a message in the status line for a while."""
        self.message = text
        self.message_until = time.monotonic() + seconds

    def step_once(self) -> None:
        self.paused = True
        self.scene.step(1)
        self._own_steps += 1
        self.alpha = 1.0

    def reload(self) -> None:
        """Load the scene file again; keep the old scene (and say why) if it fails."""
        from twig_ecs import Scene

        source = self.scene.source or self.source
        try:
            fresh = Scene.load(source, seed=self.seed, content=self.content, **self.parameters)
            fresh.step(0)
        except TwigError as exc:
            self.say(f"reload failed: {exc}", 8.0)
            print(f"reload failed: {exc}", file=sys.stderr)
            return
        self.scene.close()
        self.scene = fresh
        self._attach(fresh)
        self._press, self.command_target = None, None
        self.clock.reset()
        self.restart_clock = True
        if self.selected not in fresh.entity_names:
            self.selected, self.follow = None, False
        self.say(f"reloaded {Path(str(source)).name}")

    def save_screenshot(self, renderer: Renderer) -> Path:
        """Write the frame just drawn to a numbered PNG in ``screenshot_dir``."""
        self.screenshot_dir.mkdir(parents=True, exist_ok=True)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = self.screenshot_dir / f"twig-{self.scene.name}-{stamp}-f{self.scene.frame:06d}.png"
        k = 1
        while path.exists():
            path = path.with_name(f"{path.stem.split('~')[0]}~{k}.png")
            k += 1
        Image.fromarray(renderer.read_pixels()).save(path)
        self.last_screenshot = path
        self.say(f"saved {path}")
        return path

    # -- input --------------------------------------------------------------------------

    def bind_keys(self, key_module) -> None:
        """Remember pyglet's key constants (they exist once pyglet.window is imported)."""
        self._key = key_module

    def key_press(self, symbol: int, modifiers: int) -> str | None:
        """Apply a key; returns the action name, or None if the key is not bound."""
        key = self._key
        self.keys_down.add(symbol)
        action = {
            key.SPACE: "pause",
            key.PERIOD: "step",
            key.NUM_DECIMAL: "step",
            key.R: "reload",
            key.H: "help",
            key.F1: "inspector",
            key.F12: "screenshot",
            key.ESCAPE: "quit",
            key.TAB: "select",
            key.F: "follow",
            key.L: "hidden_links",
            key.BRACKETLEFT: "slower",
            key.BRACKETRIGHT: "faster",
            key.V: "record",
            key.BACKSPACE: "clear",
            key.Y: "yard",
            key.C: "camera",
        }.get(symbol)
        digits = (key._1, key._2, key._3, key._4, key._5, key._6, key._7, key._8, key._9)
        if action is None and symbol in digits:
            action = "command"
            self.command(digits.index(symbol) + 1)
        if action == "pause":
            self.paused = not self.paused
            self.say("paused" if self.paused else "running", 1.0)
        elif action == "step":
            self.step_once()
        elif action == "reload":
            self.reload()
        elif action == "help":
            self.show_help = not self.show_help
        elif action == "inspector":
            self.show_inspector = not self.show_inspector
        elif action == "screenshot":
            self.screenshot_requested = True
        elif action == "select":
            self.cycle_selection(-1 if modifiers & key.MOD_SHIFT else 1)
        elif action in ("slower", "faster"):
            self.change_time_scale(-1 if action == "slower" else 1)
        elif action == "record":
            self.record_requested = True  # started or stopped when the frame is drawn (its size)
        elif action == "yard":
            self.toggle_yard()
        elif action == "camera":
            self.frame_action()
        elif action == "clear":
            self.command_target, self.selected, self.follow = None, None, False
            self.say("selection cleared", 1.5)
        elif action == "follow":
            if self.selected is None:
                self.cycle_selection()
            self.follow = not self.follow and self.selected is not None
            self.say(f"following {self.selected}" if self.follow else "follow off", 1.5)
        return action

    def key_release(self, symbol: int) -> None:
        self.keys_down.discard(symbol)

    def _ray(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
        return cursor_ray(self.camera, x, y, self.window_size)

    def _ui_shown(self) -> bool:
        return self.show_inspector and self.ui is not None

    def mouse_motion(self, x: float, y: float) -> None:
        """The cursor moved with no button down: the inspector follows it (hover, scrolling)."""
        if self._ui_shown():
            self.ui.mouse_move(x, y, self.window_size[1])

    def mouse_press(self, x: float, y: float, button: int, modifiers: int, mouse) -> None:
        """A left press remembers what is under the cursor: a drag grabs it, a click selects it.
        A press on the inspector is the inspector's."""
        if self._ui_shown() and self.ui.covers(x, y, self.window_size[1]):
            self._ui_held = True
            index = {mouse.LEFT: 0, mouse.RIGHT: 1, mouse.MIDDLE: 2}.get(button, 0)
            self.ui.mouse_button(x, y, self.window_size[1], True, index)
            return
        if self.camera is None or button != mouse.LEFT or modifiers & self._key.MOD_SHIFT:
            return
        eye, direction = self._ray(x, y)
        pick = pick_node(self.scene, eye, direction)
        near = near_miss(self.scene, eye, direction) if pick is None else None
        self._press = Press(x, y, pick, ground_point(eye, direction), near)

    def _start_grab(self, pick: Pick) -> None:
        """Hold the picked part on the mouse spring; it is dragged in the plane facing the camera."""
        _, _, back = self.camera.basis()
        self._grab_plane = (pick.point.copy(), back)
        self.spring.hold(pick.body, pick.node, pick.row, pick.point)
        self.say(f"grabbed {pick.body}.{pick.node}", 2.0)

    def _drag_point(self, x: float, y: float) -> np.ndarray | None:
        """The cursor in the grab plane (None if the ray runs parallel to it)."""
        eye, direction = self._ray(x, y)
        point, normal = self._grab_plane
        facing = float(direction @ normal)
        if abs(facing) < 1e-6:
            return None
        return eye + float((point - eye) @ normal) / facing * direction

    def mouse_release(self, x: float, y: float, button: int, modifiers: int, mouse) -> None:
        """Let go of a held part (it flies on: a throw), or treat a left click as a selection."""
        if self._ui_held:
            self._ui_held = False
            index = {mouse.LEFT: 0, mouse.RIGHT: 1, mouse.MIDDLE: 2}.get(button, 0)
            self.ui.mouse_button(x, y, self.window_size[1], False, index)
            return
        press, self._press = self._press, None
        if self.spring.holding:
            name, part = self.spring.body, self.spring.part
            self.spring.let_go()
            if self.scene.has_entity(name):
                speed = float(np.linalg.norm(self.scene.entity(name).node_velocity(part)))
                self.say(f"let go of {name}.{part} at {speed:.1f} m/s", 2.5)
            return
        if press is None or button != mouse.LEFT or press.moved:
            return
        self.click(press)

    def click(self, press: Press) -> None:
        """Select a character, or (one selected) make the clicked body or ground point its target."""
        actor = self.selected if self.selected in self.characters() else None
        if press.pick is not None:
            name = press.pick.body
            if actor is None or name == actor:
                if name in self.characters():
                    self.selected, self.command_target = name, None
                    self.say(f"selected {name}: click a target", 3.0)
                else:
                    self.say(f"{name}: select a character first (click one, or Tab)", 3.0)
                return
            self.command_target = commands.Target(name=name)
        elif press.ground is not None and actor is not None:
            self.command_target = commands.ground_target(press.ground)
        else:
            return
        self.say(f"{actor} -> {self.command_target.describe()}: pick a command (1-7)", 4.0)

    def command(self, number: int) -> object:
        """Carry out menu command ``number`` for the selected character and target; returns the goal."""
        if self.selected is None or self.command_target is None:
            self.say("select a character, click a target, then press 1-7", 3.0)
            return None
        offered = {k: (label, behaviour) for k, label, behaviour in commands.available(self.scene)}
        if number not in offered:
            self.say(f"no command {number} here", 2.0)
            return None
        label, behaviour = offered[number]
        try:
            goal = commands.issue(self.scene, self.selected, behaviour, self.command_target)
        except (TwigError, KeyError) as exc:
            self.say(f"{label}: {exc}", 5.0)
            return None
        self.say(f"{self.selected}: {label} {self.command_target.describe()}", 3.0)
        self.command_target = None
        return goal

    def mouse_drag(self, x: float, y: float, dx: float, dy: float, buttons: int, modifiers: int,
                   window_height: int, mouse) -> None:  # fmt: skip
        """Left drag on a body part pulls it on the mouse spring; elsewhere left drag orbits;
        right (or middle, or shift+left) drag pans with the cursor."""
        if self._ui_held:
            self.ui.mouse_move(x, y, self.window_size[1])
            return
        if self.camera is None:
            return
        press = self._press
        if press is not None and (abs(x - press.x) + abs(y - press.y) >= CLICK_PIXELS or self.spring.holding):
            press.moved = True
        if press is not None and press.pick is not None and buttons & mouse.LEFT:
            if not press.moved:
                return
            if is_fixed(self.scene, press.pick):  # a bench: a command target, but no spring moves it
                self._tell_once(press, f"{press.pick.body} is fixed in place: it cannot be pulled")
                return
            if not self.spring.holding:
                self._start_grab(press.pick)
            target = self._drag_point(x, y)
            if target is not None:
                self.spring.move(target)
            return
        if press is not None and press.near is not None and buttons & mouse.LEFT:
            # a grab that missed (at a few frames a second the body moved on): the view stays put
            if press.moved:
                self._tell_once(press, f"missed {press.near.body}: press on a body part to pull it "
                                       "(drag away from the bodies to turn the view)")  # fmt: skip
            return
        pan = buttons & (mouse.RIGHT | mouse.MIDDLE) or (
            buttons & mouse.LEFT and modifiers & self._key.MOD_SHIFT
        )
        if pan:
            per_pixel = 2.0 * math.tan(math.radians(self.camera.fov_y) / 2.0) / max(1, window_height)
            self.camera.pan_screen(dx * per_pixel, dy * per_pixel)
            self.follow = self.follow_action = False
        elif buttons & mouse.LEFT:
            self.camera.orbit(-dx * ORBIT_DEG_PER_PIXEL, -dy * ORBIT_DEG_PER_PIXEL)

    def _tell_once(self, press: Press, text: str) -> None:
        if not press.told:
            press.told = True
            self.say(text, 3.0)

    def scroll(self, amount: float, x: float | None = None, y: float | None = None) -> None:
        """The wheel zooms, or scrolls the inspector under the cursor."""
        if self._ui_shown() and x is not None and self.ui.covers(x, y, self.window_size[1]):
            self.ui.mouse_move(x, y, self.window_size[1])
            self.ui.scroll(amount)
            return
        if self.camera is not None:
            self.camera.zoom(0.88**amount)

    # -- drawing ------------------------------------------------------------------------

    def _note_outside_steps(self) -> None:
        """Notice steps someone else took (a server) since the last draw, for the status line."""
        now = time.perf_counter()
        frame, then = self._seen
        outside = self.scene.frame - frame - self._own_steps
        if outside > 0:
            self.stepped_elsewhere = True
        if self.stepped_elsewhere:
            self.stats.add_external(max(0, outside), now - then)
        self._seen, self._own_steps = (self.scene.frame, now), 0

    def status_text(self) -> str:
        fps = 1000.0 / max(self.stats.frame_ms, 1e-3)
        if self.stepped_elsewhere:  # the server steps and times the scene; we only draw it
            sim = f"served {self.stats.external_rate:5.1f} steps/s"
        else:
            sim = f"sim {self.stats.step_ms:5.2f} ms/step"
        parts = [f"fps {fps:5.1f}", sim, f"t {self.scene.time:7.2f} s",
                 "PAUSED" if self.paused else "running"]  # fmt: skip
        if self.time_scale != 1.0:
            parts.append(f"time x{self.time_scale:g}")
        behind = self.pace.behind(self.time_scale)
        if behind is not None:  # the per-frame step cap drops time: the scene runs slower than asked
            parts.append(f"behind: x{behind:.2g} of real time")
        if self.recorder is not None:  # seconds of video: simulated time at the chosen scale
            parts.append(f"REC {self.recorder.clock:4.1f} s")
        if self.spring.holding:  # the strength of the pull, as the spring line's colour shows it
            parts.append(f"pull {self.spring.body}.{self.spring.part} {self.spring.force:4.0f} N")
        if self.selected:
            parts.append(f"{self.selected}{' (follow)' if self.follow else ''}")
        if self.message and time.monotonic() < self.message_until:
            parts.append(self.message)
        else:
            parts.append("H help")
        return "  |  ".join(parts)

    def panels(self, size: tuple[int, int], scale: float) -> list:
        """The text panels of this frame as (key, image, x, y) in framebuffer pixels."""
        width, height = size
        margin = round(10 * scale)
        out = []
        text = self.status_text()
        if self._status_cache is None or self._status_cache[0] != text or self.frames % 15 == 0:
            self._status_cache = (text, text_panel([text], scale, max_width=width - 2 * margin))
        status = self._status_cache[1]
        out.append(("status", status, margin, height - status.size[1] - margin))
        if self.show_help:
            image = self._panel("help", (scale,), lambda: text_panel(HELP_LINES, scale, title="twig play"))
            out.append(("help", image, (width - image.size[0]) // 2, (height - image.size[1]) // 2))
        if self.show_inspector and self.ui is None:  # the text inspector, without imgui-bundle
            lines = tuple(inspector_lines(self.scene, self.selected))
            image = self._panel(
                "inspector",
                (scale, lines, width),
                lambda: text_panel(lines, scale, title="inspector", max_width=width - 2 * margin),
            )
            out.append(("inspector", image, margin, margin))
        events = tuple(self.event_log.lines(self.scene.time))
        if events:  # over the status line, bottom left
            image = self._panel("events", (scale, events, width),
                                lambda: text_panel(events, scale, max_width=width - 2 * margin))  # fmt: skip
            top = height - status.size[1] - margin - image.size[1] - margin // 2
            out.append(("events", image, margin, top))
        if self.notice is not None:
            out.append(("notice", self.notice, (width - self.notice.size[0]) // 2, margin))
        if self.command_target is not None and self.selected is not None:
            lines = tuple(commands.menu_lines(self.scene, self.selected, self.command_target))
            image = self._panel("commands", (scale, lines), lambda: text_panel(lines, scale, title="command"))
            out.append(("commands", image, width - image.size[0] - margin, margin))
        return out

    def _panel(self, key: str, inputs: tuple, make) -> Image.Image:
        cached = self._panel_cache.get(key)
        if cached is None or cached[0] != inputs:
            cached = (inputs, make())
            self._panel_cache[key] = cached
        return cached[1]

    def draw(self, renderer: Renderer, size: tuple[int, int], scale: float) -> None:
        """Render the scene and panels into ``renderer.frame`` (the window presents it)."""
        if self.camera is None:
            self.camera = self.camera_spec.make(self.scene, size[0] / max(1, size[1]))
        self._note_outside_steps()
        self.history.sample(self.scene)
        renderer.options.selected = self.selected
        renderer.options.attention = self.show_inspector  # the inspector brings the focus lines
        renderer.options.extra_capsules = self.markers()
        if self.show_inspector and self.ui is None and imgui_available():
            from twig_ecs.graphics.inspector_ui import InspectorUI

            self.ui = InspectorUI(renderer.ctx)
        renderer.render(self.scene, self.camera, size, self.alpha, tuple(self.panels(size, scale)))
        if self._ui_shown():
            self.ui.draw(self, renderer.frame, size, self.window_size, self._elapsed or 1 / 60)
        if self.screenshot_requested:
            self.screenshot_requested = False
            self.save_screenshot(renderer)
        if self.record_requested:
            self.record_requested = False
            self.toggle_recording(size)
        if self.recorder is not None:
            self.recorder.add(renderer.read_pixels(), self.video_seconds())
        self.frames += 1

    def video_seconds(self) -> float:
        """The seconds of video the frame just drawn stands for.

        While running: the simulated time the scene moved on since the last recorded frame,
        over the time scale. So the video plays at real speed (or in the slow or fast motion
        chosen with [ and ]) even when the window cannot keep up and the scene runs slower
        than the wall clock. While paused: the wall time (the still scene and the camera's
        moves play as long as they were watched).
        """
        now = self.scene.time
        before, self._recorded_at = self._recorded_at, now
        if self.paused:
            return self._elapsed
        if before is None or now < before:  # the first frame, or the scene was reloaded
            return 0.0
        return (now - before) / max(self.time_scale, 1e-6)

    def markers(self) -> np.ndarray | None:
        """What the mouse is doing, drawn in the scene: the spring, and a pin on a command's target."""
        rows = [r for r in (self.spring_line(), self.target_pin()) if r is not None]
        return np.concatenate(rows) if rows else None

    def target_pin(self) -> np.ndarray | None:
        """A cyan pin over the clicked command target (above a body's top, or standing on the ground)."""
        target = self.command_target
        if target is None or self.selected is None:
            return None
        if target.name is not None:
            if not self.scene.has_entity(target.name):
                return None
            nodes = self.scene.entity(target.name).node_positions
            top = nodes[np.argmax(nodes[:, 1])] + np.array([0.0, 0.2, 0.0])
        else:
            top = np.asarray(target.point, dtype=np.float64)
        a, b = top[None, :], (top + np.array([0.0, 0.45, 0.0]))[None, :]
        colour = np.array([[0.1, 0.85, 0.95, 1.0]])
        return np.concatenate([solid_instances(a, b, np.array([0.02]), colour),
                               solid_instances(b, b, np.array([0.07]), colour)])  # fmt: skip

    def spring_line(self) -> np.ndarray | None:
        """The mouse spring as a thin capsule from the held part to the cursor, white to red with its pull."""
        if not self.spring.holding:
            return None
        a = self.scene.state.nodes.pos[self.spring.row][None, :]
        b = self.spring.target[None, :]
        red = min(1.0, self.spring.force / SPRING_RED_AT)
        colour = np.array([[1.0, 1.0 - 0.8 * red, 1.0 - 0.8 * red, 1.0]])
        ends = solid_instances(b, b, np.array([2.5 * SPRING_RADIUS]), colour)  # a dot at the cursor
        return np.concatenate([solid_instances(a, b, np.array([SPRING_RADIUS]), colour), ends])

    def toggle_recording(self, size: tuple[int, int]) -> None:
        """Start an MP4 of what the window shows (in ``screenshot_dir``), or finish the one running."""
        if self.recorder is not None:
            self.last_recording = self.recorder.close()
            self.recorder = None
            self.say(f"saved {self.last_recording}", 4.0)
            return
        self.screenshot_dir.mkdir(parents=True, exist_ok=True)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = self.screenshot_dir / f"twig-{self.scene.name}-{stamp}-f{self.scene.frame:06d}.mp4"
        try:
            self.recorder = Recorder(path, size)
        except (RecordingError, OSError) as exc:
            self.say(f"cannot record: {exc}", 5.0)
            return
        self._recorded_at = None
        self.say(f"recording {path.name} (V stops)", 2.0)

    def close(self) -> None:
        if self.recorder is not None:  # a recording still running is finished, not lost
            self.last_recording = self.recorder.close()
            self.recorder = None
        if self.ui is not None:
            self.ui.release()
            self.ui = None
        self.scene.close()


def open_window(source: str = "schoolyard", seed: int = 0, content: tuple | list = (),
                size: tuple[int, int] = (1280, 720), camera: CameraSpec | None = None,
                paused: bool = False, headless: bool = False, screenshot_dir: str | Path = ".",
                visible: bool = True, parameters: dict | None = None):  # fmt: skip
    """Open a play window (a :class:`PlayWindow`, a ``pyglet.window.Window``) on a scene."""
    from twig_ecs import kernels

    window_module = load_pyglet_window(headless)

    def make_viewer() -> Viewer:
        return Viewer(source, seed, content, camera, paused, screenshot_dir, parameters)

    window_class = _window_class(window_module)
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


@dataclass
class Loading:
    """A window's state while the kernels compile: the build, and how to make the viewer.

    With ``interim`` the viewer is made at the second frame and its scene steps with the
    kernels' plain-Python forms (:class:`~twig_ecs.kernels.InterimKernels`), each switched to
    its compiled form once the workers have cached it; without, it is made once the build
    has finished.
    """

    build: object  # a twig_ecs.kernels.KernelBuild (or anything with poll/status/fraction/cancel)
    make_viewer: object  # () -> Viewer
    caption: str
    interim: bool = False
    #: the kernels' interim state once the scene is made early (a twig_ecs.kernels.InterimKernels)
    kernels: object = None

    def start_interim(self):
        """Point the kernels at plain Python and make the viewer: the scene runs before the build ends."""
        from twig_ecs.kernels import InterimKernels

        self.kernels = InterimKernels().start()
        try:
            return self.make_viewer()
        except BaseException:
            self.end_interim()
            raise

    def end_interim(self) -> None:
        """Every kernel compiled again (the build finished or was cancelled)."""
        if self.kernels is not None:
            self.kernels.finish()

    def notice(self, scale: float) -> Image.Image:
        """The progress panel drawn over a scene already running in slow motion."""
        key = (self.build.status(), self.build.fraction, scale, "notice")
        if getattr(self, "_notice", (None,))[0] != key:
            fraction = self.build.fraction
            filled = round(24 * fraction)
            lines = [self.build.status(), f"[{'#' * filled}{'.' * (24 - filled)}] {100 * fraction:3.0f}%",
                     "slow motion until the kernels are compiled (first run only)"]  # fmt: skip
            self._notice = (key, text_panel(lines, scale))
        return self._notice[1]

    def panel(self, scale: float) -> Image.Image:
        """The progress panel: what compiles, a bar, and why the wait (made again on a change)."""
        key = (self.build.status(), self.build.fraction, scale)
        if getattr(self, "_cached", (None,))[0] != key:
            self._cached = (key, self._make_panel(scale))
        return self._cached[1]

    def _make_panel(self, scale: float) -> Image.Image:
        fraction = self.build.fraction
        filled = round(24 * fraction)
        lines = [self.build.status(), f"[{'#' * filled}{'.' * (24 - filled)}] {100 * fraction:3.0f}%",
                 "first run only: later starts load the compiled kernels from the cache"]  # fmt: skip
        return text_panel(lines, scale, title="twig play: getting ready")


_WINDOW_CLASS = None


def _window_class(window_module):
    """The pyglet window class, defined once pyglet.window has been imported."""
    global _WINDOW_CLASS
    if _WINDOW_CLASS is not None:
        return _WINDOW_CLASS
    key, mouse = window_module.key, window_module.mouse

    class PlayWindow(window_module.Window):
        """A resizable window that steps and draws a :class:`Viewer`."""

        def __init__(self, viewer: Viewer | None, size: tuple[int, int], visible: bool = True,
                     loading: Loading | None = None) -> None:  # fmt: skip
            config = pyglet.gl.Config(major_version=3, minor_version=3, forward_compatible=True,
                                      double_buffer=True)  # fmt: skip
            caption = loading.caption if viewer is None else f"twig - {viewer.scene.name}"
            try:
                super().__init__(size[0], size[1], caption=caption, resizable=True,
                                 config=config, visible=visible, vsync=True)  # fmt: skip
            except (window_module.NoSuchConfigException, pyglet.gl.ContextException) as exc:
                raise WindowError(f"cannot open an OpenGL 3.3 window: {exc}") from exc
            except _no_display_errors(window_module) as exc:  # DISPLAY names no X server now
                raise WindowError(
                    f"cannot open a window: {exc} (DISPLAY={os.environ.get('DISPLAY', '')!r} is set but no "
                    "display answers there; unset it or start the X server, or use 'twig render')"
                ) from None
            self.viewer = viewer
            self.loading = loading
            if viewer is not None:
                viewer.bind_keys(key)
            self.switch_to()
            moderngl.init_context()  # a context per window: create_context() would look for GLX
            self.ctx = moderngl.get_context()
            # Multisampling costs 2-3x on a software rasteriser: keep the window responsive there.
            software = any(s in self.ctx.info["GL_RENDERER"] for s in ("llvmpipe", "softpipe"))
            self.renderer = Renderer(self.ctx, samples=0 if software else 4)
            self._last = self._last_draw = time.perf_counter()
            self.closed = False
            self._loading_frames = 0
            #: perf_counter() when the scene first drew (None before it exists)
            self.scene_started: float | None = None if viewer is None else time.perf_counter()
            #: perf_counter() when the scene first stepped at full speed, every kernel compiled
            self.full_speed: float | None = self.scene_started
            #: perf_counter() after the scene's first step (in slow motion or not)
            self.first_step: float | None = None

        # -- the loop
        def on_draw(self) -> None:
            if self.loading is not None and not self._load_step():
                return
            now = time.perf_counter()
            elapsed, self._last = now - self._last, now
            # fps from the wall clock even when frame(elapsed) fakes the simulated time
            self.viewer.stats.add_frame((now - self._last_draw) * 1000.0)
            self._last_draw = now
            if self.viewer.advance(elapsed) and self.first_step is None:
                self.first_step = time.perf_counter()
            fb_size = self.get_framebuffer_size()
            scale = fb_size[0] / max(1, self.width)  # HiDPI: framebuffer pixels per window unit
            self.viewer.window_size = (self.width, self.height)
            self.viewer.draw(self.renderer, fb_size, scale)
            self.renderer.present(self.ctx.screen, fb_size)
            error = self.ctx.error  # read (and so clear) it: pyglet's GL checks would trip on it
            if error != "GL_NO_ERROR":
                print(f"twig play: OpenGL reported {error}", file=sys.stderr)

        def _load_step(self) -> bool:
            """While the kernels compile, draw the progress; True once the scene runs at full speed."""
            loading = self.loading
            fb_size = self.get_framebuffer_size()
            scale = fb_size[0] / max(1, self.width)
            self._loading_frames += 1
            if not loading.build.poll():
                if self.viewer is None and loading.interim and self._loading_frames > 1:
                    self._start_scene(loading.start_interim())  # the progress panel is up: now the scene
                if self.viewer is not None:
                    self._interim_frame(loading, fb_size, scale)
                    return False
                image = loading.panel(scale)
                x, y = (fb_size[0] - image.size[0]) // 2, (fb_size[1] - image.size[1]) // 2
                self.renderer.render_panels(fb_size, (("loading", image, x, y),))
                self.renderer.present(self.ctx.screen, fb_size)
                time.sleep(LOADING_FRAME_S)  # leave the cores to the compiling workers
                return False
            loading.end_interim()
            self.loading = None
            if self.viewer is None:
                self._start_scene(loading.make_viewer())  # loads the kernels the workers just cached
            else:
                self.viewer.notice = None
                self.viewer.frames = 0  # frames count from full speed, as after a plain wait
                self._last = time.perf_counter()  # the slow-motion frames' time is not simulated
            self.full_speed = time.perf_counter()
            return True

        def _start_scene(self, viewer: Viewer) -> None:
            self.viewer = viewer
            self.viewer.bind_keys(key)
            self.set_caption(f"twig - {self.viewer.scene.name}")
            self._last = self._last_draw = self.scene_started = time.perf_counter()  # not simulated time

        def _interim_frame(self, loading: Loading, fb_size: tuple[int, int], scale: float) -> None:
            """One slow-motion frame while the kernels compile: at most one plain-Python step."""
            loading.kernels.update()
            now = busy = time.perf_counter()
            self.viewer.stats.add_frame((now - self._last_draw) * 1000.0)
            self._last = self._last_draw = now
            if self.viewer.advance(self.viewer.scene.dt) and self.first_step is None:  # one step a frame
                self.first_step = time.perf_counter()
            self.viewer.notice = loading.notice(scale)
            self.viewer.draw(self.renderer, fb_size, scale)
            self.renderer.present(self.ctx.screen, fb_size)
            busy = time.perf_counter() - busy
            time.sleep(max(LOADING_FRAME_S, busy * (1.0 - INTERIM_SHARE) / INTERIM_SHARE))

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
            self.flip()

        def read_frame(self) -> np.ndarray:
            """The frame last drawn, (height, width, 3) uint8, top row first."""
            return self.renderer.read_pixels()

        # -- input
        def on_key_press(self, symbol: int, modifiers: int):
            if self.viewer is None:  # still compiling: only Esc (quit) does anything
                if symbol == key.ESCAPE:
                    self.close()
                return True
            if self.viewer.key_press(symbol, modifiers) == "quit":
                self.close()
            return True  # handled: keeps pyglet's default Esc handling out of the way

        def on_key_release(self, symbol: int, modifiers: int) -> None:
            if self.viewer is not None:
                self.viewer.key_release(symbol)

        def on_mouse_press(self, x, y, button, modifiers) -> None:
            if self.viewer is not None:
                self.viewer.window_size = (self.width, self.height)
                self.viewer.mouse_press(x, y, button, modifiers, mouse)

        def on_mouse_release(self, x, y, button, modifiers) -> None:
            if self.viewer is not None:
                self.viewer.mouse_release(x, y, button, modifiers, mouse)

        def on_mouse_drag(self, x, y, dx, dy, buttons, modifiers) -> None:
            if self.viewer is not None:
                self.viewer.window_size = (self.width, self.height)
                self.viewer.mouse_drag(x, y, dx, dy, buttons, modifiers, self.height, mouse)

        def on_mouse_scroll(self, x, y, scroll_x, scroll_y) -> None:
            if self.viewer is not None:
                self.viewer.scroll(scroll_y, x, y)

        def on_mouse_motion(self, x, y, dx, dy) -> None:
            if self.viewer is not None:
                self.viewer.window_size = (self.width, self.height)
                self.viewer.mouse_motion(x, y)

        def on_resize(self, width: int, height: int) -> None:
            pass  # the renderer follows get_framebuffer_size() every frame

        def close(self) -> None:
            if not self.closed:
                self.closed = True
                self.switch_to()
                self.renderer.release()
                if self.loading is not None:
                    self.loading.build.cancel()
                    self.loading.end_interim()
                if self.viewer is not None:
                    self.viewer.close()
            super().close()

    _WINDOW_CLASS = PlayWindow
    return PlayWindow


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
