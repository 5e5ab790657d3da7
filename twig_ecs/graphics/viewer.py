"""The play view's model: a scene, its camera and clock, and what the keys and mouse do to them.

:class:`Viewer` holds everything that is not pyglet: the scene, the camera, the fixed-step
clock (a :class:`~twig_ecs.clock.FixedStepClock`: at most ``MAX_STEPS_PER_FRAME`` steps per
drawn frame, drawing interpolated by the leftover fraction), selection, commands, the
mouse spring, overlays and the key bindings. :class:`~twig_ecs.graphics.play_view.PlayView`
hands it the window's frames and events.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from twig_ecs.clock import FixedStepClock
from twig_ecs.errors import TwigError
from twig_ecs.graphics import commands
from twig_ecs.graphics.camera import CameraSpec, OrbitCamera, action_point
from twig_ecs.graphics.eventlog import EventLog
from twig_ecs.graphics.inspector import Inspector
from twig_ecs.graphics.overlay import HELP_LINES, text_panel
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
#: The time scales [ and ] step through (simulated seconds per wall second).
TIME_SCALES = (0.25, 0.5, 1.0, 2.0, 4.0)
#: A left press that moves less than this (pixels) before release is a click, not a drag.
CLICK_PIXELS = 4
#: The mouse spring's line: radius (m), and the pull (N) at which it turns fully red.
SPRING_RADIUS = 0.012
SPRING_RED_AT = 200.0


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
        #: F1's inspector over the scene (ImGui windows, or a text panel without imgui-bundle)
        self.inspector = Inspector()
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
        #: keep each frame's scene without its panels, for :meth:`redraw` (while in slow motion)
        self.keep_scene = False
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
        self._attach(self.scene)

    @property
    def show_inspector(self) -> bool:
        """Is the inspector (F1) shown?"""
        return self.inspector.shown

    @show_inspector.setter
    def show_inspector(self, value: bool) -> None:
        self.inspector.shown = bool(value)

    @property
    def ui(self):
        """The inspector's ImGui windows (None before the first F1, or without imgui-bundle)."""
        return self.inspector.ui

    @property
    def history(self):
        """The characters' last minute, as the inspector plots it."""
        return self.inspector.history

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
        self.move_camera(elapsed)
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

    def note_own_steps(self, steps: int, ms: float) -> None:
        """Count ``steps`` this window took outside :meth:`advance` (slow motion's thread), in ``ms``."""
        self._own_steps += steps
        self.stats.add_steps(ms, steps)

    def move_camera(self, elapsed: float) -> None:
        """Move the camera by the keys held (WASD, Q/E) and the framing it follows, for ``elapsed`` s."""
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

    def mouse_motion(self, x: float, y: float) -> None:
        """The cursor moved with no button down: the inspector follows it (hover, scrolling)."""
        self.inspector.mouse_motion(x, y, self.window_size[1])

    def mouse_press(self, x: float, y: float, button: int, modifiers: int, mouse) -> None:
        """A left press remembers what is under the cursor: a drag grabs it, a click selects it.
        A press on the inspector is the inspector's."""
        if self.inspector.mouse_press(x, y, self.window_size[1], _button_index(button, mouse)):
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
        if self.inspector.mouse_release(x, y, self.window_size[1], _button_index(button, mouse)):
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
        if self.inspector.mouse_drag(x, y, self.window_size[1]):
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
        if self.inspector.scroll(amount, x, y, self.window_size[1]):
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
        image = self.inspector.text_panel(self, scale, width, margin)  # without imgui-bundle
        if image is not None:
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
        self.inspector.prepare(renderer)
        self._panels = tuple(self.panels(size, scale))
        renderer.render(self.scene, self.camera, size, self.alpha, self._panels, keep_scene=self.keep_scene)
        self.inspector.draw(self, renderer, size, self.window_size, self._elapsed or 1 / 60)
        if self.screenshot_requested:
            self.screenshot_requested = False
            self.save_screenshot(renderer)
        if self.record_requested:
            self.record_requested = False
            self.toggle_recording(size)
        if self.recorder is not None:
            self.recorder.add(renderer.read_pixels(), self.video_seconds())
        self.frames += 1

    def redraw(self, renderer: Renderer, size: tuple[int, int], scale: float) -> None:
        """Draw the last frame's shapes and panels again, the notice brought up to date, without
        reading the scene (another thread is stepping it)."""
        panels = tuple(p for p in getattr(self, "_panels", ()) if p[0] != "notice")
        if self.notice is not None:
            panels += (("notice", self.notice, (size[0] - self.notice.size[0]) // 2, round(10 * scale)),)
        if self.camera is None:  # nothing drawn yet
            renderer.render_panels(size, panels)
        else:
            renderer.render(None, self.camera, size, 1.0, panels)

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
        self.inspector.release()
        self.scene.close()


def _button_index(button: int, mouse) -> int:
    """ImGui's number for a pyglet mouse button (left 0, right 1, middle 2)."""
    return {mouse.LEFT: 0, mouse.RIGHT: 1, mouse.MIDDLE: 2}.get(button, 0)
