"""Signs of life (issue 34): a character standing or sitting with nothing to do glances about.

Breathing is older (``systems/control/respiration.py``); the glances are ``glance.py``: every
few seconds the drawn face turns 15-40 degrees to one side and a little down, for one or two
seconds, then back - nothing else moves.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs import Scene

SECONDS = 20.0


def _face_yaws(scene, person, seconds):
    """The drawn face's yaw from the hips' facing (degrees), every step for ``seconds``."""
    out = []
    for _ in range(int(round(seconds / scene.dt))):
        scene.step()
        h, f = person.face_direction, person.facing
        out.append(math.degrees(math.atan2(h[0], h[2]) - math.atan2(f[0], f[2])))
    return (np.array(out) + 180.0) % 360.0 - 180.0


def _glances(yaws, beyond=12.0):
    """How many times the face turned further than ``beyond`` degrees from the hips."""
    away = np.abs(yaws) > beyond
    return int(np.count_nonzero(np.diff(away.astype(int)) == 1) + away[0])


def test_a_character_standing_idle_glances_about_and_comes_back_with_its_feet_planted(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    person = scene.spawn("humanoid", name="waiting", character=True)
    scene.run(0.5)
    feet = [person.node("l_foot").copy(), person.node("r_foot").copy()]
    yaws = _face_yaws(scene, person, SECONDS)
    # before: the face stayed within a degree of the hips' facing for the 20 s (a statue)
    assert _glances(yaws) >= 3, f"{_glances(yaws)} glances in {SECONDS:.0f} s"
    assert 15.0 <= np.abs(yaws).max() <= 45.0
    assert 0.5 <= np.mean(np.abs(yaws) < 5.0), "most of the time it looks ahead, between glances"
    moved = max(
        float(np.linalg.norm(person.node(f) - p)) for f, p in zip(("l_foot", "r_foot"), feet, strict=True)
    )
    assert moved < 0.005, f"a foot moved {moved:.3f} m"


def test_a_walking_or_watching_character_does_not_glance_about(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    walker = scene.spawn("humanoid", name="walker", character=True)
    watcher = scene.spawn("humanoid", name="watcher", character=True, position=(3.0, 0.0, 0.0))
    watcher.look_at("walker")
    walker.walk((0.0, 0.0, 1.0))
    scene.run(0.5)
    yaws = _face_yaws(scene, walker, 8.0)
    assert np.abs(yaws).max() < 12.0, "walking, the face goes the way it walks"
    glance = scene.state.characters.glance
    assert not glance[walker.character_row, :2].any() and not glance[watcher.character_row, :2].any()


def test_a_glance_moves_nothing_but_the_drawn_face(scenes, monkeypatch):
    from twig_ecs.systems.control import glance

    hashes = []
    for first_wait in (glance.FIRST_WAIT, 1e9):  # with glances, then never one
        monkeypatch.setattr(glance, "FIRST_WAIT", first_wait)
        scene = Scene.load("empty")
        scenes.append(scene)
        person = scene.spawn("humanoid", name="p", character=True)
        scene.state.characters.glance_left[:] = first_wait
        yaws = _face_yaws(scene, person, 10.0)
        assert (_glances(yaws) >= 2) == (first_wait < 100), _glances(yaws)
        hashes.append(scene.state_hash())
    # the shoulders, the feet and what the character notices go by where the head points
    assert hashes[0] == hashes[1]


def test_glances_come_out_the_same_in_every_run(scenes):
    runs = []
    for _ in range(2):
        scene = Scene.load("empty")
        scenes.append(scene)
        person = scene.spawn("humanoid", name="waiting", character=True)
        runs.append(_face_yaws(scene, person, 8.0))
    assert np.array_equal(runs[0], runs[1])
