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
drawing targets); writes the character table's ``walk``. Each wanderer's target and stall
clock are a row of the behaviour's table (:class:`~twig_ecs.rowtable.RowTable`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Character
from twig_ecs.kernelmath import PELVIS
from twig_ecs.rowtable import Column, RowTable
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
        """Propose ``activation`` for every autonomous wandering character (as lists: selected
        over arrays)."""
        items = ctx.world.get_components(Character, Mind, Wander)
        autonomous = [mind.autonomous for _, (_, mind, _) in items]
        kept = self.scratch.get("wanderers")  # the wanderers' entities and minds, kept while the same
        if kept is None or kept[0] is not items or kept[1] != autonomous:
            picked = [(e, mind, w) for (e, (_, mind, w)), ok in zip(items, autonomous, strict=True) if ok]
            entities, minds, wanders = ([p[k] for p in picked] for k in range(3))
            kept = self.scratch["wanderers"] = (items, autonomous, entities, minds, wanders)
        _, _, entities, minds, wanders = kept
        if not entities:
            return
        values = np.array([wander.activation for wander in wanders], dtype=np.float64)
        if not np.isfinite(values).all():  # (an activation of no size: into the dicts, as it was)
            for mind, value in zip(minds, values.tolist(), strict=True):
                mind.activations[self.name] = value
            return
        self.propose_all(ctx.frame, entities, minds, values)

    def setup(self) -> None:
        """Its table of wanderers (state: a snapshot keeps it)."""
        self.targets = RowTable(**_TARGET_ROW)

    def act_batch(self, rows: list[int], entities: list[int], dt: float) -> None:
        """Steer all winners in one call of the steering kernel; draw new targets for those
        that arrived, stalled or have none yet."""
        scene = self.scene
        ch = scene.state.characters
        n = len(rows)
        table = self.targets
        table.sync(entities, "by entity", _no_target)  # a row per winner, its target kept while it wins
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
        # the target (x, z) and pace of each from the table; the kernel keeps its stall clock there
        w = self.scratch["walkers"]._replace(best=table["best"], best_at=table["best_at"])
        goal = table["goal"]
        w.point[:, 0], w.point[:, 2] = goal[:, 0], goal[:, 1]
        w.speed[:] = table["speed"]
        w.arrive[:] = np.where(w.speed > 0.0, self.scratch["arrive"], np.inf)  # no target yet: draw one
        # round everyone by their nearest node (no walls or discs, nothing held left out)
        steer_rows(around(scene, shapes=False), w, _GAINS, ch.walk, ch.mode, scene.time, dt)
        for k in np.flatnonzero((w.status == ARRIVED) | (w.status == STUCK)):
            self._draw_target(entities[k], k)

    def _draw_target(self, entity: int, k: int) -> None:
        """A new random target in the character's square for row ``k`` of the table (a rare,
        per-character event)."""
        wander = self.world.component_for_entity(entity, Wander)
        table = self.targets
        x, z = self.scene.rng.uniform(-wander.radius, wander.radius, 2)
        table["goal"][k] = (wander.centre[0] + x, wander.centre[1] + z)
        table["speed"][k] = wander.speed
        table["best"][k] = np.inf
        table["best_at"][k] = self.scene.time
        wander.targets += 1

    def stop(self, character, goal) -> None:
        """Stand still; the next wander starts with a fresh target."""
        character.stop()
        self.targets.forget(character.entity)


#: A wanderer's row in the behaviour's table: its target and how it is getting on. State (a
#: snapshot keeps it); a row is made when a character starts wandering and dropped when it stops.
_TARGET_ROW = {
    "goal": Column(np.float64, (2,), saved=True),  # (x, z) of its target
    "speed": Column(np.float64, saved=True),  # m/s; 0: no target yet (one is drawn)
    "best": Column(np.float64, saved=True),  # nearest it has been to the target (m) ...
    "best_at": Column(np.float64, saved=True),  # ... since when (s)
}


def _no_target(_: int, __: int) -> dict:
    """A new wanderer's row: no target yet."""
    return {"goal": (0.0, 0.0), "speed": 0.0, "best": np.inf, "best_at": 0.0}
