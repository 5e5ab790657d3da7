"""fight: now and then a child picks a fight with its rival (SPEC 5).

For each character with a :class:`~twig_ecs.components.Feisty`: when the rival is
within ``reach``, a fight starts at random (``temper`` per second, from the scene's
seeded RNG) as a grapple goal; at most one fight every ``COOLDOWN`` seconds.
"""

from __future__ import annotations

import esper

from twig_ecs.behavior import Behavior, register
from twig_ecs.components import Character, Feisty
from twig_ecs.steering import ground_distance

COOLDOWN = 25.0  # s between fights
FIGHT_TIME = 3.0  # s of grappling


@register
class Fight(Behavior):
    """Starts grapples with a rival, at random, now and then."""

    name = "fight"
    component = Feisty

    def setup(self) -> None:
        """When each character last fought."""
        self.last: dict[int, float] = {}

    def process(self, dt: float) -> None:
        """Maybe start fights (as grapple goals); this behaviour never acts itself."""
        scene = self.scene
        for entity, (_, feisty) in esper.get_components(Character, Feisty):
            if feisty.rival not in scene.entity_names or scene.time - self.last.get(entity, -1e9) < COOLDOWN:
                continue
            me = scene.character_handle(entity)
            if me.goals or not me.autonomous:
                continue
            rival = scene.entity(feisty.rival)
            if ground_distance(me.position, rival.position) > feisty.reach:
                continue
            if scene.rng.random() < feisty.temper * dt:
                self.last[entity] = scene.time
                feisty.fights += 1
                me.grapple(feisty.rival, duration=FIGHT_TIME)
