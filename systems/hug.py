"""hug: approach with arms out, put both arms round the target, hold, let go (SPEC 4).

Goal-driven (``character.hug(target, duration=2)``). Phases, kept in the goal's memory:
``approach`` (walk up with the arms in the hug pose, slowing to docking pace), ``wrap``
(close in at a creep while each hand - a free one, or one holding a small thing such as
a doll, which goes round holding it - glides round the target's torso to a point on its
back), ``hold`` (for ``duration`` seconds, standing in touch; a small hugger leans into a
grown-up's legs), then the arms drop and it is done.

The arms are not joined to the target: the hands are pulled to their places on its back
and the bodies keep colliding all the while, so an arm wraps round the torso's surface
instead of sinking into it. A small hugger holds a grown-up round the hips; between
equals the hugger's arms go round the partner's upper back, the partner's round its
waist. Arms that get no hand onto the back within ``WRAP_TIME`` fail the goal; one hand
round by then is a hug (a short arm round a broad body).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.steering import ground_distance, length
from twig_ecs.store import LINK_COLLIDE
from twig_ecs.systems.approach import steer_to
from twig_ecs.systems.collide import closest_segment_params
from twig_ecs.systems.embrace import (  # (importing it registers the partner's answer to a hug)
    glide,
    lower_hands,
)

CLOSE = 0.32  # m (at 1.75 m tall): pelvis to pelvis a small hugger closes in to a big partner
CLOSE_EQUAL = 0.42  # m (at 1.75 m tall): and an equal (closer, their legs would tangle)
WRAP_TIME = 3.0  # s to get the arms round
REACH_IN = 0.25  # m beyond CLOSE where the walk-up ends and the arms start to go round
CREEP = 0.3  # m/s of the last steps in, arms going round
LEAN_IN = 0.22  # m (at 1.75 m tall) a small hugger's shoulders lean into a big partner
LEAN_MOST = 25.0  # degrees of torso pitch at which that lean has faded out ...
LEAN_FADE = 10.0  # ... from full at this many degrees less
BIG = 1.25  # a partner this many times the hugger's size is big: it holds firm when leant on
DOCK_FROM = 1.6  # m (ground, pelvis to pelvis) from which the walk-up slows to docking pace
DOCK = 0.45  # m/s: docking pace - people slow down before they touch
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


@register
class Hug(Behavior):
    """Hug a character: both arms round its torso, hands on its back."""

    schema = GoalSchema(
        "hug",
        "Walk up to a character, put both arms round it for `duration` s, let go.",
        (
            Param("target", "name", figure=True, doc="whom to hug"),
            seconds("duration", 2.0, "how long the arms stay round it"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach, wrap, hold, release."""
        target = goal.params["target"]
        m = goal.memory
        phase = m.setdefault("phase", "approach")
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        scale = character.scale
        toward = _unit(other.position - character.position)  # on the ground
        gap = ground_distance(character.position, other.position)
        if phase == "approach":
            character.pose("hug")
            if gap <= CLOSE * scale + REACH_IN:
                m["phase"], m["since"] = "wrap", character.scene.time
            elif gap < DOCK_FROM:
                character.walk(toward * DOCK)  # the last steps in, at docking pace
            else:
                steer_to(character, goal, target, DOCK_FROM - 0.1)
            return
        now = character.scene.time
        # close in slowly while the arms go round until the torso meets the partner's
        # body; then stand (walking or leaning on into it would push the partner off its
        # feet: it steps to catch itself and its knee strikes - a blow)
        near = (CLOSE if other.scale > BIG * scale else CLOSE_EQUAL) * scale
        if phase == "wrap" and gap > near and torso_gap(character, other) > TOUCH * scale:
            character.walk(toward * CREEP)
        else:
            character.stop()
        if phase == "hold" and other.scale > BIG * scale:
            # into a grown-up's legs (they hold firm), but easing off as the torso tips: with
            # the shoulders against the partner, leaning on only pushes the hips back - the
            # feet step away and the child folds over (40 degrees in the schoolyard)
            share = min(1.0, max(0.0, (LEAN_MOST - character.torso_pitch) / LEAN_FADE))
            character.lean(toward * LEAN_IN * scale * share)
        level = level_of(character, other)  # (once: the hands' points are read off the same nodes)
        for hand, point in back_points(character, other, level).items():
            glide(character, hand, round_the_side(character, other, hand, point, level), HAND_SPEED * dt)
        if phase == "wrap":
            on = hands_on_back(character, other)
            if on == 2:
                m["phase"], m["since"] = "hold", now
            elif now - m["since"] > WRAP_TIME:
                if on:
                    m["phase"], m["since"] = "hold", now  # one short arm round a broad body
                else:
                    self.finish(character, goal, False, "could not get its arms round")
            return
        if now - m["since"] >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down (a carried toy stays in its hand) and stand up straight."""
        character.stoop(None)
        character.lean(None)
        lower_hands(character)
        character.pose("hang")
        character.stop()
        character.look_at(None)


def level_of(character, other) -> str:
    """The node of ``other``'s torso the arms go round: the one nearest the hugger's
    shoulder height, less a little - a child hugs a grown-up round the hips (pelvis),
    equals hug round the upper back (neck), over the arms the partner puts round their
    waist."""
    shoulder_y = character.node("neck")[1] - 0.1 * character.scale
    return min(("neck", "spine", "pelvis"), key=lambda n: abs(other.node(n)[1] - shoulder_y))


def back_points(character, other, level: str | None = None) -> dict[str, np.ndarray]:
    """Where each of ``character``'s hands goes on ``other``'s back: round the torso at
    :func:`level_of`, as far past each side towards the spine as the arms reach
    (``ROUNDS``), a little more than a forearm's thickness off its surface (its widest capsule there); no
    higher than the hugger's shoulders. ``level``: :func:`level_of` when the caller has it."""
    level = level or level_of(character, other)
    centre = other.node(level)
    through = _unit(centre - character.node("spine"))
    left = np.array([through[2], 0.0, -through[0]])  # the hugger's left
    clear = CLEAR * FOREARM * character.scale
    radius = _surface(other, level) + clear
    if level == "pelvis":  # the hips stick out sideways beyond the spine's capsule
        half = 0.5 * length(other.node("l_hip") - other.node("r_hip"))
        radius = max(radius, half + 0.08 * other.scale + clear)
    y = min(float(centre[1]), float(character.node("neck")[1]))
    arm = ARM * character.scale
    out = {}
    # as far round towards the spine as the arms will go (a straight line from the
    # shoulder, less some for the curve round the torso), the same way round on both
    # sides, from square shoulders: a hand that got further would pull its shoulder
    # forward and twist the hugger, so the other could get less far still
    neck = character.node("neck")
    half = 0.5 * length(character.node("l_shoulder") - character.node("r_shoulder"))
    for angle in ROUNDS:
        point = centre + radius * (np.cos(angle) * left + np.sin(angle) * through)
        point[1] = y
        if length(point - (neck + half * left)) <= REACHABLE * arm:
            break
    for hand, side in (("left", 1.0), ("right", -1.0)):
        point = centre + radius * (np.cos(angle) * left * side + np.sin(angle) * through)
        point[1] = y
        out[hand] = point
    return out


def round_the_side(character, other, hand: str, point: np.ndarray, level: str | None = None) -> np.ndarray:
    """Where ``hand`` heads for on its way to ``point`` on ``other``'s back: while it is
    still in front of ``other``'s torso (seen from ``character``), a point out beside the
    torso on the hand's side, a little past its widest (``PAST``), at ``point``'s height:
    an arm goes round a body, not into it. ``level``: :func:`level_of` when the caller has it."""
    palm = character.node(("l_hand", "r_hand")[hand == "right"])
    centre = other.node(level or level_of(character, other))
    through = _unit(centre - character.node("spine"))
    if float((palm - centre) @ through) >= 0.0:
        return point
    left = np.array([through[2], 0.0, -through[0]])
    side = 1.0 if hand == "left" else -1.0
    out = length((point - centre) * np.array([1.0, 0.0, 1.0]))
    beside = centre + 1.15 * out * (np.cos(PAST) * left * side + np.sin(PAST) * through)
    beside[1] = point[1]
    return beside


def hands_on_back(holder, held) -> int:
    """How many of ``holder``'s hands are on ``held``'s back: beyond its torso (the pelvis,
    spine or neck node nearest the hand) as seen from ``holder``'s spine, and within
    ON_BACK of that node."""
    count = 0
    for hand in ("l_hand", "r_hand"):
        palm = holder.node(hand)
        node = min(("pelvis", "spine", "neck"), key=lambda n: length(palm - held.node(n)))
        centre = held.node(node)
        through = _unit(centre - holder.node("spine"))
        off = palm - centre
        if length(off) <= ON_BACK and float(off @ through) > 0.0:
            count += 1
    return count


def torso_gap(character, other) -> float:
    """Surface distance (m) from ``character``'s torso capsules (lower and upper spine) to
    the nearest collidable capsule of ``other``'s body, its arms left out (a partner's arm
    coming round to hold it is no wall to stop at)."""
    links, pos = other.scene.state.links, other.scene.state.nodes.pos
    mine = [(character.node(a), character.node(b), r * character.scale)
            for a, b, r in (("pelvis", "spine", 0.12), ("spine", "neck", 0.13))]  # fmt: skip
    body = other.body
    # its own link rows (contiguous), not a pass over every link in the store
    first, last = body.link_start, body.link_start + body.link_count
    theirs = first + np.flatnonzero((links.body[first:last] == body.index)
                                    & ((links.flags[first:last] & LINK_COLLIDE) != 0))  # fmt: skip
    names = body.node_names
    arm = {body.node_start + names.index(a) for a in ARM_NODES if a in names}
    theirs = [j for j in theirs if int(links.a[j]) not in arm and int(links.b[j]) not in arm]
    rows = np.array(theirs, dtype=np.int64)
    offsets = np.empty((2 * len(rows), 3))
    torso_offsets(pos, links.a, links.b, rows, np.array([(a, b) for a, b, _ in mine]), offsets)
    best = np.inf
    for k, j in enumerate(theirs):
        rj = float(links.radius[j])
        for i, (_, _, ri) in enumerate(mine):
            best = min(best, length(offsets[2 * k + i]) - ri - rj)
    return best


@njit(cache=True)
def torso_offsets(pos, link_a, link_b, rows, mine, out):
    """For each link row ``rows[k]`` and torso segment ``mine[i]`` (its two ends): the vector
    between their closest points, into ``out[2 k + i]`` - the arithmetic of the per-pair
    numpy it replaces, term by term, in one call instead of one per pair."""
    for k in range(len(rows)):
        j = rows[k]
        c, d = pos[link_a[j]], pos[link_b[j]]
        for i in range(2):
            a, b = mine[i, 0], mine[i, 1]
            s, t = closest_segment_params(a, b, c, d)
            for q in range(3):
                out[2 * k + i, q] = (a[q] + s * (b[q] - a[q])) - (c[q] + t * (d[q] - c[q]))


def _surface(other, node: str) -> float:
    """The radius of the thickest capsule at ``other``'s ``node`` (m)."""
    links = other.scene.state.links
    at = other._row(node)
    # a node's links are its body's (contiguous rows): no pass over every link in the store
    b = other.body
    rows = slice(b.link_start, b.link_start + b.link_count)
    collide = (links.flags[rows] & LINK_COLLIDE) != 0
    body = collide & ((links.a[rows] == at) | (links.b[rows] == at))
    return float(links.radius[rows][body].max()) if body.any() else 0.0


def _unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = length(v)
    return v / n if n > 1e-9 else v
