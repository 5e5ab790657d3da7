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
from twig_ecs.systems.approach import steer_to

CLOSE = 0.32  # m (at 1.75 m tall): pelvis to pelvis when the arms start to wrap
WRAP_TIME = 3.0  # s to get both hands round
LEAN_IN = 0.15  # m (at 1.75 m tall) the hugger's shoulders lean towards the target


@register
class Hug(Behavior):
    """Hug a character: arms round its torso, hands joined behind its back."""

    name = "hug"
    goal_driven = True
    params = {"target": None, "duration": 2.0}
    required = ("target",)

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
            character.stop()  # the feet stay put: the arms do the rest
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
        # hold: the arms go slack (the grab joints keep the hands on its back) and the
        # hugger leans in until the two torsos meet; pulling with the arms instead
        # could wrench the target's torso inside out
        character.stop()
        character.pose("hang")
        toward = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
        toward /= max(float(np.linalg.norm(toward)), 1e-9)
        character._chars().lean[character._crow] = toward * LEAN_IN * scale
        if character.scene.time - m["since"] >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Let go and stand up straight."""
        character.stoop(None)
        character.release()
        character.stop()
        character.look_at(None)


def _unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v
