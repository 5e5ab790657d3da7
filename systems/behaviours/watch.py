"""watch: a caregiver keeps its eyes on its charges, the furthest away first (SPEC 5).

It also keeps its place: where it stood when it first watched is its post, and once
something has moved it more than ``OFF_POST`` from there (the steps back after each hug,
a bump) it walks back to it slowly, still watching, when no charge is within ``CLEAR``.
Without that, a parent hugged a dozen times in five minutes, stepping back after each
hug, wandered 2-3 m off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.character import CharacterHandle
from twig_ecs.steering import ground_distance


@dataclass(slots=True)
class Watchful:
    """A caregiver: keeps its eyes on its charges, the one furthest away first."""

    charges: list[str] = field(default_factory=list)
    post: list[float] | None = None  # [x, z] (m): where it stood when it first watched
    returning: bool = False  # on its way back to the post


WATCH = 0.3  # activation: above idle
OFF_POST = 0.3  # m (at 1.75 m tall): moved further than this from its post, it goes back
HOME = 0.08  # m (at 1.75 m tall): this near the post it is back
RETURN_PACE = 0.5  # m/s (at 1.75 m tall, by the root of the size): a few unhurried steps
CLEAR = 1.2  # m (at 1.75 m tall): it does not walk back into a charge standing this near


@register
class Watch(Behavior):
    """Stand and watch the charge that is furthest away."""

    name = "watch"
    component = Watchful

    def _charges(self, character) -> list:
        """Handles of the charges that exist and are characters (a name reused by a ball is no charge)."""
        scene = self.scene
        names = scene.entity_names
        handles = [scene.entity(c) for c in self.settings(character).charges if c in names]
        return [h for h in handles if isinstance(h, CharacterHandle)]

    def activation(self, character, mind: Mind, goal) -> float:
        """A steady low urge whenever a charge exists."""
        return WATCH if self._charges(character) else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Look at the furthest charge; stay put."""
        charges = self._charges(character)
        if not charges:
            return
        far = max(charges, key=lambda h: ground_distance(h.position, character.position))
        character.look_at(far.name, node="head")
        watchful = self.settings(character)
        here = character.position
        if watchful.post is None:
            watchful.post = [float(here[0]), float(here[2])]
        off = np.array([watchful.post[0] - here[0], 0.0, watchful.post[1] - here[2]])
        gap = math.hypot(off[0], off[2])
        scale = character.scale
        near = min(ground_distance(h.position, here) for h in charges)
        if gap > OFF_POST * scale:
            watchful.returning = True
        if gap < HOME * scale or near < CLEAR * scale:
            watchful.returning = False
        if watchful.returning:
            # slowing over the last steps (v = sqrt(2 a d)) so it stops on the spot
            pace = min(RETURN_PACE * math.sqrt(scale), math.sqrt(2.0 * gap))
            character.walk(tuple(off / gap * pace))
        else:
            character.stop()
