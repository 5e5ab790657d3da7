"""approach: walk to a target around obstacles, then stop at a distance (SPEC 4).

A goal-driven behaviour (``character.approach(target, stop_distance=..., direction=...,
arms=...)``). Each step it steers with the attraction + curl-repulsion field of
:mod:`twig_ecs.steering` and looks at the target; it is done within the stop distance
and fails when it makes no headway for ``STALL_TIME`` seconds. Hug, grapple, carry and
drag use :func:`steer_to` for their own approach phases.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.components import Body, Character, GrabJoint
from twig_ecs.goals import GoalSchema, Param, metres
from twig_ecs.kernelmath import GAZE_NODE, GRAPPLE, HUG, PELVIS, REACH, SIT, approach_field
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.systems.control.spatial import STEER_CELL, STEP_OVER, SpatialIndex, nearest_obstacle_nodes

STALL_TIME = 4.0  # s without getting 10 cm closer: give up
ARRIVE_SLACK = 0.1  # m beyond the stop distance that still counts as there
#: s without getting 10 cm closer after which two characters approaching each other squeeze:
#: obstacles push them ``SQUEEZE`` times as hard and neither adds the other's pace (pursuit).
#: Two people standing a body's width apart or more make a dip in the field before the gap
#: between them (their pushes cancel in the gap, not before it), where the walk vector
#: swings to and fro; two walkers there that pursue each other copy each other's dithering
#: and drift off together, and their goals fail 'stuck'. Pushed less and heading for where
#: the other is, they walk into the gap and the collisions see them past. Only that pair
#: squeezes (``mutual`` rows of :func:`steer_goals`): a walker whose target does not come
#: to meet it keeps the field it had (and the schoolyard computes what it did).
#: Half the stall time, so the other half is left to get through before it gives up.
SQUEEZE_AFTER = 0.5 * STALL_TIME
SQUEEZE = 0.4
SQUEEZE_HOLD = 2.0  # s a squeeze lasts once begun (headway on the way does not end it)


def target_point(character, target) -> np.ndarray:
    """Where a target is: a point as given, or an entity's centre of mass."""
    if isinstance(target, str):
        return character.scene.entity(target).position
    return np.asarray(target, dtype=np.float64)


def _nearest_on_links(state, rows: np.ndarray, here: np.ndarray) -> tuple[np.ndarray, float]:
    """The point of the links ``rows`` nearest to ``here`` on the ground plane, and its distance."""
    pos = state.nodes.pos
    a = pos[state.links.a[rows]] * np.array([1.0, 0.0, 1.0])
    ab = pos[state.links.b[rows]] * np.array([1.0, 0.0, 1.0]) - a
    flat = here * np.array([1.0, 0.0, 1.0])
    t = np.clip(np.einsum("ij,ij->i", flat - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    points = a + t[:, None] * ab
    d = np.linalg.norm(points - flat, axis=1)
    k = int(np.argmin(d))
    return points[k] + np.array([0.0, here[1], 0.0]), float(d[k])


def obstacles_near(character, exclude: set[str], cutoff: float, here: np.ndarray | None = None) -> np.ndarray:
    """The nearest node of every other body within ``cutoff`` (ground plane), as points;
    for a wide body, the nearest point of the disc it covers. ``here``: the character's
    position when the caller has it already."""
    scene = character.scene
    state = scene.state
    if here is None:
        here = character.position
    # what it carries is no obstacle, and neither is what the target carries
    exclude = set(exclude) | set(character.holding.values())
    for name in list(exclude):
        other = scene.entity(name) if scene.has_entity(name) else None
        if other is not None and hasattr(other, "holding"):
            exclude |= set(other.holding.values())
    skip = {character.body.index} | {scene.entity(n).body.index for n in exclude if scene.has_entity(n)}
    points = []
    # a wide body (a merry-go-round's deck) is a disc to go round, however low it lies:
    # its nearest node can be a metre from the bar one would walk into, and stepping
    # across a turning deck catches the legs in its bars
    index = SpatialIndex.of(scene)
    cx, cz, spread, wide, walls, blocked = index.footprints(scene)
    # a fence or wall is long and thin: its nearest point, not a disc round its middle
    for b, rows in walls.items():
        if b in skip or np.hypot(here[0] - cx[b], here[2] - cz[b]) - np.sqrt(spread[b]) > cutoff:
            continue
        point, d = _nearest_on_links(state, rows, here)
        if d < cutoff:
            points.append(point)
    for b in np.flatnonzero(wide):
        if b in skip:
            continue
        off = np.array([here[0] - cx[b], 0.0, here[2] - cz[b]])
        reach = float(np.linalg.norm(off))
        radius = float(np.sqrt(spread[b]))
        if reach - radius < cutoff:
            # the rim point nearest to it; from inside, the centre (it pushes outwards)
            rim = off * (radius / reach) if reach > radius else np.zeros(3)
            points.append(np.array([cx[b], here[1], cz[b]]) + rim)
    # the nearest node of each other body that stands higher than a step: things lying
    # low on the ground (a dropped doll, a ball) are stepped over or kicked
    start, entries, best, scratch, out = index.grid(scene)
    skip_rows = np.array(sorted(skip), dtype=np.int64)
    count = nearest_obstacle_nodes(state.nodes.pos, state.nodes.body, state.nodes.count, start, entries,
                                   STEER_CELL, float(here[0]), float(here[2]), float(cutoff), STEP_OVER,
                                   blocked, skip_rows, best, scratch, out)  # fmt: skip
    nodes = state.nodes.pos[out[:count]]
    if points:
        return np.concatenate([np.array(points), nodes]) if count else np.array(points)
    return nodes if count else np.zeros((0, 3))


#: Status of a row after :func:`steer_goals`.
WALKING, ARRIVED, STUCK, SAT, CHECK = 0, 1, 2, 3, 4


@njit(cache=True, nogil=True)
def steer_goals(pos, prev, mass, node_body, n_nodes, grid_start, grid_entries, crows, pelvis, me, target,
                point, stop, direction, curl, max_speed, mode, best, best_at, squeeze_until, now, dt, params,
                cx, cz, spread, wide, blocked, wall_body, wall_start, wall_links, link_a, link_b,
                grab_holder, grab_held, slot, scratch, found, obstacles, skip, walk, status, distance,
                improved, mutual):  # fmt: skip
    """Steer every row of a batch of approach goals at once: :func:`steer_to` over arrays.

    Row k is the character whose table row is ``crows[k]`` (pelvis node ``pelvis[k]``,
    body ``me[k]``), heading for ``target[k]`` = (kind, pelvis node, first node, node
    count, body): kind 0 a point (``point[k]``), 1 a body's centre of mass, 2 a
    character's pelvis. ``params`` = (speed, repulsion, cutoff, min_sq, fade, step_over,
    stall time, arrival slack, grid cell, squeeze after, squeeze, squeeze hold). ``best``/``best_at``
    (by character row) are the stall clock and ``squeeze_until`` the end of a squeeze, updated
    here (``improved[k]`` says so); only rows flagged ``mutual`` (two approaching each other)
    squeeze. Writes the walk vector into ``walk`` (the character table's) and ``status[k]``:
    WALKING, ARRIVED or STUCK (stopped: the goal ends), SAT (walking; it must stand up) or
    CHECK (a walk vector the character cannot do: left for the Python path to refuse). ``distance[k]``: to the
    target on the ground. Obstacles are found as :func:`obstacles_near` finds them, in
    the same order: walls, wide bodies (``wide``: their rows), then the nearest node of
    every other body.
    """
    speed, repulsion, cutoff, min_sq, fade = params[0], params[1], params[2], params[3], params[4]
    step_over, stall, slack, cell = params[5], params[6], params[7], params[8]
    squeeze_after, squeeze, squeeze_hold = params[9], params[10], params[11]
    n_grabs = len(grab_holder)
    for k in range(len(crows)):
        c = crows[k]
        p = pelvis[k]
        hx, hy, hz = pos[p, 0], pos[p, 1], pos[p, 2]
        kind = target[k, 0]
        tb = target[k, 4]
        vx = 0.0
        vz = 0.0
        if kind == 0:
            wx0, wz0 = point[k, 0], point[k, 2]
        else:
            first, count = target[k, 2], target[k, 3]
            msum = 0.0
            sx = sz = 0.0
            ux = uz = 0.0
            for i in range(first, first + count):
                m = mass[i]
                msum += m
                sx += pos[i, 0] * m
                sz += pos[i, 2] * m
                ux += (pos[i, 0] - prev[i, 0]) / dt * m
                uz += (pos[i, 2] - prev[i, 2]) / dt * m
            vx, vz = ux / msum, uz / msum
            if kind == 2:
                q = target[k, 1]
                wx0, wz0 = pos[q, 0], pos[q, 2]
            else:
                wx0, wz0 = sx / msum, sz / msum
        if direction[k, 3] > 0.0:
            dx, dz = direction[k, 0], direction[k, 2]
        else:
            dx, dz = hx - wx0, hz - wz0
        norm = math.sqrt(dx * dx + dz * dz)
        if norm > 1e-9:
            dx, dz = dx / norm, dz / norm
        else:
            dx = dz = 0.0
        ax = wx0 + stop[k] * dx
        az = wz0 + stop[k] * dz
        dist = math.hypot(hx - wx0, hz - wz0)
        distance[k] = dist
        improved[k] = 0
        if dist <= stop[k] + slack:
            walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
            status[k] = ARRIVED
            continue
        if dist < best[c] - 0.1:
            best[c] = dist
            best_at[c] = now
            improved[k] = 1
        elif now - best_at[c] > stall:
            walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
            status[k] = STUCK
            continue
        if mutual[k] and now - best_at[c] > squeeze_after:
            squeeze_until[c] = now + squeeze_hold
            improved[k] = 1
        squeezing = mutual[k] != 0 and now < squeeze_until[c]
        push = repulsion * squeeze if squeezing else repulsion
        # what is no obstacle: itself, the target, what it holds, and what those hold
        skip[0] = me[k]
        n_skip = 1
        if tb >= 0:
            skip[n_skip] = tb
            n_skip += 1
        for g in range(n_grabs):
            if grab_holder[g] == me[k]:
                skip[n_skip] = grab_held[g]
                n_skip += 1
        excluded = n_skip  # skip[1:excluded]: the target and what it holds; what those hold goes too
        for g in range(n_grabs):
            for s in range(1, excluded):
                if skip[s] == grab_holder[g]:
                    skip[n_skip] = grab_held[g]
                    n_skip += 1
                    break
        n_obs = 0
        for w in range(len(wall_body)):
            b = wall_body[w]
            skipped = False
            for s in range(n_skip):
                if skip[s] == b:
                    skipped = True
            if skipped or math.hypot(hx - cx[b], hz - cz[b]) - math.sqrt(spread[b]) > cutoff:
                continue
            near = np.inf
            nx = nz = 0.0
            for e in range(wall_start[w], wall_start[w + 1]):
                j = wall_links[e]
                a0, a2 = pos[link_a[j], 0], pos[link_a[j], 2]
                bx, bz = pos[link_b[j], 0] - a0, pos[link_b[j], 2] - a2
                t = ((hx - a0) * bx + (hz - a2) * bz) / max(bx * bx + bz * bz, 1e-12)
                t = min(max(t, 0.0), 1.0)
                qx, qz = a0 + t * bx, a2 + t * bz
                d = math.sqrt((qx - hx) ** 2 + (qz - hz) ** 2)
                if d < near:
                    near, nx, nz = d, qx, qz
            if near < cutoff:
                obstacles[n_obs, 0], obstacles[n_obs, 1], obstacles[n_obs, 2] = nx, hy, nz
                n_obs += 1
        for b in wide:
            skipped = False
            for s in range(n_skip):
                if skip[s] == b:
                    skipped = True
            if skipped:
                continue
            ox, oz = hx - cx[b], hz - cz[b]
            reach = math.sqrt(ox * ox + oz * oz)
            radius = math.sqrt(spread[b])
            if reach - radius < cutoff:
                if reach > radius:
                    ox, oz = ox * (radius / reach), oz * (radius / reach)
                else:
                    ox = oz = 0.0
                obstacles[n_obs, 0], obstacles[n_obs, 2] = cx[b] + ox, cz[b] + oz
                obstacles[n_obs, 1] = hy
                n_obs += 1
        count = nearest_obstacle_nodes(pos, node_body, n_nodes, grid_start, grid_entries, cell, hx, hz,
                                       cutoff, step_over, blocked, skip[:n_skip], slot, scratch,
                                       found)  # fmt: skip
        for e in range(count):
            i = found[e]
            obstacles[n_obs, 0], obstacles[n_obs, 1], obstacles[n_obs, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
            n_obs += 1
        gx, gz = approach_field(hx, hz, ax, az, obstacles, n_obs, speed, push, cutoff, min_sq,
                                curl[k] != 0, fade)  # fmt: skip
        if kind != 0 and not squeezing:  # pursuit: match a moving target's pace on top of closing in
            gx += vx
            gz += vz
            pace = math.sqrt(gx * gx + gz * gz)
            if pace > speed:
                gx *= speed / pace
                gz *= speed / pace
        if not (math.isfinite(gx) and math.isfinite(gz)) or math.sqrt(gx * gx + gz * gz) > max_speed[k]:
            walk[c, 0], walk[c, 2] = gx, gz
            status[k] = CHECK
            continue
        walk[c, 0] = gx
        walk[c, 1] = 0.0
        walk[c, 2] = gz
        status[k] = SAT if mode[c] == SIT else WALKING


def _wall_table(walls: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The static bodies of :func:`_footprints` as arrays: bodies, offsets, their links (CSR)."""
    bodies = np.array(list(walls), dtype=np.int64)
    sizes = [len(rows) for rows in walls.values()]
    start = np.zeros(len(bodies) + 1, dtype=np.int64)
    start[1:] = np.cumsum(sizes)
    links = np.concatenate(list(walls.values())).astype(np.int64) if walls else np.zeros(0, dtype=np.int64)
    return bodies, start, links


#: Gathering: a stalled walker ends "done" when another character stands still this near it
#: (m at 1.75 m tall, plus 0.3 m), nearer the target by at least SETTLE_AHEAD - it is as
#: close as the others allow. Still: its pelvis slower than SETTLE_STILL.
SETTLE_NEAR = 1.8  # (1.5 before straight-legged standing: the second ring of ten settled 1.8-2.0 m
# out, 1.3 m beyond the first, and the small child there failed 'stuck')
SETTLE_AHEAD = 0.1
SETTLE_STILL = 0.3  # m/s


def _where(character, goal: Goal) -> np.ndarray:
    """The point an approach goal walks to, now."""
    return target_point(character, goal.params["target"])


def crowded_out(character, where: np.ndarray) -> bool:
    """Do others stand still between ``character`` and the point ``where``, nearer it: is it
    as close as they allow? (Ten walkers to one point: the outer ones stall behind the inner.)"""
    scene = character.scene
    state = scene.state
    ch = state.characters
    pelvis = ch.nodes[: ch.count, PELVIS]
    pos, prev = state.nodes.pos[pelvis], state.nodes.prev[pelvis]
    here = character.position
    near_me = np.hypot(pos[:, 0] - here[0], pos[:, 2] - here[2]) < SETTLE_NEAR * character.scale + 0.3
    mine = ground_distance(here, where)
    nearer = np.hypot(pos[:, 0] - where[0], pos[:, 2] - where[2]) < mine - SETTLE_AHEAD
    still = np.hypot(pos[:, 0] - prev[:, 0], pos[:, 2] - prev[:, 2]) < SETTLE_STILL * scene.dt
    others = np.arange(ch.count) != character.character_row
    return bool(np.any(near_me & nearer & still & others))


def steer_to(character, goal: Goal, target, stop_distance: float, direction=None, curl: bool = True,
             exclude: tuple[str, ...] = (), speed: float | None = None,
             squeeze: bool = False, settle: bool = False) -> bool:  # fmt: skip
    """Walk towards ``target`` until within ``stop_distance``; True once there.

    ``speed`` (m/s) overrides the steering's usual walking pace. ``squeeze``: after
    ``SQUEEZE_AFTER`` s without headway, squeeze past obstacles (see ``SQUEEZE``).
    ``settle``: a stall behind others standing nearer the target is arrival, not a failure
    (:func:`crowded_out`).

    Fails the goal when it stalls. ``direction`` (a ground vector) makes it arrive from
    that side of the target; by default it comes from where it is.
    """
    memory = goal.memory
    here = character.position
    where = target_point(character, target)
    if direction is None:
        direction = here - where
    direction = np.asarray(direction, dtype=np.float64) * np.array([1.0, 0.0, 1.0])
    norm = float(np.linalg.norm(direction))
    direction = direction / norm if norm > 1e-9 else np.zeros(3)
    aim = where + stop_distance * direction
    distance = ground_distance(here, where)
    if distance <= stop_distance + ARRIVE_SLACK:
        character.stop()
        return True
    scene = character.scene
    if distance < memory.get("best", np.inf) - 0.1:
        memory["best"], memory["best_at"] = distance, scene.time
    elif scene.time - memory.setdefault("best_at", scene.time) > STALL_TIME:
        character.stop()
        if settle and crowded_out(character, where):
            return True
        character.scene.end_goal(character, goal, False, f"stuck {distance:.2f} m from the target")
        return False
    ignore = set(exclude) | ({target} if isinstance(target, str) else set())
    params = SteeringParams(curl=curl) if speed is None else SteeringParams(curl=curl, speed=speed)
    if squeeze and scene.time - memory["best_at"] > SQUEEZE_AFTER:
        memory["squeeze_until"] = scene.time + SQUEEZE_HOLD
    squeezing = squeeze and scene.time < memory.get("squeeze_until", -np.inf)
    if squeezing:  # no headway for a while: squeeze through
        params = dataclasses.replace(params, repulsion=params.repulsion * SQUEEZE)
    obstacles = obstacles_near(character, ignore, params.cutoff, here)
    walk = approach_velocity(here, aim, obstacles, params)
    if isinstance(target, str) and not squeezing:
        # pursuit: match a moving target's pace on top of closing in, or one that walks
        # away is never caught (the field slows down over the last metre); not while
        # squeezing: two that approach each other would copy each other's dithering and
        # drift off together
        walk = walk + scene.entity(target).velocity * np.array([1.0, 0.0, 1.0])
        pace = float(np.linalg.norm(walk))
        if pace > params.speed:
            walk *= params.speed / pace
    character.walk(walk)
    return False


#: :func:`steer_goals`'s ``params``: the approach field's gains and the thresholds above.
_GOAL_PARAMS = np.array([SteeringParams().speed, SteeringParams().repulsion, SteeringParams().cutoff,
                         SteeringParams().min_sq, SteeringParams().fade, STEP_OVER, STALL_TIME, ARRIVE_SLACK,
                         STEER_CELL, SQUEEZE_AFTER, SQUEEZE, SQUEEZE_HOLD])  # fmt: skip


@dataclass
class _Batch:
    """The arrays :func:`steer_goals` reads for one set of approach goals, packed when the set
    (or the store's rows) changes: per-character Python only when a goal starts or ends."""

    key: tuple = ()
    setups: dict = field(default_factory=dict)  # goal id -> its packed row (see Approach._setup)
    rows: list = field(default_factory=list)  # per batch row: (character row, entity, goal)
    fallback: list = field(default_factory=list)  # (entity, goal): steered by Approach.act
    arrays: dict = field(default_factory=dict)
    best: np.ndarray = field(default_factory=lambda: np.full(0, np.inf))
    best_at: np.ndarray = field(default_factory=lambda: np.zeros(0))
    squeeze_until: np.ndarray = field(default_factory=lambda: np.zeros(0))


@register
class Approach(Behavior):
    """Walk to a target (an entity or a point) and stop at a distance from it.

    A batch behaviour: every character it wins is steered by one :func:`steer_goals`
    call; a goal is looked at in Python when it starts (:meth:`_setup`) and ends.
    """

    schema = GoalSchema(
        "approach",
        "Walk to an entity or a point round obstacles and stop `stop_distance` m off it.",
        (
            Param("target", "target", doc="the entity or point to walk to"),
            metres("stop_distance", 0.6, "how far from the target to stop"),
            Param("direction", "vector", None, doc="a ground vector to arrive along (unset: from anywhere)"),
            Param("arms", "choice", None, choices=("reach", "hug", "grapple"),
                  doc="the arms on the way: reach for it, or the hug or grapple pose (unset: they swing)"),
            Param("curl", "bool", True, doc="steer sideways round obstacles (off: straight at it)"),
        ),
    )  # fmt: skip
    batch = True

    def act(self, character, mind: Mind, goal: Goal | None, dt: float) -> None:
        """Steer; look at the target; hold the arms as asked (reach, hug or grapple).

        The per-character form of :meth:`act_batch` (for a target it cannot pack)."""
        p = goal.params
        target = p["target"]
        if isinstance(target, str):
            character.look_at(target)
        if p["arms"] in ("hug", "grapple"):
            character.pose(p["arms"])
        elif p["arms"] == "reach" and isinstance(target, str):
            character.reach(target, hand="both")
        if steer_to(character, goal, target, p["stop_distance"], p["direction"], p["curl"], settle=True):
            self.finish(character, goal)

    def _setup(self, row: int, entity: int, goal: Goal) -> tuple | None:
        """One goal's packed row: (pelvis, body, target (kind, node, first, count, body), point,
        stop, direction (x, y, z, set), curl, max speed, gaze node, arms); None for a
        target that is gone (the per-character path then says what happens)."""
        scene = self.scene
        ch = scene.state.characters
        p = goal.params
        target = p["target"]
        point = (0.0, 0.0, 0.0)
        kind, node, first, count, tbody, gaze = 0, -1, 0, 0, -1, -1
        if isinstance(target, str):
            if not scene.has_entity(target):
                return None
            other = scene.entity(target)
            body = other.body
            first, count, tbody = body.node_start, len(body.node_names), body.index
            other_character = self.world.try_component(other.entity, Character)
            if other_character is not None:
                kind, node = 2, int(ch.nodes[other_character.index, PELVIS])
            else:
                kind = 1
            names = body.node_names
            # look_at's node: its centre or spine, else the node nearest its middle (moves: -2)
            gaze = next((body.node_index(n) for n in ("centre", "spine") if n in names), -2)
        else:
            point = tuple(float(v) for v in np.asarray(target, dtype=np.float64))
        direction = (0.0, 0.0, 0.0, 0.0)
        if p["direction"] is not None:
            d = np.asarray(p["direction"], dtype=np.float64) * np.array([1.0, 0.0, 1.0])
            direction = (float(d[0]), 0.0, float(d[2]), 1.0)
        me = self.world.component_for_entity(entity, Character)
        arms = p["arms"] if (p["arms"] != "reach" or kind != 0) else None
        return (int(ch.nodes[row, PELVIS]), int(ch.body[row]), (kind, node, first, count, tbody), point,
                float(p["stop_distance"]), direction, bool(p["curl"]), float(me.max_speed), gaze,
                arms)  # fmt: skip

    def _pack(self, packed: _Batch, key: tuple, rows: list[int], entities: list[int], goals: list) -> None:
        """Gather the goals' packed rows into the kernel's arrays (when the set of goals changes)."""
        scene = self.scene
        state = scene.state
        if packed.key[1:] != key[1:]:  # rows moved, or another store: every goal again
            packed.setups.clear()
        live = set(key[0])
        for gid in [g for g in packed.setups if g not in live]:
            del packed.setups[gid]
        n_chars = state.characters.count
        if len(packed.best) < n_chars:
            grow = n_chars - len(packed.best)
            packed.best = np.concatenate([packed.best, np.full(grow, np.inf)])
            packed.best_at = np.concatenate([packed.best_at, np.zeros(grow)])
            packed.squeeze_until = np.concatenate([packed.squeeze_until, np.full(grow, -np.inf)])
        packed.rows, packed.fallback = [], []
        setups = []
        for row, entity, goal in zip(rows, entities, goals, strict=True):
            if goal is None:
                continue
            setup = packed.setups.get(goal.id)
            if setup is None:
                setup = self._setup(row, entity, goal)
                if setup is None:
                    packed.fallback.append((entity, goal))
                    continue
                packed.setups[goal.id] = setup
                # the stall clock lives in the goal's memory (snapshots keep it); a copy by row here
                packed.best[row] = goal.memory.get("best", np.inf)
                packed.best_at[row] = goal.memory.get("best_at", scene.time)
                packed.squeeze_until[row] = goal.memory.get("squeeze_until", -np.inf)
            packed.rows.append((row, entity, goal))
            setups.append(setup)
        n = len(setups)
        a = packed.arrays
        a["crows"] = np.array([r for r, _, _ in packed.rows], dtype=np.int64)
        a["pelvis"] = np.array([s[0] for s in setups], dtype=np.int64)
        a["me"] = np.array([s[1] for s in setups], dtype=np.int64)
        a["target"] = np.array([s[2] for s in setups], dtype=np.int64).reshape(n, 5)
        a["point"] = np.array([s[3] for s in setups], dtype=np.float64).reshape(n, 3)
        a["stop"] = np.array([s[4] for s in setups], dtype=np.float64)
        a["direction"] = np.array([s[5] for s in setups], dtype=np.float64).reshape(n, 4)
        a["curl"] = np.array([s[6] for s in setups], dtype=np.uint8)
        a["max_speed"] = np.array([s[7] for s in setups], dtype=np.float64)
        gaze = [(k, s[8]) for k, s in enumerate(setups) if s[8] != -1]
        a["gaze_rows"] = np.array([a["crows"][k] for k, g in gaze if g >= 0], dtype=np.int64)
        a["gaze_nodes"] = np.array([g for _, g in gaze if g >= 0], dtype=np.int64)
        a["gaze_moving"] = [k for k, g in gaze if g == -2]
        for arms in ("hug", "grapple", "reach"):
            picked = [k for k, s in enumerate(setups) if s[9] == arms and (arms != "reach" or s[8] >= 0)]
            a[arms] = a["crows"][picked]
            if arms == "reach":
                a["reach_nodes"] = np.array([setups[k][8] for k in picked], dtype=np.int64)
        a["reach_moving"] = [k for k, s in enumerate(setups) if s[9] == "reach" and s[8] == -2]
        holds = [(self.world.component_for_entity(e, Body).index, joint.held)
                 for e, character in self.world.get_component(Character) if character.holding
                 for joint in (self.world.try_component(g, GrabJoint) for g in character.holding.values())
                 if joint is not None]  # fmt: skip
        holder = [b for b, held in holds if self.world.has_component(held, Body)]
        a["grab_holder"] = np.array(holder, dtype=np.int64)
        a["grab_held"] = np.array([self.world.component_for_entity(held, Body).index for _, held in holds
                                   if self.world.has_component(held, Body)], dtype=np.int64)  # fmt: skip
        a["skip"] = np.empty(2 + 2 * len(holder), dtype=np.int64)
        # two characters approaching each other: each copies the other's dithering (pursuit),
        # the case that squeezes (see SQUEEZE)
        aims = {s[1]: s[2][4] for s in setups if s[2][0] == 2}
        a["mutual"] = np.array([s[2][0] == 2 and aims.get(s[2][4]) == s[1] for s in setups], dtype=np.uint8)
        for name, dtype in (("status", np.int64), ("distance", np.float64), ("improved", np.uint8)):
            a[name] = np.empty(n, dtype=dtype)
        packed.key = key

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """Steer every approaching character in one :func:`steer_goals` call; end goals that
        arrived or stalled, and do the rare per-character parts (a sitter stands up)."""
        scene = self.scene
        state = scene.state
        if goals is None:
            goals = [self.world.component_for_entity(e, Mind).goal for e in entities]
        packed = self.scratch.get("packed")  # rebuilt from the goals when they change
        if packed is None:
            packed = self.scratch["packed"] = _Batch()
        key = (tuple(-1 if g is None else g.id for g in goals), state.version, state.nodes.count,
               state.bodies.count, id(state))  # fmt: skip
        if key != packed.key:
            self._pack(packed, key, rows, entities, goals)
        a = packed.arrays
        ch, nodes, links = state.characters, state.nodes, state.links
        # what the per-character act writes before it steers: gaze and arms
        if len(a["gaze_rows"]):
            ch.gaze_node[a["gaze_rows"]] = a["gaze_nodes"]
            ch.gaze_mode[a["gaze_rows"]] = GAZE_NODE
        if len(a["hug"]):
            ch.arm_mode[a["hug"]] = HUG
        if len(a["grapple"]):
            ch.arm_mode[a["grapple"]] = GRAPPLE
        if len(a["reach"]):
            ch.arm_node[a["reach"]] = a["reach_nodes"][:, None]
            ch.arm_mode[a["reach"]] = REACH
        for k in a["gaze_moving"]:
            row, entity, goal = packed.rows[k]
            scene.character_handle(entity).look_at(goal.params["target"])
        for k in a["reach_moving"]:
            row, entity, goal = packed.rows[k]
            scene.character_handle(entity).reach(goal.params["target"], hand="both")
        if len(packed.rows):
            index = SpatialIndex.of(scene)
            start, entries, slot, scratch, found = index.grid(scene)
            cx, cz, spread, wide, walls, blocked = index.footprints(scene)
            wall_body, wall_start, wall_links = _wall_table(walls)
            obstacles = np.empty((len(walls) + int(wide.sum()) + state.bodies.count, 3))
            steer_goals(nodes.pos, nodes.prev, nodes.mass, nodes.body, nodes.count, start, entries,
                        a["crows"], a["pelvis"], a["me"], a["target"], a["point"], a["stop"], a["direction"],
                        a["curl"], a["max_speed"], ch.mode, packed.best, packed.best_at,
                        packed.squeeze_until, scene.time, scene.dt,
                        _GOAL_PARAMS,
                        cx, cz, spread, np.flatnonzero(wide), blocked, wall_body, wall_start, wall_links,
                        links.a, links.b,
                        a["grab_holder"], a["grab_held"], slot, scratch, found, obstacles, a["skip"], ch.walk,
                        a["status"], a["distance"], a["improved"], a["mutual"])  # fmt: skip
            for k in np.flatnonzero(a["improved"]):
                row, _, goal = packed.rows[k]
                goal.memory.update(best=float(packed.best[row]), best_at=float(packed.best_at[row]))
                if packed.squeeze_until[row] > -np.inf:
                    goal.memory["squeeze_until"] = float(packed.squeeze_until[row])
            for k in np.flatnonzero(a["status"] != WALKING):
                row, entity, goal = packed.rows[k]
                character = scene.character_handle(entity)
                status = a["status"][k]
                if status == ARRIVED:
                    self.finish(character, goal)
                elif status == STUCK and crowded_out(character, _where(character, goal)):
                    self.finish(character, goal)  # as close as the others allow: gathered round it
                elif status == STUCK:
                    self.finish(character, goal, False, f"stuck {a['distance'][k]:.2f} m from the target")
                elif status == SAT:
                    character.stand()
                else:  # CHECK: a walk vector it cannot do - the handle says why
                    character.walk(ch.walk[row].copy())
        for entity, goal in packed.fallback:
            self.act(scene.character_handle(entity), self.world.component_for_entity(entity, Mind), goal, dt)

    def stop(self, character, goal: Goal | None) -> None:
        """Stand still, arms down, looking ahead."""
        packed = self.scratch.get("packed")
        if packed is not None and goal is not None:
            packed.setups.pop(goal.id, None)  # resumed later: the stall clock comes from its memory
        character.stop()
        character.look_at(None)
        character.pose("hang")
