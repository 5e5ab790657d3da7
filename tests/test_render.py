"""Offscreen rendering: what bodies put on screen, the files `twig render` writes."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.graphics.camera import CameraError, CameraSpec
from twig_ecs.graphics.closeup import MomentSpec, closeup_camera, find_moment
from twig_ecs.graphics.offscreen import OffscreenRenderer, parse_size, render_scene
from twig_ecs.graphics.renderer import build_tables, face_frames
from twig_ecs.systems.behaviours.play import yard_of

SIZE = (320, 180)


@pytest.fixture(scope="module")
def offscreen():
    with OffscreenRenderer() as off:
        yield off


@pytest.fixture
def schoolyard():
    scene = Scene.load("schoolyard")
    for name in [n for n in scene.entity_names if n.startswith("fence")]:
        scene.remove(name)  # its thin rails round a 20 m yard would only shrink the bodies in view
    yield scene
    scene.close()


def test_bodies_change_the_image_where_they_project_and_nowhere_else(offscreen, schoolyard):
    camera = CameraSpec().make(schoolyard, SIZE[0] / SIZE[1])
    with_bodies = offscreen.render(schoolyard, camera, SIZE).astype(np.int16)
    pixels = camera.project(schoolyard.state.nodes.pos[: schoolyard.state.nodes.count], *SIZE)
    for name in schoolyard.entity_names:
        schoolyard.remove(name)
    empty = offscreen.render(schoolyard, camera, SIZE).astype(np.int16)

    diff = np.abs(with_bodies - empty).sum(axis=2)
    near = np.zeros(diff.shape, dtype=bool)  # within 16 px of a projected node
    for x, y in pixels:
        near[max(0, int(y) - 16) : int(y) + 17, max(0, int(x) - 16) : int(x) + 17] = True
    assert near.mean() < 0.5, "the test needs background to compare against"
    changed = diff > 30
    assert changed.sum() > 500
    assert changed[near].mean() > 0.2  # bodies cover a good part of their own neighbourhood
    assert changed[~near].mean() < 0.005  # and leave the rest of the picture alone
    assert changed[near].mean() > 50 * changed[~near].mean()


def test_removing_bodies_leaves_ground_and_sky(offscreen):
    scene = Scene.load("empty")
    try:
        camera = CameraSpec.parse("orbit:0,20,10").make(scene, SIZE[0] / SIZE[1])
        image = offscreen.render(scene, camera, SIZE)
    finally:
        scene.close()
    top, bottom = image[:20].reshape(-1, 3).mean(axis=0), image[-20:].reshape(-1, 3).mean(axis=0)
    assert top[2] > top[0]  # bluish sky above the horizon
    assert abs(float(bottom.mean()) - float(top.mean())) > 3  # a different ground below


def test_humanoid_face_points_along_its_facing(schoolyard):
    tables = build_tables(schoolyard)
    assert len(tables.faces.head) == 4  # parent, two children and the ragdoll have heads
    pos = schoolyard.state.nodes.pos
    forward, left, up = face_frames(pos, tables.faces)
    parent = schoolyard.entity_names.index("parent")  # facing 30 degrees
    expected = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])
    assert forward[parent] @ expected > 0.97
    assert up[parent][1] > 0.9
    assert np.cross(up[parent], forward[parent]) @ left[parent] > 0.99


def test_gif_has_the_requested_frame_count(schoolyard, tmp_path):
    result = render_scene(schoolyard, 0.5, tmp_path / "clip.gif", size=(160, 90), fps=10, progress=False)
    with Image.open(tmp_path / "clip.gif") as gif:
        assert gif.n_frames == 5 == result.frames
        assert gif.size == (160, 90)
        assert gif.info["duration"] == 100
    assert schoolyard.frame == 30  # the last frame shows t = 0.5 s


def test_mp4_has_the_requested_frame_count(schoolyard, tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    render_scene(schoolyard, 0.4, tmp_path / "clip.mp4", size=(160, 96), fps=20, progress=False)
    frames, _seconds = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "clip.mp4"))
    assert frames == 8


def test_twig_render_writes_a_1280x720_png_by_default(tmp_path, capsys):
    out = tmp_path / "shot.png"
    assert main(["render", "schoolyard", "--seconds", "0.2", "-o", str(out)]) == 0
    with Image.open(out) as image:
        assert image.size == (1280, 720)
        assert np.asarray(image).std() > 10
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--size", "12x5"], "out of range"),
        (["--size", "wide"], "WIDTHxHEIGHT"),
        (["-o", "shot.bmp"], ".png, .gif or .mp4"),
        (["--camera", "follow:nobody"], "no entity"),
        (["--camera", "1,2"], "unknown camera"),
        (["--seconds", "0"], "more than 0"),
    ],
)
def test_twig_render_explains_bad_options(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["render", "empty", "-o", "x.png", "--seconds", "0.1", *args]
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_camera_specs_parse():
    assert CameraSpec.parse("auto").mode == "auto"
    assert CameraSpec.parse("follow:parent").name == "parent"
    spec = CameraSpec.parse("orbit:90,30,12")
    assert (spec.yaw, spec.pitch, spec.distance) == (90, 30, 12)
    spec = CameraSpec.parse("0,5,10@0,1,0")
    assert spec.eye.tolist() == [0, 5, 10] and spec.target.tolist() == [0, 1, 0]
    with pytest.raises(CameraError):
        CameraSpec.parse("orbit:1")
    assert parse_size("640x480") == (640, 480)


def test_eye_camera_looks_at_its_target(schoolyard):
    camera = CameraSpec.parse("0,5,10@0,1,0").make(schoolyard, 16 / 9)
    np.testing.assert_allclose(camera.eye, [0, 5, 10], atol=1e-9)
    x, y = camera.project(np.array([[0.0, 1.0, 0.0]]), 320, 180)[0]
    assert abs(x - 160) < 1e-6 and abs(y - 90) < 1e-6


def test_a_camera_eye_at_negative_x_parses_as_written_in_the_docs(tmp_path, capsys):
    """`--camera -4.45,1.42,2.78@...` (docs/characters.md) was 'expected one argument'."""
    out = tmp_path / "shot.png"
    argv = ["render", "empty", "--seconds", "0.05", "--size", "160x90", "-o", str(out)]
    assert main([*argv, "--camera", "-4.45,1.42,2.78@-3.72,0.45,5.28"]) == 0
    assert out.exists() and "wrote" in capsys.readouterr().out


def test_a_gif_keeps_the_colours_of_the_bodies(tmp_path):
    """The GIF's palette turned the blue parent and the green deck grey (median cut)."""
    png, gif = tmp_path / "yard.png", tmp_path / "yard.gif"
    same = ["render", "schoolyard", "--seconds", "0.2", "--size", "480x270", "--camera", "3,9,14@0,0.5,1"]
    assert main([*same, "-o", str(png)]) == 0
    assert main([*same, "--fps", "10", "-o", str(gif)]) == 0

    def coloured(image: Image.Image) -> np.ndarray:
        a = np.asarray(image.convert("RGB")).astype(int)
        return (a.max(axis=2) - a.min(axis=2)) > 60

    with Image.open(png) as still, Image.open(gif) as clip:
        clip.seek(clip.n_frames - 1)  # the same moment as the PNG
        want, got = coloured(still), coloured(clip)
    assert want.sum() > 100, "the frame shows coloured bodies"
    assert (want & got).sum() > 0.6 * want.sum()


@pytest.mark.parametrize(
    ("at", "extra", "message"),
    [
        ("dance", [], "unknown moment 'dance'"),
        ("hug:0", [], "not a count from 1"),
        ("kick", ["--seconds", "3"], "shows the moment itself"),
        ("hug", ["--within", "3"], "has 0 hug moments in its first 3 s"),
    ],
)
def test_twig_render_at_explains_a_moment_it_cannot_show(at, extra, message, tmp_path, capsys):
    argv = ["render", "schoolyard", "--at", at, "--size", "160x90", "-o", str(tmp_path / "x.png"), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err
    assert not (tmp_path / "x.png").exists()


def test_a_moment_not_found_lists_the_moments_that_were(tmp_path, capsys):
    argv = ["render", "schoolyard", "--at", "push:50", "--within", "20", "-o", str(tmp_path / "x.png")]
    assert main(argv) == 2
    said = capsys.readouterr().err
    assert re.search(r"moments seen: .*kick x\d", said), said  # the big child kicks at 15.8 s (session 15)


@pytest.fixture(scope="module")
def first_kick():
    """The schoolyard (seed 0, its fence kept) run to its first kick (at 15.8 s, session 15) and
    the moment found, once for the tests that only read them."""
    scene = Scene.load("schoolyard")
    try:
        yield scene, find_moment(scene, MomentSpec.parse("kick"), within=20.0)
    finally:
        scene.close()


@pytest.mark.xdist_group("first-kick")  # with workers, in the one that ran to the kick
def test_the_first_kick_is_the_step_a_leg_meets_the_speeding_ball(first_kick):
    schoolyard, moment = first_kick
    assert moment.names == ("big_child", "ball")
    assert schoolyard.frame == moment.frame and schoolyard.time == pytest.approx(moment.time)
    ball = schoolyard.entity("ball")
    assert np.linalg.norm(ball.velocity) > 0.4
    kicker = schoolyard.entity("big_child")
    feet = [kicker.node("l_foot"), kicker.node("r_foot")]
    assert min(np.linalg.norm(f - ball.position) for f in feet) < 0.3


@pytest.mark.xdist_group("first-kick")
def test_a_close_up_of_the_first_kick_frames_everyone_involved_from_inside_the_yard(first_kick):
    scene, moment = first_kick  # with its fence: the eye stays inside it
    check_close_up_from_inside_the_yard(scene, moment)


def test_a_close_up_of_a_scuffle_frames_everyone_involved_from_inside_the_yard(scenes):
    scene = Scene.load("schoolyard")  # with its fence: the eye stays inside it
    scenes.append(scene)
    check_close_up_from_inside_the_yard(scene, find_moment(scene, MomentSpec.parse("scuffle"), within=20.0))


def check_close_up_from_inside_the_yard(scene, moment) -> None:
    """The close-up camera of ``moment`` (now) has its eye inside the fence and frames everyone
    involved, the tallest most of the picture's height. It only reads the scene."""
    yard = yard_of(scene)
    spec = closeup_camera(scene, moment.names, 16 / 9, yard)
    camera = spec.make(scene, 16 / 9)
    assert (yard[0] < camera.eye[[0, 2]]).all() and (camera.eye[[0, 2]] < yard[1]).all()
    for name in moment.names:
        xy = camera.project(scene.entity(name).node_positions, 320, 180)
        assert ((xy >= 0) & (xy <= (320, 180))).all(), f"{name} leaves the picture"
    heights = [np.ptp(camera.project(scene.entity(n).node_positions, 320, 180)[:, 1]) for n in moment.names]
    assert max(heights) > 0.6 * 180  # close: the tallest one framed is most of the picture's height


def test_twig_render_at_with_a_gif_runs_on_from_the_moment(tmp_path, capsys):
    out = tmp_path / "kick.gif"
    argv = ["render", "schoolyard", "--at", "kick", "--seconds", "0.5", "--fps", "10", "--size", "160x90"]
    assert main([*argv, "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert re.match(r"kick 1 at \d+\.\d\d s: big_child and ball \(camera ", said), said
    with Image.open(out) as gif:
        assert gif.n_frames == 5
