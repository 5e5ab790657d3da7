"""approach: walk to a target around obstacles, then stop at a distance (SPEC 4).

A goal-driven behaviour (``character.approach(target, stop_distance=..., direction=...,
arms=...)``). Each step it steers with the attraction + curl-repulsion field of
:mod:`twig_ecs.steering` and looks at the target; it is done within the stop distance
and fails when it makes no headway for ``STALL_TIME`` seconds. Hug, grapple, carry and
drag use :func:`steer_to` for their own approach phases.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.goals import GoalSchema, Param, metres
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.store import LINK_COLLIDE, NODE_LOCKED
from twig_ecs.systems.collide import _cell_hash

STALL_TIME = 4.0  # s without getting 10 cm closer: give up
STEP_OVER = 0.3  # m: bodies with no node higher than this are no obstacle
WIDE = 1.0  # m: a body whose nodes spread further than this from its centre is steered round as a disc
ARRIVE_SLACK = 0.1  # m beyond the stop distance that still counts as there


def target_point(character, target) -> np.ndarray:
    """Where a target is: a point as given, or an entity's centre of mass."""
    if isinstance(target, str):
        return character.scene.entity(target).position
    return np.asarray(target, dtype=np.float64)


_FOOTPRINTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _footprints(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict, np.ndarray]:
    """Each body's ground centre (x, z), squared spread, whether it is WIDE, and, for a
    static body (every node locked: a fence, a wall), its collidable links, and which
    bodies are either (steered round by their shape, not their nearest node); computed
    once per step however many characters steer (kept aside, not in the scene's state)."""
    cached = _FOOTPRINTS.get(scene)
    if cached is not None and cached[0] == scene.frame:
        return cached[1]
    state = scene.state
    pos, body = state.nodes.pos[: state.nodes.count], state.nodes.body[: state.nodes.count]
    n_bodies = state.bodies.count
    counts = np.maximum(np.bincount(body, minlength=n_bodies), 1)
    cx = np.bincount(body, pos[:, 0], n_bodies) / counts
    cz = np.bincount(body, pos[:, 2], n_bodies) / counts
    spread = np.zeros(n_bodies)
    np.maximum.at(spread, body, (pos[:, 0] - cx[body]) ** 2 + (pos[:, 2] - cz[body]) ** 2)
    free = np.bincount(body, (state.nodes.flags[: state.nodes.count] & NODE_LOCKED) == 0, n_bodies)
    static = (free == 0) & (np.sqrt(spread) > WIDE)
    links = state.links
    collide = (links.flags[: links.count] & LINK_COLLIDE) != 0
    walls = {
        int(b): np.flatnonzero(collide & (links.body[: links.count] == b)) for b in np.flatnonzero(static)
    }
    wide = (np.sqrt(spread) > WIDE) & ~static
    # bodies steered round as discs or walls, not by their nearest node
    blocked = wide | static
    result = (cx, cz, spread, wide, walls, blocked)
    _FOOTPRINTS[scene] = (scene.frame, result)
    return result


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


#: Edge (m) of the ground grid steering finds obstacles in: above the usual cut-off
#: (1.8 m), so a character's disc spans at most 2 x 2 cells.
STEER_CELL = 2.0
#: A disc spanning more cells than this (a cut-off much longer than the cell) scans every node.
MAX_CELLS = 16


@njit(cache=True, inline="always")
def _ground_bucket(x, z, cell, mask):
    """The hash bucket of the ground cell holding (x, z); a lost (non-finite) node goes in bucket 0."""
    if not (math.isfinite(x) and math.isfinite(z)):
        return 0
    return _cell_hash(int(math.floor(x / cell)), 0, int(math.floor(z / cell)), mask)


@njit(cache=True)
def ground_grid(pos, n, cell, start, entries):
    """Bin the first ``n`` nodes by their ground cell (x, z) in a spatial hash.

    ``start`` is a power of two plus one long: bucket h holds the node rows
    ``entries[start[h]:start[h + 1]]``, in ascending order. Built once per step and
    shared by every character that steers (:func:`nearest_obstacle_nodes`).
    """
    mask = len(start) - 2
    start[:] = 0
    for i in range(n):
        h = _ground_bucket(pos[i, 0], pos[i, 2], cell, mask)
        start[h + 1] += 1
    for h in range(mask + 1):
        start[h + 1] += start[h]
    fill = start[:-1].copy()
    for i in range(n):
        h = _ground_bucket(pos[i, 0], pos[i, 2], cell, mask)
        entries[fill[h]] = i
        fill[h] += 1


@njit(cache=True)
def nearest_obstacle_nodes(pos, body, n, start, entries, cell, x, z, cutoff, step_over, blocked, skip,
                           best, scratch, out):  # fmt: skip
    """The nearest node of every body within ``cutoff`` of (x, z) on the ground that stands
    higher than ``step_over``, into ``out``; returns how many.

    Bodies flagged in ``blocked`` (steered round another way) and those in ``skip`` are
    left out. The candidates come from the grid cells the disc touches, visited in
    ascending node order, so the result - which node wins a tie, and the order of the
    bodies (by their first node in reach) - is the same as scanning every node.
    ``best`` (one slot per body) must hold -1 and is left so; ``scratch`` holds ``n``.
    """
    mask = len(start) - 2
    lo_x, hi_x = int(math.floor((x - cutoff) / cell)), int(math.floor((x + cutoff) / cell))
    lo_z, hi_z = int(math.floor((z - cutoff) / cell)), int(math.floor((z + cutoff) / cell))
    m = 0
    if (hi_x - lo_x + 1) * (hi_z - lo_z + 1) > MAX_CELLS or not (math.isfinite(x) and math.isfinite(z)):
        for i in range(n):
            scratch[i] = i
        m = n
    else:
        buckets = np.empty(MAX_CELLS, dtype=np.int64)
        nb = 0
        for ix in range(lo_x, hi_x + 1):
            for iz in range(lo_z, hi_z + 1):
                h = _cell_hash(ix, 0, iz, mask)
                seen = False
                for k in range(nb):  # two cells can share a bucket: take its nodes once
                    if buckets[k] == h:
                        seen = True
                if seen:
                    continue
                buckets[nb] = h
                nb += 1
                for e in range(start[h], start[h + 1]):
                    scratch[m] = entries[e]
                    m += 1
        scratch[:m].sort()
    reach = cutoff**2
    count = 0
    for c in range(m):
        i = scratch[c]
        d2 = (pos[i, 0] - x) ** 2 + (pos[i, 2] - z) ** 2
        if not d2 < reach:
            continue
        b = body[i]
        if blocked[b] or pos[i, 1] <= step_over:
            continue
        skipped = False
        for k in range(len(skip)):
            if skip[k] == b:
                skipped = True
        if skipped:
            continue
        j = best[b]
        if j < 0:
            best[b] = i
            out[count] = b
            count += 1
        elif d2 < (pos[j, 0] - x) ** 2 + (pos[j, 2] - z) ** 2:
            best[b] = i
    for k in range(count):  # bodies to their nearest nodes; the slots back to -1
        b = out[k]
        out[k] = best[b]
        best[b] = -1
    return count


_GRIDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _steering_grid(scene) -> tuple:
    """This step's ground grid of the nodes and the scratch arrays of a query (built on the
    first call of a step, shared by every character; nodes stand still from the collide
    pass until gait, which is when behaviours steer)."""
    state = scene.state
    n = state.nodes.count
    cached = _GRIDS.get(scene)
    if cached is not None and cached[0] == (scene.frame, n, state.bodies.count):
        return cached[1]
    size = 1 << max(4, int(2 * n - 1).bit_length())  # >= 2 x nodes, a power of two
    start = np.empty(size + 1, dtype=np.int64)
    entries = np.empty(max(n, 1), dtype=np.int64)
    ground_grid(state.nodes.pos, n, STEER_CELL, start, entries)
    best = np.full(state.bodies.count, -1, dtype=np.int64)
    grid = (start, entries, best, np.empty(max(n, 1), dtype=np.int64), np.empty(max(n, 1), dtype=np.int64))
    _GRIDS[scene] = ((scene.frame, n, state.bodies.count), grid)
    return grid


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
    cx, cz, spread, wide, walls, blocked = _footprints(scene)
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
    start, entries, best, scratch, out = _steering_grid(scene)
    skip_rows = np.array(sorted(skip), dtype=np.int64)
    count = nearest_obstacle_nodes(state.nodes.pos, state.nodes.body, state.nodes.count, start, entries,
                                   STEER_CELL, float(here[0]), float(here[2]), float(cutoff), STEP_OVER,
                                   blocked, skip_rows, best, scratch, out)  # fmt: skip
    nodes = state.nodes.pos[out[:count]]
    if points:
        return np.concatenate([np.array(points), nodes]) if count else np.array(points)
    return nodes if count else np.zeros((0, 3))


def steer_to(character, goal: Goal, target, stop_distance: float, direction=None, curl: bool = True,
             exclude: tuple[str, ...] = (), speed: float | None = None) -> bool:  # fmt: skip
    """Walk towards ``target`` until within ``stop_distance``; True once there.

    ``speed`` (m/s) overrides the steering's usual walking pace.

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
        character.scene.end_goal(character, goal, False, f"stuck {distance:.2f} m from the target")
        return False
    ignore = set(exclude) | ({target} if isinstance(target, str) else set())
    params = SteeringParams(curl=curl) if speed is None else SteeringParams(curl=curl, speed=speed)
    obstacles = obstacles_near(character, ignore, params.cutoff, here)
    walk = approach_velocity(here, aim, obstacles, params)
    if isinstance(target, str):
        # pursuit: match a moving target's pace on top of closing in, or one that walks
        # away is never caught (the field slows down over the last metre)
        walk = walk + scene.entity(target).velocity * np.array([1.0, 0.0, 1.0])
        pace = float(np.linalg.norm(walk))
        if pace > params.speed:
            walk *= params.speed / pace
    character.walk(walk)
    return False


@register
class Approach(Behavior):
    """Walk to a target (an entity or a point) and stop at a distance from it."""

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

    def act(self, character, mind: Mind, goal: Goal | None, dt: float) -> None:
        """Steer; look at the target; hold the arms as asked (reach, hug or grapple)."""
        p = goal.params
        target = p["target"]
        if isinstance(target, str):
            character.look_at(target)
        if p["arms"] in ("hug", "grapple"):
            character.pose(p["arms"])
        elif p["arms"] == "reach" and isinstance(target, str):
            character.reach(target, hand="both")
        if steer_to(character, goal, target, p["stop_distance"], p["direction"], p["curl"]):
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Stand still, arms down, looking ahead."""
        character.stop()
        character.look_at(None)
        character.pose("hang")
