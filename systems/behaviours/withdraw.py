"""withdraw: the pain reflex - a fast, open-loop retreat from whatever hurt (SPEC 4).

Reads this step's ``pain`` events; when a character is hurt it staggers back from the
body that hurt it - for ``DURATION`` seconds it backs off at ``SPEED`` with its arms up
and its eyes on the source - then turns its back on it and walks away for ``TURN_AWAY``
seconds. Its activation beats any commanded goal, so it wins at once; afterwards the
interrupted goal carries on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Character
from twig_ecs.step import StepContext


@dataclass(slots=True)
class Withdrawing:
    """A pain withdrawal under way (systems/behaviours/withdraw.py): backing off, then walking away."""

    until: float  # s (scene time) the whole retreat ends
    stagger_until: float  # s the stagger back, facing the source, ends; it walks away after
    away: np.ndarray  # unit vector on the ground away from the source
    source: int  # entity of the body that hurt it


DURATION = 0.8  # s of retreat per blow
SPEED = 1.6  # m/s at 1.75 m tall; smaller bodies go slower (the root of their scale): their steps are shorter
TURN_AWAY = 1.2  # s of walking away afterwards, its back to the source
AWAY_PACE = 0.9  # m/s (at 1.75 m tall, by the root of scale like SPEED)
ACTIVATION = 1.3  # beats goals (0.8) by more than select_behavior's URGENT margin


@register
class Withdraw(Behavior):
    """Pain withdrawal: back away from the source of a painful blow."""

    name = "withdraw"
    reflex = True

    def run(self, ctx: StepContext) -> None:
        """Start retreats for this step's blows, then propose activations."""
        scene = self.scene
        for event in scene.events:
            if event.kind != "pain" or not ctx.world.has_component(event.body, Character):
                continue
            me = scene.character_handle(event.body)
            other = scene.name_of(event.source_body)
            there = scene.entity(other).position if other else me.position - me.facing
            away = (me.position - there) * np.array([1.0, 0.0, 1.0])
            norm = float(np.linalg.norm(away))
            away = away / norm if norm > 1e-6 else -me.facing
            now = scene.time
            # a new blow restarts the retreat (the component, if one is under way, is renewed)
            ctx.world.add_component(event.body, Withdrawing(now + DURATION + TURN_AWAY, now + DURATION, away,
                                                        event.source_body))  # fmt: skip
        super().run(ctx)

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters whose retreat is still running (not every character)."""
        now = self.scene.time
        world = self.world
        return [(e, world.component_for_entity(e, Mind)) for e, retreat in world.get_component(Withdrawing)
                if retreat.until > now and world.has_component(e, Mind)]  # fmt: skip

    def activation(self, character, mind: Mind, goal) -> float:
        """High while a retreat is running."""
        retreat = self.world.try_component(character.entity, Withdrawing)
        return ACTIVATION if retreat is not None and retreat.until > self.scene.time else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Back off, arms up, watching the source; then turn away and walk off."""
        retreat = self.world.component_for_entity(character.entity, Withdrawing)
        away = retreat.away
        if retreat.stagger_until > self.scene.time:
            character.walk(away * SPEED * character.scale**0.5)
            character.pose("grapple")
            source = self.scene.name_of(retreat.source)
            if source and source != character.name:
                character.look_at(source)
            return
        character.walk(away * AWAY_PACE * character.scale**0.5)  # facing where it goes
        character.pose("hang")
        character.look_at(None)

    def stop(self, character, goal) -> None:
        """Stand, arms down; the retreat, if over, is forgotten."""
        retreat = self.world.try_component(character.entity, Withdrawing)
        if retreat is not None and retreat.until <= self.scene.time:
            self.world.remove_component(character.entity, Withdrawing)
        character.stop()
        character.pose("hang")
        character.look_at(None)
