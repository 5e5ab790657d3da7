"""Playing in the window: grab and throw, click-commands, time scale, recording.

Every test opens the real play window (pyglet's headless EGL window) and drives it with
synthetic pyglet mouse and key events, as a person's hand would send them; frames are
drawn by hand with ``PlayWindow.frame``.
"""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.graphics import commands
from twig_ecs.graphics.app import load_pyglet_window, open_window
from twig_ecs.graphics.camera import CameraSpec
from twig_ecs.graphics.picking import cursor_ray, pick_node

SIZE = (480, 270)


@pytest.fixture(scope="module")
def pyglet_window():
    return load_pyglet_window(headless=True)


def screen_xy(window, point) -> tuple[float, float]:
    """Window pixels (pyglet's: y up from the bottom) of a world point."""
    width, height = window.width, window.height
    px = window.viewer.camera.project(np.asarray(point, dtype=float)[None], width, height)[0]
    return float(px[0]), float(height - px[1])


def under_cursor(window, point) -> tuple[str, str] | None:
    """The (body, node) the window would pick at a world point's pixel."""
    viewer = window.viewer
    eye, direction = cursor_ray(viewer.camera, *screen_xy(window, point), (window.width, window.height))
    pick = pick_node(viewer.scene, eye, direction)
    return None if pick is None else (pick.body, pick.node)


def press_key(window, symbol: int) -> None:
    window.dispatch_event("on_key_press", symbol, 0)
    window.dispatch_event("on_key_release", symbol, 0)


def click(window, mouse, xy) -> None:
    window.dispatch_event("on_mouse_press", xy[0], xy[1], mouse.LEFT, 0)
    window.dispatch_event("on_mouse_release", xy[0], xy[1], mouse.LEFT, 0)


def drag(window, mouse, start, offset, frames: int, release: bool = True) -> None:
    """Press at ``start``, move by ``offset`` pixels over ``frames`` drawn frames, release."""
    x, y = start
    window.dispatch_event("on_mouse_press", x, y, mouse.LEFT, 0)
    for k in range(1, frames + 1):
        nx, ny = x + offset[0] * k / frames, y + offset[1] * k / frames
        window.dispatch_event("on_mouse_drag", nx, ny, offset[0] / frames, offset[1] / frames, mouse.LEFT, 0)
        window.frame(elapsed=1 / 60)
    if release:
        window.dispatch_event("on_mouse_release", nx, ny, mouse.LEFT, 0)


def test_dragging_the_ball_moves_it_and_letting_go_throws_it(pyglet_window):
    mouse = pyglet_window.mouse
    window = open_window("schoolyard", size=SIZE, headless=True, camera=CameraSpec.parse("follow:ball"))
    try:
        window.frame(elapsed=1 / 60)
        viewer, ball = window.viewer, window.viewer.scene.entity("ball")
        start = ball.position
        drag(window, mouse, screen_xy(window, start), (120, 80), frames=20, release=False)
        assert viewer.spring.holding and viewer.spring.body == "ball"
        assert viewer.spring.force > 1.0
        assert f"pull ball.centre {viewer.spring.force:4.0f} N" in viewer.status_text()  # strength shown
        moved = ball.position - start
        assert np.linalg.norm(moved) > 0.5  # pulled along after the cursor
        assert moved[1] > 0.2  # up the screen is up in the world: off the ground

        # a snapshot mid-drag (the server's checkpoint under twig serve --window) restores, spring and all
        restored = Scene.restore(viewer.scene.snapshot())
        try:
            spring = restored.schedule.stages["mouse_spring"].system
            assert spring.holding and spring.body == "ball"
        finally:
            restored.close()

        window.dispatch_event("on_mouse_release", 0, 0, mouse.LEFT, 0)
        window.frame(elapsed=1 / 60)
        assert not viewer.spring.holding
        at_release, speed = ball.position, np.linalg.norm(ball.velocity)
        assert speed > 2.0  # thrown: it flies on with the drag's speed
        for _ in range(6):
            window.frame(elapsed=1 / 60)
        flown = ball.position - at_release
        assert np.linalg.norm(flown) > 0.5  # in the direction it was going, not dropped dead
        assert np.dot(flown, moved) > 0
    finally:
        window.close()


def test_yanking_a_childs_hand_hurts(pyglet_window):
    mouse = pyglet_window.mouse
    window = open_window("schoolyard", size=SIZE, headless=True,
                         camera=CameraSpec.parse("follow:small_child"))  # fmt: skip
    try:
        for _ in range(3):
            window.frame(elapsed=1 / 60)
        scene = window.viewer.scene
        scene.remove("ragdoll")  # the child carries it in front of its hands
        window.frame(elapsed=1 / 60)
        child = scene.entity("small_child")
        pains = []
        scene.on("pain", pains.append)
        assert child.pain == 0.0
        # the hand a person would click: one the cursor finds first (not behind the body)
        hand = next(h for h in ("l_hand", "r_hand")
                    if under_cursor(window, child.node(h)) == ("small_child", h))  # fmt: skip
        drag(window, mouse, screen_xy(window, child.node(hand)), (0, 90), frames=10, release=False)
        assert (window.viewer.spring.body, window.viewer.spring.part) == ("small_child", hand)
        window.dispatch_event("on_mouse_release", 0, 0, mouse.LEFT, 0)
        window.frame(elapsed=1 / 60)
        assert any(e.body == child.entity and e.link == hand for e in pains)
        assert child.pain > 0.5  # the sensor's level, as after a blow
        assert scene.entity("big_child").pain == 0.0  # only the body pulled feels it
    finally:
        window.close()


def run_until(window, done, seconds: float, per_frame: float = 8 / 60) -> bool:
    """Draw frames of ``per_frame`` simulated seconds until ``done()`` or ``seconds`` have passed."""
    scene = window.viewer.scene
    end = scene.time + seconds
    while scene.time < end:
        window.frame(elapsed=per_frame)
        if done():
            return True
    return False


def test_a_click_command_sends_a_character_to_hug_another(pyglet_window):
    mouse, key = pyglet_window.mouse, pyglet_window.key
    window = open_window("schoolyard", size=SIZE, headless=True, camera=CameraSpec.parse("orbit:205,35,9"))
    try:
        window.frame(elapsed=1 / 60)
        viewer = window.viewer
        scene = viewer.scene
        parent, child = scene.entity("parent"), scene.entity("big_child")
        assert under_cursor(window, parent.position)[0] == "parent"
        click(window, mouse, screen_xy(window, parent.position))
        window.frame(elapsed=1 / 60)
        assert viewer.selected == "parent" and viewer.command_target is None

        click(window, mouse, screen_xy(window, child.position))
        window.frame(elapsed=1 / 60)
        assert viewer.command_target.name == "big_child"
        assert "parent -> big_child: pick a command" in viewer.status_text()
        menu = {k: label for k, label, _ in commands.available(scene)}
        assert menu[2] == "hug"
        press_key(window, key._2)
        window.frame(elapsed=1 / 60)
        goals = scene.entity("parent").goals
        assert [g.behavior for g in goals] == ["hug"] and goals[0].params["target"] == "big_child"

        assert run_until(window, lambda: "parent: hug done" in viewer.goal_log, seconds=20.0)
        assert "parent: hug done" in viewer.status_text()  # the goal's end shows in the status line
    finally:
        window.close()


def simulated_per_wall_second(window, frames: int) -> tuple[float, float]:
    """Draw ``frames`` frames at the real wall clock; the scene's simulated seconds per wall
    second the clock counted, and those wall seconds.

    Simulated time the clock had to drop (a frame so slow that more than the per-frame cap
    of steps fell due: a busy machine) counts as simulated, from the clock's own books.
    """
    viewer = window.viewer
    clock, scene = viewer.clock, viewer.scene
    frame0, wall0, dropped0 = scene.frame, clock.wall, clock.dropped
    for _ in range(frames):
        window.frame()  # no elapsed override: the window measures the wall time itself
    wall = clock.wall - wall0
    simulated = (scene.frame - frame0) * scene.dt + (clock.dropped - dropped0)
    return simulated / wall, wall


def test_slow_motion_halves_simulated_time_per_wall_second(pyglet_window):
    key = pyglet_window.key
    window = open_window("schoolyard", size=(160, 90), headless=True)
    try:
        viewer = window.viewer
        window.frame(elapsed=1 / 60)
        normal, wall_normal = simulated_per_wall_second(window, 40)
        press_key(window, key.BRACKETLEFT)
        window.frame(elapsed=0.0)
        assert viewer.time_scale == 0.5 and "time x0.5" in viewer.status_text()
        half, wall_half = simulated_per_wall_second(window, 40)
        # whole steps only: what the clock still owes is less than one step of simulated time
        assert normal == pytest.approx(1.0, abs=viewer.scene.dt / wall_normal + 1e-9)
        assert half == pytest.approx(0.5, abs=viewer.scene.dt / wall_half + 1e-9)
        # and the clock's books balance: steps paid + owed + dropped = wall time x scale
        clock = viewer.clock
        books = clock.paid * clock.dt + clock.accumulator + clock.dropped
        assert books == pytest.approx(clock.simulated_wall)
        press_key(window, key.BRACKETLEFT)
        press_key(window, key.BRACKETRIGHT)
        press_key(window, key.BRACKETRIGHT)
        press_key(window, key.BRACKETRIGHT)
        window.frame(elapsed=0.0)
        assert viewer.time_scale == 2.0 and viewer.clock.scale == 2.0
        for _ in range(3):
            press_key(window, key.BRACKETRIGHT)
        window.frame(elapsed=0.0)
        assert viewer.time_scale == 4.0  # the fastest; more presses stay there
        viewer.clock.reset()  # nothing owed: earlier frames timed by the wall clock leave up to a step
        frame = viewer.scene.frame
        window.frame(elapsed=0.1)
        assert viewer.scene.frame - frame == 24  # 0.1 s at 4x: 0.4 s of steps (the 1x cap is 8 a frame)
    finally:
        window.close()


def test_recording_writes_a_playable_mp4_of_the_window(pyglet_window, tmp_path):
    import imageio_ffmpeg

    key = pyglet_window.key
    window = open_window("schoolyard", size=(322, 181), headless=True, screenshot_dir=tmp_path)
    try:
        viewer = window.viewer
        window.frame(elapsed=1 / 60)
        press_key(window, key.V)
        window.frame(elapsed=1 / 15)  # the recording starts with this frame
        started = viewer.scene.time
        for _ in range(15):
            window.frame(elapsed=1 / 15)  # 1 s at 15 frames/s: 30 video frames after the first
        shown = window.read_frame()
        recorded = viewer.scene.time - started
        press_key(window, key.V)
        window.frame(elapsed=1 / 15)
        path = viewer.last_recording
        assert path is not None and path.suffix == ".mp4" and viewer.recorder is None
    finally:
        window.close()
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    assert tuple(meta["size"]) == (322, 180)  # even sides for H.264: the odd row left out
    frames = [np.frombuffer(f, dtype=np.uint8).reshape(180, 322, 3) for f in reader]
    assert recorded == pytest.approx(1.0)
    assert len(frames) == 31  # the first frame, then 30 more over the second recorded
    assert meta["fps"] == pytest.approx(30.0)
    last = frames[-1].astype(np.int16)
    assert last.std() > 10  # a picture, not a blank
    assert np.abs(last - shown[:180, :322].astype(np.int16)).mean() < 8  # what the window showed


def test_inspector_slider_changes_the_running_scene_and_writes_the_yaml(pyglet_window, tmp_path):
    import shutil

    from twig_ecs.components import Attachment
    from twig_ecs.graphics.tuning import builtin_scene

    mouse, key = pyglet_window.mouse, pyglet_window.key
    original = Scene.load("schoolyard")
    source = original.source
    original.close()
    assert builtin_scene(source)
    scene_file = tmp_path / "yard.yaml"
    shutil.copy(source, scene_file)
    window = open_window(str(scene_file), size=(1280, 720), headless=True)
    try:
        viewer = window.viewer
        press_key(window, key.F1)
        for _ in range(3):
            window.frame(elapsed=1 / 60)
        assert viewer.ui is not None and len(viewer.ui.windows) == 3
        scene = viewer.scene
        child = scene.entity("small_child")
        attachment = scene.world.component_for_entity(child.entity, Attachment)
        window.frame(elapsed=0.5)
        assert attachment.anxiety == 0.0  # near the parent (inside 2.5 m): no anxiety

        # drag the safe-distance slider all the way to the left: 0 m, so the child is "away"
        yaw = viewer.camera.yaw
        x0, y0, x1, y1 = viewer.ui.rects["small_child.attachment.safe_distance"]
        height = window.height
        start = ((x0 + x1) / 2, height - (y0 + y1) / 2)
        window.dispatch_event("on_mouse_motion", *start, 0, 0)
        window.frame(elapsed=0.0)
        window.dispatch_event("on_mouse_press", *start, mouse.LEFT, 0)
        window.frame(elapsed=0.0)
        for k in range(1, 6):
            window.dispatch_event("on_mouse_drag", start[0] - 80 * k, start[1], -80, 0, mouse.LEFT, 0)
            window.frame(elapsed=0.0)
        window.dispatch_event("on_mouse_release", start[0] - 400, start[1], mouse.LEFT, 0)
        window.frame(elapsed=0.0)
        assert attachment.safe_distance == 0.0
        assert not viewer.spring.holding and viewer.camera.yaw == yaw  # the drag was the slider's only
        for _ in range(4):
            window.frame(elapsed=0.25)
        assert attachment.anxiety > 0.01  # the running child now frets
        plotted = viewer.history.series("small_child")  # what the history window plots
        assert {"anxiety", "pain", "play"} <= set(plotted)
        assert plotted["anxiety"][0] == 0.0 and plotted["anxiety"][-1] == pytest.approx(attachment.anxiety)

        # write it back into the scene file
        bx0, by0, bx1, by1 = viewer.ui.rects["write"]
        button = ((bx0 + bx1) / 2, height - (by0 + by1) / 2)
        window.dispatch_event("on_mouse_motion", *button, 0, 0)
        window.frame(elapsed=0.0)
        window.dispatch_event("on_mouse_press", *button, mouse.LEFT, 0)
        window.frame(elapsed=0.0)
        window.dispatch_event("on_mouse_release", *button, mouse.LEFT, 0)
        for _ in range(2):
            window.frame(elapsed=0.0)
        assert viewer.ui.message.startswith("wrote 1 parameter"), viewer.ui.message
    finally:
        window.close()
    text = scene_file.read_text()
    assert "safe_distance: 0  " in text and "# m: closer than this anxiety fades" in text  # comments kept
    reloaded = Scene.load(str(scene_file))
    try:
        attachment = reloaded.world.component_for_entity(reloaded.entity("small_child").entity, Attachment)
        assert attachment.safe_distance == 0.0 and attachment.per_metre == pytest.approx(0.012)
    finally:
        reloaded.close()


def picture_share(window, name: str) -> float:
    """How much of the picture's height a body covers (its nodes' projected extent)."""
    viewer = window.viewer
    px = viewer.camera.project(viewer.scene.entity(name).node_positions, window.width, window.height)
    return float(px[:, 1].max() - px[:, 1].min()) / window.height


def test_default_camera_frames_the_characters_follows_them_and_shows_the_yard_on_a_key(pyglet_window):
    from twig_ecs.graphics.camera import action_point

    key = pyglet_window.key
    window = open_window("schoolyard", size=SIZE, headless=True)
    try:
        window.frame(elapsed=1 / 60)
        viewer = window.viewer
        scene = viewer.scene
        assert 0.22 < picture_share(window, "parent") < 0.45  # the tallest: about a third of the height
        for name in ("parent", "big_child", "small_child"):
            px = viewer.camera.project(scene.entity(name).position, window.width, window.height)[0]
            assert 0 < px[0] < window.width and 0 < px[1] < window.height

        # the action moves off: everyone walks 6 m along x; the camera goes with them
        start = viewer.camera.target.copy()
        for name in ("parent", "big_child", "small_child", "ragdoll"):
            scene.entity(name).translate((6.0, 0.0, 0.0))
        for _ in range(30):
            window.frame(elapsed=0.2)
        centre = action_point(scene)
        assert viewer.camera.target[0] - start[0] > 3.0
        assert np.linalg.norm((viewer.camera.target - centre)[[0, 2]]) < 2.0

        press_key(window, key.Y)  # the whole yard
        window.frame(elapsed=1 / 60)
        fences = [n for n in scene.entity_names if n.startswith("fence")]
        fence = np.vstack([scene.entity(n).node_positions for n in fences])
        px = viewer.camera.project(fence, window.width, window.height)
        assert (px[:, 0] > 0).all() and (px[:, 0] < window.width).all()
        assert (px[:, 1] > 0).all() and (px[:, 1] < window.height).all()
        assert picture_share(window, "parent") < 0.15
        press_key(window, key.Y)  # and back to the action
        window.frame(elapsed=1 / 60)
        assert 0.22 < picture_share(window, "parent") < 0.45
    finally:
        window.close()


FALLBACK = """
import sys
sys.modules["imgui_bundle"] = None  # as if the optional 'window' extra were not installed
import numpy as np
from twig_ecs.graphics.app import load_pyglet_window, open_window
key = load_pyglet_window(headless=True).key
window = open_window("schoolyard", size=(480, 270), headless=True)
window.frame(elapsed=1 / 60)
plain = window.read_frame().astype(np.int16)
window.dispatch_event("on_key_press", key.F1, 0)
window.frame(elapsed=0.0)
covered = (np.abs(window.read_frame().astype(np.int16) - plain)[:60, :150].sum(axis=2) > 40).mean()
print("ui", window.viewer.ui, "covered", round(float(covered), 2))
window.close()
"""


def test_the_window_keeps_its_text_inspector_without_imgui_bundle():
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", FALLBACK], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    words = done.stdout.split()
    assert words[:2] == ["ui", "None"]  # no ImGui, no error
    assert float(words[-1]) > 0.3  # the text inspector panel covers the top-left corner
