"""The goal melee (issue 31): characters told to grapple, hug, carry and drag one another.

Loads ``content/scenes/melee.yaml`` and, whenever a character has no goal left, gives it
a new one through the public goal API (``grapple``, ``hug``, ``carry``, ``drag``) at
another character or a ragdoll, all chosen by the seed's own RNG (not the scene's, so
the scene's behaviours draw the same numbers whatever the driver does). Every step is
measured by :class:`twig_ecs.soak.Health`, as ``twig run --soak`` does.

Used by ``tests/test_melee_soak.py`` and ``benchmarks/melee_soak.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twig_ecs import Scene
from twig_ecs.errors import TwigError
from twig_ecs.soak import Health, SoakLimits, Violation

#: The goals the melee gives, each at any other character or doll.
GOALS = ("grapple", "hug", "carry", "drag")


@dataclass
class MeleeRun:
    """What a melee run did: the health figures, the first violation and the goals given."""

    seed: int
    frames: int
    figures: dict  # Health.figures(): the worst of each
    violation: Violation | None
    given: dict[str, int] = field(default_factory=dict)  # goal name (or "refused") -> how many
    ended: dict[str, int] = field(default_factory=dict)  # "carry.done", "hug.failed"... -> how many
    state_hash: str = ""


def give_goal(scene: Scene, name: str, rng: np.random.Generator, ended: dict[str, int]) -> str:
    """Give character ``name`` one random goal at another body; returns the goal's name."""
    me = scene.entity(name)
    others = [n for n in scene.entity_names if n != name and n.startswith(("adult", "child", "doll"))]
    kind = GOALS[int(rng.integers(len(GOALS)))]
    target = others[int(rng.integers(len(others)))]
    hand = ("left", "right")[int(rng.integers(2))]

    def count_end(goal) -> None:
        key = f"{goal.behavior}.{goal.status}"
        ended[key] = ended.get(key, 0) + 1

    if kind == "grapple":
        me.grapple(target, duration=float(rng.uniform(1.0, 6.0)), on_end=count_end)
    elif kind == "hug":
        me.hug(target, duration=float(rng.uniform(1.0, 5.0)), on_end=count_end)
    elif kind == "carry":
        to = others[int(rng.integers(len(others)))] if rng.random() < 0.5 else None
        if to == target:
            to = None
        me.carry(target, to=to, hand=hand, on_end=count_end)
    else:
        speed = float(rng.uniform(0.5, min(2.0, me.character.max_speed)))
        me.drag(target, distance=float(rng.uniform(1.0, 6.0)), hand=hand, speed=speed, on_end=count_end)
    return kind


def run_melee(seed: int, seconds: float, limits: SoakLimits | None = None, count: int = 16,
              dolls: int = 4, scene: Scene | None = None, every: int = 30) -> MeleeRun:  # fmt: skip
    """Run the melee for ``seconds``; stop at the first limit crossed (``limits``) or NaN.

    Goals are topped up every ``every`` steps. ``scene``: go on with this one (a restored
    snapshot) instead of loading a new melee; its driver RNG then starts afresh.
    """
    own = scene is None
    if scene is None:
        scene = Scene.load("melee", seed=seed, count=count, dolls=dolls)
    rng = np.random.default_rng([31, seed])
    characters = [n for n in scene.entity_names if n.startswith(("adult", "child"))]
    health = Health(scene, limits or SoakLimits())
    given: dict[str, int] = {}
    ended: dict[str, int] = {}
    try:
        frames = round(seconds / scene.dt)
        for f in range(frames):
            if f % every == 0:
                for name in characters:
                    if not scene.entity(name).goals:
                        try:
                            kind = give_goal(scene, name, rng, ended)
                        except TwigError:
                            kind = "refused"
                        given[kind] = given.get(kind, 0) + 1
            scene.step()
            health.update()
            if health.nan or health.violation is not None:
                break
        figures, violation = health.figures(), health.violation
        return MeleeRun(seed, scene.frame, figures, violation, given, ended, scene.state_hash())
    finally:
        if own:
            scene.close()
