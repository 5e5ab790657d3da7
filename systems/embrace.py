"""embrace: a character being hugged holds the hugger back (BELIEVABILITY "Touch").

Not commanded: every autonomous character whom someone is hugging - a hug goal aimed
at it in its ``wrap`` or ``hold`` phase, the hugger within ``NEAR`` - stops what it was
doing (its activation beats watching, play and goals), turns its head and shoulders to
the hugger, stoops to a smaller one, and puts its free hands round it, on its back:
each hand reaches for a point just behind the hugger's spine (a little to its side), so
the arms close round the hugger's torso. When the hug is over it lets go (the arms
relax) and stands up; what it was doing resumes.
"""

from __future__ import annotations

import esper
import numpy as np

from twig_ecs.behavior import Behavior, Mind, register

EMBRACE = 0.9  # activation: above goals (0.8), below pain withdrawal
NEAR = 1.0  # m (ground) between the two for a hug to be answered
BACK = 0.12  # m (at 1.75 m tall, the hugger's) behind its spine that the hands aim for
SIDE = 0.07  # m (at 1.75 m tall, the hugger's) either side of the spine for two hands
HAND_SPEED = 0.5  # m/s: how fast the point a hand reaches for moves (a hand that flew at a
# small child's back would be a blow: 1 kg at 1.3 m/s hurts a 1.05 m child)


def huggers_of(scene) -> dict[int, int]:
    """Who is hugging whom right now: {hugged entity: hugger entity} (wrap or hold phase)."""
    out: dict[int, int] = {}
    for entity, mind in scene.goal_holders():
        goal = mind.goal
        if goal is None or goal.behavior != "hug" or goal.memory.get("phase") not in ("wrap", "hold"):
            continue
        target = goal.params.get("target")
        if target in scene.entity_names:
            out[scene.entity(target).entity] = entity
    return out


@register
class Embrace(Behavior):
    """Hold someone who hugs you: face them, stoop to them, arms round their back."""

    name = "embrace"

    def setup(self) -> None:
        """Who hugs whom this step (looked up once per step); where each hand is reaching."""
        self.hugged_by: dict[int, int] = {}
        self.aims: dict[tuple[int, str], np.ndarray] = {}

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters someone is hugging."""
        self.hugged_by = huggers_of(self.scene)
        return [(e, esper.component_for_entity(e, Mind)) for e in self.hugged_by
                if esper.entity_exists(e) and esper.has_component(e, Mind)]  # fmt: skip

    def activation(self, character, mind: Mind, goal) -> float:
        """High while a hugger is close."""
        hugger = self.hugged_by.get(character.entity)
        if hugger is None:
            return 0.0
        other = self.scene.character_handle(hugger)
        near = np.hypot(*(other.position - character.position)[[0, 2]]) < NEAR
        return EMBRACE if near else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Face the hugger, get down to it, hands on its back."""
        other = self.scene.character_handle(self.hugged_by[character.entity])
        character.stop()
        character.look_at(other.name, node="head")
        spine = other.node("spine")
        through = (spine - character.node("spine")) * np.array([1.0, 0.0, 1.0])
        through /= max(float(np.linalg.norm(through)), 1e-9)
        left = np.array([through[2], 0.0, -through[0]])
        back = spine + through * BACK * other.scale
        character.stoop(tuple(back))
        for hand, side in (("left", 1.0), ("right", -1.0)):
            if hand in character.holding:
                continue
            # the point reached for glides from the hand to the back at HAND_SPEED
            key = (character.entity, hand)
            aim = self.aims.get(key)
            if aim is None:
                aim = character.node(("l_hand", "r_hand")[hand == "right"])
            goal_point = back + left * side * SIDE * other.scale
            step = goal_point - aim
            far = float(np.linalg.norm(step))
            if far > HAND_SPEED * dt:
                step *= HAND_SPEED * dt / far
            self.aims[key] = aim = aim + step
            character.reach(tuple(aim), hand=hand)

    def stop(self, character, goal) -> None:
        """Arms down, stand up."""
        character.stoop(None)
        for hand in ("left", "right"):
            self.aims.pop((character.entity, hand), None)
            if hand not in character.holding:
                character.pose("hang", hand=hand)
        character.look_at(None)
