"""hug: approach with arms out, wrap them round the target, hold, let go (SPEC 4).

Goal-driven (``character.hug(target, duration=2)``). Phases, kept in the goal's memory:
``approach`` (walk up with the arms in the hug pose), ``wrap`` (reach the free hands -
both, unless one holds something - behind the target's back, grabbing its spine node
with each as it comes within reach: zero-length links join the hands behind the
target's torso), ``hold`` (for ``duration`` seconds), then release and done. Arms
that cannot close round it within ``WRAP_TIME`` fail the goal.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GRAB_REACH
from twig_ecs.errors import TwigError
from twig_ecs.steering import ground_distance
from twig_ecs.store import LINK_COLLIDE
from twig_ecs.systems import embrace  # noqa: F401  (registers the partner's answer to a hug)
from twig_ecs.systems.approach import steer_to

CLOSE = 0.32  # m (at 1.75 m tall): pelvis to pelvis when the arms start to wrap
WRAP_TIME = 3.0  # s to get both hands round
REACH_IN = 0.25  # m beyond CLOSE where the walk-up ends and the arms start to go round
CREEP = 0.3  # m/s of the last steps in, arms going round
LEAN_IN = 0.22  # m (at 1.75 m tall) the hugger's shoulders lean towards the target
DOCK_FROM = 1.6  # m (ground, pelvis to pelvis) from which the walk-up slows to docking pace
BACK_OF = 0.2  # m (at 1.75 m tall) behind the held torso node that the hands reach for
DOCK = 0.45  # m/s: docking pace - people slow down before they touch


@register
class Hug(Behavior):
    """Hug a character: arms round its torso, hands joined behind its back."""

    name = "hug"
    goal_driven = True
    params = {"target": None, "duration": 2.0}
    required = ("target",)
    kinds = {"target": "figure", "duration": "seconds"}

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach, wrap, hold, release."""
        target = goal.params["target"]
        m = goal.memory
        phase = m.setdefault("phase", "approach")
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        scale = character.scale
        toward = _unit(other.position - character.position)  # on the ground
        if phase == "approach":
            character.pose("hug")
            gap = ground_distance(character.position, other.position)
            if gap <= CLOSE * scale + REACH_IN:
                m["phase"], m["since"] = "wrap", character.scene.time
            elif gap < DOCK_FROM:
                character.walk(toward * DOCK)  # the last steps in, at docking pace
            else:
                steer_to(character, goal, target, DOCK_FROM - 0.1)
            return
        if phase == "wrap":
            now = character.scene.time
            # close in slowly while the arms go round
            if ground_distance(character.position, other.position) > CLOSE * scale:
                character.walk(toward * CREEP)
            else:
                character.stop()
            # the back is held at the torso node nearest the hugger's shoulder height: a
            # child hugs a grown-up round the waist
            shoulder_y = character.node("neck")[1] - 0.1 * scale
            held = m.setdefault(
                "node", min(("spine", "pelvis"), key=lambda n: abs(other.node(n)[1] - shoulder_y))
            )
            back = other.node(held) + 0.12 * scale * _unit(other.node(held) - character.node("spine"))
            hands = m.setdefault("hands", [h for h in ("left", "right") if h not in character.holding])
            if not hands:
                self.finish(character, goal, False, "both hands are full")
                return
            # a hand holding a small thing (a doll) goes round too, holding it
            for hand in _toy_hands(character, target):
                character.reach(tuple(back), hand=hand)
            for hand in hands:
                if character.holding.get(hand) == target:
                    continue
                character.reach(tuple(back), hand=hand)
                grip = _within_reach(character, other, hand, held, late=now - m["since"] > 0.5 * WRAP_TIME)
                if grip is not None:
                    standoff = _surface(other, grip)
                    try:
                        character.grab(target, hand=hand, node=grip, standoff=standoff)
                        character.pose("hug", hand=hand)
                    except TwigError:
                        pass
            if all(character.holding.get(h) == target for h in hands):
                m["phase"], m["since"] = "hold", now
            elif now - m["since"] > WRAP_TIME:
                self.finish(character, goal, False, "could not get its arms round")
            return
        # hold: the arms go slack (the grab joints keep the hands on its back) and the
        # hugger leans in until the two torsos meet; pulling with the arms instead
        # could wrench the target's torso inside out
        if ground_distance(character.position, other.position) > 0.8 * CLOSE * scale:
            character.walk(toward * 0.5 * CREEP)
        else:
            character.stop()
        held = m.get("node", "spine")
        through = _unit(other.node(held) - character.node("spine"))
        back = other.node(held) + BACK_OF * scale * through
        # the hands gripping the torso slide round to its back: each reaches for a
        # point behind it on its own side (the grip keeps it on the torso's surface)
        left = np.array([through[2], 0.0, -through[0]])
        for hand in m["hands"]:
            side = 1.0 if hand == "left" else -1.0
            character.reach(tuple(back + left * side * 0.05 * scale), hand=hand)
        for hand in _toy_hands(character, target):
            character.reach(tuple(back), hand=hand)
        character.lean(toward * LEAN_IN * scale)
        if character.scene.time - m["since"] >= goal.params["duration"]:
            self.finish(character, goal)

    def setup(self) -> None:
        """Whom each character is hugging (to let go of only that one, even after the goal ended)."""
        self.hugging: dict[int, str] = {}

    def start(self, character, goal: Goal | None) -> None:
        """Remember the target."""
        if goal is not None:
            self.hugging[character.entity] = goal.params["target"]

    def stop(self, character, goal: Goal | None) -> None:
        """Let go (of the one it hugged only: a carried toy stays) and stand up straight."""
        character.stoop(None)
        target = self.hugging.pop(character.entity, None)
        for hand, held in list(character.holding.items()):
            if held == target:
                character.release(hand)
        character.stop()
        character.look_at(None)


def _toy_hands(character, target: str) -> list[str]:
    """The hands holding something other than ``target`` (a doll): they hug holding it."""
    return [h for h, held in character.holding.items() if held != target]


def _within_reach(character, other, hand: str, held: str, late: bool) -> str | None:
    """The node of ``other`` that ``hand`` can grip now: the one behind its back, or late
    in the wrap (a short arm, one hand round a grown-up) the nearer of its hips."""
    palm = character.node(("l_hand", "r_hand")[hand == "right"])
    reach = GRAB_REACH * character.scale
    candidates = (held, "l_hip", "r_hip") if late and held == "pelvis" else (held,)
    if late and held == "spine":
        candidates = (held, "l_shoulder", "r_shoulder")
    best = min(candidates, key=lambda n: float(np.linalg.norm(palm - other.node(n))))
    return best if np.linalg.norm(palm - other.node(best)) < reach else None


def _surface(other, node: str) -> float:
    """How far from ``other``'s ``node`` a hand rests: on the surface of the thickest
    capsule there (the arm ignores what it holds, so the forearm may sink in a little)."""
    links = other.scene.state.links
    collide = (links.flags[: links.count] & LINK_COLLIDE) != 0
    at = other._row(node)
    body = collide & ((links.a[: links.count] == at) | (links.b[: links.count] == at))
    return float(links.radius[: links.count][body].max()) if body.any() else 0.0


def _unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v
