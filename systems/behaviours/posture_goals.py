"""sit, stand, freeze and gesture as goals (SPEC 4): posture and arm modes on command.

Reads each character's current goal; writes its posture mode, arm modes or node locks.
``sit`` walks to the seat first when it is more than a step away; ``freeze`` locks every
node of the body where it is until the goal ends (after ``duration`` seconds, or when
another goal is queued).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GESTURES
from twig_ecs.components import Character
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.systems.behaviours.approach import steer_to
from twig_ecs.systems.behaviours.footwork import pivot

STOOD = 0.05  # fraction of standing height

# -- sitting on a seat (all lengths at 1.75 m tall, scaled by the body's size) ------------------
#: m the pelvis stands out from the seat's front edge before it sits: the calves just short of
#: the edge, so the lowering takes the hips back over the seat, the feet staying planted
STAND_OFF = 0.22
#: m kept between the body's middle and either end of the seat (half a hip width and more)
END_MARGIN = 0.2
SIDE_BY_SIDE = 0.55  # m between the places of two 1.75 m tall sitting side by side (by their sizes)
ARRIVED = 0.12  # m from the standing spot that counts as there
#: m from the spot within which it walks straight at it, slowing (the approach field's
#: obstacle push would have it creep along the seat for seconds)
DOCK = 1.8
DOCK_PACE = (0.35, 1.0)  # m/s: the slowest and the fastest pace of the last metre (at 1.75 m)
DOCK_TIME = 3.0  # s for the last metre, else it is stuck
TURN_TIME = 3.0  # s to pivot before it sits anyway
LOWER_TIME = 0.9  # s from standing to seated (BELIEVABILITY: 0.5-1 s)
LOWER_LEAN = 0.14  # m the shoulders lead the pelvis at the middle of the lowering
SEATED = 0.03  # m: the pelvis this near its seated height (above or below) counts as seated ...
RESTING = 0.15  # m/s: ... once it moves no faster than this
SETTLE_TIME = 2.0  # s after the lowering for the pelvis to come to rest on the seat
SIT_TIME = 9.5  # s from the start of the goal to sitting, else it fails (the issue: within 10 s)
HANDS_ON_THIGHS = 0.6  # of the way from hip to knee where the hands rest while lowering
LEAN_OVER_TIME = 0.4  # s: from a seat, the shoulders lean out over the feet before it rises
LEAN_OVER = 0.18  # m (at 1.75 m) the shoulders lead the pelvis by then


@dataclass(frozen=True, slots=True)
class SeatFrame:
    """Where a seat is and which way it is sat on: its top surface's middle and axes."""

    centre: np.ndarray  # (x, y, z): the middle of the top surface, y its height
    along: np.ndarray  # unit ground vector along the seat's length
    front: np.ndarray  # unit ground vector out of the side it is sat on from
    half_length: float  # m
    half_depth: float  # m, from the middle to the front edge


def seat_frame(character, seat: str) -> SeatFrame:
    """The frame of ``seat`` as ``character`` sees it.

    The top surface is the seat's highest nodes (within 5 cm, their radii added); its long
    axis is the surface's principal axis, and its front the side that faces the character:
    a bench has no back, so it is sat on from the side one comes from (a character at an
    end takes the side its ``front_*`` nodes are on, if it has any).
    """
    scene = character.scene
    body = scene.entity(seat)
    rows = body.body.rows
    pos = scene.state.nodes.pos[rows]
    radius = scene.state.nodes.radius[rows]
    tops = pos[:, 1] + radius
    top = float(tops.max())
    on_top = tops > top - 0.05
    flat = pos[on_top][:, [0, 2]]
    mid = flat.mean(axis=0)
    spread = flat - mid
    if len(flat) > 1 and float(np.abs(spread).max()) > 1e-6:
        _, vectors = np.linalg.eigh(spread.T @ spread)
        along = vectors[:, -1]  # the principal axis: the seat's length
    else:  # a stool: one point on top, sat on facing away from the character
        along = np.array([1.0, 0.0])
    normal = np.array([-along[1], along[0]])
    edge = float(radius[on_top].max())
    half_length = float(np.abs(spread @ along).max()) + edge
    half_depth = float(np.abs(spread @ normal).max()) + edge
    here = character.position[[0, 2]] - mid
    side = float(here @ normal)
    if abs(side) < 0.05:
        names = [n for n, keep in zip(body.node_names, on_top, strict=True) if keep]
        fronts = [k for k, n in enumerate(names) if n.startswith("front")]
        side = float((spread[fronts] @ normal).mean()) if fronts else side
    if side < 0.0:
        normal = -normal
    return SeatFrame(
        np.array([mid[0], top, mid[1]]),
        np.array([along[0], 0.0, along[1]]),
        np.array([normal[0], 0.0, normal[1]]),
        half_length,
        half_depth,
    )


def hands_on_thighs(character) -> None:
    """Reach each hand to the top of its thigh, ``HANDS_ON_THIGHS`` of the way to the knee."""
    for hand, side in (("left", "l"), ("right", "r")):
        hip, knee = character.node(f"{side}_hip"), character.node(f"{side}_knee")
        thigh = hip + HANDS_ON_THIGHS * (knee - hip)
        character.reach(tuple(thigh + np.array([0.0, 0.08 * character.scale, 0.0])), hand=hand)


def on_seat(character, height: float) -> bool:
    """Whether the pelvis sits at ``height`` (``character.seat``'s: the hip bar on the seat's
    top), within ``SEATED``, or higher by as much as the lower spine's capsule is thicker
    than the hip bar: then that capsule rests on the seat (the pelvis came down behind the
    hip bar, as it does when the hips end up turned across the seat's front edge)."""
    nodes = character.scene.state.nodes
    rows = character.node_row("pelvis"), character.node_row("l_hip")
    thicker = max(0.0, float(nodes.radius[rows[0]] - nodes.radius[rows[1]]))
    return -SEATED < character.position[1] - height < SEATED + thicker


def _smooth(x: float) -> float:
    """0 to 1 with zero slope at both ends (a smoothstep)."""
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


@register
class SitDown(Behavior):
    """Sit on the ground, or walk to a seat and sit on it.

    On a seat: walk to a spot before the side of the seat it comes to (``seat_frame``),
    pivot to turn its back to the seat, then lower over ``LOWER_TIME``: the pelvis goes
    back and down onto the seat while the feet stay planted, the shoulders lean forward
    and the hands rest on the thighs. Done once the pelvis rests on the seat; a seat it
    cannot get to, or that it cannot sit on, fails the goal with the reason (standing).
    """

    schema = GoalSchema(
        "sit",
        "Sit on the ground, or walk to a seat entity and sit on it.",
        (Param("on", "name", None, doc="the seat (unset: the ground where it stands)"),),
        handle_method=False,  # handle.sit is the immediate control: do("sit", ...) queues the goal
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach the seat's front, turn, lower; done once the pelvis rests on it."""
        seat = goal.params["on"]
        m = goal.memory
        if seat is None:
            if "seat" not in m:
                character.sit()
                m["seat"] = float(character.seat[1])
            if abs(character.position[1] - m["seat"]) < 0.08:
                self.finish(character, goal)
            return
        scene = character.scene
        if scene.time - goal.started > SIT_TIME:
            self._fail(character, goal, f"could not sit on '{seat}' within {SIT_TIME:g} s")
            return
        phase = m.setdefault("phase", "walk")
        if phase == "walk":
            self._walk(character, goal, seat)
        elif phase == "turn":
            self._turn(character, goal)
        else:
            self._lower(character, goal, seat)

    def _walk(self, character, goal: Goal, seat: str) -> None:
        """Walk to the standing spot before the seat's front."""
        m = goal.memory
        s = character.scale
        if "spot" not in m and not self._choose_place(character, goal, seat):
            return
        spot = m["spot"]
        off = (spot - character.position) * np.array([1.0, 0.0, 1.0])
        gap = float(np.linalg.norm(off))
        if gap > DOCK * s and "dock_at" not in m:
            steer_to(character, goal, spot, 0.0)  # round the seat, and anything else, to the spot
            if goal.finished:  # stuck on the way
                goal.reason = f"could not get to '{seat}': {goal.reason}"
            return
        # the last metre: straight at the spot, slowing down to stop there
        m.setdefault("dock_at", character.scene.time)
        if character.scene.time - m["dock_at"] > DOCK_TIME:
            self._fail(character, goal, f"could not get to '{seat}': stuck {gap:.2f} m from its front")
            return
        if gap >= ARRIVED * s:
            pace = min(DOCK_PACE[1], max(DOCK_PACE[0], 1.2 * gap)) * math.sqrt(s)
            character.walk(off / gap * pace)
        else:
            character.stop()
            m["phase"], m["phase_at"] = "turn", character.scene.time
            character.look_at(tuple(spot + 3.0 * m["front"] + np.array([0.0, 1.5 * s, 0.0])))

    def _choose_place(self, character, goal: Goal, seat: str) -> bool:
        """Pick the place on the seat (once per goal): the side it comes to, as near as it
        can to where it stands along the seat and a body's width from anyone sitting there
        or on the way to; False when the goal failed (too high, no room)."""
        m = goal.memory
        frame = seat_frame(character, seat)
        s = character.scale
        if frame.centre[1] > character.stand_height:  # above the hips: no lowering onto that
            top = frame.centre[1]
            self._fail(character, goal, f"'{seat}' is too high to sit on (its top is {top:.2f} m up)")
            return False
        room = max(0.0, frame.half_length - END_MARGIN * s)
        want = float((character.position - frame.centre) @ frame.along)
        taken = [
            (float((p - frame.centre) @ frame.along), size) for p, size in self._places_taken(character, seat)
        ]
        # where it stands along the seat if that is free, else one of the places a body's
        # width apart spread evenly along it (a seat for two is sat on at both ends)
        width = SIDE_BY_SIDE * s
        count = int(2.0 * room / width) + 1
        spread = [0.0] if count == 1 else [float(c) for c in np.linspace(-room, room, count)]
        choices = [max(-room, min(room, want)), *spread]
        free = [
            c
            for c in choices
            if all(abs(c - t) >= 0.5 * SIDE_BY_SIDE * (s + size) - 1e-9 for t, size in taken)
        ]
        if not free:
            self._fail(character, goal, f"no room on '{seat}'")
            return False
        offset = min(free, key=lambda c: abs(c - want))
        spot = frame.centre + offset * frame.along + (frame.half_depth + STAND_OFF * s) * frame.front
        spot[1] = 0.0
        m["spot"], m["front"], m["seat_at"] = spot, frame.front, frame.centre + offset * frame.along
        return True

    def _places_taken(self, character, seat: str) -> list[tuple[np.ndarray, float]]:
        """Where others sit on ``seat``, or are going to, and their sizes (``scale``):
        pelvises on it, and the places of other sit goals on it."""
        scene = character.scene
        body = scene.entity(seat)
        rows = body.body.rows
        pos = scene.state.nodes.pos[rows]
        lo, hi = pos.min(axis=0) - 0.2, pos.max(axis=0) + 0.2
        places = []
        for entity, (_, mind) in self.world.get_components(Character, Mind):
            if entity == character.entity:
                continue
            other = scene.character_handle(entity)
            goal = mind.goals[0] if mind.goals else None
            going = goal is not None and goal.behavior == self.name and goal.params["on"] == seat
            if going and "seat_at" in goal.memory:
                places.append((goal.memory["seat_at"], other.scale))
                continue
            p = other.position
            on_it = (lo[[0, 2]] <= p[[0, 2]]).all() and (p[[0, 2]] <= hi[[0, 2]]).all()
            if other.posture in ("sit", "rise") and on_it:
                places.append((p, other.scale))
        return places

    def _turn(self, character, goal: Goal) -> None:
        """Pivot on the spot to turn the back to the seat."""
        m = goal.memory
        character.stop()
        hands_on_thighs(character)  # held, not flung out by the turn
        if pivot(character, m["front"]) or character.scene.time - m["phase_at"] > TURN_TIME:
            m["phase"], m["phase_at"] = "lower", character.scene.time
            m["from"] = character.position

    def _lower(self, character, goal: Goal, seat: str) -> None:
        """Lower the pelvis back and down onto the seat, hands on the thighs."""
        m = goal.memory
        scene = character.scene
        if "height" not in m:
            character.sit(on=seat)
            m["height"] = float(character.seat[1])
        t = (scene.time - m["phase_at"]) / LOWER_TIME
        k = _smooth(t)
        start, end = m["from"], m["seat_at"]
        target = start + k * (end - start)
        target[1] = start[1] + k * (m["height"] - start[1])
        rows = scene.state.characters
        rows.seat[character.character_row] = target
        bell = math.sin(math.pi * min(1.0, t))
        character.lean(tuple(m["front"] * LOWER_LEAN * character.scale * bell))
        hands_on_thighs(character)
        if t < 1.0:
            return
        resting = on_seat(character, m["height"]) and np.linalg.norm(character.velocity) < RESTING
        if resting and character.posture == "sit":
            character.lean(None)
            character.pose("hang")
            self.finish(character, goal)
        elif scene.time - m["phase_at"] > LOWER_TIME + SETTLE_TIME:
            self._fail(character, goal, f"could not get down onto '{seat}' (is something in the way?)")

    def _fail(self, character, goal: Goal, reason: str) -> None:
        """Give up standing: never left half sat, on the ground by the seat."""
        if character.posture == "sit":
            character.stand()
        character.stop()
        character.lean(None)
        character.pose("hang")
        self.finish(character, goal, False, reason)

    def stop(self, character, goal: Goal | None) -> None:
        """Look ahead again; the arms hang unless it sits on."""
        character.look_at(None)
        if character.posture != "sit":
            character.lean(None)
            character.pose("hang")


@register
class StandUp(Behavior):
    """Stand up (from sitting, or from limp).

    From a seat: the shoulders lean out over the feet first (``LEAN_OVER_TIME``), hands on
    the thighs, then the posture controller's rise lifts the pelvis with the shoulders held
    over the feet; the arms hang again once it stands.
    """

    schema = GoalSchema("stand", "Stand up (from sitting, or from limp).", handle_method=False)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Lean over the feet, rise; done once standing at full height."""
        m = goal.memory
        now = character.scene.time
        if "started" not in m:
            m["started"] = now
            m["seated"] = character.posture == "sit"
            if not m["seated"]:
                character.stand()
        if m["seated"] and "rising" not in m:
            k = _smooth((now - m["started"]) / LEAN_OVER_TIME)
            character.lean(tuple(character.facing * LEAN_OVER * character.scale * k))
            hands_on_thighs(character)
            if k < 1.0 and character.posture == "sit":
                return
            m["rising"] = True
            character.lean(None)
            character.stand()
        if character.posture == "rise":
            hands_on_thighs(character)  # pushing off them
        elif m["seated"] and character.arm_modes["left"] == "reach":
            character.pose("hang")
        if character.posture == "stand" and abs(character.position[1] - character.stand_height) < (
            STOOD * character.stand_height
        ):
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Upright, arms hanging, if it was stopped half way."""
        character.lean(None)
        if goal is not None and goal.memory.get("seated"):
            character.pose("hang")


@register
class Freeze(Behavior):
    """Hold perfectly still: every node of the body locked where it is."""

    schema = GoalSchema(
        "freeze",
        "Hold every node still for `duration` s, or until the next goal.",
        (seconds("duration", None, "how long to hold still (unset: until another goal is queued)"),),
    )

    def start(self, character, goal: Goal | None) -> None:
        """Lock every node."""
        for node in character.node_names:
            character.lock(node)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Stay locked; done after the duration, or when another goal waits."""
        duration = goal.params["duration"]
        waited = character.scene.time - goal.started
        if (duration is not None and waited >= duration) or len(mind.goals) > 1:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Unlock every node; the feet plant again on their own."""
        for node in character.node_names:
            character.unlock(node)


@register
class Gesture(Behavior):
    """Wave or point for a while."""

    schema = GoalSchema(
        "gesture",
        "Wave, or point at a target, for `duration` s.",
        (
            Param("name", "choice", choices=GESTURES, doc="the gesture"),
            Param("target", "target", None, doc="what to point at (an entity or a point)"),
            seconds("duration", 2.0, "how long to keep it up"),
        ),
        handle_method=False,  # handle.gesture is the immediate control: do("gesture", ...) is the goal
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Hold the gesture; done after the duration."""
        p = goal.params
        if "started" not in goal.memory:
            goal.memory["started"] = True
            character.gesture(p["name"], p["target"])
        if character.scene.time - goal.started >= p["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down."""
        character.gesture(None)
