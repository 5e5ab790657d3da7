"""approach: walk to a target around obstacles, then stop at a distance (SPEC 4).

A goal-driven behaviour (``character.approach(target, stop_distance=..., direction=...,
arms=...)``). Each step it steers with the attraction + curl-repulsion field of
:mod:`twig_ecs.steering` and looks at the target; it is done within the stop distance
and fails when it makes no headway for ``STALL_TIME`` seconds. Hug, grapple, carry and
drag use :func:`steer_to` for their own approach phases.
"""

from __future__ import annotations

import weakref

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.goals import GoalSchema, Param, metres
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.store import LINK_COLLIDE, NODE_LOCKED

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


def _footprints(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
    """Each body's ground centre (x, z), squared spread, whether it is WIDE, and, for a
    static body (every node locked: a fence, a wall), its collidable links; computed
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
    result = (cx, cz, spread, (np.sqrt(spread) > WIDE) & ~static, walls)
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


def obstacles_near(character, exclude: set[str], cutoff: float) -> np.ndarray:
    """The nearest node of every other body within ``cutoff`` (ground plane), as points;
    for a wide body, the nearest point of the disc it covers."""
    scene = character.scene
    state = scene.state
    here = character.position
    pos, body = state.nodes.pos[: state.nodes.count], state.nodes.body[: state.nodes.count]
    d2 = (pos[:, 0] - here[0]) ** 2 + (pos[:, 2] - here[2]) ** 2
    near = np.flatnonzero(d2 < cutoff**2)
    # what it carries is no obstacle, and neither is what the target carries
    exclude = set(exclude) | set(character.holding.values())
    for name in list(exclude):
        other = scene.entity(name) if name in scene.entity_names else None
        if other is not None and hasattr(other, "holding"):
            exclude |= set(other.holding.values())
    skip = {character.body.index} | {scene.entity(n).body.index for n in exclude if n in scene.entity_names}
    points = []
    # a wide body (a merry-go-round's deck) is a disc to go round, however low it lies:
    # its nearest node can be a metre from the bar one would walk into, and stepping
    # across a turning deck catches the legs in its bars
    cx, cz, spread, wide, walls = _footprints(scene)
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
    best: dict[int, int] = {}
    for i in near:
        b = int(body[i])
        if b in skip or wide[b] or b in walls or pos[i, 1] <= STEP_OVER:
            continue
        if b not in best or d2[i] < d2[best[b]]:
            best[b] = int(i)
    points += [pos[i] for i in best.values()]
    return np.array(points) if points else np.zeros((0, 3))


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
    obstacles = obstacles_near(character, ignore, params.cutoff)
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
