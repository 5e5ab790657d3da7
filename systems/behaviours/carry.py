"""carry and drag: fetch a thing in one hand, then carry it somewhere or drag it away.

Goal-driven. ``character.carry(target, to=None)``: approach the target, reach for it,
grab it when the hand is close enough (a zero-length link), then walk to ``to`` (a
point or entity) if given; done on arrival (still holding it). ``character.drag(target,
distance=5)``: the same fetch, then walk straight away from where it lay for
``distance`` metres, pulling it along; it lets go when the goal ends. ``cradle`` (not
commanded) keeps a carried thing up in front of the body whenever its hand is not busy.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GRAB_REACH
from twig_ecs.components import Character, GrabJoint
from twig_ecs.errors import TwigError
from twig_ecs.goals import GoalSchema, Param, metres, speed
from twig_ecs.kernelmath import HANG
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.approach import steer_to
from twig_ecs.systems.behaviours.footwork import flat_unit, pivot, step_back

FETCH_TIME = 4.0  # s to get a hand on it once there


def fetch(character, goal: Goal, target: str, hand: str) -> bool:
    """Approach ``target`` and grab it in ``hand``; True once held.

    A hand that holds something else lets go of it first (it held on before, and the goal
    "carried" what it already had).
    """
    held = character.holding.get(hand)
    if held == target:
        return True
    if held is not None:
        character.release(hand)
    m = goal.memory
    scale = character.scale
    character.look_at(target)
    if not m.get("near"):
        if not steer_to(character, goal, target, 0.45 * scale):
            return False
        m["near"] = character.scene.time
    other = character.scene.entity(target)
    hand_node = ("l_hand", "r_hand")[hand == "right"]
    nearest = nearest_hold(character, other, hand_node)
    character.reach(target, hand=hand, node=nearest)
    character.stoop(tuple(other.node(nearest)))  # get down to it if it is low
    if np.linalg.norm(character.node(hand_node) - other.node(nearest)) < GRAB_REACH * scale:
        try:
            character.grab(target, hand=hand, node=nearest)
            character.stoop(None)
            if on_feet(other):  # led by the hand, not hoisted: lifting a knee up before the
                character.pose("hang", hand=hand)  # belly threw both down and about (melee seed 3)
            return True
        except TwigError:
            pass
    if character.scene.time - m["near"] > FETCH_TIME:
        character.scene.end_goal(character, goal, False, f"could not get a hand on '{target}'")
    return False


@register
class Carry(Behavior):
    """Fetch a thing and carry it (somewhere)."""

    schema = GoalSchema(
        "carry",
        "Fetch a thing in one hand, then carry it to a point or an entity.",
        (
            Param("target", "name", doc="the thing to fetch"),
            Param("to", "target", None, doc="where to take it (unset: pick it up and stop)"),
            Param("hand", "choice", "right", choices=("left", "right"), doc="the hand that holds it"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Fetch, then walk to the destination."""
        p = goal.params
        if not fetch(character, goal, p["target"], p["hand"]):
            return
        if p["to"] is None:
            self.finish(character, goal)
            return
        if not goal.memory.get("carrying"):  # a new leg of the trip: reset stall tracking
            goal.memory.pop("best", None)
            goal.memory.pop("best_at", None)
            goal.memory["carrying"] = True
        if steer_to(character, goal, p["to"], 0.5, exclude=(p["target"],)):
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Stand still (keep holding it)."""
        character.stop()
        character.stoop(None)
        character.look_at(None)


#: Pairs of nodes a body is dragged by, in the order they are tried: the wrists, the ankles.
DRAG_HOLDS = (("l_hand", "r_hand"), ("l_foot", "r_foot"))
#: lengths at 1.75 m tall, scaled by the dragger's size
DRAG_STAND = 0.5  # m from the held wrists (or ankles) to where the dragger stands to take them
DRAG_STRIDE = 0.35  # m: a backward step's length, unloaded
DRAG_MOST_PACE = 0.5  # m/s (at 1.75 m, by the root of the size): the fastest backward pace
DRAG_LEAN = 0.1  # m the shoulders are held behind the pelvis: leaning back against the load
DRAG_CROUCH = 0.1  # of standing height: knees bent, braced (0.06 before straight-legged standing:
# the legs then hardly bent, and a backward step reached no further than 0.23 m from its hip)
DRAG_HANDS = (0.35, 0.75, 0.14)  # m ahead of the pelvis, height over the ground, apart: arms long
DRAG_GRAB_TIME = 4.0  # s to get both hands on once there
DRAG_MAKE_DO = 2.5  # s: a hand that has not got its wrist (or ankle) by then takes the nearest part
UPRIGHT = 0.5  # of its standing height: a character with its pelvis higher is on its feet
ANKLES_FURTHER = 1.0  # m (at 1.75 m): the ankles are taken only when this much nearer than the wrists


def on_feet(body) -> bool:
    """Is ``body`` a character standing (or walking) under its own control?"""
    return (
        hasattr(body, "posture") and body.posture != "limp" and body.position[1] > UPRIGHT * body.stand_height
    )


def nearest_hold(character, other, hand_node: str) -> str:
    """The node of ``other`` nearest to ``character``'s ``hand_node`` that a hand may take:
    any, but never a foot of someone on their feet (a stepping foot flies a set arc -
    kinematic, as heavy as the world - and, held, flings whoever holds it)."""
    names = [n for n in other.node_names if not (n in ("l_foot", "r_foot") and on_feet(other))]
    gaps = [float(np.linalg.norm(other.node(n) - character.node(hand_node))) for n in names]
    return names[int(np.argmin(gaps))]


def drag_holds(character, target: str, taken: set[tuple[str, str]]) -> tuple[str, str] | None:
    """The pair of nodes of ``target`` to drag it by - its wrists, or its ankles when they are
    much nearer, and not ``taken`` by another dragger (two take an end each) - or None for
    a body that has neither (dragged by one hand instead)."""
    other = character.scene.entity(target)
    pairs = [p for p in DRAG_HOLDS if all(n in other.node_names for n in p)]
    if not pairs:
        return None
    if on_feet(other):
        # someone on their feet is pulled along by the hands: a foot it steps with flies a
        # set arc (kinematic), and held, it would fling whoever holds it
        pairs = pairs[:1]
    pairs = [p for p in pairs if p not in taken] or pairs
    here = character.position

    def cost(pair: tuple[str, str]) -> float:
        """How far the pair is, the ankles counted ANKLES_FURTHER further (the wrists are
        the usual hold: the legs, the heavier half, then slide on the ground)."""
        gap = float(np.linalg.norm((other.node(pair[0]) + other.node(pair[1])) / 2 - here))
        return gap + (ANKLES_FURTHER * character.scale if pair == DRAG_HOLDS[1] else 0.0)

    return min(pairs, key=cost)


@register
class Drag(Behavior):
    """Take a body by both wrists (or ankles) and walk backwards pulling it along the ground."""

    schema = GoalSchema(
        "drag",
        "Take a character, ragdoll or thing by both wrists or ankles (a thing: in one hand) and walk "
        "backwards `distance` m pulling it (a heavy load, or a pace past what it can step backwards, "
        "slows it).",
        (
            Param("target", "name", doc="what to drag"),
            metres("distance", 5.0, "how far to walk away pulling it"),
            Param("hand", "choice", "right", choices=("left", "right"), doc="the hand that holds a thing"),
            speed("speed", 1.0, "the walking pace while pulling"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Get to the body's wrists or ankles, take them, then step backwards pulling."""
        p = goal.params
        m = goal.memory
        target = p["target"]
        if "holds" not in m:  # chosen once: the ends do not swap as it walks round the body
            taken = set()
            for entity, mind in self.candidates():
                there = mind.goals[0] if mind.goals else None
                if entity == character.entity or there is None or there.behavior != self.name:
                    continue
                if there.params["target"] == target and there.memory.get("holds"):
                    taken.add(tuple(there.memory["holds"]))
                    if there.memory.get("spot") is not None:  # stand off on the far side from it
                        m["avoid"] = there.memory["spot"]
            m["holds"] = drag_holds(character, target, taken)
        holds = tuple(m["holds"]) if m["holds"] else None
        if holds == DRAG_HOLDS[1] and on_feet(character.scene.entity(target)):
            # it got up: its feet step now, and held, a stepping foot flings its holder
            character.release()
            self.finish(character, goal, False, f"'{target}' got to its feet")
            return
        if holds is None:  # a thing: one hand, as a carry
            if not fetch(character, goal, target, p["hand"]):
                return
        elif not self._take(character, goal, target, holds):
            return
        if "start" not in m:
            m["start"] = character.position
            other = character.scene.entity(target)
            m["facing"] = flat_unit(other.position - character.position)
            if not m["facing"].any():
                m["facing"] = character.facing
            load = other.mass
            mine = character.mass
            m["stride"] = DRAG_STRIDE * character.scale
            # the load slows it: the pace it would go, times its share of the mass it moves
            m["pace"] = min(p["speed"], DRAG_MOST_PACE * math.sqrt(character.scale)) * mine / (mine + load)
            character.stoop(None)
            character.look_at(target)
        facing = m["facing"]
        s = character.scale
        ch, row = character.scene.state.characters, character.character_row
        ch.crouch[row] = DRAG_CROUCH * character.stand_height
        character.lean(tuple(-facing * DRAG_LEAN * s))
        self._grip(character, facing, holds)
        pivot(character, facing)
        step_back(character, m, facing, m["stride"], m["pace"])
        if ground_distance(character.position, m["start"]) >= p["distance"]:
            self.finish(character, goal)

    def _take(self, character, goal: Goal, target: str, holds: tuple[str, str]) -> bool:
        """Walk to stand beyond the held end of the body, facing it, stoop and take hold with
        both hands; True once both hold."""
        m = goal.memory
        other = character.scene.entity(target)
        held = character.holding
        if held.get("left") == target and held.get("right") == target:
            return True
        for hand, thing in list(held.items()):
            if thing != target:
                character.release(hand)
        s = character.scale
        ends = (other.node(holds[0]) + other.node(holds[1])) / 2
        if "spot" not in m:
            out = flat_unit(ends - (m["avoid"] if "avoid" in m else other.position))
            if not out.any():
                out = flat_unit(character.position - ends)
            m["spot"] = ends + out * DRAG_STAND * s
            m["spot"][1] = 0.0
        if not m.get("near"):
            gap = ground_distance(character.position, m["spot"])
            if gap > 0.15 * s:
                if gap > 1.0 * s:
                    steer_to(character, goal, m["spot"], 0.0, exclude=(target,))
                else:
                    character.walk(flat_unit(m["spot"] - character.position) * max(0.3, min(1.0, 1.2 * gap)))
                return False
            character.stop()
            m["near"] = character.scene.time
        facing = flat_unit(ends - character.position)
        if not pivot(character, facing) and character.scene.time - m["near"] < 1.5:
            return False
        character.look_at(target)
        character.stoop(tuple(ends))
        # each hand to the wrist (or ankle) on its own side
        left = np.array([facing[2], 0.0, -facing[0]])
        a, b = other.node(holds[0]), other.node(holds[1])
        pairs = (("left", holds[0]), ("right", holds[1])) if (a - b) @ left > 0 else (
            ("left", holds[1]), ("right", holds[0]))  # fmt: skip
        late = character.scene.time - m["near"] > DRAG_MAKE_DO
        for hand, node in pairs:
            if held.get(hand) == target:
                continue
            hand_node = ("l_hand", "r_hand")[hand == "right"]
            if late:  # that wrist (or ankle) is out of reach, under the body say: the nearest part will do
                node = nearest_hold(character, other, hand_node)
            character.reach(target, hand=hand, node=node)
            if np.linalg.norm(character.node(hand_node) - other.node(node)) < GRAB_REACH * s:
                try:
                    character.grab(target, hand=hand, node=node)
                except TwigError:
                    pass
        held = character.holding
        if held.get("left") == target and held.get("right") == target:
            return True
        if character.scene.time - m["near"] > DRAG_GRAB_TIME:
            character.scene.end_goal(character, goal, False, f"could not get both hands on '{target}'")
        return False

    @staticmethod
    def _grip(character, facing: np.ndarray, holds) -> None:
        """Hold the hands low and out in front, arms long: the load's held end just off the ground."""
        ahead, height, apart = (v * character.scale for v in DRAG_HANDS)
        left = np.array([facing[2], 0.0, -facing[0]])
        base = character.position * np.array([1.0, 0.0, 1.0]) + facing * ahead + np.array([0.0, height, 0.0])
        if holds is None:
            return
        for hand, sign in (("left", 1.0), ("right", -1.0)):
            character.reach(tuple(base + sign * 0.5 * apart * left), hand=hand)

    def stop(self, character, goal: Goal | None) -> None:
        """Let go and stand."""
        character.release()
        character.stop()
        character.stoop(None)
        character.lean(None)
        character.look_at(None)


@register
class Cradle(Behavior):
    """Holds what a hand carries up in front of the body, clear of the legs.

    Never proposed, never acts: every step, each hand that holds a small loose thing (not
    a character, nothing fixed) and is left hanging by whatever the character is doing is
    put in the ``carry`` pose - a doll is held before the belly, where no swinging leg
    kicks it through, rather than dangled beside the thigh. A behaviour that wants that
    hand (a hug puts it round the partner, doll and all) takes it over as usual.
    """

    name = "cradle"

    def run(self, ctx: StepContext) -> None:
        """Put every hanging hand that holds a loose thing in the carry pose."""
        if not ctx.world.get_component(GrabJoint):  # no hand holds anything (a crowd's usual step)
            return
        scene = self.scene
        modes = scene.state.characters.arm_mode
        for entity, (character, _) in ctx.world.get_components(Character, Mind):
            if not character.holding:
                continue
            me = scene.character_handle(entity)
            if me.posture == "limp":
                continue  # no control: its arms hang, whatever they hold
            for hand, held in me.holding.items():
                h = int(hand == "right")
                if modes[me.character_row, h] == HANG and _loose(scene, held):
                    me.pose("carry", hand=hand)


def _loose(scene, name: str) -> bool:
    """Is ``name`` a thing a hand carries about: not a character, no node fixed in place."""
    if not scene.has_entity(name):
        return False
    thing = scene.entity(name)
    if hasattr(thing, "holding"):
        return False
    body = thing.body
    rows = body.rows
    return not bool((scene.state.nodes.flags[rows] & NODE_LOCKED).any())
