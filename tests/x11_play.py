"""The play window on a real X display, driven by xdotool: run by tests/test_window_x11.py.

``python tests/x11_play.py SCENARIO OUT_DIR`` with ``DISPLAY`` naming an X server (Xvfb).
It opens the window ``twig play`` opens (not pyglet's headless one: an X window through
GLX) and draws it frame by frame as ``twig play --frames`` does, while ``xdotool`` sends
it real X mouse and key events through the server. A frame rate can be imposed (each
frame then takes at least ``1 / fps`` s of wall time, as on a slow machine). It prints
one JSON line with what a person would have seen.

Scenarios: ``sit`` (click the stander, click the bench, key 6), ``missed_grab`` (two
presses just beside a character dragged at 5 fps), ``slow`` (4 fps: the lag indicator,
then a recording started and stopped with V).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from twig_ecs.graphics.app import load_pyglet_window, open_window
from twig_ecs.graphics.camera import CameraSpec
from twig_ecs.graphics.picking import cursor_ray, near_miss, pick_node

SIZE = (640, 360)
#: The playground seen from the stander's side, the bench on the left: both big enough to click.
BENCH_VIEW = "-4.4,2.4,5.2@-4.6,0.5,0.6"
#: A common screen's refresh rate. On a screen ``twig play``'s window waits for vsync (it asks
#: for it) and pyglet's loop for 1/120 s; Xvfb has no vsync, so the scenarios without a slow
#: machine's rate draw at most this many frames a second, as on a 60 Hz screen, not as many as
#: the CPU allows (which took a core from everything else the machine was doing).
DISPLAY_FPS = 60.0
WALL_LIMIT = 120.0  # s: a scenario that has not finished by then reports what it has
FIRST_RUN_LIMIT = 300.0  # s: the same for a first run, which compiles every kernel


class Driver:
    """Draws a window's frames (at most ``fps`` a second) and sends it X events with xdotool."""

    def __init__(self, window, fps: float | None = None) -> None:
        self.window = window
        self.frame_s = 1.0 / fps if fps else 0.0
        self.started = time.perf_counter()
        self.recorded: list[float] = []  # the scene time of each frame drawn into a recording

    @property
    def viewer(self):
        return self.window.viewer

    def frame(self) -> None:
        began = time.perf_counter()
        self.window.frame()
        if self.viewer.recorder is not None:
            self.recorded.append(self.viewer.scene.time)
        rest = self.frame_s - (time.perf_counter() - began)
        if rest > 0:
            time.sleep(rest)
        if time.perf_counter() - self.started > WALL_LIMIT:
            raise TimeoutError("the scenario ran out of time")

    def frames(self, count: int) -> None:
        for _ in range(count):
            self.frame()

    def xdotool(self, *args) -> None:
        """Run xdotool, drawing frames meanwhile (the window reads its events at each frame)."""
        done = subprocess.Popen(["xdotool", *map(str, args)])
        while done.poll() is None:
            self.frame()
        assert done.returncode == 0, f"xdotool {args} failed"
        self.frames(2)  # the events reach the window at its next frames

    def pixel(self, point) -> tuple[int, int]:
        """X's window coordinates (from the top-left) of a world point."""
        camera, window = self.viewer.camera, self.window
        px = camera.project(np.asarray(point, dtype=float)[None], window.width, window.height)[0]
        return round(float(px[0])), round(float(px[1]))

    def pick(self, xy: tuple[int, int], near: bool = False):
        """What a press at X pixel ``xy`` picks (or, with ``near``, just misses)."""
        window = self.window
        eye, direction = cursor_ray(
            self.viewer.camera, xy[0], window.height - xy[1], (window.width, window.height)
        )
        if near:
            return near_miss(self.viewer.scene, eye, direction)
        return pick_node(self.viewer.scene, eye, direction)

    def click(self, xy: tuple[int, int]) -> None:
        self.xdotool("mousemove", "--window", self.window._window, *xy, "click", "1")

    def key(self, name: str) -> None:
        self.xdotool("key", name)  # to the window under the pointer (Xvfb has no window manager)


def bench_spot(driver: Driver) -> tuple[int, int]:
    """A pixel of the bench that nothing stands in front of (the sitter covers its middle)."""
    bench = driver.viewer.scene.entity("bench")
    nodes, names = bench.node_positions, bench.node_names
    for a, b in (("front_l", "front_r"), ("back_l", "back_r"), ("front_l", "foot_l"), ("front_r", "foot_r")):
        pa, pb = nodes[names.index(a)], nodes[names.index(b)]
        for share in (0.1, 0.2, 0.8, 0.9, 0.5):
            xy = driver.pixel(pa + share * (pb - pa))
            pick = driver.pick(xy)
            if pick is not None and pick.body == "bench":
                return xy
    raise AssertionError("no pixel of the bench is in view")


def sit(out: Path) -> dict:
    window = open_window("playground", size=SIZE, camera=CameraSpec.parse(BENCH_VIEW), screenshot_dir=out)
    driver = Driver(window, fps=DISPLAY_FPS)
    try:
        driver.frames(3)
        viewer, scene = driver.viewer, driver.viewer.scene
        stander = scene.entity("stander")
        driver.click(driver.pixel(stander.node("spine")))
        selected = viewer.selected
        driver.click(bench_spot(driver))
        target = viewer.command_target.name if viewer.command_target is not None else None
        driver.key("6")
        goals = [(g.behavior, g.params.get("on")) for g in stander.goals]
        end = scene.time + 15.0
        while scene.time < end and "stander: sit done" not in viewer.goal_log:
            driver.frame()
        driver.key("F12")
        seat = scene.entity("bench").node_positions[:4]
        return {"selected": selected, "target": target, "goals": goals, "goal_log": viewer.goal_log,
                "posture": stander.posture, "position": stander.position.tolist(),
                "seat": seat.tolist(), "screenshot": str(viewer.last_screenshot)}  # fmt: skip
    finally:
        window.close()


def beside(driver: Driver, name: str) -> tuple[int, int]:
    """A pixel about 30 cm to the side of a character's spine: a press there just misses it."""
    right = driver.viewer.camera.basis()[0]
    spine = driver.viewer.scene.entity(name).node("spine")
    for gap in np.arange(0.3, 0.5, 0.02):
        xy = driver.pixel(spine + gap * right)
        if driver.pick(xy) is None and driver.pick(xy, near=True) is not None:
            return xy
    raise AssertionError(f"no pixel just beside {name}")


def missed_grab(out: Path) -> dict:
    window = open_window("schoolyard", size=SIZE, screenshot_dir=out)
    driver = Driver(window, fps=5.0)
    try:
        driver.frames(3)
        viewer = driver.viewer
        driver.xdotool("mousemove", "--window", window._window, 5, 5)
        driver.key("space")  # paused: the child stays where the press is aimed (the camera still follows)
        before = (viewer.camera.yaw, viewer.camera.pitch, viewer.camera.distance)
        messages = []
        for _ in range(2):
            x, y = beside(driver, "big_child")
            wid = window._window  # drag 160 px up the screen: an orbit would take the eye below the child
            driver.xdotool("mousemove", "--window", wid, x, y, "mousedown", "1",
                           "mousemove", "--window", wid, x - 40, y - 160, "mouseup", "1")  # fmt: skip
            messages.append(viewer.message)
        camera = viewer.camera
        return {"before": before, "after": (camera.yaw, camera.pitch, camera.distance),
                "eye_height": float(camera.eye[1]), "holding": viewer.spring.holding,
                "messages": messages, "fps": 1000.0 / viewer.stats.frame_ms}  # fmt: skip
    finally:
        window.close()


def slow(out: Path) -> dict:
    window = open_window("schoolyard", size=SIZE, screenshot_dir=out)
    driver = Driver(window, fps=4.0)
    try:
        viewer = driver.viewer
        driver.xdotool("mousemove", "--window", window._window, 5, 5)
        driver.frames(12)  # 3 s at 4 fps: the pace measured over the last 2 s
        status = viewer.status_text()
        factor = viewer.pace.factor
        driver.key("F12")
        driver.key("v")
        while len(driver.recorded) < 16:  # 4 s at 4 fps
            driver.frame()
        driver.key("v")
        recorded = driver.recorded
        return {"status": status, "factor": factor, "fps": 1000.0 / viewer.stats.frame_ms,
                "simulated": recorded[-1] - recorded[0], "frames_drawn": len(recorded),
                "video": str(viewer.last_recording), "screenshot": str(viewer.last_screenshot)}  # fmt: skip
    finally:
        window.close()


class FirstRun:
    """Draws a first run's frames as ``twig play`` does, noting when each ended and what it showed."""

    def __init__(self, window) -> None:
        self.window = window
        self.started = time.perf_counter()
        self.ends: list[float] = []  # perf_counter() after each frame drawn
        self.totals: set[str] = set()  # the progress totals shown ("/20")
        self.slow: list[tuple[float, float]] = []  # (wall s, scene time) of each slow-motion frame
        self.status = ""  # the build's last status line

    def frame(self) -> None:
        began = time.perf_counter()
        self.window.frame()
        now = time.perf_counter()
        self.ends.append(now)
        loading = self.window.loading
        if loading is not None:
            status = self.status = loading.build.status()
            if "/" in status:
                self.totals.add(status.split("/")[1].split()[0])
            if self.window.viewer is not None:
                self.slow.append((now - self.started, self.window.viewer.scene.time))
        if now - self.started > FIRST_RUN_LIMIT:
            raise TimeoutError("the first run ran out of time")
        rest = 1.0 / DISPLAY_FPS - (time.perf_counter() - began)
        if rest > 0:  # as vsync paces twig play on a screen; the next frame's gap includes it
            time.sleep(rest)

    def gaps(self) -> tuple[float, float]:
        """The longest wall time between two frames drawn (s), and when it ended (s from the start)."""
        ends = [self.started, *self.ends]
        gap, end = max((b - a, b) for a, b in zip(ends, ends[1:], strict=False))
        return gap, end - self.started

    def result(self) -> dict:
        moved = self.slow[-1][1] - self.slow[0][1] if len(self.slow) > 1 else 0.0
        wall = self.slow[-1][0] - self.slow[0][0] if len(self.slow) > 1 else 0.0
        gap, at = self.gaps()
        return {"frames": len(self.ends), "max_gap": gap, "max_gap_at": at, "totals": sorted(self.totals),
                "slow_frames": len(self.slow), "slow_simulated": moved, "slow_wall": wall,
                "first_step": self.window.first_step and self.window.first_step - self.started,
                "build": self.status}  # fmt: skip


def first_run_esc(out: Path) -> dict:
    """A first run (an empty kernel cache: the caller sets TWIG_CACHE_DIR) with Esc pressed once the
    scene has moved in slow motion for ``ESC_AFTER`` s: the frames' gaps and how soon Esc closed it."""
    window = open_window("schoolyard", size=SIZE, screenshot_dir=out)
    run = FirstRun(window)
    assert window.loading is not None, "the kernel cache is not empty"
    esc_after = float(os.environ.get("TWIG_ESC_AFTER", "6"))
    try:
        while not run.slow or run.slow[-1][0] - run.slow[0][0] < esc_after:
            assert window.loading is not None, "the build ended before Esc"
            run.frame()
        subprocess.run(["xdotool", "mousemove", "--window", str(window._window), "5", "5"], check=True)
        run.frame()
        pressed = time.perf_counter()  # from before xdotool starts: its own start-up counts too
        sent = subprocess.Popen(["xdotool", "key", "Escape"])
        while sent.poll() is None and not window.closed:
            run.frame()
        sent.wait()
        while not window.closed:
            run.frame()
            assert time.perf_counter() - pressed < 30, "Esc did nothing for 30 s"
        return {**run.result(), "esc_s": time.perf_counter() - pressed}
    finally:
        window.close()


def first_run_full(out: Path) -> dict:
    """A first run (an empty kernel cache) drawn until the scene runs at full speed."""
    window = open_window("schoolyard", size=SIZE, screenshot_dir=out)
    run = FirstRun(window)
    assert window.loading is not None, "the kernel cache is not empty"
    try:
        while window.loading is not None:
            run.frame()
        compiling = run.gaps()  # while the kernels compiled
        for _ in range(30):
            run.frame()
        return {
            **run.result(),
            "full_speed": window.full_speed - run.started,
            "max_gap_compiling": compiling[0],
        }
    finally:
        window.close()


SCENARIOS = {"sit": sit, "missed_grab": missed_grab, "slow": slow, "first_run_esc": first_run_esc,
             "first_run_full": first_run_full}  # fmt: skip


if __name__ == "__main__":
    load_pyglet_window(headless=False)
    result = SCENARIOS[sys.argv[1]](Path(sys.argv[2]))
    print(json.dumps(result))
