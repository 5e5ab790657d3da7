"""The scenes ``twig bench`` times: the schoolyard, crowds, goal-driven crowds (approach,
hugging pairs, a brawl), a plain-Python plug-in behaviour and ragdoll piles."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior
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


def _grid_of_pairs(count: int, seed: int) -> tuple[Scene, list]:
    """``count`` characters (rounded down to even) as pairs facing each other 1.6 m apart,
    the pairs on a square grid 4 m apart; returns the scene and the pairs."""
    scene = Scene.load("empty")
    pairs = count // 2
    side = max(1, math.ceil(math.sqrt(pairs)))
    rng = np.random.default_rng(seed)
    out = []
    for k in range(pairs):
        x, z = (k % side) * 4.0, (k // side) * 4.0
        turn = float(rng.uniform(0, 360))
        dx, dz = 0.8 * math.sin(math.radians(turn)), 0.8 * math.cos(math.radians(turn))
        a = scene.spawn("humanoid", name=f"a{k}", position=(x - dx, 0.0, z - dz), facing=turn, character=True)
        b = scene.spawn("humanoid", name=f"b{k}", position=(x + dx, 0.0, z + dz), facing=turn + 180,
                        character=True)  # fmt: skip
        out.append((a, b))
    return scene, out


def hugging_pairs(count: int) -> Scene:
    """``count`` characters in pairs, one of each hugging the other (a long hug: the whole
    run is walk-up, arms round and holding, the partner answering with its embrace)."""
    scene, pairs = _grid_of_pairs(count, seed=3)
    for a, b in pairs:
        a.hug(b.name, duration=600.0)
    return scene


def brawl(count: int) -> Scene:
    """``count`` characters in pairs, one of each grappling the other (a long fight; the
    partner defends)."""
    scene, pairs = _grid_of_pairs(count, seed=4)
    for a, b in pairs:
        a.grapple(b.name, duration=600.0)
    return scene


@dataclass
class Strolling:
    """A stroller's circle: centre (x, z) and radius (m) - the plug-in behaviour's component."""

    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 1.5


class Stroll(Behavior):
    """A plug-in behaviour written in plain Python, as a user would (docs/authoring-behaviours.md):
    walk round a circle through the handle API, looking where it goes. ``twig bench``'s
    ``plugin`` case times its cost per character."""

    name = "stroll"
    component = Strolling

    def activation(self, character, mind, goal) -> float:
        """Always a little keen."""
        return 0.5

    def act(self, character, mind, goal, dt: float) -> None:
        """Walk along the circle's tangent, pulled back onto it."""
        circle = self.settings(character)
        here = character.position
        off = np.array([here[0] - circle.centre[0], 0.0, here[2] - circle.centre[1]])
        r = float(np.linalg.norm(off)) or 1e-9
        tangent = np.array([-off[2], 0.0, off[0]]) / r
        character.walk(0.9 * tangent - 0.5 * (r - circle.radius) * off / r)
        character.look_at(here + 2.0 * tangent)


class StrollCrowd(Behavior):
    """:class:`Stroll` written over arrays (docs/authoring-behaviours.md, "A behaviour over
    arrays"): the same walk for every stroller in a few numpy calls a step, not a Python call
    each. ``twig bench``'s ``plugin_batch`` case times it."""

    name = "stroll"
    component = Strolling

    def propose_crowd(self, crowd) -> np.ndarray:
        """Always a little keen, every one."""
        return np.full(len(crowd), 0.5)

    def act_crowd(self, crowd) -> None:
        """Walk along each circle's tangent, pulled back onto it."""
        here = crowd.positions
        centre, radius = crowd.settings("centre"), crowd.settings("radius")
        off = np.stack([here[:, 0] - centre[:, 0], np.zeros(len(here)), here[:, 2] - centre[:, 1]], axis=1)
        r = np.linalg.norm(off, axis=1)
        r[r == 0.0] = 1e-9
        tangent = np.stack([-off[:, 2], np.zeros(len(here)), off[:, 0]], axis=1) / r[:, None]
        crowd.walk(0.9 * tangent - (0.5 * (r - radius))[:, None] * off / r[:, None])  # (Stroll's order)
        crowd.look_at(here + 2.0 * tangent)


def plugin_strollers(count: int, batch: bool = False) -> Scene:
    """``count`` characters, each strolling round its own circle under :class:`Stroll` (or,
    with ``batch``, :class:`StrollCrowd`)."""
    scene = Scene.load("empty")
    scene.add_system(StrollCrowd() if batch else Stroll())
    side = math.ceil(math.sqrt(count))
    for k in range(count):
        x, z = (k % side) * 4.0, (k // side) * 4.0
        person = scene.spawn("humanoid", name=f"s{k}", position=(x + 1.5, 0.0, z), character=True)
        scene.world.add_component(person.entity, Strolling(centre=(x, z)))
    return scene


def plugin_batch_strollers(count: int) -> Scene:
    """:func:`plugin_strollers` under the batch plug-in :class:`StrollCrowd`."""
    return plugin_strollers(count, batch=True)
