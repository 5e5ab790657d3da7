"""Attention (SPEC 4): what a character sees, remembers and looks at, on a tiny world.

The system runs alone (``Scene(plugins=[])`` and ``add_system``) beside a character and a few
balls; the view-cone rule's plain-float arithmetic is checked against the rule written with
numpy, which it must answer as, or leave to.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.components import Memory
from twig_ecs.errors import SceneError
from twig_ecs.kernelmath import GAZE_NODE
from twig_ecs.systems.control.attention import AttentionSystem, _in_view


def _watcher(scenes, balls: dict[str, tuple[float, float, float]], **perception) -> Scene:
    """A character at the origin facing +z, with perception, and balls where given."""
    scene = Scene(plugins=[])
    scenes.append(scene)
    scene.add_system(AttentionSystem())
    scene.spawn("humanoid", name="kid", character=True, perception=perception)
    for name, where in balls.items():
        scene.spawn("ball", name=name, position=where)
    return scene


def test_a_character_remembers_what_is_in_its_view_cone_and_looks_at_it(scenes):
    scene = _watcher(scenes, {"ahead": (0.3, 0.0, 4.0), "behind": (0.0, 0.0, -4.0), "far": (0.0, 0.0, 30.0)})
    scene.step(1)
    memory = scene.world.component_for_entity(scene.entity_id("kid"), Memory)
    assert set(memory.strength) == {"ahead"}  # not the one behind it, nor the one beyond 15 m
    assert memory.strength["ahead"] == 1.0
    assert memory.focus == "ahead"
    where = np.array(memory.where["ahead"])
    assert np.linalg.norm(where - scene.entity("ahead").position) < 0.2  # its centre, where it was seen
    ch, row = scene.state.characters, scene.entity("kid").character_row
    assert ch.gaze_mode[row] == GAZE_NODE
    assert ch.gaze_node[row] == scene.entity("ahead").node_row("centre")


def test_what_leaves_the_view_cone_fades_with_the_memory_half_life(scenes):
    scene = _watcher(scenes, {"ball": (0.0, 0.0, 3.0)}, memory_half_life=2.0)
    scene.step(1)
    memory = scene.world.component_for_entity(scene.entity_id("kid"), Memory)
    assert memory.strength["ball"] == 1.0
    ball = scene.entity("ball")
    ball.translate((0.0, 0.0, -6.0))  # behind the character now
    steps = round(2.0 / scene.dt)  # one half-life
    scene.step(steps)
    assert memory.strength["ball"] == pytest.approx(0.5, rel=0.02)
    assert memory.where["ball"][2] > 2.5  # still remembered where it was last seen


def test_spawn_gives_a_character_the_perception_and_behaviours_it_names(scenes):
    scene = Scene()
    scenes.append(scene)
    scene.spawn("ball", name="ball", position=(0.0, 0.0, 3.0))
    kid = scene.spawn("humanoid", name="kid", character=True, perception={"valence": {"ball": 0.8}},
                      behaviors=[{"use": "play", "toy": "ball"}])  # fmt: skip
    scene.step(30)
    memory = scene.world.component_for_entity(kid.entity, Memory)
    assert memory.focus == "ball"
    assert kid.mind.winner == "play"
    with pytest.raises(SceneError, match="unknown behaviour 'plya'.*play"):
        scene.spawn("humanoid", name="other", character=True, behaviors=[{"use": "plya"}])
    with pytest.raises(SceneError, match="only characters perceive"):
        scene.spawn("ball", name="ball2", perception={})
    assert not scene.has_entity("other") and not scene.has_entity("ball2")


def _numpy_rule(off: np.ndarray, face: np.ndarray, view_distance: float, cos_half: float) -> bool:
    """The view-cone rule written with numpy, as the attention system wrote it before."""
    dist = math.sqrt(off.dot(off))
    return dist < view_distance and (dist < 0.5 or off @ face / dist >= cos_half)


def test_the_plain_float_view_test_answers_as_numpy_or_leaves_it_to_numpy():
    rng = np.random.default_rng(7)
    cos_half = math.cos(math.radians(60.0))
    answered = 0
    for _ in range(20000):
        off = rng.normal(size=3) * rng.choice([0.3, 3.0, 10.0])
        face = rng.normal(size=3)
        face /= np.linalg.norm(face)
        x, y, z = off.tolist()
        fx, fy, fz = face.tolist()
        dist = math.sqrt(x * x + y * y + z * z)
        seen = _in_view(dist, (x * fx + y * fy + z * fz) / dist, 15.0, cos_half)
        if seen is not None:
            answered += 1
            assert seen == _numpy_rule(off, face, 15.0, cos_half)
    assert answered > 19900  # numpy is asked only near an edge


def test_on_an_edge_of_the_view_cone_the_plain_float_test_defers():
    cos_half = math.cos(math.radians(60.0))
    assert _in_view(15.0, 1.0, 15.0, cos_half) is None  # at the view distance
    assert _in_view(0.5, -1.0, 15.0, cos_half) is None  # at the always-seen radius
    assert _in_view(3.0, cos_half, 15.0, cos_half) is None  # on the cone's side
    assert _in_view(3.0, math.nan, 15.0, cos_half) is None
    assert _in_view(3.0, cos_half + 1e-6, 15.0, cos_half) is True
    assert _in_view(3.0, cos_half - 1e-6, 15.0, cos_half) is False
    assert _in_view(0.4, -1.0, 15.0, cos_half) is True
