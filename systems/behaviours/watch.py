"""watch: a caregiver keeps its eyes on its charges, the furthest away first (SPEC 5)."""

from __future__ import annotations

from dataclasses import dataclass, field

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.character import CharacterHandle
from twig_ecs.steering import ground_distance


@dataclass(slots=True)
class Watchful:
    """A caregiver: keeps its eyes on its charges, the one furthest away first."""

    charges: list[str] = field(default_factory=list)


WATCH = 0.3  # activation: above idle


@register
class Watch(Behavior):
    """Stand and watch the charge that is furthest away."""

    name = "watch"
    component = Watchful

    def _charges(self, character) -> list:
        """Handles of the charges that exist and are characters (a name reused by a ball is no charge)."""
        scene = self.scene
        handles = [scene.entity(c) for c in self.settings(character).charges if scene.has_entity(c)]
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
        character.stop()
        character.look_at(far.name, node="head")
