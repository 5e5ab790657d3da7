"""grapple: close to arm's length, then shove and hit the target, face to face (SPEC 4).

Goal-driven (``character.grapple(target, duration=3)``): approach with the arms up
(the grapple pose), then, standing square to the target within arm's reach, a shove
with both hands to its chest and blows at its chest and head, one hand then the other -
impacts that hurt it (its pain withdrawal may well win: it staggers back and turns
away). It steps after a target that backs off still facing it, at a walk, and stands
guard, never chasing, while the target's back is turned; one that gets away (out of reach
or turned away for ``LET_GO`` seconds) ends the fight. Done after ``duration`` seconds of
fighting within reach, or when the target gets away; failed if it cannot get to it.

A batch behaviour: every grappler of a step acts in one pass over arrays (:func:`act_grapples`,
the ones still walking up steered in one call), with :meth:`Grapple.act`'s arithmetic; a step
with a rare event in it is done a character at a time by :meth:`Grapple.act`, which says what
happened. A rule added to ``act`` goes into ``act_grapples`` too (tests/test_brawl_batch.py
compares the two).
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import CharacterHandle
from twig_ecs.components import Character
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.kernelmath import (
    GAZE_NODE,
    GRAPPLE,
    HEAD,
    L_ELBOW,
    L_HAND,
    L_HIP,
    L_SHOULDER,
    NECK,
    PELVIS,
    R_ELBOW,
    R_HAND,
    R_HIP,
    REACH,
    SIT,
    SPINE,
)
from twig_ecs.rowtable import Column, RowTable
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.approach import steer_to
from twig_ecs.systems.behaviours.arrays import GROUND, ground_gaps, roots, steer_to_rows, units, walkable
from twig_ecs.validate import LIMIT

ARMS_LENGTH = 0.55  # m (at 1.75 m tall): where the fight starts
PUNCH = 0.5  # s per blow or shove
THROUGH = 0.3  # m (at 1.75 m tall) beyond the struck point that a punch aims at
PUNCH_SPEED = 8.0  # m/s of a thrown fist (at 1.75 m tall; a smaller fighter throws slower)
SHOVE_SPEED = 3.0  # m/s of the two hands of a shove (at 1.75 m tall)
APPROACH = 1.4  # m/s: a fighter walks up briskly
FOLLOW = 0.9  # m/s: it steps after a target that backs off, at a walk (not a chase)
EDGE_IN = 0.4  # m/s (at 1.75 m tall): within reach but beyond arm's length, it edges in
TURNED_AWAY = 0.5  # cos: a target facing more than 60 deg away from the fighter has turned away
LET_GO = 1.5  # s out of reach (or its back turned) after which the target has got away: the fight is over
#: Grapplers from which a step's fighting goes over arrays (:func:`act_grapples`). The pass over
#: arrays costs about 0.4 ms a step whatever the count, the per-character form 0.07-0.14 ms a
#: grappler, and both write the same; the schoolyard has one fight or two.
ARRAYS_FROM = 4


@register
class Grapple(Behavior):
    """Fight: arms bash the target in turns."""

    schema = GoalSchema(
        "grapple",
        "Close to arm's length and shove and hit the target for `duration` s.",
        (
            Param("target", "name", figure=True, doc="whom to fight"),
            seconds("duration", 3.0, "how long to fight within reach"),
        ),
    )
    batch = True

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """:meth:`act` for every grappler at once, over arrays (:func:`act_grapples`); one whose
        target is no character (a ragdoll), and every one in a step with a rare event in it (a
        walk-up stalled...) or with fewer than ARRAYS_FROM grapplers, a character at a time."""
        if goals is None:
            goals = [self.world.component_for_entity(e, Mind).goal for e in entities]
        live = [k for k, goal in enumerate(goals) if goal is not None]
        rows, entities, goals = [rows[k] for k in live], [entities[k] for k in live], [goals[k] for k in live]
        few = len(goals) < ARRAYS_FROM
        for k in range(len(goals)) if few else act_grapples(self, rows, entities, goals, dt):
            mind = self.world.component_for_entity(entities[k], Mind)
            self.act(self.scene.character_handle(entities[k]), mind, goals[k], dt)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Close in, then shove and punch in turn, square to the target (one grappler: the
        per-character form of :meth:`act_batch`)."""
        target = goal.params["target"]
        m = goal.memory
        scale = character.scale
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        now = character.scene.time
        if "fighting" not in m:
            character.pose("grapple")
            if steer_to(character, goal, target, ARMS_LENGTH * scale, speed=APPROACH):
                m["fighting"] = m["in_reach"] = now
                m.pop("best", None)
            return
        here, there = character.position, other.position
        gap = ground_distance(here, there)
        away = _unit((here - there) * np.array([1.0, 0.0, 1.0]))
        # (a character faces somewhere; a body has no facing - the property computed twice here)
        if isinstance(other, CharacterHandle) and float(other.facing @ away) < TURNED_AWAY:
            # turned away (it flinched, it is leaving), near or already a step off: no blows at
            # its side or back and no chase, guard up; the fight's clock waits, and if it stays
            # turned away it has got away (the straight-legged fighter, a step behind, went on
            # hitting a child walking off; stepping after it, it caught up with the flinch)
            character.pose("grapple")
            character.stop()
            if now - m["in_reach"] > LET_GO:
                self.finish(character, goal)
            return
        if gap > 1.3 * ARMS_LENGTH * scale:
            # it backed off: step after it with the arms up; blows and the fight's clock
            # wait, and if it stays out of reach it has got away
            character.pose("grapple")
            if now - m["in_reach"] > LET_GO:
                self.finish(character, goal)
                return
            toward = _unit((there - here) * np.array([1.0, 0.0, 1.0]))
            character.walk(tuple(toward * FOLLOW * scale**0.5))
            return
        m["in_reach"] = now
        if gap > ARMS_LENGTH * scale:
            # a little beyond arm's length (it stopped short, or the target leaned back):
            # edge in while the blows go on, else the fists fall short
            toward = _unit((there - here) * np.array([1.0, 0.0, 1.0]))
            character.walk(tuple(toward * EDGE_IN * scale**0.5))
        else:
            character.stop()
        m["fought"] = fought = m.get("fought", 0.0) + dt
        blow = int(fought / PUNCH)
        if m.get("blow") != blow:
            m["blow"] = blow
            if blow % 3 == 0:  # a shove: both hands to the chest
                aim = _unit(other.node("spine") - character.node("neck"))
                for node in ("l_hand", "l_elbow", "r_hand", "r_elbow"):
                    character.set_node_velocity(node, tuple(SHOVE_SPEED * scale**0.5 * aim))
            else:  # a blow, one hand then the other: it starts with a throw, hand and elbow set
                # moving (SPEC 3's "set velocity" node control)
                side = ("l_", "r_")[blow % 2]
                struck = other.node("neck" if blow % 3 == 2 else "spine")
                aim = _unit(struck - character.node(side + "shoulder"))
                for node in (side + "hand", side + "elbow"):
                    character.set_node_velocity(node, tuple(PUNCH_SPEED * scale**0.5 * aim))
        # the hands follow through past what they hit (a hit still moving when it lands)
        if blow % 3 == 0:
            chest = other.node("spine")
            through = _unit(chest - character.node("neck"))
            character.reach(tuple(chest + THROUGH * scale * through), hand="both")
        else:
            hand, spare = (("left", "right"), ("right", "left"))[blow % 2]
            side = ("l_", "r_")[hand == "right"]
            struck = other.node("neck" if blow % 3 == 2 else "spine")
            aim = _unit(struck - character.node(side + "shoulder"))
            character.reach(tuple(struck + THROUGH * scale * aim), hand=hand)
            character.pose("grapple", hand=spare)
        if fought >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down, stand."""
        character.pose("hang")
        character.stop()
        character.look_at(None)


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v


# -- the batch form: every grappler of a step at once (issue 36) --------------------------------

#: A grapple goal's row (:func:`grapple_row`): its target's rows and what the walk-up reads of
#: it, looked up once per goal (again when the store's rows change).
_GRAPPLE_ROW = {
    "target": Column(np.int64),  # the target's character row
    "entity": Column(np.int64),  # the target's entity
    "body": Column(np.int64),  # its body row: no obstacle to the walk-up
    "first": Column(np.int64),  # its nodes (its pace: a target backing off is pursued)
    "count": Column(np.int64),
    "mass": Column(np.float64),  # kg, numpy's sum (the one BodyHandle.velocity divides by)
    "duration": Column(np.float64),  # s of fighting within reach
    "max_speed": Column(np.float64),  # the grappler's own top speed (m/s): a faster walk is refused
}


def grapple_row(scene, entity: int, goal: Goal) -> dict | None:
    """One grapple goal's row of the table (``_GRAPPLE_ROW``); None when its target is gone, is
    itself or is no character (the per-character form says so)."""
    target = goal.params["target"]
    if not scene.has_entity(target) or target == scene.name_of(entity):
        return None
    other = scene.entity(target)
    them = scene.world.try_component(other.entity, Character)
    if them is None:
        return None
    body = other.body
    first, count = body.node_start, len(body.node_names)
    return dict(target=them.index, entity=other.entity, body=body.index, first=first, count=count,
                mass=scene.state.nodes.mass[first : first + count].sum(), duration=goal.params["duration"],
                max_speed=scene.world.component_for_entity(entity, Character).max_speed)  # fmt: skip


def act_grapples(grapple: Behavior, rows: list[int], entities: list[int], goals: list[Goal],
                 dt: float) -> list[int]:  # fmt: skip
    """``Grapple.act`` for every grappler at once (row k: character ``rows[k]``, entity
    ``entities[k]``, its grapple goal ``goals[k]``): close in (one steering call for all that
    are still walking up), then shove and punch in turn. Returns the k left to the
    per-character form: those whose target is no character (a ragdoll) or is gone; all of
    them, with nothing written, when a rare event wants the per-character form."""
    scene = grapple.scene
    state = scene.state
    table = grapple.scratch.get("brawl")
    if table is None:
        table = grapple.scratch["brawl"] = RowTable(**_GRAPPLE_ROW)
    table.sync([goal.id for goal in goals], (state.version, id(state)),
               lambda i, _: grapple_row(scene, entities[i], goals[i]))  # fmt: skip
    left = list(table.missing)
    # one that fights per character throws its blows after these (so none may pursue it)
    busy = {entities[k] for k in left if "fighting" in goals[k].memory}
    at = table.positions.tolist()
    packed = [rows[k] for k in at], [entities[k] for k in at], [goals[k] for k in at]
    if not _act_packed(grapple, table, *packed, dt, busy):
        return list(range(len(goals)))
    return left


def _act_packed(grapple: Behavior, table: RowTable, rows: list[int], entities: list[int], goals: list[Goal],
                dt: float, busy: set[int]) -> bool:  # fmt: skip
    """:func:`act_grapples` for the grapplers with a row of ``table`` (in its order); False,
    nothing written, when a rare event wants the per-character form (``busy``: the entities
    of grapplers fighting per character)."""
    scene = grapple.scene
    ch = scene.state.characters
    nodes = scene.state.nodes
    pos = nodes.pos
    if not goals:
        return True
    crows = np.array(rows, dtype=np.int64)
    mine, theirs = ch.nodes[crows], ch.nodes[table["target"]]
    here, there = pos[mine[:, PELVIS]], pos[theirs[:, PELVIS]]
    scale = ch.scale[crows]
    root = roots(scale)
    limit = table["max_speed"]
    memories = [goal.memory for goal in goals]
    now = scene.time
    fighting = np.array(["fighting" in m for m in memories], dtype=bool)
    walking = np.flatnonzero(~fighting)
    fights = np.flatnonzero(fighting)
    if len(walking) and (len(fights) or busy):
        busy = busy | {entities[k] for k in fights.tolist()}
        if any(e in busy for e in table["entity"][walking].tolist()):
            return False  # it pursues one that throws blows: their order matters (per character)

    # -- the walk-up: steer_to(character, goal, target, ARMS_LENGTH * scale, speed=APPROACH) --
    up = steer_to_rows(scene, crows[walking], [memories[k] for k in walking.tolist()], table, walking,
                       here[walking], there[walking], ARMS_LENGTH * scale[walking], APPROACH)  # fmt: skip
    if up is None:
        return False
    up_walk, arrived = up
    going = walking[~arrived]
    if not walkable(up_walk[~arrived], limit[going]):
        return False

    # -- the fight: within reach, edging in, or stepping after a target that backed off --
    gap = ground_gaps(here[fights], there[fights])
    s = scale[fights]
    # turned away, near or a step off (CharacterHandle.facing: (left hip - right hip) x up):
    # guard up, standing, no blows and no chase, the fight's clock waiting
    tf = theirs[fights]
    hips = pos[tf[:, L_HIP]] - pos[tf[:, R_HIP]]
    facing = units(np.stack([-hips[:, 2], np.zeros(len(fights)), hips[:, 0]], axis=1))
    back = units((here[fights] - there[fights]) * GROUND)
    turned = np.einsum("ij,ij->i", facing, back) < TURNED_AWAY
    away = ~turned & (gap > 1.3 * ARMS_LENGTH * s)  # backed off, facing it: step after it
    let_go = np.array([now - memories[k]["in_reach"] > LET_GO for k in fights.tolist()], dtype=bool)
    let_go &= away | turned
    toward = units((there[fights] - here[fights]) * GROUND)
    root_f = root[fights, None]
    step = np.where(away[:, None], toward * FOLLOW * root_f, toward * EDGE_IN * root_f)
    stepping = (away & ~let_go) | (~away & ~turned & (gap > ARMS_LENGTH * s))
    if not walkable(step[stepping], limit[fights[stepping]]):
        return False
    close = fights[~away & ~turned]
    fought = [memories[k].get("fought", 0.0) + dt for k in close.tolist()]
    blow = np.array([int(f / PUNCH) for f in fought], dtype=np.int64)
    was = [memories[k].get("blow") for k in close.tolist()]
    thrown = np.array([w != b for w, b in zip(was, blow.tolist(), strict=True)], dtype=bool)
    shove = blow % 3 == 0
    hand = blow % 2  # a blow's hand: 0 left, 1 right
    cm, ct = mine[close], theirs[close]
    c = np.arange(len(close))
    # a shove aims both hands from the neck at the chest; a blow one hand from its shoulder at
    # the chest, or (every third) at the neck
    struck = pos[np.where(shove | (blow % 3 == 1), ct[:, SPINE], ct[:, NECK])]
    start = pos[np.where(shove, cm[:, NECK], cm[c, L_SHOULDER + hand])]
    aim = units(struck - start)
    point = struck + (THROUGH * scale[close])[:, None] * aim  # the hands follow through past it
    if not (np.isfinite(point).all() and (np.abs(point) <= LIMIT).all()):
        return False
    speed = np.where(shove, SHOVE_SPEED * root[close], PUNCH_SPEED * root[close])
    velocity = speed[:, None] * aim

    # -- nothing refused: write it all --
    ch.gaze_node[crows] = theirs[:, HEAD]  # look_at(target, node="head")
    ch.gaze_mode[crows] = GAZE_NODE
    ch.arm_mode[crows[walking]] = GRAPPLE
    ch.arm_mode[crows[fights[away | turned]]] = GRAPPLE
    ch.walk[crows[walking]] = up_walk  # (an arrived one stops: its walk is nought)
    ch.walk[crows[fights[~away & ~stepping]]] = 0.0  # within arm's length: it stands
    ch.walk[crows[fights[stepping]]] = step[stepping]
    ch.walk[crows[fights[stepping]], 1] = 0.0  # (a walk is on the ground)
    for k in walking[arrived].tolist():
        memories[k]["fighting"] = memories[k]["in_reach"] = now
        memories[k].pop("best", None)
    # the blows thrown this step: hand and elbow (both of each for a shove) set moving, as
    # set_node_velocity does (Verlet: the previous position moves)
    throw = np.flatnonzero(thrown)
    both = throw[shove[throw]]
    one = throw[~shove[throw]]
    moved = [cm[both, L_HAND], cm[both, L_ELBOW], cm[both, R_HAND], cm[both, R_ELBOW],
             cm[one, L_HAND + hand[one]], cm[one, L_ELBOW + hand[one]]]  # fmt: skip
    kicked = [velocity[both]] * 4 + [velocity[one]] * 2
    for at, v in zip(moved, kicked, strict=True):
        nodes.prev[at] = pos[at] - v * scene.dt
    arms = crows[close]
    ch.arm_node[arms[shove]] = -1
    ch.arm_point[arms[shove]] = point[shove, None, :]
    ch.arm_mode[arms[shove]] = REACH
    punch = np.flatnonzero(~shove)
    ch.arm_node[arms[punch], hand[punch]] = -1
    ch.arm_point[arms[punch], hand[punch]] = point[punch]
    ch.arm_mode[arms[punch], hand[punch]] = REACH
    ch.arm_mode[arms[punch], 1 - hand[punch]] = GRAPPLE  # the spare hand keeps its guard
    for j, k in enumerate(close.tolist()):
        memories[k]["in_reach"] = now
        memories[k]["fought"] = fought[j]
        if thrown[j]:
            memories[k]["blow"] = int(blow[j])
    for k in going.tolist() + fights[stepping].tolist():
        if ch.mode[rows[k]] == SIT:
            scene.character_handle(entities[k]).stand()  # (a walk stands a sitter up)
    # the goals over: fought their time, or the target got away
    over = [k for k, f in zip(close.tolist(), fought, strict=True) if f >= table["duration"][k]]
    for k in sorted(over + fights[let_go].tolist()):
        grapple.finish(scene.character_handle(entities[k]), goals[k])
    return True
