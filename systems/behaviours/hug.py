"""hug: walk up, put both arms round the target, hold, let go and step back (SPEC 4).

Goal-driven (``character.hug(target, duration=2, run=False)``). Phases, kept in the goal's
memory: ``approach`` (walk up at the hugger's own pace - or run, ``run=True`` - its arms
swinging, braking over the last steps), ``wrap`` (the last step in, slowing to a creep:
the arms rise, aimed at the partner's torso at the partner's height, each hand - a free
one, or one holding a small thing such as a doll, which goes round holding it - gliding
round the target's torso to a point on its back), ``hold`` (for ``duration``
seconds, standing in touch; a small hugger leans into a grown-up's legs, a grown-up
stoops to a small child); then the arms drop and it is done. Letting go, both step back
to a social gap (:class:`StepBack`, a short wind-down after the goal, like a reflex).

Two characters each told to hug the other: the one told first leads (its arms go round
the other's upper back), the other walks up too and answers as a hugged partner does
(:func:`~twig_ecs.systems.behaviours.embrace.embrace_arms`: hands round the leader's
waist); when the leader lets go both goals are done and both step back.

The arms are not joined to the target: the hands are pulled to their places on its back
and the bodies keep colliding all the while, so an arm wraps round the torso's surface
instead of sinking into it. A small hugger holds a grown-up round the hips; between
equals the hugger's arms go round the partner's upper back, the partner's round its
waist. Arms that get no hand onto the back within ``WRAP_TIME`` fail the goal; one hand
round by then is a hug (a short arm round a broad body).

A batch behaviour: every walking hugger of a step is walked up in one pass over arrays (the
ones still far off steered round the others in one
:func:`~twig_ecs.systems.control.steer.steer_rows` call, with ``steer_to``'s arithmetic),
who hugs whom kept in a table of the hug goals; every hugger whose arms are going round or
holding is moved by one :func:`hug_arms` call, with the pair's fixed figures (the partner's
rows, its torso's thickness, the capsules it is touched on) packed once per goal. A step
with a rare event in a walk-up (a partner gone, a stall, a walk it cannot do) is done a
character at a time (``Hug._act_each``, the per-character form), which says what happened.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import methodcaller

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.components import Character
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.kernelmath import (
    CARRY,
    GAZE_NODE,
    HANG,
    HEAD,
    L_HAND,
    L_HIP,
    L_SHOULDER,
    NECK,
    PELVIS,
    R_HAND,
    R_HIP,
    R_SHOULDER,
    SIT,
    SPINE,
    clamp,
)
from twig_ecs.rowtable import Column, RowTable
from twig_ecs.steering import ground_distance
from twig_ecs.store import LINK_COLLIDE
from twig_ecs.systems.behaviours.approach import (
    steer_batch,
    steer_to,
)
from twig_ecs.systems.behaviours.embrace import (  # (importing it registers the partner's answer to a hug)
    FACED,
    HOLD,
    PHASES,
    STAND_UP,
    STOOP,
    TURN_PACE,
    WRAP,
    embrace_arms,
    glide_hand,
    holding_hands,
    hug_goal_ids,
    lower_hands,
    mutual_hug,
)
from twig_ecs.systems.control.steer import (
    ARRIVED,
)
from twig_ecs.systems.physics.collide import segment_gap2
from twig_ecs.validate import LIMIT

CLOSE = 0.32  # m (at 1.75 m tall): pelvis to pelvis a small hugger closes in to a big partner
CLOSE_EQUAL = 0.42  # m (at 1.75 m tall): and an equal (closer, their legs would tangle)
ARMS_NOT_ROUND = "could not get its arms round"  # the reason a hug fails in its wrap
WRAP_TIME = 4.0  # s to get the arms round (the last step in included: the wrap begins 0.75 m out)
REACH_IN = 0.75  # m beyond CLOSE where the walk-up ends and the arms rise and go round (the last step)
CREEP = 0.3  # m/s: the least pace of the last steps in, arms going round
WALK_PACE = 1.3  # m/s at 1.75 m tall: a hugger's own walking pace (by the root of its size:
# bodies of other sizes walk alike at equal Froude numbers - a 1.05 m child ~1.0 m/s)
RUN_FROUDE = 1.2  # v^2 / (g L) of a run up (``run=True``): past the walk's limit of 0.5, a run
BRAKE = 1.5  # m/s^2: how hard the walk-up slows over its last steps (a person stops within a step)
SOCIAL = 1.1  # m (at 1.75 m tall, pelvis to pelvis) the two step back to after a hug (turning back
# to face each other brings them in a little: they end 0.8-0.9 m apart)
PART_PACE = 0.7  # m/s (at 1.75 m tall, by the root of the size) of the steps back
PART_TIME = 1.5  # s at most of stepping back (a wall behind it: it stops there)
TURN_BACK = 1.5  # s at most of turning back to face the partner after
PARTING = 0.85  # activation of stepping back: above goals (0.8) and play, below squaring up to a
# fighter (0.9: stepping back from a hug it was attacked and did not face the fighter) and pain
LEAN_IN = 0.22  # m (at 1.75 m tall) a small hugger's shoulders lean into a big partner
LEAN_MOST = 25.0  # degrees of torso pitch at which that lean has faded out ...
LEAN_FADE = 10.0  # ... from full at this many degrees less
BIG = 1.25  # a partner this many times the hugger's size is big: it holds firm when leant on
SMALL = 0.8  # a partner this many times the hugger's size is small: the hugger stoops to it
SMALL_BACK = 0.25  # of the way from a small partner's neck down to its spine node the arms go round
DOCK_FROM = 1.6  # m (ground, pelvis to pelvis) from which the walk-up goes straight at the partner
DOCK = 0.3  # m/s: the least pace of the last steps in - people slow down before they touch
HAND_SPEED = 0.6  # m/s: how fast the point a hand reaches for glides round (a hand that
# flew at the back would be a blow)
ROUNDS = (1.1, 0.9, 0.7, 0.55, 0.45, 0.35, 0.3)  # rad past the torso's side, towards its spine, that a
# hand goes round to: the furthest its arm reaches
PAST = 0.2  # rad past the torso's side of the way-point a hand in front of it goes round by
ARM = 0.56  # m (at 1.75 m tall): shoulder to hand, straight
REACHABLE = 0.95  # of ARM, straight from the shoulder: a point the hand gets to round a torso
ON_BACK = 0.3  # m: a hand this close to a torso node, beyond it, is on the back (the recorder's too)
TOUCH = 0.015  # m (at 1.75 m tall): torso this close to the partner's body: in touch, stop closing in
ARM_NODES = ("l_elbow", "r_elbow", "l_hand", "r_hand")
FOREARM = 0.04  # m (at 1.75 m tall): forearm capsule radius
CLEAR = 1.5  # forearm radii off the surface the hands rest: on the back, not squeezing it


#: ``ROUNDS`` as (cos, sin) rows, for the kernel
_ROUNDS = np.array([(math.cos(a), math.sin(a)) for a in ROUNDS])
_COS_PAST, _SIN_PAST = math.cos(PAST), math.sin(PAST)
_TORSO = (NECK, SPINE, PELVIS)  # the torso nodes an arm goes round, top down (level_of's choice)


@njit(cache=True, nogil=True)
def count_hands_on_back(pos, spine, l_hand, r_hand, pelvis_at, spine_at, neck_at):
    """How many of a holder's hands (nodes ``l_hand``, ``r_hand``; its spine ``spine``) are on
    a held body's back: beyond its torso (the pelvis, spine or neck node nearest the hand,
    ``*_at``) as seen from the holder's spine, and within ON_BACK of that node."""
    count = 0
    for palm in (l_hand, r_hand):
        centre, best = pelvis_at, np.inf
        for node in (pelvis_at, spine_at, neck_at):
            dx, dy, dz = pos[palm, 0] - pos[node, 0], pos[palm, 1] - pos[node, 1], pos[palm, 2] - pos[node, 2]
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            if d < best:
                centre, best = node, d
        ux, uz = pos[centre, 0] - pos[spine, 0], pos[centre, 2] - pos[spine, 2]
        n = math.sqrt(ux * ux + uz * uz)
        if n > 1e-9:
            ux, uz = ux / n, uz / n
        ox, oz = pos[palm, 0] - pos[centre, 0], pos[palm, 2] - pos[centre, 2]
        if best <= ON_BACK and ox * ux + oz * uz > 0.0:
            count += 1
    return count


@njit(cache=True, nogil=True)
def mean_velocities(pos, prev, mass, first, count, total, dt, out):
    """Row k: the mass-weighted mean velocity (m/s) over the last step of the nodes
    ``first[k]`` .. ``first[k] + count[k]`` of total mass ``total[k]``, into ``out[k]``. The
    sum runs node by node, as numpy's column sum does (``BodyHandle.velocity``): the same figures."""
    for k in range(len(first)):
        i = first[k]
        for j in range(3):
            out[k, j] = (pos[i, j] - prev[i, j]) / dt * mass[i]
        for i in range(first[k] + 1, first[k] + count[k]):
            for j in range(3):
                out[k, j] += (pos[i, j] - prev[i, j]) / dt * mass[i]
        for j in range(3):
            out[k, j] /= total[k]


@njit(cache=True, nogil=True)
def torso_gap(pos, nodes, c, s, link_a, link_b, link_radius, rows):
    """Surface distance (m) from character ``c``'s torso capsules (lower and upper spine; scale
    ``s``) to the nearest of the partner's capsules ``rows`` (link rows: its collidable
    ones, its arms left out - a partner's arm coming round to hold it is no wall to stop at)."""
    best = np.inf
    for j in rows:
        rj = link_radius[j]
        for i in range(2):
            ri = (0.12 if i == 0 else 0.13) * s
            d2 = segment_gap2(pos, nodes[c, PELVIS + i], nodes[c, SPINE + i], link_a[j], link_b[j])
            best = min(best, math.sqrt(d2) - ri - rj)
    return best


# fmt: off
@njit(cache=True, nogil=True)
def hug_arms(pos, prev, link_a, link_b, link_radius, nodes, scale, mode, walk, lean, hand_aim, arm_point,
             arm_node, arm_mode, crows, partners, phase, surface, gap_links, gap_start, gap_count, rounds, dt,
             on_back, stoop_at, asks):
    """Move every hugger whose arms are going round (``phase[k]`` WRAP) or holding (HOLD) at once:
    row k is character ``crows[k]`` hugging character ``partners[k]``. Closes in at a creep
    until the torsos touch, then stands (a small hugger leans into a big partner); each hand
    glides round the partner's torso to its point on the back (:func:`back_points`'s figures:
    ``surface[k]`` the partner's thickest capsule at its neck, spine and pelvis, ``gap_links``
    from ``gap_start[k]``, ``gap_count[k]`` long, its capsules the torso stops at). Writes
    ``on_back[k]`` (hands on the back, while wrapping) and ``asks[k]``, bits: STAND_UP (it was
    sitting), STOOP (to ``stoop_at[k]``: a small partner, its back below the arms' reach)."""
    step = HAND_SPEED * dt
    for k in range(len(crows)):
        c, o = crows[k], partners[k]
        nd, od = nodes[c], nodes[o]
        s, other = scale[c], scale[o]
        asks[k] = 0
        on_back[k] = 0
        dx, dz = pos[od[PELVIS], 0] - pos[nd[PELVIS], 0], pos[od[PELVIS], 2] - pos[nd[PELVIS], 2]
        n = math.sqrt(dx * dx + dz * dz)
        tx, tz = (dx / n, dz / n) if n > 1e-9 else (dx, dz)  # towards the partner, on the ground
        big = other > BIG * s
        near = (CLOSE if big else CLOSE_EQUAL) * s
        # close in slowly while the arms go round until the torso meets the partner's
        # body; then stand (walking or leaning on into it would push the partner off its
        # feet: it steps to catch itself and its knee strikes - a blow)
        if (phase[k] == WRAP and n > near
                and torso_gap(pos, nodes, c, s, link_a, link_b, link_radius,
                              gap_links[gap_start[k]:gap_start[k] + gap_count[k]]) > TOUCH * s):
            # the last step in, braking as the walk-up did (v = sqrt(2 a d) stops it at ``near``)
            pace = clamp(math.sqrt(2.0 * BRAKE * (n - near)), CREEP, WALK_PACE * math.sqrt(s))
            walk[c, 0], walk[c, 1], walk[c, 2] = tx * pace, 0.0, tz * pace
            if mode[c] == SIT:
                asks[k] = STAND_UP
        else:
            walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
        if phase[k] == HOLD and big:
            # into a grown-up's legs (they hold firm), but easing off as the torso tips: with
            # the shoulders against the partner, leaning on only pushes the hips back - the
            # feet step away and the child folds over (40 degrees in the schoolyard)
            ux = pos[nd[NECK], 0] - pos[nd[PELVIS], 0]
            uz = pos[nd[NECK], 2] - pos[nd[PELVIS], 2]
            uy = pos[nd[NECK], 1] - pos[nd[PELVIS], 1]
            pitch = math.degrees(math.atan2(math.sqrt(ux * ux + uz * uz), uy))
            share = clamp((LEAN_MOST - pitch) / LEAN_FADE, 0.0, 1.0)
            lean[c, 0], lean[c, 1], lean[c, 2] = tx * LEAN_IN * s * share, 0.0, tz * LEAN_IN * s * share
        # the hands glide at HAND_SPEED relative to the hugger's body: on the last steps in,
        # the body carries them on too (gliding only at HAND_SPEED over the ground, they
        # trailed behind the walk and got round only once it stopped)
        carried = math.sqrt((pos[nd[PELVIS], 0] - prev[nd[PELVIS], 0]) ** 2
                            + (pos[nd[PELVIS], 2] - prev[nd[PELVIS], 2]) ** 2)
        # round the partner's torso node nearest the hugger's shoulder height, less a little
        # (level_of): a child round a grown-up's hips, equals round the upper back
        shoulder_y = pos[nd[NECK], 1] - 0.1 * s
        level = 0
        best = abs(pos[od[_TORSO[0]], 1] - shoulder_y)
        for lv in range(1, 3):
            d = abs(pos[od[_TORSO[lv]], 1] - shoulder_y)
            if d < best:
                level, best = lv, d
        centre = od[_TORSO[level]]
        cx, cy, cz = pos[centre, 0], pos[centre, 1], pos[centre, 2]
        ux, uz = cx - pos[nd[SPINE], 0], cz - pos[nd[SPINE], 2]  # through the partner, on the ground
        n = math.sqrt(ux * ux + uz * uz)
        if n > 1e-9:
            ux, uz = ux / n, uz / n
        lx, lz = uz, -ux  # the hugger's left
        clear = CLEAR * FOREARM * s
        radius = surface[k, level] + clear  # a forearm's thickness off its surface
        if _TORSO[level] == PELVIS:  # the hips stick out sideways beyond the spine's capsule
            hx = pos[od[L_HIP], 0] - pos[od[R_HIP], 0]
            hy = pos[od[L_HIP], 1] - pos[od[R_HIP], 1]
            hz = pos[od[L_HIP], 2] - pos[od[R_HIP], 2]
            radius = max(radius, 0.5 * math.sqrt(hx * hx + hy * hy + hz * hz) + 0.08 * other + clear)
        y = min(cy, pos[nd[NECK], 1])  # no higher than the hugger's shoulders
        if other < SMALL * s:
            # a child in a grown-up's arms: its upper back is below where the arms reach from
            # standing (an adult's hands at a 1.05 m child's neck are 0.6 m below its
            # shoulders), so the grown-up bends and sinks to it (CharacterHandle.stoop, after);
            # the arms go round below the child's shoulders, not over them (a hand riding up
            # over a shoulder came 10 cm above the child's neck)
            y -= SMALL_BACK * (cy - pos[od[SPINE], 1])
            stoop_at[k, 0], stoop_at[k, 1], stoop_at[k, 2] = cx, y, cz
            asks[k] |= STOOP
        # as far round towards the spine as the arms will go (a straight line from the
        # shoulder, less some for the curve round the torso), the same way round on both
        # sides, from square shoulders: a hand that got further would pull its shoulder
        # forward and twist the hugger, so the other could get less far still
        wx = pos[nd[L_SHOULDER], 0] - pos[nd[R_SHOULDER], 0]
        wy = pos[nd[L_SHOULDER], 1] - pos[nd[R_SHOULDER], 1]
        wz = pos[nd[L_SHOULDER], 2] - pos[nd[R_SHOULDER], 2]
        half = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
        sx, sy, sz = pos[nd[NECK], 0] + half * lx, pos[nd[NECK], 1], pos[nd[NECK], 2] + half * lz
        ca, sa = rounds[len(rounds) - 1, 0], rounds[len(rounds) - 1, 1]
        for r in range(len(rounds)):
            ca, sa = rounds[r, 0], rounds[r, 1]
            px, pz = cx + radius * (ca * lx + sa * ux), cz + radius * (ca * lz + sa * uz)
            if math.sqrt((px - sx) ** 2 + (y - sy) ** 2 + (pz - sz) ** 2) <= REACHABLE * ARM * s:
                break
        for h in range(2):
            side = 1.0 - 2.0 * h
            px, pz = cx + radius * (ca * lx * side + sa * ux), cz + radius * (ca * lz * side + sa * uz)
            palm = nd[L_HAND + h]
            if (pos[palm, 0] - cx) * ux + (pos[palm, 2] - cz) * uz < 0.0:
                # still in front of the torso: first out beside it, a little past its widest
                # (an arm goes round a body, not into it)
                out = 1.15 * math.sqrt((px - cx) ** 2 + (pz - cz) ** 2)
                px = cx + out * (_COS_PAST * lx * side + _SIN_PAST * ux)
                pz = cz + out * (_COS_PAST * lz * side + _SIN_PAST * uz)
            glide_hand(pos, palm, hand_aim, arm_point, arm_node, arm_mode, c, h, px, y, pz, step + carried)
        if phase[k] == WRAP:
            on_back[k] = count_hands_on_back(pos, nd[SPINE], nd[L_HAND], nd[R_HAND], od[PELVIS], od[SPINE],
                                             od[NECK])
# fmt: on


#: A hugger's row in the behaviour's table while its arms go round or hold (:meth:`Hug._setup`):
#: the pair's fixed figures, looked up once per goal.
_HUG_ROW = {
    "partner": Column(np.int64),  # the partner's character row
    "surface": Column(np.float64, (3,)),  # its thickest capsule at its neck, spine and pelvis (m)
    "gap_links": Column(np.int64, ragged=True),  # its capsules the hugger's torso stops at
    "duration": Column(np.float64),  # s to hold
}


#: A hug goal's row in the behaviour's table of goals (:meth:`Hug._goal_row`): its partner and
#: what the walk-up reads of it, looked up once per goal (again when the hug goals or the
#: store's rows change: whether the partner is hugging it back depends on the partner's goal).
_GOAL_ROW = {
    "partner": Column(np.int64),  # the partner's character row
    "partner_entity": Column(np.int64),
    "body": Column(np.int64),  # its body row: no obstacle to the walk-up
    "pelvis": Column(np.int64),  # its pelvis node: where it is
    "head": Column(np.int64),  # its head node: looked at
    "first": Column(np.int64),  # its nodes (its velocity: a partner walking off is pursued)
    "count": Column(np.int64),
    "mass": Column(np.float64),  # kg, numpy's sum (the one BodyHandle.velocity divides by)
    "mutual": Column(np.uint8),  # the partner is hugging it back
    "answers": Column(np.uint8),  # ... and was told first: this one answers its lead (mutual_hug)
    "run": Column(np.uint8),
    "max_speed": Column(np.float64),  # its own top speed (m/s): a faster walk is refused
}

#: The walk-up's steering gains: approach's (the same field and figures as ``steer_to``).


_LED = methodcaller("get", "led")  # a hug goal's memory: it answered a mutual hug


@register
class Hug(Behavior):
    """Hug a character: both arms round its torso, hands on its back."""

    schema = GoalSchema(
        "hug",
        "Walk up to a character, put both arms round it for `duration` s, let go and step back.",
        (
            Param("target", "name", figure=True, doc="whom to hug"),
            seconds("duration", 2.0, "how long the arms stay round it"),
            Param("run", "bool", False, doc="run up to it (a child running home), not walk"),
        ),
    )
    batch = True

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach, wrap, hold, release: the per-character form of :meth:`act_batch`."""
        self._act_each([character.character.index], [character.entity], [goal], dt)

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """Walk up, wrap and hold for every hugger at once (and answer, as a hugged partner
        does, for every one led in a mutual hug).

        The walk-up is one pass over arrays (:meth:`_walk_up_batch`); a step with a rare
        event in it (a partner gone, a walk-up stalled, a walk the character cannot do) is
        done per character instead (:meth:`_act_each`), which says what went wrong."""
        if goals is None:
            goals = [self.world.component_for_entity(e, Mind).goal for e in entities]
        if not all(goals):  # (a goal is always true)
            live = [k for k, goal in enumerate(goals) if goal is not None]
            rows, entities = [rows[k] for k in live], [entities[k] for k in live]
            goals = [goals[k] for k in live]
        if not goals:
            return
        scene = self.scene
        state = scene.state
        table = self._goal_table()
        hugs = hug_goal_ids(scene, self.scratch)
        ids = [goal.id for goal in goals]
        table.sync(ids, (hugs, state.version, id(state)),
                   lambda i, _: self._goal_row(rows[i], entities[i], goals[i]))  # fmt: skip
        if table.missing or not self._act_over_arrays(rows, entities, goals, table, dt, ids):
            self._act_each(rows, entities, goals, dt)

    def _act_each(self, rows: list[int], entities: list[int], goals: list, dt: float) -> None:
        """:meth:`act_batch` a character at a time: the walk-up per character (``steer_to``),
        then wrap and hold, and answer, over arrays."""
        scene = self.scene
        close, answering = [], []
        for row, entity, goal in zip(rows, entities, goals, strict=True):
            if goal is None:
                continue
            phase = goal.memory.get("phase", "approach")
            leader = mutual_hug(scene, entity, goal)
            if leader is not None and phase in ("wrap", "hold"):
                answering.append((row, entity, goal, leader))
            elif phase == "approach":
                self._walk_up(scene.character_handle(entity), goal, self._hugged_back(entity, goal))
            elif goal.memory.get("led"):  # it answered a mutual hug, and the leader has let go
                self.finish(scene.character_handle(entity), goal)
            else:
                close.append((row, entity, goal))
        if close:
            self._wrap_and_hold(close, dt)
        if answering:
            self._answer(answering, dt)

    def _goal_row(self, row: int, entity: int, goal: Goal) -> dict | None:
        """One hug goal's row of the table of goals (``_GOAL_ROW``); None when its partner is
        gone, is not a character, is itself or has no head (the per-character path says so)."""
        scene = self.scene
        target = goal.params["target"]
        if not scene.has_entity(target) or target == scene.name_of(entity):
            return None
        other = scene.entity(target)
        them = self.world.try_component(other.entity, Character)
        body = other.body
        if them is None or "head" not in body.node_names:
            return None
        mind = self.world.try_component(other.entity, Mind)
        theirs = mind.goal if mind is not None else None
        mutual = (theirs is not None and theirs.behavior == "hug"
                  and theirs.params.get("target") == scene.name_of(entity))  # fmt: skip
        first, count = body.node_start, len(body.node_names)
        return dict(partner=them.index, partner_entity=other.entity, body=body.index,
                    pelvis=int(scene.state.characters.nodes[them.index, PELVIS]),
                    head=body.node_index("head"),
                    first=first, count=count, mass=scene.state.nodes.mass[first : first + count].sum(),
                    mutual=mutual, answers=mutual and (theirs.id, other.entity) < (goal.id, entity),
                    run=bool(goal.params.get("run", False)),
                    max_speed=self.world.component_for_entity(entity, Character).max_speed)  # fmt: skip

    def _goal_table(self) -> RowTable:
        """This behaviour's table of hug goals (a cache of who hugs whom)."""
        table = self.scratch.get("goals")
        if table is None:
            table = self.scratch["goals"] = RowTable(**_GOAL_ROW)
        return table

    def _act_over_arrays(self, rows: list[int], entities: list[int], goals: list, table: RowTable,
                         dt: float, ids: list[int]) -> bool:  # fmt: skip
        """:meth:`_act_each`'s work with the walk-up over arrays (every goal has its row in
        ``table``, in order; ``ids``: the goals' ids); False, having changed nothing, when a rare
        event wants the per-character path."""
        scene = self.scene
        memories = [goal.memory for goal in goals]
        phases = [memory.get("phase", "approach") for memory in memories]
        if "approach" not in phases and not table["answers"].any() and not any(map(_LED, memories)):
            # every one wraps or holds, none answering (a long hug's usual step)
            self._wrap_and_hold(list(zip(rows, entities, goals, strict=True)), dt, (ids, memories, phases))
            return True
        answers = table["answers"].tolist()
        walking = [k for k, phase in enumerate(phases) if phase == "approach"]
        close, answering, done = [], [], []
        for k, phase in enumerate(phases):
            if phase == "approach":
                continue
            if answers[k] and phase in ("wrap", "hold"):
                partner = int(table["partner_entity"][k])
                leader = (int(table["partner"][k]), self.world.component_for_entity(partner, Mind).goal)
                answering.append((rows[k], entities[k], goals[k], leader))
            elif goals[k].memory.get("led"):  # it answered a mutual hug, and the leader has let go
                done.append(k)
            else:
                close.append((rows[k], entities[k], goals[k]))
        if walking:
            # one that lets go in the loop above and is walked up to (hugging back) would be
            # seen as gone from then on: per character
            if done and set(table["partner_entity"][walking].tolist()) & {entities[k] for k in done}:
                return False
            picked = np.array(walking, dtype=np.int64)
            walk_up = self._walk_up_batch([rows[k] for k in walking], [entities[k] for k in walking],
                                          [goals[k] for k in walking], table, picked)  # fmt: skip
            if walk_up is None:
                return False
            walk_up()
        for k in done:
            self.finish(scene.character_handle(entities[k]), goals[k])
        if close:
            self._wrap_and_hold(close, dt)
        if answering:
            self._answer(answering, dt)
        return True

    def _walk_up_batch(self, rows: list[int], entities: list[int], goals: list, table: RowTable,
                       at: np.ndarray):  # fmt: skip
        """:meth:`_walk_up` for every walking hugger at once (row k: character ``rows[k]``,
        entity ``entities[k]``, its goal ``goals[k]``, its row ``at[k]`` of ``table``), with the
        same arithmetic: the steered ones in one :func:`steer_rows` call. Returns what writes it all (a
        function), or None when one of them stalled or asks for a walk it cannot do (the
        per-character path fails the goal or says why)."""
        scene = self.scene
        state = scene.state
        ch = state.characters
        pos = state.nodes.pos
        crows = np.array(rows, dtype=np.int64)
        partners, mutual = table["partner"][at], table["mutual"][at] != 0
        here = pos[ch.nodes[crows, PELVIS]]
        there = pos[table["pelvis"][at]]
        # ground_distance's figures (math.hypot, not numpy's)
        dx, dz = (here[:, 0] - there[:, 0]).tolist(), (here[:, 2] - there[:, 2]).tolist()
        gap = np.array([math.hypot(x, z) for x, z in zip(dx, dz, strict=True)])
        scale = ch.scale[crows]
        big = ch.scale[partners] > BIG * scale
        wrap_at = np.where(big, CLOSE, CLOSE_EQUAL) * scale + REACH_IN
        wrapping = gap <= wrap_at
        moving = np.flatnonzero(~wrapping)
        # own_pace: a walk by the root of its size, or a run at RUN_FROUDE for its legs
        run = table["run"][at][moving] != 0
        froude = RUN_FROUDE * abs(scene.settings.gravity[1])
        legs = ch.leg_length[crows[moving]]
        pace = np.where(run, np.sqrt(froude * legs), WALK_PACE * np.sqrt(scale[moving]))
        walk = np.zeros((len(moving), 3))
        docking = gap[moving] < DOCK_FROM
        dock = np.flatnonzero(docking)
        if len(dock):
            # the last steps, straight in: v = sqrt(2 a d) stops it as the torsos meet
            d = moving[dock]
            left = (gap[d] - (wrap_at[d] - REACH_IN)) * np.where(mutual[d], 0.5, 1.0)
            speed = np.sqrt(2.0 * BRAKE * np.maximum(left, 0.0))
            speed = np.where(speed < DOCK, DOCK, np.where(speed > pace[dock], pace[dock], speed))
            toward = (there[d] - here[d]) * np.array([1.0, 0.0, 1.0])
            walk[dock] = toward / np.maximum(gap[d], 1e-9)[:, None] * speed[:, None]
        steered = np.flatnonzero(~docking)
        memory = []
        status = np.zeros(len(moving), dtype=np.int64)
        if len(steered):
            m = moving[steered]
            w = self._steer(crows[m], [goals[k] for k in m], table, at[m], here[m], there[m], pace[steered],
                            mutual[m])  # fmt: skip
            if w is None:
                return None
            walk[steered], status[steered], memory = w
        if len(moving):
            # what CharacterHandle.walk refuses (not finite, too big, over its top speed): per
            # character, which says why (a margin on the speed: the handle's own hypot decides)
            walk[:, 1] = 0.0
            limit = table["max_speed"][at][moving]
            if not (np.isfinite(walk).all() and np.abs(walk).max() <= LIMIT
                    and (np.hypot(walk[:, 0], walk[:, 2]) <= limit * (1.0 - 1e-9)).all()):  # fmt: skip
                return None

        def write() -> None:
            ch.gaze_node[crows] = table["head"][at]  # look at the partner's head
            ch.gaze_mode[crows] = GAZE_NODE
            now = scene.time
            for k in np.flatnonzero(wrapping):
                goals[k].memory["phase"], goals[k].memory["since"] = "wrap", now
            if not len(moving):
                return
            movers = crows[moving]
            # the arms swing as it walks: they rise as the wrap begins. Running, a hand that
            # carries something (a doll, the cradle's pose) keeps it held up until the last
            # steps in: hung at a run, the doll swung between the 1.05 m child's legs, a foot
            # planted on it and the child fell; held up to the end, it came between the two
            # and the arm could not go round (walking up, it hangs as before)
            keep = (ch.arm_mode[movers] == CARRY) & (run & ~docking)[:, None]
            ch.arm_mode[movers] = np.where(keep, CARRY, HANG)
            ch.walk[movers] = walk  # (an arrived one stops: its walk is nought)
            for goal, update, unless in memory:
                goal.memory.update(update)
                for key, value in unless.items():
                    goal.memory.setdefault(key, value)
            for k in np.flatnonzero((ch.mode[movers] == SIT) & (status != ARRIVED)):
                scene.character_handle(entities[moving[k]]).stand()

        return write

    def _steer(self, crows: np.ndarray, goals: list, table: RowTable, at: np.ndarray, here: np.ndarray,
               there: np.ndarray, pace: np.ndarray, mutual: np.ndarray):  # fmt: skip
        """``steer_to(character, goal, where, 0.0, exclude=(target,), speed=pace)`` for every
        row at once (``where``: the partner's pelvis ``there``; a partner not hugging back is
        pursued): (walk vectors, statuses, the goal memories' updates), nothing written; None
        when one has stalled. The figures are ``steer_to``'s: the direction's and the pursuit's
        lengths are numpy's (``np.linalg.norm``: a dot product per row)."""
        scene = self.scene
        state = scene.state
        direction = (here - there) * np.array([1.0, 0.0, 1.0])
        norm = np.sqrt(np.array([d.dot(d) for d in direction]))
        far = norm > 1e-9
        direction[far] /= norm[far, None]
        direction[~far] = 0.0
        memories = [goal.memory for goal in goals]
        steered = steer_batch(scene, crows, table["body"][at], there, direction, 0.0, pace, memories)
        if steered is None:
            return None  # stalled (the goal fails), or a walk it cannot do
        w, walk, best, squeeze_until, now = steered
        going = w.status != ARRIVED
        updates = []
        for k in np.flatnonzero(going):
            update, unless = {}, {}
            if w.best[k] != best[k]:
                update["best"], update["best_at"] = float(w.distance[k]), now
            else:
                unless["best_at"] = now
            if w.squeeze_until[k] != squeeze_until[k]:
                update["squeeze_until"] = float(w.squeeze_until[k])
            updates.append((goals[k], update, unless))
        # pursuit: match a partner's pace on top of closing in, or one that walks away is never
        # caught (not when it walks up to hug back: both would halve their paces)
        pursue = np.flatnonzero(going & ~mutual)
        if len(pursue):
            t = at[pursue]
            velocity = np.empty((len(pursue), 3))
            mean_velocities(state.nodes.pos, state.nodes.prev, state.nodes.mass, table["first"][t],
                            table["count"][t], table["mass"][t], scene.dt, velocity)  # fmt: skip
            walk[pursue] = walk[pursue] + velocity * np.array([1.0, 0.0, 1.0])
            speed = np.sqrt(np.array([v.dot(v) for v in walk[pursue]]))
            over = speed > pace[pursue]
            walk[pursue[over]] *= (pace[pursue[over]] / speed[over])[:, None]
        return walk, w.status, updates

    def _partner(self, character, goal: Goal):
        """The hug's partner (a character), or None when the goal has failed for want of one."""
        target = goal.params["target"]
        if not character.scene.has_entity(target):
            self.finish(character, goal, False, f"'{target}' is gone")
            return None
        other = character.scene.entity(target)
        if self.world.try_component(other.entity, Character) is None:
            self.finish(character, goal, False, f"'{target}' is not a character: there is no one to hug back")
            return None
        return other

    def _hugged_back(self, entity: int, goal: Goal) -> bool:
        """Is the partner of this hug walking up to hug it too (a mutual hug, either side)?"""
        target = goal.params["target"]
        if not self.scene.has_entity(target):
            return False
        mind = self.world.try_component(self.scene.entity(target).entity, Mind)
        theirs = mind.goal if mind is not None else None
        return (theirs is not None and theirs.behavior == "hug"
                and theirs.params.get("target") == self.scene.name_of(entity))  # fmt: skip

    def _walk_up(self, character, goal: Goal, mutual: bool) -> None:
        """Walk (or run) up at its own pace, arms swinging, braking over the last steps; the
        arms rise in the last step or two, opening towards the partner's chest; then wrap.
        ``mutual``: the partner is walking up too (each brakes for half the gap left)."""
        other = self._partner(character, goal)
        if other is None:
            return
        target = goal.params["target"]
        character.look_at(target, node="head")
        scale = character.scale
        big = other.scale > BIG * scale
        wrap_at = (CLOSE if big else CLOSE_EQUAL) * scale + REACH_IN
        gap = ground_distance(character.position, other.position)
        if gap <= wrap_at:
            goal.memory["phase"], goal.memory["since"] = "wrap", character.scene.time
            return
        # the arms swing as it walks (running, a carried doll held up until the last steps
        # in): they rise as the wrap begins
        swing_arms(character, carrying=bool(goal.params.get("run", False)) and gap >= DOCK_FROM)
        pace = own_pace(character, bool(goal.params.get("run", False)))
        if gap < DOCK_FROM:
            # the last steps, straight in: v = sqrt(2 a d) stops it as the torsos meet
            left = (gap - (wrap_at - REACH_IN)) * (0.5 if mutual else 1.0)
            speed = clamp(math.sqrt(2.0 * BRAKE * max(left, 0.0)), DOCK, pace)
            toward = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
            character.walk(toward / max(gap, 1e-9) * speed)
        else:
            # round what is in the way, at its own pace; aimed at the partner itself (the
            # field slows only over the last metre, which the straight steps above take).
            # Two walking up to each other head for where the other is now: matching its
            # pace (pursuit, for a partner walking off) would halve both their paces
            where = other.position if mutual else target
            steer_to(character, goal, where, 0.0, exclude=(target,), speed=pace)

    def _let_go(self, character, goal: Goal) -> None:
        """The hold is over: done; the two step back from each other (:class:`StepBack`)."""
        self.finish(character, goal)
        target = goal.params["target"]
        if not character.scene.has_entity(target):
            return
        other = character.scene.entity(target).entity
        mind = self.world.try_component(other, Mind)
        theirs = mind.goal if mind is not None else None
        if theirs is not None and theirs.memory.get("led") and theirs.params.get("target") == character.name:
            self.finish(character.scene.character_handle(other), theirs)  # it answered this hug: done too
        step_back(character.scene, character.entity, other)

    def _answer(self, answering: list, dt: float) -> None:
        """Mutual hugs: every one led by the other (told second) holds its leader as a hugged
        partner does (:func:`embrace_arms`), in the leader's phase; its own goal follows the
        leader's: it holds while the leader holds, and lets go when the leader does."""
        scene = self.scene
        state = scene.state
        ch = state.characters
        crows = np.array([row for row, _, _, _ in answering], dtype=np.int64)
        leaders = np.array([ch_row for _, _, _, (ch_row, _) in answering], dtype=np.int64)
        phase = np.array([PHASES.get(lead_goal.memory.get("phase", "approach"), 0)
                          for _, _, _, (_, lead_goal) in answering], dtype=np.int64)  # fmt: skip
        ch.gaze_node[crows] = ch.nodes[leaders, HEAD]
        ch.gaze_mode[crows] = GAZE_NODE
        stoop_at = np.empty((len(answering), 3))
        asks = np.empty(len(answering), dtype=np.int64)
        entities = [entity for _, entity, _, _ in answering]
        embrace_arms(state.nodes.pos, ch.nodes, ch.scale, ch.mode, ch.walk, ch.crouch, ch.lean, ch.hand_aim,
                     ch.arm_point, ch.arm_node, ch.arm_mode, crows, leaders, phase,
                     holding_hands(scene, entities), dt, stoop_at, asks)  # fmt: skip
        for k, (_, entity, goal, (_, lead_goal)) in enumerate(answering):
            character = scene.character_handle(entity)
            if asks[k] & STAND_UP:
                character.stand()
            if asks[k] & STOOP:
                character.stoop(stoop_at[k].copy())
            goal.memory["led"] = True
            if lead_goal.memory.get("phase") == "hold" and goal.memory.get("phase") != "hold":
                goal.memory["phase"], goal.memory["since"] = "hold", scene.time

    def _setup(self, row: int, entity: int, goal: Goal) -> dict | None:
        """One goal's row of the table (``_HUG_ROW``): its partner's character row, the
        partner's thickest capsule at neck, spine and pelvis, the link rows of its body the
        torso stops at, how long to hold; None when the partner is gone (the goal has failed)."""
        other = self._partner(self.scene.character_handle(entity), goal)
        if other is None:
            return None
        links = self.scene.state.links
        body = other.body
        # its own link rows (contiguous), not a pass over every link in the store
        rows = np.arange(body.link_start, body.link_start + body.link_count)
        rows = rows[(links.body[rows] == body.index) & ((links.flags[rows] & LINK_COLLIDE) != 0)]
        names = body.node_names
        arm = [body.node_start + names.index(a) for a in ARM_NODES if a in names]
        torso = rows[~(np.isin(links.a[rows], arm) | np.isin(links.b[rows], arm))]
        surface = []
        for name in ("neck", "spine", "pelvis"):
            at = body.node_index(name)
            touching = rows[(links.a[rows] == at) | (links.b[rows] == at)]
            surface.append(float(links.radius[touching].max()) if len(touching) else 0.0)
        return dict(partner=self.world.component_for_entity(other.entity, Character).index, surface=surface,
                    gap_links=torso, duration=goal.params["duration"])  # fmt: skip

    def _table(self) -> RowTable:
        """This behaviour's table of huggers wrapping or holding (a cache of their partners' figures)."""
        table = self.scratch.get("close")
        if table is None:
            table = self.scratch["close"] = RowTable(**_HUG_ROW)
        return table

    def _wrap_and_hold(self, close: list, dt: float, known: tuple | None = None) -> None:
        """Wrap the arms round and hold, for the huggers ``close`` (row, entity, goal); ``known``:
        their goals' ids, memories and phases, where the caller has them."""
        scene = self.scene
        state = scene.state
        ch = state.characters
        table = self._table()
        crow_list, _, goals = zip(*close, strict=True)
        ids, memories, phases = known if known is not None else ([goal.id for goal in goals], None, None)
        table.sync(ids, (state.version, id(state)), lambda i, _: self._setup(*close[i]))
        if table.missing:  # those whose partner has gone have failed: left out
            close = [close[i] for i in table.positions]
            if not close:
                return
            crow_list, _, goals = zip(*close, strict=True)
            memories = phases = None
        if memories is None:
            memories = [goal.memory for goal in goals]
            phases = [memory["phase"] for memory in memories]
        crows = np.array(crow_list, dtype=np.int64)
        partners = table["partner"]
        ch.gaze_node[crows] = ch.nodes[partners, HEAD]  # look at the partner's head
        ch.gaze_mode[crows] = GAZE_NODE
        phase = np.array([PHASES[name] for name in phases], dtype=np.int64)
        on_back = np.empty(len(close), dtype=np.int64)
        asks = np.empty(len(close), dtype=np.int64)
        stoop_at = np.empty((len(close), 3))
        links = state.links
        hug_arms(state.nodes.pos, state.nodes.prev, links.a, links.b, links.radius, ch.nodes, ch.scale,
                 ch.mode, ch.walk, ch.lean, ch.hand_aim, ch.arm_point, ch.arm_node, ch.arm_mode, crows,
                 partners, phase,
                 table["surface"], table["gap_links"], table["gap_links_start"], table["gap_links_count"],
                 _ROUNDS, dt, on_back, stoop_at, asks)  # fmt: skip
        now = scene.time
        since = np.array([memory["since"] for memory in memories])
        ending = (phase == WRAP) & ((on_back == 2) | (now - since > WRAP_TIME))
        ending |= (phase == HOLD) & (now - since >= table["duration"])
        for k in np.flatnonzero(ending | (asks != 0)):
            _, entity, goal = close[k]
            character = scene.character_handle(entity)
            if asks[k] & STAND_UP:
                character.stand()
            if asks[k] & STOOP:
                character.stoop(stoop_at[k].copy())
            if not ending[k]:
                continue
            if phase[k] == HOLD:
                self._let_go(character, goal)
            elif on_back[k]:  # both hands round, or one short arm round a broad body in time
                goal.memory["phase"], goal.memory["since"] = "hold", now
            else:
                self.finish(character, goal, False, ARMS_NOT_ROUND)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down (a carried toy stays in its hand) and stand up straight."""
        if goal is not None:
            self._table().forget(goal.id)
        character.stoop(None)
        character.lean(None)
        lower_hands(character)
        character.pose("hang")
        character.stop()
        character.look_at(None)


def swing_arms(character, carrying: bool = True) -> None:
    """Let the arms hang and swing as the character walks, but a hand that carries something
    (the cradle's ``carry`` pose) keeps it held up in front while ``carrying``."""
    modes = character.scene.state.characters.arm_mode[character.character_row]
    for hand, h in (("left", 0), ("right", 1)):
        if not (carrying and modes[h] == CARRY):
            character.pose("hang", hand=hand)


def own_pace(character, run: bool = False) -> float:
    """A character's own pace (m/s): its walk (``WALK_PACE`` by the root of its size), or a
    run at ``RUN_FROUDE`` for its legs (v = sqrt(Fr g L)), whichever ``run`` asks for."""
    if run:
        leg = float(character.scene.state.characters.leg_length[character.character_row])
        return math.sqrt(RUN_FROUDE * abs(character.scene.settings.gravity[1]) * leg)
    return WALK_PACE * math.sqrt(character.scale)


def hands_on_back(holder, held) -> int:
    """How many of ``holder``'s hands are on ``held``'s back (:func:`count_hands_on_back`)."""
    pos = holder.scene.state.nodes.pos
    hands = (holder.node_row("spine"), holder.node_row("l_hand"), holder.node_row("r_hand"))
    back = (held.node_row("pelvis"), held.node_row("spine"), held.node_row("neck"))
    return int(count_hands_on_back(pos, *hands, *back))


@dataclass(slots=True)
class Parting:
    """Stepping back after a hug (systems/behaviours/hug.py): from whom, until when at most,
    and whether it has got to a social gap and is turning back to face the partner."""

    partner: int  # entity of the one it hugged or was hugged by
    until: float  # s (scene time): it stops then, wherever it is
    turning: bool = False  # far enough: now turning to face the partner again


def step_back(scene, a: int, b: int) -> None:
    """Two who have just let go of a hug step back from each other (the characters of the two)."""
    until = scene.time + PART_TIME
    for me, other in ((a, b), (b, a)):
        if scene.world.has_component(me, Character) and scene.world.has_component(me, Mind):
            scene.world.add_component(me, Parting(other, until))


@register
class StepBack(Behavior):
    """After a hug: arms down, a few steps away from the partner to a social gap, then a
    turn on the spot to face it again.

    Runs even for a scripted character, as a reflex does: it is the hug's wind-down (the goal
    is done when the arms let go), and it lasts ``PART_TIME`` (and ``TURN_BACK``) at most.
    The gait walks where the pelvis faces, so the steps away turn the body from the
    partner; it turns back once there.
    """

    name = "step_back"
    component = Parting
    reflex = True

    def activation(self, character, mind: Mind, goal) -> float:
        """High until it stands at a social gap facing the partner (or the time is up)."""
        parting = self.world.component_for_entity(character.entity, Parting)
        if self.scene.time > parting.until or not self.world.entity_exists(parting.partner):
            return 0.0
        return PARTING

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Step away from the partner until the pelvises are ``SOCIAL`` apart, then face it."""
        parting = self.world.component_for_entity(character.entity, Parting)
        other = self.scene.character_handle(parting.partner)
        away = (character.position - other.position) * np.array([1.0, 0.0, 1.0])
        gap = float(np.hypot(away[0], away[2]))
        away /= max(gap, 1e-9)
        character.pose("hang")
        character.look_at(other.name, node="head")
        if not parting.turning and gap >= SOCIAL * max(character.scale, other.scale):
            parting.turning, parting.until = True, self.scene.time + TURN_BACK
        if not parting.turning:
            character.walk(away * PART_PACE * math.sqrt(character.scale))
        elif float(character.facing @ -away) < math.cos(FACED):
            character.walk(-away * TURN_PACE * character.scale)  # slow steps on the spot, turning to it
        else:
            parting.until = self.scene.time  # facing it at a social gap: over
            character.stop()

    def stop(self, character, goal) -> None:
        """Stand; the parting is forgotten."""
        if self.world.has_component(character.entity, Parting):
            self.world.remove_component(character.entity, Parting)
        character.stop()
        character.look_at(None)
