"""hug: approach with arms out, wrap them round the target, hold, let go (SPEC 4).

Goal-driven (``character.hug(target, duration=2)``). Phases, kept in the goal's memory:
``approach`` (walk up with the arms in the hug pose), ``wrap`` (reach both hands behind
the target's back, grabbing its spine node with each as it comes within reach: two
zero-length links join the hands behind the target's torso), ``hold`` (for ``duration``
seconds), then release and done. Arms that cannot close round it within ``WRAP_TIME``
fail the goal.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GRAB_REACH
from twig_ecs.errors import TwigError
from twig_ecs.steering import ground_distance
from twig_ecs.systems.approach import steer_to

CLOSE = 0.32  # m (at 1.75 m tall): pelvis to pelvis when the arms start to wrap
WRAP_TIME = 3.0  # s to get both hands round
TORSO = 0.13  # m (at 1.75 m tall): the upper spine's radius; two of them apart is touching


@register
class Hug(Behavior):
    """Hug a character: arms round its torso, hands joined behind its back."""

    name = "hug"
    goal_driven = True
    params = {"target": None, "duration": 2.0}

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach, wrap, hold, release."""
        target = goal.params["target"]
        m = goal.memory
        phase = m.setdefault("phase", "approach")
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        scale = character._chars().scale[character._crow]
        if phase == "approach":
            character.pose("hug")
            if steer_to(character, goal, target, CLOSE * scale):
                m["phase"], m["since"] = "wrap", character.scene.time
            return
        if phase == "wrap":
            # keep closing in gently: the arms pull the two together once joined
            if ground_distance(character.position, other.position) > CLOSE * scale:
                away = other.position - character.position
                character.walk(away / max(np.linalg.norm(away), 1e-9) * 0.4)
            else:
                character.stop()
            back = other.node("spine") + 0.12 * scale * _unit(other.node("spine") - character.node("spine"))
            for hand in ("left", "right"):
                if hand in character.holding:
                    continue
                character.reach(tuple(back), hand=hand)
                node = ("l_hand", "r_hand")[hand == "right"]
                if np.linalg.norm(character.node(node) - other.node("spine")) < GRAB_REACH * scale:
                    try:
                        character.grab(target, hand=hand, node="spine")
                        character.pose("hug", hand=hand)
                    except TwigError:
                        pass
            if len(character.holding) == 2:
                m["phase"], m["since"] = "hold", character.scene.time
            elif character.scene.time - m["since"] > WRAP_TIME:
                self.finish(character, goal, False, "could not get both arms round")
            return
        # hold: the arms draw the hands (and so the target's back) in towards the chest,
        # until the two torsos meet and push back
        character.stop()
        hold = character.node("neck") + character.shoulder_facing * TORSO * 2.5 * scale
        hold[1] -= 0.1 * scale
        character.reach(tuple(hold), hand="both")
        if character.scene.time - m["since"] >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Let go and stand."""
        character.release()
        character.stop()
        character.look_at(None)


def _unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v
