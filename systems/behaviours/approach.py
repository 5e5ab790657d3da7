"""approach: walk to a target around obstacles, then stop at a distance (SPEC 4).

A goal-driven behaviour (``character.approach(target, stop_distance=..., direction=...,
arms=...)``). Each step it steers with the attraction + curl-repulsion field of
:mod:`twig_ecs.steering` and looks at the target; it is done within the stop distance
and fails when it makes no headway for ``STALL_TIME`` seconds. Hug, grapple, carry,
drag, follow and sit use :func:`steer_to` for their own approach phases, play and ride
:func:`walk_towards` (a walk vector, no arrival or stall clock). All are rows
of the one steering kernel (:mod:`twig_ecs.systems.control.steer`); the goals' rows are
kept in a :class:`~twig_ecs.rowtable.RowTable`.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.components import Body, Character, GrabJoint
from twig_ecs.goals import GoalSchema, Param, metres
from twig_ecs.kernelmath import GAZE_NODE, GRAPPLE, HUG, PELVIS, REACH
from twig_ecs.rowtable import Column, RowTable
from twig_ecs.steering import ground_distance
from twig_ecs.store import LayoutCache
from twig_ecs.systems.control.spatial import STEP_OVER
from twig_ecs.systems.control.steer import (  # noqa: F401 (the statuses: what approach's callers read)
    ALONG_UNIT,
    ARRIVED,
    CHECK,
    SAT,
    STUCK,
    WALKING,
    Gains,
    Walkers,
    around,
    gains,
    row_obstacles,
    steer_rows,
    walkers,
)

STALL_TIME = 4.0  # s without getting 10 cm closer: give up
ARRIVE_SLACK = 0.1  # m beyond the stop distance that still counts as there
#: s without getting 10 cm closer after which two characters approaching each other squeeze:
#: obstacles push them ``SQUEEZE`` times as hard and neither adds the other's pace (pursuit).
#: Two people standing a body's width apart or more make a dip in the field before the gap
#: between them (their pushes cancel in the gap, not before it), where the walk vector
#: swings to and fro; two walkers there that pursue each other copy each other's dithering
#: and drift off together, and their goals fail 'stuck'. Pushed less and heading for where
#: the other is, they walk into the gap and the collisions see them past. Only that pair
#: squeezes (``squeeze`` rows of :func:`steer_rows`): a walker whose target does not come
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


def obstacles_near(character, exclude: set[str], cutoff: float) -> np.ndarray:
    """The obstacle points the steering kernel sees round ``character`` within ``cutoff`` m
    (ground plane), in the order it sums them: the nearest point of each wall, the nearest
    rim point of each wide body, the nearest node of every other body higher than a step.
    ``exclude``: entities that are no obstacle (a target); what it holds, and what those
    hold, are none either. (A query for tests and tools: the kernel gathers its own.)"""
    scene = character.scene
    skip = np.array([scene.entity(name).body.index for name in sorted(exclude) if scene.has_entity(name)],
                    dtype=np.int64)  # fmt: skip
    at = around(scene, holds_now(scene), extra_skip=len(skip))
    here = character.position
    count = row_obstacles(at, here[0], here[1], here[2], character.body.index, skip, cutoff, STEP_OVER)
    return at.obstacles[:count].copy()


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

    The steering kernel's one-row batch (:func:`~twig_ecs.systems.control.steer.steer_rows`):
    the target's point and the direction are found here, the walk vector there, and a
    named target's pace is added here (numpy's arithmetic, as before the kernel steered it).
    """
    memory = goal.memory
    scene = character.scene
    here = character.position
    where = target_point(character, target)
    if direction is None:
        direction = here - where
    direction = np.asarray(direction, dtype=np.float64) * np.array([1.0, 0.0, 1.0])
    norm = float(np.linalg.norm(direction))
    direction = direction / norm if norm > 1e-9 else np.zeros(3)
    ignore = set(exclude) | ({target} if isinstance(target, str) else set())
    row = _one_row(character, where, speed, ignore)
    row.stop[0] = stop_distance
    row.arrive[0] = stop_distance + ARRIVE_SLACK
    row.direction[0] = (direction[0], direction[1], direction[2], ALONG_UNIT)
    row.curl[0] = curl
    row.stall[0] = STALL_TIME
    row.squeeze[0] = squeeze
    before = (memory.get("best", np.inf), memory.get("best_at", scene.time),
              memory.get("squeeze_until", -np.inf))  # fmt: skip
    row.best[0], row.best_at[0], row.squeeze_until[0] = before
    walk = _steer_one(character, row, _GAINS)
    status, distance = row.status[0], float(row.distance[0])
    if status == ARRIVED:
        character.stop()
        return True
    if row.best[0] != before[0]:
        memory["best"], memory["best_at"] = distance, scene.time
    else:
        memory.setdefault("best_at", scene.time)
    if row.squeeze_until[0] != before[2]:
        memory["squeeze_until"] = float(row.squeeze_until[0])
    if status == STUCK:
        character.stop()
        if settle and crowded_out(character, where):
            return True
        character.scene.end_goal(character, goal, False, f"stuck {distance:.2f} m from the target")
        return False
    walk = walk[0].copy()
    squeezing = squeeze and scene.time < row.squeeze_until[0]
    if isinstance(target, str) and not squeezing:
        # pursuit: match a moving target's pace on top of closing in, or one that walks
        # away is never caught (the field slows down over the last metre); not while
        # squeezing: two that approach each other would copy each other's dithering and
        # drift off together
        walk = walk + scene.entity(target).velocity * np.array([1.0, 0.0, 1.0])
        pace = float(np.linalg.norm(walk))
        if pace > row.speed[0]:
            walk *= row.speed[0] / pace
    character.walk(walk)
    return False


def walk_towards(character, point: np.ndarray, speed: float, exclude: tuple[str, ...] = (),
                 cutoff: float | None = None) -> np.ndarray:  # fmt: skip
    """The walk vector (x, 0, z) that takes ``character`` towards ``point`` round what is in the
    way, at ``speed`` m/s: the steering kernel's one-row batch without its arrival or stall
    clock, for a behaviour that judges by its own rules when it is there (play, ride).

    ``exclude``: entities that are no obstacle; ``cutoff`` (m): obstacles further off are
    none (default: the field's, :class:`~twig_ecs.steering.SteeringParams`).
    """
    row = _one_row(character, point, speed, exclude)
    row.arrive[0] = -np.inf  # never there: the caller decides
    field = _FIELD_GAINS if cutoff is None else _FIELD_GAINS._replace(cutoff=cutoff)
    return _steer_one(character, row, field)[0]


def steer_batch(scene, crows: np.ndarray, skip_bodies: np.ndarray, there: np.ndarray, direction: np.ndarray,
                stop, speed, memories: list[dict]):  # fmt: skip
    """The steering kernel's call of :func:`steer_to` for many walkers at once (the hug's and the
    brawl's walk-ups): character ``crows[k]`` walks to ``there[k]``, stopping ``stop`` (m, one or
    per row) short, at ``speed`` (m/s, one or per row), body ``skip_bodies[k]`` no obstacle to it,
    ``direction[k]`` the unit ground vector from the point to it (the caller's arithmetic), its
    stall clock read from ``memories[k]`` (its goal's).

    Returns (the walkers after the call, the walk vectors, ``best`` and ``squeeze_until`` as they
    were before it, the time) - the caller writes the clocks back as its goals keep them; None
    when one has stalled or asks for a walk it cannot do (the per-character form says why)."""
    n = len(crows)
    ch = scene.state.characters
    w = walkers(n)._replace(crows=np.arange(n), skip_bodies=skip_bodies, skip_start=np.arange(n),
                            skip_count=np.ones(n, dtype=np.int64))  # fmt: skip
    w.stop[:] = stop
    w.pelvis[:] = ch.nodes[crows, PELVIS]
    w.me[:] = ch.body[crows]
    w.point[:] = there
    w.arrive[:] = stop + ARRIVE_SLACK
    w.direction[:, :3] = direction
    w.direction[:, 3] = ALONG_UNIT
    w.speed[:] = speed
    w.stall[:] = STALL_TIME
    now = scene.time
    w.best[:] = [m.get("best", np.inf) for m in memories]
    w.best_at[:] = [m.get("best_at", now) for m in memories]
    w.squeeze_until[:] = [m.get("squeeze_until", -np.inf) for m in memories]
    best, squeeze_until = w.best.copy(), w.squeeze_until.copy()
    walk = np.zeros((n, 3))
    steer_rows(around(scene, holds_now(scene), extra_skip=1), w, _GAINS, walk, ch.mode[crows], now,
               scene.dt)  # fmt: skip
    if ((w.status != WALKING) & (w.status != SAT) & (w.status != ARRIVED)).any():
        return None  # stalled (the goal fails), or a walk it cannot do
    return w, walk, best, squeeze_until, now


def _one_row(character, point, speed: float | None, exclude) -> Walkers:
    """A one-row batch of :func:`steer_rows` for ``character`` walking to ``point`` (from
    where it is, at ``speed``: None, the field's pace), the entities ``exclude`` names no obstacle."""
    scene = character.scene
    row = walkers(1)
    row.pelvis[0] = scene.state.characters.nodes[character.character_row, PELVIS]
    row.me[0] = character.body.index
    row.point[0] = point
    if speed is not None:
        row.speed[0] = speed
    skip = [scene.entity(name).body.index for name in sorted(exclude) if scene.has_entity(name)]
    row.skip_count[0] = len(skip)
    return row._replace(skip_bodies=np.array(skip, dtype=np.int64)) if skip else row


def _steer_one(character, row: Walkers, field: Gains) -> np.ndarray:
    """Run the steering kernel on the one-row batch ``row``; its walk vector, as a (1, 3) array."""
    scene = character.scene
    walk = np.zeros((1, 3))
    me = character.character_row
    steer_rows(around(scene, holds_now(scene), extra_skip=len(row.skip_bodies)), row, field, walk,
               scene.state.characters.mode[me : me + 1], scene.time, scene.dt)  # fmt: skip
    return walk


#: Per store: :func:`grab_pairs`, by layout version.
_HOLDS = LayoutCache()


def holds_now(scene) -> tuple[np.ndarray, np.ndarray]:
    """:func:`grab_pairs` of ``scene``'s world, the same tuple until the store's layout changes
    (every grab and every release adds or removes a link row): what :func:`around` keeps
    its arrays for."""
    return _HOLDS.get(scene.state, scene.state.version, lambda: grab_pairs(scene.world))


def grab_pairs(world) -> tuple[np.ndarray, np.ndarray]:
    """(holder, held) body rows of every grab joint a character holds by: what it holds is
    no obstacle to its steering (nor what its target holds)."""
    holds = [(world.component_for_entity(e, Body).index, joint.held)
             for e, character in world.get_component(Character) if character.holding
             for joint in (world.try_component(g, GrabJoint) for g in character.holding.values())
             if joint is not None]  # fmt: skip
    holder = [b for b, held in holds if world.has_component(held, Body)]
    held = [world.component_for_entity(h, Body).index for _, h in holds if world.has_component(h, Body)]
    return np.array(holder, dtype=np.int64), np.array(held, dtype=np.int64)


#: The field's gains and the squeeze's figures (:func:`steer_rows`).
_GAINS = gains(SQUEEZE_AFTER, SQUEEZE, SQUEEZE_HOLD)
#: The field's gains alone (no squeeze): :func:`walk_towards`.
_FIELD_GAINS = gains()


#: An approach goal's row in the behaviour's table (:meth:`Approach._setup` makes it): where it
#: steers from, to what, how; and its stall clock (a copy of the goal's memory, which
#: snapshots keep: the kernel updates the row, the row updates the memory).
_GOAL_ROW = {
    "pelvis": Column(np.int64),
    "me": Column(np.int64),  # its body row
    "target": Column(np.int64, (5,)),  # (kind, pelvis node, first node, node count, body)
    "point": Column(np.float64, (3,)),
    "stop": Column(np.float64),
    "arrive": Column(np.float64),  # the stop distance and ARRIVE_SLACK
    "skip": Column(np.int64, ragged=True),  # the target's body: no obstacle
    "direction": Column(np.float64, (4,)),  # (x, y, z, how: steer.FROM_HERE or steer.ALONG)
    "curl": Column(np.uint8),
    "max_speed": Column(np.float64),
    "gaze": Column(np.int64),  # node to look at; -2: a target that moves (looked at in Python); -1: none
    "arms": Column(object),  # "hug", "grapple", "reach" or None
    "best": Column(np.float64),
    "best_at": Column(np.float64),
    "squeeze_until": Column(np.float64),
}


@register
class Approach(Behavior):
    """Walk to a target (an entity or a point) and stop at a distance from it.

    A batch behaviour: every character it wins is steered by one :func:`steer_rows`
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

    def _setup(self, row: int, entity: int, goal: Goal) -> dict | None:
        """One goal's row of the table (see ``_GOAL_ROW``); None for a target that is gone
        (the per-character path then says what happens)."""
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
        memory = goal.memory  # the stall clock: the goal's memory keeps it (snapshots do), a copy here
        return dict(pelvis=int(ch.nodes[row, PELVIS]), me=int(ch.body[row]),
                    target=(kind, node, first, count, tbody), point=point, stop=float(p["stop_distance"]),
                    arrive=float(p["stop_distance"]) + ARRIVE_SLACK, skip=[tbody] if tbody >= 0 else [],
                    direction=direction, curl=bool(p["curl"]), max_speed=float(me.max_speed), gaze=gaze,
                    arms=arms, best=memory.get("best", np.inf), best_at=memory.get("best_at", scene.time),
                    squeeze_until=memory.get("squeeze_until", -np.inf))  # fmt: skip

    def _table(self) -> RowTable:
        """This behaviour's table of approach goals (a cache: the goals' memories are the state)."""
        table = self.scratch.get("goals")
        if table is None:
            table = self.scratch["goals"] = RowTable(**_GOAL_ROW)
        return table

    def _pack(self, table: RowTable, rows: list[int], entities: list[int], goals: list) -> dict:
        """The kernel's arrays derived from the table's rows (when the set of goals changes)."""
        a = {}
        k_rows = table.positions
        a["crows"] = np.array(rows, dtype=np.int64)[k_rows] if len(k_rows) else np.zeros(0, dtype=np.int64)
        a["entries"] = [(rows[i], entities[i], goals[i]) for i in k_rows]
        a["fallback"] = [(entities[i], goals[i]) for i in table.missing]
        gaze, arms_of = table["gaze"], table["arms"]
        looked = np.flatnonzero(gaze >= 0)
        a["gaze_rows"], a["gaze_nodes"] = a["crows"][looked], gaze[looked]
        a["gaze_moving"] = np.flatnonzero(gaze == -2).tolist()
        for arms in ("hug", "grapple", "reach"):
            picked = [
                k for k in range(len(table)) if arms_of[k] == arms and (arms != "reach" or gaze[k] >= 0)
            ]
            a[arms] = a["crows"][picked]
            if arms == "reach":
                a["reach_nodes"] = gaze[picked]
        a["reach_moving"] = [k for k in range(len(table)) if arms_of[k] == "reach" and gaze[k] == -2]
        a["holds"] = grab_pairs(self.world)  # (as of the packing, like the rest)
        # two characters approaching each other: each copies the other's dithering (pursuit),
        # the case that squeezes (see SQUEEZE)
        target, me = table["target"], table["me"]
        aims = {int(me[k]): int(target[k, 4]) for k in range(len(table)) if target[k, 0] == 2}
        a["mutual"] = np.array([target[k, 0] == 2 and aims.get(int(target[k, 4])) == me[k]
                                for k in range(len(table))], dtype=np.uint8)  # fmt: skip
        n = len(table)
        a["walkers"] = walkers(n)._replace(
            crows=a["crows"], pelvis=table["pelvis"], me=table["me"], target=table["target"],
            point=table["point"], stop=table["stop"], arrive=table["arrive"], direction=table["direction"],
            curl=table["curl"],
            max_speed=table["max_speed"], stall=np.full(n, STALL_TIME), squeeze=a["mutual"],
            skip_bodies=table["skip"], skip_start=table["skip_start"], skip_count=table["skip_count"],
            best=table["best"], best_at=table["best_at"], squeeze_until=table["squeeze_until"],
        )  # fmt: skip
        return a

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """Steer every approaching character in one :func:`steer_rows` call; end goals that
        arrived or stalled, and do the rare per-character parts (a sitter stands up)."""
        scene = self.scene
        state = scene.state
        if goals is None:
            goals = [self.world.component_for_entity(e, Mind).goal for e in entities]
        table = self._table()
        live = [k for k, g in enumerate(goals) if g is not None]
        layout = (state.version, state.nodes.count, state.bodies.count, id(state))
        rows = [rows[k] for k in live]
        entities = [entities[k] for k in live]
        goals = [goals[k] for k in live]
        if table.sync(
            [g.id for g in goals], layout, lambda i, _: self._setup(rows[i], entities[i], goals[i])
        ):
            self.scratch["arrays"] = self._pack(table, rows, entities, goals)
        a = self.scratch["arrays"]
        entries = a["entries"]
        ch = state.characters
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
            row, entity, goal = entries[k]
            scene.character_handle(entity).look_at(goal.params["target"])
        for k in a["reach_moving"]:
            row, entity, goal = entries[k]
            scene.character_handle(entity).reach(goal.params["target"], hand="both")
        if len(entries):
            w = a["walkers"]
            at = around(scene, a["holds"], extra_skip=1)
            steer_rows(at, w, _GAINS, ch.walk, ch.mode, scene.time, scene.dt)
            for k in np.flatnonzero(w.improved):
                _, _, goal = entries[k]
                goal.memory.update(best=float(w.best[k]), best_at=float(w.best_at[k]))
                if w.squeeze_until[k] > -np.inf:
                    goal.memory["squeeze_until"] = float(w.squeeze_until[k])
            for k in np.flatnonzero(w.status != WALKING):
                row, entity, goal = entries[k]
                character = scene.character_handle(entity)
                status = w.status[k]
                if status == ARRIVED:
                    self.finish(character, goal)
                elif status == STUCK and crowded_out(character, _where(character, goal)):
                    self.finish(character, goal)  # as close as the others allow: gathered round it
                elif status == STUCK:
                    self.finish(character, goal, False, f"stuck {w.distance[k]:.2f} m from the target")
                elif status == SAT:
                    character.stand()
                else:  # CHECK: a walk vector it cannot do - the handle says why
                    character.walk(ch.walk[row].copy())
        for entity, goal in a["fallback"]:
            self.act(scene.character_handle(entity), self.world.component_for_entity(entity, Mind), goal, dt)

    def stop(self, character, goal: Goal | None) -> None:
        """Stand still, arms down, looking ahead."""
        if goal is not None:
            self._table().forget(goal.id)  # resumed later: the stall clock comes from its memory
        character.stop()
        character.look_at(None)
        character.pose("hang")
