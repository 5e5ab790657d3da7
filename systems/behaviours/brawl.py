"""brawl: grapple and defend over arrays - every fighter and every defender of a step at once.

The batch forms of :meth:`~twig_ecs.systems.behaviours.grapple.Grapple.act` and of
:class:`~twig_ecs.systems.behaviours.fight.Defend`'s activation and act (issue 36: 500 fights
cost 20 ms a step of per-character Python through the handle API). The arithmetic is the
handle code's, operation for operation, so both forms write the same bits from the same state
(``tests/test_brawl_batch.py``): ``math.hypot`` for ground distances (``ground_distance``; numpy's
hypot is not CPython's), numpy's ``vecdot`` for the lengths ``np.linalg.norm`` took (one BLAS dot
a row, as ``norm`` makes), Python's ``**`` for a root of the size, and the products in the order
the handle code multiplies. Grapplers still walking up are steered in one
:func:`~twig_ecs.systems.control.steer.steer_rows` call with the rows ``steer_to`` makes.

Reads the store and the goals' memories; writes what the handle calls write (walk vectors, arm
modes and points, gaze, the blows' node velocities) and the memories. A step with a rare event
in it is done a character at a time by the behaviours' own ``act`` (which says what went
wrong), nothing written here first: a target gone, itself or no character, a walk-up stalled,
a walk or a point the handle would refuse, a grappler walking up to one that is fighting (it
pursues that one at its pace, which the blows change as they are thrown, in the order the
per-character form throws them).
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.behavior import Behavior, Goal
from twig_ecs.components import Character
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
from twig_ecs.systems.behaviours.approach import (
    ARRIVE_SLACK,
    SQUEEZE,
    SQUEEZE_AFTER,
    SQUEEZE_HOLD,
    STALL_TIME,
    grab_pairs,
)
from twig_ecs.systems.behaviours.fight import DEFEND, FACED, SQUARE_UP, TURN_PACE
from twig_ecs.systems.behaviours.grapple import (
    APPROACH,
    ARMS_LENGTH,
    EDGE_IN,
    FOLLOW,
    LET_GO,
    PUNCH,
    PUNCH_SPEED,
    SHOVE_SPEED,
    THROUGH,
)
from twig_ecs.systems.behaviours.hug import mean_velocities
from twig_ecs.systems.control.steer import (
    ALONG_UNIT,
    ARRIVED,
    SAT,
    WALKING,
    around,
    gains,
    steer_rows,
    walkers,
)
from twig_ecs.validate import LIMIT

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

#: The walk-up's steering gains: approach's (the same field and figures as ``steer_to``).
_GAINS = gains(SQUEEZE_AFTER, SQUEEZE, SQUEEZE_HOLD)
_GROUND = np.array([1.0, 0.0, 1.0])


def _lengths(v: np.ndarray) -> np.ndarray:
    """Each row's ``np.linalg.norm``, to the bit (a BLAS dot a row, then the root)."""
    return np.sqrt(np.vecdot(v, v))


def _units(v: np.ndarray) -> np.ndarray:
    """grapple's ``_unit`` of every row: ``v / |v|``, or ``v`` itself where it has no length."""
    n = _lengths(v)
    long = n > 1e-9
    return np.where(long[:, None], v / np.where(long, n, 1.0)[:, None], v)


def _ground_gaps(here: np.ndarray, there: np.ndarray) -> np.ndarray:
    """``ground_distance`` of every row (``math.hypot``, as it takes it)."""
    dx, dz = (here[:, 0] - there[:, 0]).tolist(), (here[:, 2] - there[:, 2]).tolist()
    return np.array([math.hypot(x, z) for x, z in zip(dx, dz, strict=True)])


def _roots(values: np.ndarray) -> np.ndarray:
    """``value ** 0.5`` of every value, as Python's power makes it (the handle code's)."""
    return np.array([v**0.5 for v in values.tolist()])


def _walkable(walk: np.ndarray, limit: np.ndarray) -> bool:
    """Would ``CharacterHandle.walk`` take every row (finite, not too big, within its top speed;
    a margin on the speed: the handle's own hypot decides)?"""
    return bool(np.isfinite(walk).all() and (np.abs(walk) <= LIMIT).all()
                and (np.hypot(walk[:, 0], walk[:, 2]) <= limit * (1.0 - 1e-9)).all())  # fmt: skip


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
                 dt: float) -> bool:  # fmt: skip
    """``Grapple.act`` for every grappler at once (row k: character ``rows[k]``, entity
    ``entities[k]``, its grapple goal ``goals[k]``): close in (one steering call for all that
    are still walking up), then shove and punch in turn. False, with nothing written, when a
    rare event wants the per-character form."""
    scene = grapple.scene
    state = scene.state
    ch = state.characters
    nodes = state.nodes
    pos = nodes.pos
    table = grapple.scratch.get("brawl")
    if table is None:
        table = grapple.scratch["brawl"] = RowTable(**_GRAPPLE_ROW)
    table.sync([goal.id for goal in goals], (state.version, id(state)),
               lambda i, _: grapple_row(scene, entities[i], goals[i]))  # fmt: skip
    if table.missing:
        return False
    crows = np.array(rows, dtype=np.int64)
    mine, theirs = ch.nodes[crows], ch.nodes[table["target"]]
    here, there = pos[mine[:, PELVIS]], pos[theirs[:, PELVIS]]
    scale = ch.scale[crows]
    root = _roots(scale)
    limit = table["max_speed"]
    memories = [goal.memory for goal in goals]
    now = scene.time
    fighting = np.array(["fighting" in m for m in memories], dtype=bool)
    walking = np.flatnonzero(~fighting)
    fights = np.flatnonzero(fighting)
    if len(walking) and len(fights):
        busy = {entities[k] for k in fights.tolist()}
        if any(e in busy for e in table["entity"][walking].tolist()):
            return False  # it pursues one that throws blows: their order matters (per character)

    # -- the walk-up: steer_to(character, goal, target, ARMS_LENGTH * scale, speed=APPROACH) --
    up = _walk_up(scene, crows[walking], [memories[k] for k in walking.tolist()], table, walking,
                  here[walking], there[walking], ARMS_LENGTH * scale[walking])  # fmt: skip
    if up is None:
        return False
    up_walk, arrived = up
    going = walking[~arrived]
    if not _walkable(up_walk[~arrived], limit[going]):
        return False

    # -- the fight: within reach, edging in, or stepping after a target that backed off --
    gap = _ground_gaps(here[fights], there[fights])
    s = scale[fights]
    away = gap > 1.3 * ARMS_LENGTH * s
    let_go = np.array([now - memories[k]["in_reach"] > LET_GO for k in fights.tolist()], dtype=bool) & away
    toward = _units((there[fights] - here[fights]) * _GROUND)
    root_f = root[fights, None]
    step = np.where(away[:, None], toward * FOLLOW * root_f, toward * EDGE_IN * root_f)
    stepping = (away & ~let_go) | (~away & (gap > ARMS_LENGTH * s))
    if not _walkable(step[stepping], limit[fights[stepping]]):
        return False
    close = fights[~away]
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
    aim = _units(struck - start)
    point = struck + (THROUGH * scale[close])[:, None] * aim  # the hands follow through past it
    if not (np.isfinite(point).all() and (np.abs(point) <= LIMIT).all()):
        return False
    speed = np.where(shove, SHOVE_SPEED * root[close], PUNCH_SPEED * root[close])
    velocity = speed[:, None] * aim

    # -- nothing refused: write it all --
    ch.gaze_node[crows] = theirs[:, HEAD]  # look_at(target, node="head")
    ch.gaze_mode[crows] = GAZE_NODE
    ch.arm_mode[crows[walking]] = GRAPPLE
    ch.arm_mode[crows[fights[away]]] = GRAPPLE
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


def _walk_up(scene, crows: np.ndarray, memories: list[dict], table: RowTable, at: np.ndarray,
             here: np.ndarray, there: np.ndarray, stop: np.ndarray):  # fmt: skip
    """``steer_to(character, goal, target, stop, speed=APPROACH)`` for every row at once (the
    target pursued at its pace): (walk vectors, which have arrived), the memories' stall clocks
    updated; None, nothing written, when one has stalled or asks for a walk it cannot do."""
    n = len(crows)
    if not n:
        return np.zeros((0, 3)), np.zeros(0, dtype=bool)
    ch = scene.state.characters
    direction = (here - there) * _GROUND
    norm = _lengths(direction)
    far = norm > 1e-9
    direction[far] /= norm[far, None]
    direction[~far] = 0.0  # (steer_to: no length, no direction)
    w = walkers(n)._replace(crows=np.arange(n), skip_bodies=table["body"][at], skip_start=np.arange(n),
                            skip_count=np.ones(n, dtype=np.int64), stop=stop.copy())  # fmt: skip
    w.pelvis[:] = ch.nodes[crows, PELVIS]
    w.me[:] = ch.body[crows]
    w.point[:] = there
    w.arrive[:] = stop + ARRIVE_SLACK
    w.direction[:, :3] = direction
    w.direction[:, 3] = ALONG_UNIT
    w.speed[:] = APPROACH
    w.stall[:] = STALL_TIME
    now = scene.time
    w.best[:] = [m.get("best", np.inf) for m in memories]
    w.best_at[:] = [m.get("best_at", now) for m in memories]
    w.squeeze_until[:] = [m.get("squeeze_until", -np.inf) for m in memories]
    best, squeeze_until = w.best.copy(), w.squeeze_until.copy()
    walk = np.zeros((n, 3))
    steer_rows(around(scene, grab_pairs(scene.world), extra_skip=1), w, _GAINS, walk, ch.mode[crows], now,
               scene.dt)  # fmt: skip
    if ((w.status != WALKING) & (w.status != SAT) & (w.status != ARRIVED)).any():
        return None  # stalled (the goal fails), or a walk it cannot do
    arrived = w.status == ARRIVED
    going = np.flatnonzero(~arrived)
    if len(going):
        # pursuit: match the target's pace on top of closing in (BodyHandle.velocity's sums)
        t = at[going]
        velocity = np.empty((len(going), 3))
        state = scene.state
        nodes = state.nodes
        mean_velocities(nodes.pos, nodes.prev, nodes.mass, table["first"][t], table["count"][t],
                        table["mass"][t], scene.dt, velocity)  # fmt: skip
        walk[going] = walk[going] + velocity * _GROUND
        pace = _lengths(walk[going])
        over = going[pace > APPROACH]
        walk[over] *= (APPROACH / pace[pace > APPROACH])[:, None]
        walk[:, 1] = 0.0
    for k in going.tolist():
        m = memories[k]
        if w.best[k] != best[k]:
            m["best"], m["best_at"] = float(w.distance[k]), now
        else:
            m.setdefault("best_at", now)
        if w.squeeze_until[k] != squeeze_until[k]:
            m["squeeze_until"] = float(w.squeeze_until[k])
    return walk, arrived


def defend_activations(defend: Behavior, attacked_by: dict[int, int], entities: list[int]) -> np.ndarray:
    """``Defend.activation`` of every character ``entities`` at once: ``DEFEND`` where the one
    fighting it (``attacked_by``) is within ``SQUARE_UP`` on the ground, else 0."""
    world = defend.world
    ch = defend.scene.state.characters
    pos = defend.scene.state.nodes.pos
    out = np.zeros(len(entities))
    pairs = [(k, attacked_by.get(e)) for k, e in enumerate(entities)]
    pairs = [(k, f) for k, f in pairs if f is not None]
    if not pairs:
        return out
    picked = np.array([k for k, _ in pairs], dtype=np.int64)
    mine = [world.component_for_entity(entities[k], Character).index for k, _ in pairs]
    theirs = [world.component_for_entity(f, Character).index for _, f in pairs]
    gap = _ground_gaps(pos[ch.nodes[mine, PELVIS]], pos[ch.nodes[theirs, PELVIS]])
    out[picked] = np.where(gap < SQUARE_UP, DEFEND, 0.0)
    return out


def act_defences(defend: Behavior, attacked_by: dict[int, int], rows: list[int], entities: list[int]) -> bool:
    """``Defend.act`` for every defender at once: face the fighter (``attacked_by``), guard up,
    slow steps round to face it when turned away. False, nothing written, when one would be
    refused (the per-character form raises)."""
    scene = defend.scene
    world = defend.world
    ch = scene.state.characters
    pos = scene.state.nodes.pos
    fighters = [attacked_by[e] for e in entities]
    if any(f == e for f, e in zip(fighters, entities, strict=True)):
        return False
    crows = np.array(rows, dtype=np.int64)
    mine = ch.nodes[crows]
    theirs = ch.nodes[[world.component_for_entity(f, Character).index for f in fighters]]
    to = (pos[theirs[:, PELVIS]] - pos[mine[:, PELVIS]]) * _GROUND
    to /= np.maximum(_lengths(to), 1e-9)[:, None]
    # CharacterHandle.facing: (left hip - right hip) x up, of length 1
    left = pos[mine[:, L_HIP]] - pos[mine[:, R_HIP]]
    facing = np.zeros((len(rows), 3))
    facing[:, 0], facing[:, 2] = -left[:, 2], left[:, 0]
    length = _lengths(facing)
    facing /= np.where(length != 0.0, length, 1.0)[:, None]
    turning = np.vecdot(facing, to) < FACED
    walk = to * TURN_PACE * ch.scale[crows][:, None]
    limit = np.array([world.component_for_entity(e, Character).max_speed for e in entities])
    if not _walkable(walk[turning], limit[turning]):
        return False
    ch.gaze_node[crows] = theirs[:, HEAD]  # look_at(fighter, node="head")
    ch.gaze_mode[crows] = GAZE_NODE
    ch.arm_mode[crows] = GRAPPLE
    ch.walk[crows] = 0.0
    ch.walk[crows[turning]] = walk[turning]
    ch.walk[crows, 1] = 0.0
    for k in np.flatnonzero(turning & (ch.mode[crows] == SIT)).tolist():
        scene.character_handle(entities[k]).stand()
    return True
