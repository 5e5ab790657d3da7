"""fight: now and then a child picks a fight with its rival (SPEC 5).

For each character with a :class:`Feisty`: when the rival is
within ``reach``, a fight starts at random (``temper`` per second, from the scene's
seeded RNG) as a grapple goal; at most one fight every ``COOLDOWN`` seconds, and none
while the rival is on its way to a hug or in one. The one attacked squares up to the
fighter (:class:`Defend`): it faces it with its guard up, raises a forearm at a fist
coming at its head, staggers back when a shove or a blow lands, and answers a shove with
a shove.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, goal_targets, register
from twig_ecs.components import Character
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.systems.behaviours.footwork import pivot
from twig_ecs.systems.behaviours.grapple import (
    OUT_OF_REACH,
    STAGGER,
    STRIKE,
    Striking,
    announce,
    end_strike,
    fighting_gap,
    knocked_back,
    load,
    shoved_by,
    stagger,
    strike,
)


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


@dataclass(slots=True)
class Guard:
    """A defender's side of the exchanges (systems/behaviours/fight.py, ``defend``)."""

    stagger_until: float = -1.0  # s (scene time): shoved, it staggers back until then
    counter_at: float = -1.0  # s: its shove back starts then (a load, then the strike); < 0: none due
    gap: float = 0.0  # m: its fighting gap to the fighter (grapple.fighting_gap)


COOLDOWN = 25.0  # s between fights
FIGHT_TIME = 3.0  # s of grappling
DEFEND = 0.9  # activation of squaring up to a fighter: above play, rides and goals, below pain
SQUARE_UP = 2.0  # m (ground): a fighter this near is faced
TURN_PACE = 0.25  # m/s (at 1.75 m tall) of the steps round to face it
FACED = 0.8  # cosine: facing it this squarely is facing it
COUNTER_AFTER = 0.1  # s after its stagger that a defender starts to shove back
COUNTER_LOAD = 0.2  # s it draws its hands back for that shove (quicker than the fighter's)
BLOCK_SPEED = 2.0  # m/s: a fist coming at it this fast...
BLOCK_NEAR = 0.7  # m (at 1.75 m tall): ... and this near its neck is blocked with a forearm


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

    def setup(self) -> None:
        """Who is attacked by whom this step (looked up once per step)."""
        self.attacked_by: dict[int, int] = {}

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters someone is fighting."""
        self.attacked_by = attackers_of(self.scene)
        return [(e, self.world.component_for_entity(e, Mind)) for e in self.attacked_by
                if self.world.entity_exists(e) and self.world.has_component(e, Mind)]  # fmt: skip

    def activation(self, character, mind: Mind, goal) -> float:
        """High while the fighter is near."""
        fighter = self.attacked_by.get(character.entity)
        if fighter is None:
            return 0.0
        other = self.scene.character_handle(fighter)
        return DEFEND if ground_distance(character.position, other.position) < SQUARE_UP else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Face the fighter, guard up; stagger back when struck, then answer a shove with a
        shove; block a fist coming at the head; turn to face it (on the spot within reach)."""
        other = self.scene.character_handle(self.attacked_by[character.entity])
        now = self.scene.time
        guard = self.world.try_component(character.entity, Guard)
        if guard is None:
            guard = Guard(gap=fighting_gap(character, other))
            self.world.add_component(character.entity, guard)
        character.look_at(other.name, node="head")
        if now >= guard.stagger_until and shoved_by(self.scene, character.entity, other.entity):
            knocked_back(character, other)
            guard.stagger_until = now + STAGGER
            striking = self.world.try_component(other.entity, Striking)
            if striking is not None and striking.kind == "shove":
                # a shove is answered with a shove (a fist is only blocked): its turn next, the
                # fighter waits, guard up, for this shove back to be over
                guard.counter_at = guard.stagger_until + COUNTER_AFTER
                announce(character, guard.counter_at + COUNTER_LOAD, "shove")
        if now < guard.stagger_until:
            stagger(character, other)
            return
        near = ground_distance(character.position, other.position) < OUT_OF_REACH * guard.gap
        if 0.0 <= guard.counter_at <= now and near:
            # the shove back: hands drawn back, then thrown through the fighter's chest
            if now < guard.counter_at + COUNTER_LOAD:
                load(character, other)
                character.stop()
                return
            if now < guard.counter_at + COUNTER_LOAD + STRIKE:
                strike(character, other, "shove", step_in=False)
                return
        if guard.counter_at >= 0.0 and (now >= guard.counter_at + COUNTER_LOAD + STRIKE or not near):
            guard.counter_at = -1.0
        # its guard: fists up before its chest, not held out at arm's length (the fighter's
        # hands, winding up, met a guard held out and folded its elbows)
        load(character, other)
        block(character, other)
        to = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
        to /= max(float(np.linalg.norm(to)), 1e-9)
        within_reach = ground_distance(character.position, other.position) <= guard.gap
        if float(character.facing @ to) < FACED and not within_reach:
            character.walk(tuple(to * TURN_PACE * character.scale))  # slow steps round to face it
        else:
            # within reach it turns on the spot (steps round towards it walked it into the fighter)
            character.stop()
            pivot(character, to)

    def stop(self, character, goal) -> None:
        """Guard down; the exchange is forgotten."""
        end_strike(self.scene, character.entity)
        if self.world.has_component(character.entity, Guard):
            self.world.remove_component(character.entity, Guard)
        character.pose("hang")
        character.stop()
        character.look_at(None)


def block(character, fighter) -> None:
    """Raise a forearm across the way of a fist coming at the head: the hand on that side goes
    to a point between the fist and the neck (a blow at the body lands)."""
    nodes, dt = character.scene.state.nodes, character.scene.dt
    neck = character.node("neck")
    for side in ("l_", "r_"):
        row = fighter.node_row(side + "hand")
        fist = nodes.pos[row]
        velocity = (nodes.pos[row] - nodes.prev[row]) / dt
        to_me = neck - fist
        gap = float(np.linalg.norm(to_me))
        at_head = fist[1] > neck[1] - 0.1 * character.scale
        if at_head and gap < BLOCK_NEAR * character.scale and float(velocity @ to_me) > BLOCK_SPEED * gap:
            # the fighter's left fist comes at its right side, as it faces it
            hand = "right" if side == "l_" else "left"
            character.reach(tuple(neck - 0.55 * to_me), hand=hand)
