"""wander: roam a square, one random target after another, round everyone else (crowds).

For each character with a :class:`Wander`: its activation is the
component's ``activation`` (autonomous characters only). Winning, it walks to its
target with the approach field of SPEC 4 (:func:`~twig_ecs.kernelmath.approach_field`,
the same compiled function ``approach`` steers with), the obstacles being the nearest
node of every other body that stands higher than a step, within the cut-off. On
arrival, or when it makes no headway for ``patience`` s, it draws a new target.

A *batch* behaviour: one call of the steering kernel
(:func:`~twig_ecs.systems.control.steer.steer_rows`, approach's too) steers every wandering
character (the spatial index's ground grid finds the neighbours), so a crowd of a thousand
costs one call, not a thousand. Reads node positions and the Wander components (only when
drawing targets); writes the character table's ``walk`` and ``steer_*`` columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Character
from twig_ecs.kernelmath import PELVIS
from twig_ecs.step import StepContext
from twig_ecs.systems.control.steer import ARRIVED, STUCK, around, gains, steer_rows, walkers

#: The approach field's gains (wander never squeezes).
_GAINS = gains()


@dataclass(slots=True)
class Wander:
    """Roams: picks a random point in a square and walks there round others, then another.

    Targets are drawn from the square of half-size ``radius`` (m) round ``centre``
    ([x, z]); a target counts as reached within ``arrive`` m, and one not got 10 cm
    closer to in ``patience`` s is given up for a new one.
    """

    radius: float = 10.0
    centre: list[float] = field(default_factory=lambda: [0.0, 0.0])
    speed: float = 1.2  # m/s
    arrive: float = 0.6  # m
    patience: float = 4.0  # s
    activation: float = 0.3  # above idle, below commanded goals
    targets: int = 0  # how many targets it has picked


@register
class WanderBehavior(Behavior):
    """Roam from random target to random target, avoiding the others."""

    name = "wander"
    component = Wander
    batch = True

    def run(self, ctx: StepContext) -> None:
        """Propose ``activation`` for every autonomous wandering character."""
        for _, (_, mind, wander) in ctx.world.get_components(Character, Mind, Wander):
            if mind.autonomous:
                mind.activations["wander"] = wander.activation

    def act_batch(self, rows: list[int], entities: list[int], dt: float) -> None:
        """Steer all winners in one call of the steering kernel; draw new targets for those
        that arrived, stalled or have none yet."""
        scene = self.scene
        ch = scene.state.characters
        n = len(rows)
        # per-character parameters: kept while the winners stay the same (they rarely change)
        key = (tuple(entities), scene.state.version, id(scene.state))
        if self.scratch.get("key") != key:
            comps = [self.world.component_for_entity(e, Wander) for e in entities]
            w = self.scratch["walkers"] = walkers(n)
            w.crows[:] = rows
            w.pelvis[:], w.me[:] = ch.nodes[w.crows, PELVIS], ch.body[w.crows]
            w.stall[:] = [c.patience for c in comps]
            self.scratch["arrive"] = np.array([w.arrive for w in comps], dtype=np.float64)
            self.scratch["key"] = key
        w = self.scratch["walkers"]
        crows = w.crows
        # the target (x, z) and pace of each, the stall clock: the character table's steer_* columns
        w.point[:, 0], w.point[:, 2] = ch.steer_goal[crows, 0], ch.steer_goal[crows, 1]
        w.speed[:] = ch.steer_speed[crows]
        w.arrive[:] = np.where(w.speed > 0.0, self.scratch["arrive"], np.inf)  # no target yet: draw one
        w.best[:], w.best_at[:] = ch.steer_best[crows], ch.steer_best_at[crows]
        # round everyone by their nearest node (no walls or discs, nothing held left out)
        steer_rows(around(scene, shapes=False), w, _GAINS, ch.walk, ch.mode, scene.time, dt)
        ch.steer_best[crows], ch.steer_best_at[crows] = w.best, w.best_at
        for k in np.flatnonzero((w.status == ARRIVED) | (w.status == STUCK)):
            self._draw_target(entities[k], rows[k])

    def _draw_target(self, entity: int, row: int) -> None:
        """A new random target in the character's square (a rare, per-character event)."""
        wander = self.world.component_for_entity(entity, Wander)
        ch = self.scene.state.characters
        x, z = self.scene.rng.uniform(-wander.radius, wander.radius, 2)
        ch.steer_goal[row] = (wander.centre[0] + x, wander.centre[1] + z)
        ch.steer_speed[row] = wander.speed
        ch.steer_best[row] = np.inf
        ch.steer_best_at[row] = self.scene.time
        wander.targets += 1

    def stop(self, character, goal) -> None:
        """Stand still; the next wander starts with a fresh target."""
        character.stop()
        self.scene.state.characters.steer_speed[character.character.index] = 0.0
