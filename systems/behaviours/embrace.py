"""embrace: a character being hugged holds the hugger back (BELIEVABILITY "Touch").

Not commanded: every autonomous character whom someone is coming to hug - a hug goal
aimed at it, the hugger within ``TURN_NEAR`` - stops what it was doing (its activation
beats watching, play and goals) and turns to the hugger, head and body (a few slow
steps on the spot). Once the hug's arms go round (``wrap`` or ``hold``, within
``NEAR``) it bends over a smaller hugger, and puts its free hands round it, on its back:
each hand reaches for a point just behind the hugger's spine (a little to its side), so
the arms close round the hugger's torso. When the hug is over it lets go (the arms
relax) and stands up; what it was doing resumes.

A batch behaviour: every embracing character is moved by one :func:`embrace_arms` call
over arrays; the pairs (who hugs whom) are looked up again only when the hug goals or
the store's rows change. :func:`glide_hand` (a hand's reach point gliding round a body,
kept in the character table's ``hand_aim``) is shared with the hug.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Mind, goal_targets, register
from twig_ecs.components import Character, GrabJoint
from twig_ecs.kernelmath import (
    GAZE_NODE,
    HEAD,
    L_HAND,
    L_HIP,
    NECK,
    PELVIS,
    R_HIP,
    REACH,
    SIT,
    SPINE,
    clamp,
    forward_xz,
)
from twig_ecs.step import StepContext

EMBRACE = 0.9  # activation: above goals (0.8), below pain withdrawal
NEAR = 1.0  # m (ground) between the two for a hug to be answered
TURN_NEAR = 3.0  # m (ground): a hugger coming this close is turned to
TURN_PACE = 0.25  # m/s (at 1.75 m tall) of the steps on the spot that turn the body to it
FACED = 0.35  # rad: facing the hugger this nearly is facing it
BACK = 0.12  # m (at 1.75 m tall, the hugger's) behind its spine that the hands aim for
HIGH = 0.05  # m (at 1.75 m tall, the hugger's) above a small hugger's neck node: the top of its back
LEAN = 0.0  # m (at 1.75 m tall) the shoulders lean over a small hugger (more would push it off)
UP = 0.12  # m (at 1.75 m tall, the hugger's) above a small hugger's neck node the hands wait
SHOULDER = 0.22  # m (at 1.75 m tall, the hugger's) either side of its neck they wait, over its shoulders
SIDE = 0.07  # m (at 1.75 m tall, the hugger's) either side of the spine for two hands
HAND_SPEED = 0.5  # m/s: how fast the point a hand reaches for moves (a hand that flew at a
# small child's back would be a blow: 1 kg at 1.3 m/s hurts a 1.05 m child)

#: A hug's phases as the kernels number them (``goal.memory["phase"]``).
PHASES = {"approach": 0, "wrap": 1, "hold": 2}
WRAP, HOLD = PHASES["wrap"], PHASES["hold"]
#: What a hug or embrace kernel row asks of the Python after it (bits; rare, per character):
#: stand up (it walked while sitting) or stoop to ``stoop_at`` (someone smaller to hold).
STAND_UP, STOOP = 1, 2


@njit(cache=True, nogil=True)
def glide_hand(pos, hand_node, hand_aim, arm_point, arm_node, arm_mode, row, h, px, py, pz, step):
    """Reach hand ``h`` (0 left, 1 right) of character ``row`` for a point that moves from
    where it got to (``hand_aim``; the hand itself when NaN: it starts gliding) towards
    ``(px, py, pz)`` by at most ``step`` metres this step: a hand that flew at a body would be a blow."""
    ax, ay, az = hand_aim[row, h, 0], hand_aim[row, h, 1], hand_aim[row, h, 2]
    if ax != ax:
        ax, ay, az = pos[hand_node, 0], pos[hand_node, 1], pos[hand_node, 2]
    mx, my, mz = px - ax, py - ay, pz - az
    far = math.sqrt(mx * mx + my * my + mz * mz)
    if far > step:
        shrink = step / far
        mx, my, mz = mx * shrink, my * shrink, mz * shrink
    ax, ay, az = ax + mx, ay + my, az + mz
    hand_aim[row, h, 0], hand_aim[row, h, 1], hand_aim[row, h, 2] = ax, ay, az
    arm_point[row, h, 0], arm_point[row, h, 1], arm_point[row, h, 2] = ax, ay, az
    arm_node[row, h] = -1
    arm_mode[row, h] = REACH


def mutual_hug(scene, entity: int, goal) -> tuple[int, object] | None:
    """Two told to hug each other: when ``goal`` (the hug of ``entity``) is the one told
    second, its partner's hug goal aimed back at it leads: (the leader's character row, its
    goal); None when it leads, or its partner is not hugging it back."""
    target = goal.params.get("target")
    if not scene.has_entity(target):
        return None
    other = scene.entity(target).entity
    mind = scene.world.try_component(other, Mind)
    theirs = mind.goal if mind is not None else None
    if theirs is None or theirs.behavior != "hug" or theirs.params.get("target") != scene.name_of(entity):
        return None
    if (theirs.id, other) > (goal.id, entity):
        return None  # told first: it leads
    return scene.world.component_for_entity(other, Character).index, theirs


def lower_hands(character) -> None:
    """Forget where the hands were gliding to (a hug or an embrace is over)."""
    character.scene.state.characters.hand_aim[character.character.index] = np.nan


# fmt: off
@njit(cache=True, nogil=True)
def embrace_arms(pos, nodes, scale, mode, walk, crouch, lean, hand_aim, arm_point, arm_node, arm_mode,
                 crows, huggers, phase, free, dt, stoop_at, asks):
    """Move every embracing character at once: row k is character ``crows[k]`` held by the
    character ``huggers[k]`` whose hug is in ``phase[k]``; ``free[k, h]``: hand h holds nothing.
    Turns to a coming hugger (slow steps on the spot); once its arms go round, stands (or bends
    over a small hugger) and glides each free hand to the hugger's back. ``asks[k]``: what the
    Python must do after (``STAND_UP``, ``STOOP`` to ``stoop_at[k]``), else 0."""
    step = HAND_SPEED * dt
    for k in range(len(crows)):
        c, o = crows[k], huggers[k]
        nd, od = nodes[c], nodes[o]
        s, other = scale[c], scale[o]
        asks[k] = 0
        tx = pos[od[PELVIS], 0] - pos[nd[PELVIS], 0]
        tz = pos[od[PELVIS], 2] - pos[nd[PELVIS], 2]
        norm = max(math.sqrt(tx * tx + tz * tz), 1e-9)
        tx, tz = tx / norm, tz / norm
        if phase[k] != WRAP and phase[k] != HOLD:
            # turn the whole body to it: a few slow steps on the spot, facing it
            fx, fz = forward_xz(pos, nd[L_HIP], nd[R_HIP])
            off = math.acos(clamp(fx * tx + fz * tz, -1.0, 1.0))
            if off > FACED:
                walk[c, 0], walk[c, 1], walk[c, 2] = tx * TURN_PACE * s, 0.0, tz * TURN_PACE * s
                if mode[c] == SIT:
                    asks[k] = STAND_UP
            else:
                walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
            continue
        walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
        # where on its back (held_at): the upper back of a small hugger, the lower back of an
        # equal (under its arms), the mid-back of a bigger one
        small = other < 0.8 * s
        waist = not small and other < 1.25 * s
        if waist:
            cx = 0.5 * (pos[od[PELVIS], 0] + pos[od[SPINE], 0])
            cy = 0.5 * (pos[od[PELVIS], 1] + pos[od[SPINE], 1])
            cz = 0.5 * (pos[od[PELVIS], 2] + pos[od[SPINE], 2])
        else:
            centre = od[NECK] if small else od[SPINE]
            cx, cy, cz = pos[centre, 0], pos[centre, 1], pos[centre, 2]
        ux, uz = cx - pos[nd[SPINE], 0], cz - pos[nd[SPINE], 2]
        norm = max(math.sqrt(ux * ux + uz * uz), 1e-9)
        ux, uz = ux / norm, uz / norm
        left_x, left_z = uz, -ux
        bx, by, bz = cx + ux * BACK * other, cy, cz + uz * BACK * other
        wrapping = phase[k] == WRAP
        if small and wrapping:
            # a small hugger: stand tall while its arms go round (bending over it now
            # would push it off), the hands coming to rest over its shoulders
            bx, by, bz = cx, cy + UP * other, cz
            crouch[c] = 0.0
            lean[c, 0] = lean[c, 1] = lean[c, 2] = 0.0
        elif small:  # then the hands on its upper back, bending a little over it (a
            # deeper bend or a crouch would push it off)
            by += HIGH * other
            lean[c, 0], lean[c, 1], lean[c, 2] = ux * LEAN * s, 0.0, uz * LEAN * s
        elif waist:  # an equal: stand tall, arms round its lower back, under its own arms
            # (bending or crouching would push it off)
            crouch[c] = 0.0
            lean[c, 0] = lean[c, 1] = lean[c, 2] = 0.0
        else:  # a bigger hugger: get down to it (CharacterHandle.stoop, after)
            stoop_at[k, 0], stoop_at[k, 1], stoop_at[k, 2] = bx, by, bz
            asks[k] = STOOP
        spread = (SHOULDER if small and wrapping else SIDE) * other
        for h in range(2):
            if free[k, h]:
                side = 1.0 - 2.0 * h
                glide_hand(pos, nd[L_HAND + h], hand_aim, arm_point, arm_node, arm_mode, c, h,
                           bx + left_x * side * spread, by, bz + left_z * side * spread, step)
# fmt: on


def holding_hands(scene, entities) -> np.ndarray:
    """(n, 2) bools: which hands of each of ``entities`` hold nothing (left, right). Found
    from the scene's grab joints, which are few, rather than a look-up per character."""
    free = np.ones((len(entities), 2), dtype=np.bool_)
    holders = {joint.holder for _, joint in scene.world.get_component(GrabJoint)}
    if holders:
        for k, entity in enumerate(entities):
            if entity in holders:
                holding = scene.world.component_for_entity(entity, Character).holding
                free[k] = ("left" not in holding, "right" not in holding)
    return free


def hug_goal_ids(scene, scratch) -> tuple[int, ...]:
    """The ids of the hug goals being carried out (the current goals of the hug's goal holders):
    a key for what is made from who hugs whom. Kept in ``scratch`` (a behaviour's) until a goal
    is given or ends."""

    def ids() -> tuple[int, ...]:
        return tuple(mind.goals[0].id for _, mind in scene.goal_holders_of("hug"))

    return scratch.keyed("hug_ids", scene.goals.changes, ids)


@register
class Embrace(Behavior):
    """Hold someone who hugs you: face them, stoop to them, arms round their back."""

    name = "embrace"
    batch = True

    def _pairs(self) -> list[tuple]:
        """Per pair: hugged entity, its mind, hugged row, hugger entity, hugger row, hug goal -
        looked up again when the hug goals or the store's rows change."""
        scene = self.scene
        state = scene.state
        key = (hug_goal_ids(scene, self.scratch), state.version, id(state))
        return self.scratch.keyed("pairs", key, self._find_pairs)

    def _find_pairs(self) -> list[tuple]:
        scene = self.scene
        pairs = []
        for hugged, (hugger, goal) in goal_targets(scene, "hug").items():
            if not (self.world.entity_exists(hugged) and self.world.has_component(hugged, Mind)):
                continue
            me = self.world.try_component(hugged, Character)
            them = self.world.try_component(hugger, Character)
            if me is None or them is None:
                continue
            mind = self.world.component_for_entity(hugged, Mind)
            own = mind.goal
            if (
                own is not None
                and own.behavior == "hug"
                and own.params.get("target") == scene.name_of(hugger)
            ):
                continue  # hugging it back: two told to hug each other (the hug answers, not the embrace)
            pairs.append((hugged, mind, me.index, hugger, them.index, goal))
        return pairs

    def run(self, ctx: StepContext) -> None:
        """Propose EMBRACE for every autonomous character a hugger is close to (or coming to)."""
        pairs = self._pairs()
        # the pairs and each one's hug phase (PHASES), this step (made again each step from the
        # hug goals: a cache, which a snapshot does not keep), for act_batch
        phases = [PHASES.get(pair[5].memory.get("phase", "approach"), 0) for pair in pairs]
        phases = np.array(phases, dtype=np.int64)
        rows = self.scratch["this_step"] = (self._rows(), phases)
        if not pairs:
            return
        pos, nodes = ctx.state.nodes.pos, ctx.state.characters.nodes
        hugged, huggers, _ = rows[0]
        mine, theirs = pos[nodes[hugged, PELVIS]], pos[nodes[huggers, PELVIS]]
        far = np.hypot(theirs[:, 0] - mine[:, 0], theirs[:, 2] - mine[:, 2])
        near = np.where((phases == WRAP) | (phases == HOLD), NEAR, TURN_NEAR)
        # (a scripted character does only what it is told)
        close = [k for k in np.flatnonzero(far < near).tolist() if pairs[k][1].autonomous]
        if not close:
            return
        kept = self.scratch.get("close")  # the proposal's lists, kept while the same pairs are close
        if kept is None or kept[0] is not pairs or kept[1] != close:
            entities, minds = [pairs[k][0] for k in close], [pairs[k][1] for k in close]
            kept = self.scratch["close"] = (pairs, close, entities, minds)
        self.propose_all(ctx.frame, kept[2], kept[3], EMBRACE)

    def _rows(self) -> tuple[np.ndarray, np.ndarray, dict[int, int]]:
        """The pairs' hugged and hugger character rows, and each hugged entity's pair (made
        again with the pairs)."""
        pairs = self._pairs()
        key = self.scratch["pairs"][0]

        def rows() -> tuple[np.ndarray, np.ndarray, dict[int, int]]:
            hugged = np.array([p[2] for p in pairs], dtype=np.int64)
            huggers = np.array([p[4] for p in pairs], dtype=np.int64)
            return hugged, huggers, {p[0]: k for k, p in enumerate(pairs)}

        return self.scratch.keyed("rows", key, rows)

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Turn to a coming hugger; then bend to it, hands on its back."""
        self.act_batch([character.character.index], [character.entity], dt)

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """Turn, stand or stoop, and glide the free hands, for every embracing character at once."""
        scene = self.scene
        state = scene.state
        ch = state.characters
        (_, hugger_rows, slots), phases = self.scratch["this_step"]
        picked = self.scratch.get("picked")  # the pairs of these entities (kept while they are the same)
        if picked is None or picked[0] is not slots or picked[1] != entities:
            picked = self.scratch["picked"] = (slots, list(entities), np.array([slots[e] for e in entities],
                                                                              dtype=np.int64))  # fmt: skip
        picked = picked[2]
        huggers = hugger_rows[picked]
        crows = np.array(rows, dtype=np.int64)
        phase = phases[picked]
        ch.gaze_node[crows] = ch.nodes[huggers, HEAD]  # look at the hugger's head
        ch.gaze_mode[crows] = GAZE_NODE
        stoop_at = np.empty((len(rows), 3))
        asks = np.empty(len(rows), dtype=np.int64)
        embrace_arms(state.nodes.pos, ch.nodes, ch.scale, ch.mode, ch.walk, ch.crouch, ch.lean, ch.hand_aim,
                     ch.arm_point, ch.arm_node, ch.arm_mode, crows, huggers, phase,
                     holding_hands(scene, entities), dt, stoop_at, asks)  # fmt: skip
        for k in np.flatnonzero(asks):
            character = scene.character_handle(entities[k])
            if asks[k] == STAND_UP:
                character.stand()
            else:
                character.stoop(stoop_at[k].copy())

    def stop(self, character, goal) -> None:
        """Arms down, stand up."""
        character.stoop(None)
        character.lean(None)
        lower_hands(character)
        for hand in ("left", "right"):
            if hand not in character.holding:
                character.pose("hang", hand=hand)
        character.look_at(None)
