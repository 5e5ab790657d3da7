"""grapple: close to arm's length, then the arms bash the target (SPEC 4).

Goal-driven (``character.grapple(target, duration=3)``): approach with the arms up
(the grapple pose), then throw the hands at the target's head and chest in turn -
shoves and punches whose impacts hurt it (its pain withdrawal may well win). Follows
the target when it backs off; done after ``duration`` seconds of fighting within reach
(and failed, like an approach, if it cannot catch up).
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.steering import ground_distance
from twig_ecs.systems.approach import steer_to

ARMS_LENGTH = 0.55  # m (at 1.75 m tall): where the fight starts
PUNCH = 0.4  # s per blow; the hands take turns
THROUGH = 0.3  # m (at 1.75 m tall) beyond the struck point that a punch aims at
PUNCH_SPEED = 9.0  # m/s of a thrown fist
CHASE = 1.6  # m/s: a fighter goes after its target faster than a walk


@register
class Grapple(Behavior):
    """Fight: arms bash the target in turns."""

    name = "grapple"
    goal_driven = True
    params = {"target": None, "duration": 3.0}
    required = ("target",)
    kinds = {"target": "figure", "duration": "seconds"}

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Close in, then punch left and right in turn."""
        target = goal.params["target"]
        m = goal.memory
        scale = character.scale
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        if "fighting" not in m:
            character.pose("grapple")
            if steer_to(character, goal, target, ARMS_LENGTH * scale, speed=CHASE):
                m["fighting"] = character.scene.time
                m.pop("best", None)  # following it later starts stall-watching afresh
            return
        if ground_distance(character.position, other.position) > 1.3 * ARMS_LENGTH * scale:
            # it backed off: follow with the arms up; blows and the fight's clock wait
            # until it is within reach again (a fight is not over because one ran off)
            character.pose("grapple")
            steer_to(character, goal, target, ARMS_LENGTH * scale, speed=CHASE)
            return
        character.stop()
        m.pop("best", None)
        m["fought"] = fought = m.get("fought", 0.0) + dt
        hand = ("left", "right")[int(fought / PUNCH) % 2]
        spare = ("right", "left")[int(fought / PUNCH) % 2]
        # a punch aims through the target, so the hand is still fast when it lands, and
        # starts with a throw: hand and elbow set moving at PUNCH_SPEED (SPEC 3's "set
        # velocity" node control)
        blow = int(fought / PUNCH)
        struck = other.node("neck" if blow % 4 < 2 else "spine")
        side = ("l_", "r_")[hand == "right"]
        aim = _unit(struck - character.node(side + "shoulder"))
        character.reach(tuple(struck + THROUGH * scale * aim), hand=hand)
        if m.get("blow") != blow:
            m["blow"] = blow
            for node in (side + "hand", side + "elbow"):
                character.set_node_velocity(node, tuple(PUNCH_SPEED * aim))
        character.pose("grapple", hand=spare)
        if fought >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down, stand."""
        character.pose("hang")
        character.stop()
        character.look_at(None)


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else v
