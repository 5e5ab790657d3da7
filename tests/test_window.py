"""The play window, opened for real: pyglet's headless EGL window needs no display.

Frames are driven by hand (``PlayWindow.frame``) with synthetic key events, as a person
pressing keys would send them.
"""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from twig_ecs.graphics.app import load_pyglet_window, open_window


@pytest.fixture(scope="module")
def key():
    return load_pyglet_window(headless=True).key


def press(window, symbol: int, modifiers: int = 0) -> None:
    window.dispatch_event("on_key_press", symbol, modifiers)
    window.dispatch_event("on_key_release", symbol, modifiers)


def test_window_runs_pauses_steps_screenshots_and_closes_five_times(key, tmp_path):
    for round_ in range(5):
        window = open_window(
            "schoolyard", size=(320, 180), headless=True, screenshot_dir=tmp_path / str(round_)
        )
        viewer = window.viewer
        scene = viewer.scene
        for _ in range(3):
            window.frame(elapsed=1 / 60)
        assert scene.frame >= 2  # the clock runs: about one step per 1/60 s frame

        press(window, key.SPACE)
        window.frame(elapsed=1 / 60)
        paused_at = scene.frame
        window.frame(elapsed=0.5)
        assert viewer.paused and scene.frame == paused_at

        press(window, key.PERIOD)
        window.frame(elapsed=1 / 60)
        assert scene.frame == paused_at + 1

        press(window, key.F12)
        window.frame(elapsed=1 / 60)
        shot = viewer.last_screenshot
        assert shot is not None and shot.exists()
        with Image.open(shot) as image:
            assert image.size == (320, 180)
            assert np.asarray(image).std() > 10

        frame = window.read_frame()
        assert frame.shape == (180, 320, 3)
        assert frame.std() > 10 and len(np.unique(frame.reshape(-1, 3), axis=0)) > 50

        press(window, key.ESCAPE)
        window.frame(elapsed=1 / 60)
        assert window.closed
        with pytest.raises(Exception, match="closed"):
            scene.step()


def test_overlays_and_selection_show_on_screen(key, tmp_path):
    window = open_window("schoolyard", size=(480, 270), headless=True, screenshot_dir=tmp_path)
    try:
        window.frame(elapsed=1 / 60)
        plain = window.read_frame().astype(np.int16)
        press(window, key.F1)
        press(window, key.TAB)
        window.frame(elapsed=0.0)
        assert window.viewer.selected == "parent"
        with_inspector = window.read_frame().astype(np.int16)
        top_left = np.abs(with_inspector - plain)[:60, :150].sum(axis=2)
        assert (top_left > 40).mean() > 0.3  # the inspector panel covers the top-left corner

        press(window, key.H)
        press(window, key.F)
        window.frame(elapsed=1 / 60)
        assert window.viewer.show_help and window.viewer.follow
        press(window, key.R)
        window.frame(elapsed=1 / 60)
        assert window.viewer.scene.frame <= 1  # reloaded from the file: time starts again
        assert window.viewer.selected == "parent"
    finally:
        window.close()


def test_mouse_orbits_pans_and_zooms(key):
    window = open_window("empty", size=(320, 180), headless=True)
    try:
        window.frame(elapsed=1 / 60)
        camera = window.viewer.camera
        yaw, distance, target = camera.yaw, camera.distance, camera.target.copy()
        mouse = load_pyglet_window(headless=True).mouse
        window.dispatch_event("on_mouse_drag", 100, 100, 20, 0, mouse.LEFT, 0)
        window.dispatch_event("on_mouse_scroll", 100, 100, 0, 2)
        window.dispatch_event("on_mouse_drag", 100, 100, 0, 30, mouse.RIGHT, 0)
        window.frame(elapsed=1 / 60)
        assert camera.yaw != yaw
        assert camera.distance < distance
        assert not np.allclose(camera.target, target)
    finally:
        window.close()


def test_a_display_that_does_not_answer_gives_one_error_line():
    """A stale DISPLAY (no X server there) was a 29-line NoSuchDisplayException traceback."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "DISPLAY": ":97", "WAYLAND_DISPLAY": ""}
    done = subprocess.run([sys.executable, "-m", "twig_ecs", "play", "empty"], env=env, capture_output=True,
                          text=True, timeout=300)  # fmt: skip
    assert done.returncode == 2
    lines = [ln for ln in done.stderr.splitlines() if ln.strip() and not ln.startswith("twig: compiling")]
    assert len(lines) == 1 and lines[0].startswith("error: cannot open a window"), done.stderr
    assert "DISPLAY=':97'" in lines[0] and "Traceback" not in done.stderr
