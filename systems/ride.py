"""ride: a child goes to the merry-go-round now and then and pushes it round (SPEC 5).

For each character with a :class:`~twig_ecs.components.Rider`: on a whim (``whim``
per second) it walks to the merry-go-round's rim, puts its hands on the nearest
handle and shoves it round (a push of ``push`` newtons along the rim) for
``PUSH_TIME`` seconds, standing at the rim.
"""

from __future__ import annotations

import esper
import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Character, Rider
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.systems.approach import obstacles_near

PUSH_TIME = 3.0  # s of pushing
WANT = 0.65  # activation while it wants a spin: above play
GIVE_UP = 12.0  # s to get there


@register
class Ride(Behavior):
    """Spin the merry-go-round."""

    name = "ride"
    component = Rider

    def setup(self) -> None:
        """Per child: since when it wants a spin, and since when it pushes."""
        self.since: dict[int, float] = {}
        self.pushing: dict[int, float] = {}

    def process(self, dt: float) -> None:
        """Maybe get the urge; then propose."""
        scene = self.scene
        for entity, (_, rider) in esper.get_components(Character, Rider):
            if entity not in self.since and rider.ride in scene.entity_names:
                if scene.rng.random() < rider.whim * dt:
                    self.since[entity] = scene.time
        super().process(dt)

    def activation(self, character, mind: Mind, goal) -> float:
        """High while the urge lasts."""
        return WANT if character.entity in self.since else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Go to the rim, then push the nearest handle round."""
        rider = self.settings(character)
        ride = self.scene.entity(rider.ride)
        now = self.scene.time
        names = ride.node_names
        pos = ride.node_positions
        centre = ride.node("hub") if "hub" in names else pos.mean(axis=0)
        handles = [k for k, n in enumerate(names) if n.startswith("handle")] or list(range(len(names)))
        nearest = min(handles, key=lambda k: ground_distance(pos[k], character.position))
        handle = pos[nearest]
        out = (handle - centre) * np.array([1.0, 0.0, 1.0])
        radius = float(np.linalg.norm(out))
        out /= max(radius, 1e-9)
        spot = centre + out * (radius + 0.9)  # just outside the rim by the handle
        character.look_at(rider.ride)
        start = self.pushing.get(character.entity)
        if start is None:
            if ground_distance(character.position, spot) < 0.5:
                self.pushing[character.entity] = now
                rider.spins += 1
            elif now - self.since[character.entity] > GIVE_UP:
                self._done(character)
            else:
                obstacles = obstacles_near(character, set(), 1.2)
                walk = approach_velocity(character.position, spot, obstacles, SteeringParams(speed=1.6))
                character.walk(walk)
            return
        tangent = np.cross([0.0, 1.0, 0.0], out)  # round the axle
        character.reach(tuple(handle), hand="both")
        ride.apply_force(names[nearest], tuple(rider.push * tangent))
        character.stop()  # stands at the rim and shoves; the next handle comes round
        if now - start > PUSH_TIME:
            self._done(character)

    def _done(self, character) -> None:
        self.since.pop(character.entity, None)
        self.pushing.pop(character.entity, None)

    def stop(self, character, goal) -> None:
        """Let go of the bar, stop."""
        character.stop()
        character.pose("hang")
