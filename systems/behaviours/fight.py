"""fight: now and then a child picks a fight with its rival (SPEC 5).

For each character with a :class:`Feisty`: when the rival is
within ``reach``, a fight starts at random (``temper`` per second, from the scene's
seeded RNG) as a grapple goal; at most one fight every ``COOLDOWN`` seconds, and none
while the rival is on its way to a hug or in one. The one attacked squares up to the
fighter (:class:`Defend`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, goal_targets, register
from twig_ecs.components import Character
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext


@dataclass(slots=True)
class Feisty:
    """Picks a fight with a rival now and then, when it is near."""

    rival: str = ""
    temper: float = 0.06  # chance per second of starting a fight when within reach
    reach: float = 2.5  # m
    fights: int = 0


@dataclass(slots=True)
class LastFight:
    """When a feisty character last started a fight (systems/behaviours/fight.py: one per cooldown)."""

    at: float  # s (scene time)


COOLDOWN = 25.0  # s between fights
FIGHT_TIME = 3.0  # s of grappling
DEFEND = 0.9  # activation of squaring up to a fighter: above play, rides and goals, below pain
SQUARE_UP = 2.0  # m (ground): a fighter this near is faced
TURN_PACE = 0.25  # m/s (at 1.75 m tall) of the steps round to face it
FACED = 0.8  # cosine: facing it this squarely is facing it


@register
class Fight(Behavior):
    """Starts grapples with a rival, at random, now and then."""

    name = "fight"
    component = Feisty

    def run(self, ctx: StepContext) -> None:
        """Maybe start fights (as grapple goals); this behaviour never acts itself."""
        dt = ctx.dt
        scene = self.scene
        for entity, (_, feisty) in ctx.world.get_components(Character, Feisty):
            last = ctx.world.try_component(entity, LastFight)
            cooling = last is not None and scene.time - last.at < COOLDOWN
            if not scene.has_entity(feisty.rival) or cooling:
                continue
            me = scene.character_handle(entity)
            if me.goals or not me.autonomous:
                continue
            rival = scene.entity(feisty.rival)
            if ground_distance(me.position, rival.position) > feisty.reach:
                continue
            if any(g.behavior == "hug" for g in getattr(rival, "goals", ())):
                continue  # not while it runs to (or hugs) its grown-up
            if scene.rng.random() < feisty.temper * dt:
                ctx.world.add_component(entity, LastFight(scene.time))
                feisty.fights += 1
                me.grapple(feisty.rival, duration=FIGHT_TIME)


def attackers_of(scene) -> dict[int, int]:
    """Who is fighting whom right now: {target entity: fighter entity} (grapple goals)."""
    return {target: fighter for target, (fighter, _) in goal_targets(scene, "grapple").items()}


@register
class Defend(Behavior):
    """Square up to someone who comes to fight: face it, arms up (not commanded).

    Every autonomous character someone is coming at with a grapple goal, within
    ``SQUARE_UP`` metres, stops what it was doing (its activation beats play, rides and
    goals, not pain: a blow that hurts makes it stagger back and turn away, see
    withdraw), turns to the fighter and holds its arms up in guard.
    """

    name = "defend"
    batch = True

    def setup(self) -> None:
        """Who is attacked by whom this step (looked up once per step)."""
        self.attacked_by: dict[int, int] = {}

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters someone is fighting."""
        self.attacked_by = attackers_of(self.scene)
        return [(e, self.world.component_for_entity(e, Mind)) for e in self.attacked_by
                if self.world.entity_exists(e) and self.world.has_component(e, Mind)]  # fmt: skip

    def propose_crowd(self, crowd) -> np.ndarray:
        """:meth:`activation` of every one at once (systems/behaviours/brawl.py)."""
        from twig_ecs.systems.behaviours.brawl import defend_activations  # (it reads this module's figures)

        return defend_activations(self, self.attacked_by, crowd.entities)

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """:meth:`act` for every defender at once, over arrays (systems/behaviours/brawl.py);
        a character at a time where one would be refused."""
        from twig_ecs.systems.behaviours.brawl import act_defences  # (it reads this module's figures)

        if not act_defences(self, self.attacked_by, rows, entities):
            for entity in entities:
                mind = self.world.component_for_entity(entity, Mind)
                self.act(self.scene.character_handle(entity), mind, None, dt)

    def activation(self, character, mind: Mind, goal) -> float:
        """High while the fighter is near (one character: the per-character form of
        :meth:`propose_crowd`)."""
        fighter = self.attacked_by.get(character.entity)
        if fighter is None:
            return 0.0
        other = self.scene.character_handle(fighter)
        return DEFEND if ground_distance(character.position, other.position) < SQUARE_UP else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Face the fighter, guard up; a step round to face it when turned away."""
        other = self.scene.character_handle(self.attacked_by[character.entity])
        character.look_at(other.name, node="head")
        character.pose("grapple")
        to = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
        to /= max(float(np.linalg.norm(to)), 1e-9)
        if float(character.facing @ to) < FACED:
            character.walk(tuple(to * TURN_PACE * character.scale))  # slow steps round to face it
        else:
            character.stop()

    def stop(self, character, goal) -> None:
        """Guard down."""
        character.pose("hang")
        character.stop()
        character.look_at(None)
