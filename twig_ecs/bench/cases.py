"""The scenes ``twig bench`` times: the schoolyard, crowds, approach crowds and ragdoll piles."""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.scene import Scene


def schoolyard() -> Scene:
    """The schoolyard demo (SPEC 5), seed 0."""
    return Scene.load("schoolyard", seed=0)


def crowd(count: int) -> Scene:
    """``count`` autonomous characters wandering, collisions on (``content/scenes/crowd.yaml``)."""
    return Scene.load("crowd", seed=0, count=count)


def ragdoll_pile(count: int) -> Scene:
    """``count`` full-size humanoid ragdolls in a square grid 1.2 m apart, dropped from 0.5-2 m."""
    scene = Scene.load("empty")
    side = math.ceil(math.sqrt(count))
    rng = np.random.default_rng(1)
    for k in range(count):
        x, z = (k % side) * 1.2, (k // side) * 1.2
        body = scene.spawn("humanoid", name=f"r{k}", position=(x, float(rng.uniform(0.5, 2.0)), z),
                           facing=float(rng.uniform(0, 360)))  # fmt: skip
        body.set_node_velocity("head", tuple(rng.normal(0.0, 1.0, 3)))
    return scene


def approach_crowd(count: int) -> Scene:
    """``count`` characters spawned as a user would, each given ``approach`` to another one.

    They stand on a square grid 2 m apart (the crowd's density), facing random ways; each
    approaches a random other character (a fixed seed), so they cross and steer round
    each other for the whole run instead of arriving at once.
    """
    scene = Scene.load("empty")
    side = math.ceil(math.sqrt(count))
    rng = np.random.default_rng(2)
    people = []
    for k in range(count):
        where = ((k % side) * 2.0, 0.0, (k // side) * 2.0)
        facing = float(rng.uniform(0, 360))
        people.append(scene.spawn("humanoid", name=f"c{k}", position=where, facing=facing, character=True))
    if count > 1:
        for k, person in enumerate(people):
            person.approach(people[(k + int(rng.integers(1, count))) % count].name)
    return scene
