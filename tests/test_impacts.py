"""Impacts move bodies in proportion to their masses (issue 34): a child's bump barely moves
a grown-up, a grown-up's moves a child; a caregiver keeps its place."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene


def ground_gap(p: np.ndarray, q: np.ndarray) -> float:
    return float(np.hypot(*(p - q)[[0, 2]]))


def collide(scenes, runner: str, runner_height: float, stood_height: float, speed: float) -> float:
    """``runner`` runs at ``speed`` into a character standing 3 m ahead and stops a quarter
    of a second after it touches; returns the furthest the one it hit got (m, pelvis, on
    the ground) over the next 4 s."""
    scene = Scene.load("empty")
    scenes.append(scene)
    stood = scene.spawn("humanoid", name="stood", character=True, height=stood_height, facing=180)
    mover = scene.spawn("humanoid", name=runner, character=True, height=runner_height, position=(0, 0, -3.0))
    scene.run(0.5)
    touched = []
    scene.on(
        "contact", lambda e: touched.append(scene.time) if stood.entity in (e.body, e.other_body) else None
    )
    start = stood.position.copy()
    mover.walk((0.0, 0.0, speed))
    furthest, stopped = 0.0, False
    for _ in range(4 * 60):
        scene.step()
        if touched and not stopped and scene.time > touched[0] + 0.25:
            mover.stop()
            stopped = True
        furthest = max(furthest, ground_gap(stood.position, start))
    assert touched, "they collided"
    return furthest


def test_a_child_running_into_a_grown_up_moves_it_less_than_half_a_metre(scenes):
    # a 1.35 m child (30 kg) at 3 m/s knocks a 1.75 m parent (65 kg) with 7-12 J: it hurts,
    # but a blow from a body half its weight makes the parent flinch, not retreat 2 m
    assert collide(scenes, "child", 1.35, 1.75, 3.0) <= 0.5


def test_the_same_knock_from_a_grown_up_sends_a_child_back_metres(scenes):
    moved = collide(scenes, "adult", 1.75, 1.35, 3.0)
    assert moved >= 1.0, "the lighter body is moved, and further than the heavy one"


def test_a_blow_from_a_lighter_body_makes_a_shorter_retreat():
    from twig_ecs.systems.behaviours.withdraw import mass_share

    scene = Scene.load("empty")
    try:
        adult = scene.spawn("humanoid", name="adult", character=True)
        child = scene.spawn("humanoid", name="child", character=True, height=1.05, position=(2, 0, 0))
        ball = scene.spawn("ball", name="ball", position=(4, 0, 0))
        assert mass_share(scene, child.entity, adult.entity) == pytest.approx(child.mass / adult.mass)
        assert mass_share(scene, adult.entity, child.entity) == 1.0
        assert mass_share(scene, ball.entity, adult.entity) < 0.01
    finally:
        scene.close()


def test_the_schoolyard_parent_keeps_its_place_through_a_minute_of_hugs(scenes):
    # seed 1: the small child runs home for hugs; after each the parent stepped back
    # ~0.4 m from it, always the same way, and drifted 3.2 m in five minutes
    scene = Scene.load("schoolyard", seed=1)
    scenes.append(scene)
    parent = scene.entity("parent")
    start = parent.position.copy()
    hugged = []
    scene.on(
        "behavior.changed",
        lambda e: hugged.append(e) if (e.character, e.new) == (parent.entity, "embrace") else None,
    )
    furthest = 0.0
    for _ in range(90 * 60):
        scene.step()
        furthest = max(furthest, ground_gap(parent.position, start))
    assert len(hugged) >= 2, "the small child came for hugs"
    assert ground_gap(parent.position, start) <= 0.3, "it is back at its post"
    assert furthest <= 0.8
