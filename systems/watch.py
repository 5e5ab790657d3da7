"""watch: a caregiver keeps its eyes on its charges, the furthest away first (SPEC 5)."""

from __future__ import annotations

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Watchful
from twig_ecs.steering import ground_distance

WATCH = 0.3  # activation: above idle


@register
class Watch(Behavior):
    """Stand and watch the charge that is furthest away."""

    name = "watch"
    component = Watchful

    def activation(self, character, mind: Mind, goal) -> float:
        """A steady low urge whenever a charge exists."""
        names = self.scene.entity_names
        return WATCH if any(c in names for c in self.settings(character).charges) else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Look at the furthest charge; stay put."""
        names = self.scene.entity_names
        charges = [c for c in self.settings(character).charges if c in names]
        far = max(charges, key=lambda c: ground_distance(self.scene.entity(c).position, character.position))
        character.stop()
        character.look_at(far, node="head")
