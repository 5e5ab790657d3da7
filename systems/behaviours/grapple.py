"""grapple: close to a fighting gap, then exchanges of shoves and blows, face to face (SPEC 4).

Goal-driven (``character.grapple(target, duration=3)``): approach with the arms up (the
grapple pose) to the fighting gap (:func:`fighting_gap`: where straight arms just reach
the target's chest), then fight in exchanges, each ``EXCHANGE`` s: guard up while it
steps in, the hands drawn back before the chest (``LOAD``, ``WIND``: elbows bent), then
thrown out (``STRIKE``) - both hands through the target's chest (a shove) or one fist at
its chest or head, in turn (``SEQUENCE``) - and back to guard (``RECOVER``). A strike
lands through contact; one struck by a strike's hands (:func:`shoved_by`) is knocked back
in proportion to the masses and staggers back, still facing (:func:`knocked_back`,
:func:`stagger`). The defender (``defend``, ``systems/behaviours/fight.py``) answers a
shove with a shove, and the two take turns (:class:`Striking`): both bodies move. A blow
that hurts sets off the target's pain withdrawal (it staggers back and turns away): the
fighter stops striking, steps after it while it faces it and lets it go once it turns its
back. It steps after a target that backs off, at a walk; one that gets away (out of reach
for ``LET_GO`` s) ends the fight. Done after ``duration`` seconds of fighting within
reach, or when the target gets away; failed if it cannot get to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.approach import steer_to
from twig_ecs.systems.behaviours.footwork import pivot
from twig_ecs.systems.behaviours.withdraw import Withdrawing, mass_share
from twig_ecs.systems.control.arms import unfold

#: m (at 1.75 m tall): the radius of the upper spine's capsule, the chest a shove meets
CHEST = 0.13
TORSO = 0.52  # m (at 1.75 m tall): pelvis to neck, by which the chest's radius is scaled
#: of the gap at which straight arms touch the chest: where the two stand between strikes
#: (bent arms well clear of the other: no tangle of arms; the old 0.55 m between adults left
#: no room to straighten an arm, and they stood chest to chest)
STANCE = 1.1
LOAD = 0.3  # s: guard up, stepping in, then the hands drawn back...
WIND = 0.2  # s: ... over the last of it, elbows bent
STRIKE = 0.22  # s: the arms thrown out, a step in behind them
DRIVE = 0.6  # of STRIKE: the hands are driven at the opponent that long at most (:func:`drive`)
RECOVER = 0.3  # s: the hands back to guard, the feet settle
EXCHANGE = LOAD + STRIKE + RECOVER
#: the exchanges in turn: a jab with one fist at the chest, a two-handed shove to the chest,
#: a blow at the head with the other fist, another shove (a defender shoves back after a
#: shove, and only blocks a fist: the fighter's shoves come every other exchange)
SEQUENCE = ("left_chest", "shove", "right_head", "shove")
THROUGH = 0.3  # m (at 1.75 m tall) beyond the struck point that a shove or a punch aims at
PUNCH_SPEED = 8.0  # m/s of a thrown fist (at 1.75 m tall; a smaller fighter throws slower)
SHOVE_SPEED = 3.0  # m/s of the two hands of a shove (at 1.75 m tall)
STEP_IN = 0.6  # m/s (at 1.75 m tall, by the root of the size): the step in behind a strike
APPROACH = 1.4  # m/s: a fighter walks up briskly
FOLLOW = 0.9  # m/s: it steps after a target that backs off, at a walk (not a chase)
EDGE_IN = 0.4  # m/s (at 1.75 m tall): a little beyond the fighting gap, it edges in
CLOSE_ENOUGH = 0.85  # of the fighting gap: a strike is thrown from this near (straight arms
#: reach 1 / STANCE of it: they go through the chest)...
WAIT = 0.6  # s: ... or after closing in this long, wherever it is
CLOSE_IN = 1.2  # m/s (at 1.75 m tall, by the root of the size): its pace closing in to strike
LET_GO = 1.5  # s out of reach after which the target has got away: the fight is over
OUT_OF_REACH = 1.75  # of the fighting gap: further than this, the target has backed off
STAGGER = 0.4  # s: a character shoved staggers back this long...
STAGGER_PACE = 1.0  # m/s (at 1.75 m tall, by the root of the size): ... at this pace
KNOCK = 1.2  # m/s (at 1.75 m tall, by the root of the size): a shove sends the upper body back
#: the nodes a knock sends back (the arms too: left behind, they folded at the elbow)
UPPER_BODY = ("pelvis", "spine", "neck", "head", "l_shoulder", "r_shoulder", "l_hip", "r_hip",
              "l_elbow", "r_elbow", "l_hand", "r_hand")  # fmt: skip


@dataclass(slots=True)
class Striking:
    """A shove or a blow on its way (systems/behaviours/grapple.py): wound up from the time it
    is announced, in flight from ``since``; its hands, meeting the opponent before ``until``,
    knock it back (:func:`shoved_by`). Fighters take turns: neither winds up while the
    other's strike is on its way (:func:`busy`)."""

    since: float  # s (scene time): the hands are thrown
    until: float  # s: the strike is over
    kind: str = "shove"  # one of SEQUENCE


@register
class Grapple(Behavior):
    """Fight: exchanges of shoves and blows, arms drawn back and thrown out, both bodies moving."""

    schema = GoalSchema(
        "grapple",
        "Close to arm's length and shove and hit the target for `duration` s.",
        (
            Param("target", "name", figure=True, doc="whom to fight"),
            seconds("duration", 3.0, "how long to fight within reach"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Close in, then exchanges: load, strike with a step in, recover; stagger when shoved."""
        target = goal.params["target"]
        m = goal.memory
        scale = character.scale
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        now = character.scene.time
        if "gap" not in m:
            m["gap"] = fighting_gap(character, other)
        span = m["gap"]
        if "fighting" not in m:
            character.pose("grapple")
            if steer_to(character, goal, target, span, speed=APPROACH):
                m["fighting"] = m["in_reach"] = now
                m.pop("best", None)
            return
        if now >= m.get("stagger_until", 0.0) and shoved_by(character.scene, character.entity, other.entity):
            knocked_back(character, other)
            m["stagger_until"] = now + STAGGER
            # the exchange it was in is broken off; the next (in SEQUENCE) starts with a load
            m["clock"] = 0.0
            m.pop("kind", None)
        gap = ground_distance(character.position, other.position)
        retreat = character.scene.world.try_component(other.entity, Withdrawing)
        if retreat is not None and retreat.until > now:
            # hurt, it staggers back: no more blows, guard up, a step after it while it faces
            # this way; once it turns its back and walks off, it is let go - the fight is over
            character.pose("grapple")
            m["clock"] = 0.0
            m.pop("kind", None)
            if now >= retreat.stagger_until:
                character.stop()
                if gap > OUT_OF_REACH * span:
                    self.finish(character, goal)
            elif gap > span:
                character.walk(tuple(toward(character, other) * FOLLOW * scale**0.5))
            else:
                character.stop()
            return
        if gap > OUT_OF_REACH * span:
            # it backed off: step after it with the arms up; blows and the fight's clock
            # wait, and if it stays out of reach it has got away
            character.pose("grapple")
            if now - m["in_reach"] > LET_GO:
                self.finish(character, goal)
                return
            character.walk(tuple(toward(character, other) * FOLLOW * scale**0.5))
            return
        m["in_reach"] = now
        m["fought"] = fought = m.get("fought", 0.0) + dt
        if fought >= goal.params["duration"]:
            self.finish(character, goal)
            return
        if now < m.get("stagger_until", 0.0):
            stagger(character, other)
            return
        m["clock"] = clock = m.get("clock", 0.0) + dt
        phase = clock % EXCHANGE
        if m.get("number") != int(clock // EXCHANGE):
            m["number"] = int(clock // EXCHANGE)
            m.pop("kind", None)  # a new exchange: its strike is chosen as the load begins
        if phase < LOAD:
            if "kind" not in m:
                if busy(character.scene, other.entity):
                    # the other's turn: wait, guard up, until its strike is over
                    m["clock"] = clock - dt
                    character.pose("grapple")
                    keep_gap(character, other, gap, span)
                    return
                m["exchange"] = count = m.get("exchange", -1) + 1
                m["kind"] = SEQUENCE[count % len(SEQUENCE)]
                m["wound"] = 0.0
            # guard up, it steps in to where a straight arm goes through the other's chest and
            # winds up over the last WIND of the load (wound up while it walked in, its hands
            # met the other's guard and folded its elbows past 150 degrees)
            near = gap <= CLOSE_ENOUGH * span
            if near:
                character.stop()
            else:
                character.walk(tuple(toward(character, other) * CLOSE_IN * scale**0.5))
            if phase < LOAD - WIND:
                character.pose("grapple")
            elif not near and m["wound"] < WAIT:
                character.pose("grapple")
                m["clock"] = clock - dt  # not near enough yet: the blow would fall short
                m["wound"] += dt
            else:
                load(character, other)
                if phase + dt >= LOAD and not busy(character.scene, character.entity):
                    announce(character, now + dt, m["kind"])
        elif phase < LOAD + STRIKE:
            strike(character, other, m["kind"], step_in=gap > CLOSE_ENOUGH * span)
        else:
            character.pose("grapple")
            keep_gap(character, other, gap, span)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down, stand."""
        end_strike(character.scene, character.entity)
        character.pose("hang")
        character.stop()
        character.look_at(None)


def toward(character, other) -> np.ndarray:
    """Unit ground vector from ``character`` to ``other``."""
    return _unit((other.position - character.position) * np.array([1.0, 0.0, 1.0]))


def load(character, other) -> None:
    """Draw both hands back to before the chest, elbows bent (the wind-up of a strike)."""
    ahead = toward(character, other)
    chest = 0.5 * (character.node("spine") + character.node("neck"))
    for hand, side in (("left", "l_"), ("right", "r_")):
        shoulder = character.node(side + "shoulder")
        # fists before the chest, a little in, the elbows bent ~110 degrees (nearer the
        # shoulder, they folded past the 145 degrees an elbow bends)
        point = shoulder + 0.2 * character.scale * ahead + 0.3 * (chest - shoulder)
        point[1] = shoulder[1] - 0.12 * character.scale
        character.reach(tuple(point), hand=hand)
        # a reaching hand keeps to the elbow's hinge alone: pressed by the other's arms, it
        # folded the elbow past 150 degrees; held in close, it is kept from that as the
        # grapple pose keeps its hands (arms.unfold)
        nodes = character.scene.state.nodes
        rows = (character.node_row(side + n) for n in ("shoulder", "elbow", "hand"))
        unfold(nodes.pos, nodes.prev, *rows)


def _aims(character, other, kind: str) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(hand, struck point, unit aim) for each hand a strike of ``kind`` throws: a shove and a
    blow at the chest go to the middle of the upper spine, a blow at the head to the head."""
    chest = 0.5 * (other.node("spine") + other.node("neck"))
    if kind == "shove":
        aim = _unit(chest - character.node("neck"))
        return [("left", chest, aim), ("right", chest, aim)]
    hand = "left" if kind.startswith("left") else "right"
    struck = other.node("head") if kind.endswith("head") else chest
    aim = _unit(struck - character.node(hand[0] + "_shoulder"))
    return [(hand, struck, aim)]


def announce(character, at: float, kind: str) -> None:
    """A strike of ``kind`` (in ``SEQUENCE``) whose hands will be thrown at ``at`` (s, scene
    time), in flight for ``STRIKE`` s (:class:`Striking`)."""
    character.scene.world.add_component(character.entity, Striking(at, at + STRIKE, kind))


def busy(scene, entity: int) -> bool:
    """Is a strike of this character's on its way (wound up or in flight)?"""
    striking = scene.world.try_component(entity, Striking)
    return striking is not None and striking.until > scene.time


def drive(character, other, kind: str) -> None:
    """Keep the striking hands and elbows moving at the opponent (SPEC 3's set velocity) for the
    first ``DRIVE`` of the strike, each until its arm is straight: set once, the arm's reach
    servo slowed a fist to ~2 m/s within 0.15 m, blows thrown from before the chest landed as
    pats, and a shove's second hand stopped where it met a raised forearm."""
    striking = character.scene.world.try_component(character.entity, Striking)
    now = character.scene.time
    if striking is None or not striking.since <= now < striking.since + DRIVE * STRIKE:
        return
    speed = (SHOVE_SPEED if kind == "shove" else PUNCH_SPEED) * character.scale**0.5
    for hand, _, aim in _aims(character, other, kind):
        side = hand[0] + "_"
        arm = float(np.linalg.norm(character.node(side + "shoulder") - character.node(side + "elbow")))
        arm += float(np.linalg.norm(character.node(side + "elbow") - character.node(side + "hand")))
        out = float(np.linalg.norm(character.node(side + "hand") - character.node(side + "shoulder")))
        if out < 0.95 * arm:
            for node in (side + "hand", side + "elbow"):
                character.set_node_velocity(node, tuple(speed * aim))


def strike(character, other, kind: str, step_in: bool = True) -> None:
    """The striking hands reach through what they hit, the spare one guards; a step in behind
    (unless ``step_in`` is off: already close)."""
    drive(character, other, kind)
    struck_hands = set()
    for hand, struck, aim in _aims(character, other, kind):
        character.reach(tuple(struck + THROUGH * character.scale * aim), hand=hand)
        struck_hands.add(hand)
    for spare in {"left", "right"} - struck_hands:
        character.pose("grapple", hand=spare)
    if step_in:
        character.walk(tuple(toward(character, other) * STEP_IN * character.scale**0.5))
    else:
        character.stop()


def fighting_gap(character, other) -> float:
    """Pelvis to pelvis on the ground (m) where ``character`` fights ``other``: ``STANCE``
    times the gap at which its straight arms just reach ``other``'s chest - the arm's length
    seen level from the shoulders' height to the chest's, plus the chest's radius (by
    ``other``'s torso length: it may be a ragdoll) - so a strike lands with the step in."""
    arm = float(np.linalg.norm(character.node("l_shoulder") - character.node("l_elbow")))
    arm += float(np.linalg.norm(character.node("l_elbow") - character.node("l_hand")))
    shoulders = 0.5 * (character.node("l_shoulder")[1] + character.node("r_shoulder")[1])
    chest = 0.5 * (other.node("spine") + other.node("neck"))
    drop = shoulders - float(chest[1])
    reach = math.sqrt(max(arm * arm - drop * drop, (0.3 * arm) ** 2))
    torso = float(np.linalg.norm(other.node("neck") - other.node("pelvis")))
    return STANCE * (reach + CHEST * torso / TORSO)


def keep_gap(character, other, gap: float, span: float) -> None:
    """Edge in when a little beyond the fighting gap ``span``, step back (facing it) when too
    close for an arm to straighten, else stand (feet planted)."""
    if gap > 1.15 * span:
        character.walk(tuple(toward(character, other) * EDGE_IN * character.scale**0.5))
    elif gap < 0.95 * span:
        stagger(character, other)
    else:
        character.stop()


def knocked_back(character, other) -> None:
    """A shove or a blow that landed: the upper body is sent back from ``other`` at
    ``KNOCK`` m/s times the mass share (the shover's mass over its own, at most 1: a child's
    shove barely rocks a grown-up). The hands' push alone hardly moves it - the arms'
    controllers are soft, and posture holds the pelvis over the feet - so the push the
    shove gives is set here; :func:`stagger` then steps back under it."""
    away = -toward(character, other) * KNOCK * math.sqrt(character.scale)
    away *= mass_share(character.scene, other.entity, character.entity)
    nodes, dt = character.scene.state.nodes, character.scene.dt
    for node in UPPER_BODY:
        row = character.node_row(node)
        rise = (nodes.pos[row, 1] - nodes.prev[row, 1]) / dt
        character.set_node_velocity(node, (float(away[0]), rise, float(away[2])))


def stagger(character, other) -> None:
    """Shoved: back off from the opponent at ``STAGGER_PACE``, still facing it (the hips are
    turned to it, :func:`~footwork.pivot`, while the gait steps after the pelvis), arms up."""
    facing = toward(character, other)
    character.pose("grapple")
    character.walk(tuple(-facing * STAGGER_PACE * math.sqrt(character.scale)))
    pivot(character, facing)


def shoved_by(scene, me: int, other: int) -> bool:
    """Did a strike of ``other``'s land on ``me`` this step: a hand or forearm of ``other``,
    thrown in the last ``STRIKE`` s, met it (a contact event either way round)? A shove or a
    fist, on the body or on a raised arm; hands that rest on it after do not count."""
    striking = scene.world.try_component(other, Striking)
    if striking is None or not striking.since <= scene.time <= striking.until:
        return False
    for event in scene.events:
        if event.kind != "contact":
            continue
        if (event.body, event.other_body) == (me, other) and "hand" in event.other_link:
            return True
        if (event.body, event.other_body) == (other, me) and "hand" in event.link:
            return True
    return False


def end_strike(scene, entity: int) -> None:
    """Forget a character's strike (when it stops fighting)."""
    if scene.world.has_component(entity, Striking):
        scene.world.remove_component(entity, Striking)


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v
