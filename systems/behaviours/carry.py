"""carry and drag: fetch a thing in one hand, then carry it somewhere or drag it away.

Goal-driven. ``character.carry(target, to=None)``: approach the target, reach for it,
grab it when the hand is close enough (a zero-length link), then walk to ``to`` (a
point or entity) if given; done on arrival (still holding it). ``character.drag(target,
distance=5)``: the same fetch, then walk straight away from where it lay for
``distance`` metres, pulling it along; it lets go when the goal ends. ``cradle`` (not
commanded) keeps a carried thing up in front of the body whenever its hand is not busy.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GRAB_REACH
from twig_ecs.components import Character
from twig_ecs.errors import TwigError
from twig_ecs.goals import GoalSchema, Param, metres, speed
from twig_ecs.kernelmath import HANG
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.approach import steer_to, target_point

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
    pos = other.node_positions
    nearest = other.node_names[int(np.argmin(np.linalg.norm(pos - character.node(hand_node), axis=1)))]
    character.reach(target, hand=hand, node=nearest)
    character.stoop(tuple(other.node(nearest)))  # get down to it if it is low
    if np.linalg.norm(character.node(hand_node) - other.node(nearest)) < GRAB_REACH * scale:
        try:
            character.grab(target, hand=hand, node=nearest)
            character.stoop(None)
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


@register
class Drag(Behavior):
    """Grab a character or ragdoll and walk away pulling it."""

    schema = GoalSchema(
        "drag",
        "Grab a character, ragdoll or thing and walk `distance` m straight away from it, pulling it.",
        (
            Param("target", "name", doc="what to drag"),
            metres("distance", 5.0, "how far to walk away pulling it"),
            Param("hand", "choice", "right", choices=("left", "right"), doc="the hand that holds it"),
            speed("speed", 1.0, "the walking pace while pulling"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Fetch, then walk away from where it lay."""
        p = goal.params
        m = goal.memory
        if not fetch(character, goal, p["target"], p["hand"]):
            return
        if "start" not in m:
            m["start"] = character.position
            away = (character.position - target_point(character, p["target"])) * np.array([1.0, 0.0, 1.0])
            m["away"] = away / max(float(np.linalg.norm(away)), 1e-9)
        character.look_at(None)
        character.walk(m["away"] * p["speed"])
        if ground_distance(character.position, m["start"]) >= p["distance"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Let go and stand."""
        character.release()
        character.stop()
        character.stoop(None)


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
    rows = slice(body.node_start, body.node_start + len(body.node_names))
    return not bool((scene.state.nodes.flags[rows] & NODE_LOCKED).any())
