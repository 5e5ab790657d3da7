"""withdraw: the pain reflex - a fast, open-loop retreat from whatever hurt (SPEC 4).

Reads this step's ``pain`` events; when a character is hurt it staggers back from the
body that hurt it - for ``DURATION`` seconds it backs off at ``SPEED`` with its arms up
and its eyes on the source - then turns its back on it and walks away for ``TURN_AWAY``
seconds. Its activation beats any commanded goal, so it wins at once; afterwards the
interrupted goal carries on.

The retreat is in proportion to the masses (issue 34: "impacts move bodies in proportion to
their masses"): struck by a body lighter than itself - a child running into a grown-up, a
ball - it staggers back slower and for less time, both by the share ``source mass / own
mass`` (at most 1), so that distance goes by its square; it walks away slower by the share
and for less time by its square (a grown-up does not turn its back on a child that bumped
into it and walk off: it is soon back at what it was doing). A 65 kg parent
knocked by a 30 kg child (7-11 J, past its pain threshold) went back 1.9-2.1 m; now it flinches
a few tenths of a metre and stands its ground. A blow from a body as heavy or heavier, or from
something fixed in place, makes the whole retreat as before.

Every retreating character of a step is proposed for and moved at once, over arrays
(:func:`act_withdrawals`), with :meth:`Withdraw.act`'s arithmetic
(tests/test_brawl_batch.py compares the two).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Body, Character
from twig_ecs.kernelmath import GAZE_AHEAD, GAZE_NODE, GRAPPLE, HANG, SIT, SPINE
from twig_ecs.step import StepContext
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.arrays import roots, walkable


@dataclass(slots=True)
class Withdrawing:
    """A pain withdrawal under way (systems/behaviours/withdraw.py): backing off, then walking away."""

    until: float  # s (scene time) the whole retreat ends
    stagger_until: float  # s the stagger back, facing the source, ends; it walks away after
    away: np.ndarray  # unit vector on the ground away from the source
    source: int  # entity of the body that hurt it
    share: float = 1.0  # the source's mass over its own (at most 1): speeds and times are scaled by it


DURATION = 0.8  # s of retreat per blow
SPEED = 1.6  # m/s at 1.75 m tall; smaller bodies go slower (the root of their scale): their steps are shorter
TURN_AWAY = 1.2  # s of walking away afterwards, its back to the source
AWAY_PACE = 0.9  # m/s (at 1.75 m tall, by the root of scale like SPEED)
FLINCH = 0.25  # s: the shortest stagger, however light what hurt it (a flinch reads)
ACTIVATION = 1.3  # beats goals (0.8) by more than select_behavior's URGENT margin
#: Retreating characters from which a step's retreats go over arrays (:func:`act_withdrawals`):
#: for one, the per-character form costs 12-27 us against the arrays' 38-70 us, both writing the same.
ARRAYS_FROM = 2


def mass_share(scene, source: int, body: int) -> float:
    """How far a blow from ``source`` sends ``body`` back: the source's mass over the body's,
    at most 1 (1 too for a source fixed in place - every node locked: a post, a fence - or
    for a source or body without nodes)."""
    theirs = scene.world.try_component(source, Body)
    mine = scene.world.try_component(body, Body)
    if theirs is None or mine is None:
        return 1.0
    nodes = scene.state.nodes
    rows = theirs.rows
    if (nodes.flags[rows] & NODE_LOCKED).all():  # (a character's planted foot is locked too: all)
        return 1.0
    heavy = float(nodes.mass[rows].sum())
    own = float(nodes.mass[mine.rows].sum())
    return min(1.0, heavy / own) if own > 0.0 else 1.0


@register
class Withdraw(Behavior):
    """Pain withdrawal: back away from the source of a painful blow."""

    name = "withdraw"
    reflex = True
    batch = True

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
            share = mass_share(scene, event.source_body, event.body)
            stagger = max(FLINCH, DURATION * share)
            # a new blow restarts the retreat (the component, if one is under way, is renewed)
            until = now + stagger + TURN_AWAY * share**2
            ctx.world.add_component(
                event.body, Withdrawing(until, now + stagger, away, event.source_body, share)
            )
        super().run(ctx)

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters whose retreat is still running (not every character)."""
        now = self.scene.time
        world = self.world
        return [(e, world.component_for_entity(e, Mind)) for e, retreat in world.get_component(Withdrawing)
                if retreat.until > now and world.has_component(e, Mind)]  # fmt: skip

    def propose_crowd(self, crowd) -> np.ndarray:
        """:meth:`activation` of every one at once."""
        now = self.scene.time
        retreats = [self.world.try_component(e, Withdrawing) for e in crowd.entities]
        return np.array([ACTIVATION if r is not None and r.until > now else 0.0 for r in retreats])

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """:meth:`act` for every retreating character at once, over arrays (:func:`act_withdrawals`);
        a character at a time where one would be refused, or for a lone one."""
        if len(entities) < ARRAYS_FROM or not act_withdrawals(self, rows, entities):
            for entity in entities:
                mind = self.world.component_for_entity(entity, Mind)
                self.act(self.scene.character_handle(entity), mind, None, dt)

    def activation(self, character, mind: Mind, goal) -> float:
        """High while a retreat is running (one character: the per-character form of
        :meth:`propose_crowd`)."""
        retreat = self.world.try_component(character.entity, Withdrawing)
        return ACTIVATION if retreat is not None and retreat.until > self.scene.time else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Back off, arms up, watching the source; then turn away and walk off."""
        retreat = self.world.component_for_entity(character.entity, Withdrawing)
        away = retreat.away
        if retreat.stagger_until > self.scene.time:
            character.walk(away * SPEED * retreat.share * character.scale**0.5)
            character.pose("grapple")
            source = self.scene.name_of(retreat.source)
            if source and source != character.name:
                character.look_at(source)
            return
        character.walk(away * AWAY_PACE * retreat.share * character.scale**0.5)  # facing where it goes
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


def act_withdrawals(withdraw: Behavior, rows: list[int], entities: list[int]) -> bool:
    """``Withdraw.act`` for every retreating character at once: staggering back, arms up, eyes
    on the source; then walking away, arms down. False, nothing written, when one would be
    refused or looks at a source that is no character (the per-character form does that)."""
    scene = withdraw.scene
    world = withdraw.world
    ch = scene.state.characters
    now = scene.time
    retreats = [world.component_for_entity(e, Withdrawing) for e in entities]
    crows = np.array(rows, dtype=np.int64)
    staggering = np.array([r.stagger_until > now for r in retreats], dtype=bool)
    away = np.array([r.away for r in retreats], dtype=np.float64).reshape(-1, 3)
    root = roots(ch.scale[crows]) * np.array([r.share for r in retreats])
    walk = np.where(staggering[:, None], away * SPEED * root[:, None], away * AWAY_PACE * root[:, None])
    limit = np.array([world.component_for_entity(e, Character).max_speed for e in entities])
    if not walkable(walk, limit):
        return False
    # whom a staggering one watches (not itself): the node look_at tracks, by source
    state = scene.state
    tracked = withdraw.scratch.keyed("watched", (state.version, id(state)), dict)
    watched, watch = [], []
    for k in np.flatnonzero(staggering).tolist():
        source = retreats[k].source
        node = tracked.get(source)
        if node is None:
            node = tracked[source] = _watched_node(scene, source)
        if node == _UNWATCHED or source == entities[k]:
            continue
        if node == _NOT_A_CHARACTER:
            return False
        watched.append(k)
        watch.append(node)
    ch.walk[crows] = walk
    ch.walk[crows, 1] = 0.0
    ch.arm_mode[crows] = np.where(staggering, GRAPPLE, HANG)[:, None]
    ch.gaze_node[crows[watched]] = watch
    ch.gaze_mode[crows[watched]] = GAZE_NODE
    ch.gaze_mode[crows[~staggering]] = GAZE_AHEAD
    for k in np.flatnonzero(ch.mode[crows] == SIT).tolist():
        scene.character_handle(entities[k]).stand()  # (a walk stands a sitter up)
    return True


#: What :func:`_watched_node` says of a source that has no name (nothing to look at), and of
#: one that is no character (look_at finds the node to track: per character).
_UNWATCHED, _NOT_A_CHARACTER = -1, -2


def _watched_node(scene, source: int) -> int:
    """The node ``look_at(name of source)`` tracks on a character: its node called spine (a
    character's spine role); ``_UNWATCHED`` for a source without a name, ``_NOT_A_CHARACTER``
    for one that is no character or has a node called centre (which look_at would track)."""
    if not scene.name_of(source):
        return _UNWATCHED
    them = scene.world.try_component(source, Character)
    if them is None or "centre" in scene.world.component_for_entity(source, Body).node_names:
        return _NOT_A_CHARACTER
    return int(scene.state.characters.nodes[them.index, SPINE])
