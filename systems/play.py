"""play: run after the toy and kick it about (SPEC 5).

For each character with a :class:`~twig_ecs.components.Playful`: its activation is its
joy, damped by its anxiety if it has an attachment. Winning, it runs at the toy round
obstacles and, once within a stride, kicks it: the toy gets a shove away from the
child (a ballistic velocity, SPEC 3's node control) and bounces off over the ground.
"""

from __future__ import annotations

import esper
import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Attachment, Playful
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.systems.approach import obstacles_near

KICK_RANGE = 0.55  # m (at 1.75 m tall) from pelvis to toy
KICK_SPEED = 2.5  # m/s given to the toy
KICK_EVERY = 1.2  # s between kicks


@register
class Play(Behavior):
    """Chase the toy and kick it."""

    name = "play"
    component = Playful

    def setup(self) -> None:
        """When each child last kicked."""
        self.last_kick: dict[int, float] = {}

    def activation(self, character, mind: Mind, goal) -> float:
        """Joy, less the anxiety of an attached child."""
        playful = self.settings(character)
        if playful.toy not in self.scene.entity_names:
            return 0.0
        attachment = esper.try_component(character.entity, Attachment)
        anxiety = attachment.anxiety if attachment is not None else 0.0
        return playful.joy * (1.0 - 0.5 * anxiety)

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Run at the toy; kick it when close."""
        playful = self.settings(character)
        toy = self.scene.entity(playful.toy)
        character.look_at(playful.toy)
        scale = character.scale
        where = toy.position
        if ground_distance(character.position, where) < KICK_RANGE * scale:
            now = self.scene.time
            if now - self.last_kick.get(character.entity, -1e9) > KICK_EVERY:
                self.last_kick[character.entity] = now
                away = (where - character.position) * np.array([1.0, 0.0, 1.0])
                away /= max(float(np.linalg.norm(away)), 1e-9)
                turn = self.scene.rng.normal(0.0, 0.5)  # kicks go roughly, not exactly, ahead
                c, s = np.cos(turn), np.sin(turn)
                kick = np.array([c * away[0] + s * away[2], 0.0, -s * away[0] + c * away[2]])
                toy.set_velocity(tuple(KICK_SPEED * kick + np.array([0.0, 1.0, 0.0])))
                playful.touches += 1
        params = SteeringParams(speed=playful.speed)
        obstacles = obstacles_near(character, {playful.toy}, params.cutoff)
        character.walk(approach_velocity(character.position, where, obstacles, params))

    def stop(self, character, goal) -> None:
        """Stop running."""
        character.stop()
