"""embrace: a character being hugged holds the hugger back (BELIEVABILITY "Touch").

Not commanded: every autonomous character whom someone is coming to hug - a hug goal
aimed at it, the hugger within ``TURN_NEAR`` - stops what it was doing (its activation
beats watching, play and goals) and turns to the hugger, head and body (a few slow
steps on the spot). Once the hug's arms go round (``wrap`` or ``hold``, within
``NEAR``) it bends over a smaller hugger, and puts its free hands round it, on its back:
each hand reaches for a point just behind the hugger's spine (a little to its side), so
the arms close round the hugger's torso. When the hug is over it lets go (the arms
relax) and stands up; what it was doing resumes.
"""

from __future__ import annotations

import esper
import numpy as np

from twig_ecs.behavior import Behavior, Mind, goal_targets, register
from twig_ecs.components import HandAims
from twig_ecs.steering import length

EMBRACE = 0.9  # activation: above goals (0.8), below pain withdrawal
NEAR = 1.0  # m (ground) between the two for a hug to be answered
TURN_NEAR = 3.0  # m (ground): a hugger coming this close is turned to
TURN_PACE = 0.25  # m/s (at 1.75 m tall) of the steps on the spot that turn the body to it
FACED = 0.35  # rad: facing the hugger this nearly is facing it
BACK = 0.12  # m (at 1.75 m tall, the hugger's) behind its spine that the hands aim for
HIGH = 0.05  # m (at 1.75 m tall, the hugger's) above a small hugger's neck node: the top of its back
LEAN = 0.0  # m (at 1.75 m tall) the shoulders lean over a small hugger (more would push it off)
UP = 0.12  # m (at 1.75 m tall, the hugger's) above a small hugger's neck node the hands wait
SHOULDER = 0.22  # m (at 1.75 m tall, the hugger's) either side of its neck they wait, over its shoulders
SIDE = 0.07  # m (at 1.75 m tall, the hugger's) either side of the spine for two hands
HAND_SPEED = 0.5  # m/s: how fast the point a hand reaches for moves (a hand that flew at a
# small child's back would be a blow: 1 kg at 1.3 m/s hurts a 1.05 m child)


def glide(character, hand: str, point: np.ndarray, step: float) -> None:
    """Reach ``hand`` for a point that moves from the hand towards ``point`` by at most
    ``step`` metres this step (the character's :class:`~twig_ecs.components.HandAims`
    keeps it between steps): a hand that flew at a body would be a blow."""
    aims = esper.try_component(character.entity, HandAims)
    if aims is None:
        aims = HandAims()
        esper.add_component(character.entity, aims)
    aim = aims.points.get(hand)
    if aim is None:
        aim = character.node(("l_hand", "r_hand")[hand == "right"])
    move = point - aim
    far = length(move)
    if far > step:
        move *= step / far
    aims.points[hand] = aim = aim + move
    character.reach(aim, hand=hand)  # (a fresh float array: no conversion from a tuple)


def lower_hands(character) -> None:
    """Forget where the hands were reaching (a hug or an embrace is over)."""
    if esper.has_component(character.entity, HandAims):
        esper.remove_component(character.entity, HandAims)


def held_at(character, hugger) -> str:
    """Where on ``hugger``'s back ``character``'s hands go: its upper back ("neck") when
    it is much smaller - a child at a grown-up's hips; its lower back ("waist", between
    pelvis and spine) when it is about as big, under the hugger's own arms round its
    upper back; else (a giant) its mid-back ("spine")."""
    if hugger.scale < 0.8 * character.scale:
        return "neck"
    return "waist" if hugger.scale < 1.25 * character.scale else "spine"


def huggers_of(scene) -> dict[int, tuple[int, str]]:
    """Who is hugging whom right now: {hugged entity: (hugger entity, hug phase)}."""
    return {
        hugged: (hugger, goal.memory.get("phase", "approach"))
        for hugged, (hugger, goal) in goal_targets(scene, "hug").items()
    }


@register
class Embrace(Behavior):
    """Hold someone who hugs you: face them, stoop to them, arms round their back."""

    name = "embrace"

    def setup(self) -> None:
        """Who hugs whom this step (looked up once per step)."""
        self.hugged_by: dict[int, int] = {}

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters someone is hugging."""
        self.hugged_by = huggers_of(self.scene)
        return [(e, esper.component_for_entity(e, Mind)) for e in self.hugged_by
                if esper.entity_exists(e) and esper.has_component(e, Mind)]  # fmt: skip

    def activation(self, character, mind: Mind, goal) -> float:
        """High while a hugger is close (or coming, to turn to it)."""
        hugger, phase = self.hugged_by.get(character.entity, (None, ""))
        if hugger is None:
            return 0.0
        other = self.scene.character_handle(hugger)
        far = np.hypot(*(other.position - character.position)[[0, 2]])
        return EMBRACE if far < (NEAR if phase in ("wrap", "hold") else TURN_NEAR) else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Turn to a coming hugger; then bend to it, hands on its back."""
        hugger, phase = self.hugged_by[character.entity]
        other = self.scene.character_handle(hugger)
        character.look_at(other.name, node="head")
        to = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
        to /= max(length(to), 1e-9)
        if phase not in ("wrap", "hold"):
            # turn the whole body to it: a few slow steps on the spot, facing it
            off = float(np.arccos(np.clip(character.facing @ to, -1.0, 1.0)))
            if off > FACED:
                character.walk(tuple(to * TURN_PACE * character.scale))
            else:
                character.stop()
            return
        character.stop()
        back_node = held_at(character, other)
        if back_node == "waist":
            centre = 0.5 * (other.node("pelvis") + other.node("spine"))
        else:
            centre = other.node(back_node)
        through = (centre - character.node("spine")) * np.array([1.0, 0.0, 1.0])
        through /= max(length(through), 1e-9)
        left = np.array([through[2], 0.0, -through[0]])
        back = centre + through * BACK * other.scale
        small = back_node == "neck"
        if small and phase == "wrap":
            # a small hugger: stand tall while its arms go round (bending over it now
            # would push it off), the hands coming to rest over its shoulders
            back = centre + UP * other.scale * np.array([0.0, 1.0, 0.0])
            character.stoop(None)
        elif small:  # then the hands on its upper back, bending a little over it (a
            # deeper bend or a crouch would push it off)
            back[1] += HIGH * other.scale
            character.lean(tuple(through * LEAN * character.scale))
        elif back_node == "waist":  # an equal: stand tall, arms round its lower back, under
            # its own arms (bending or crouching would push it off)
            character.stoop(None)
        else:
            character.stoop(tuple(back))  # a smaller (not small) hugger: get down to it
        for hand, side in (("left", 1.0), ("right", -1.0)):
            if hand in character.holding:
                continue
            spread = SIDE if not (small and phase == "wrap") else SHOULDER
            glide(character, hand, back + left * side * spread * other.scale, HAND_SPEED * dt)

    def stop(self, character, goal) -> None:
        """Arms down, stand up."""
        character.stoop(None)
        character.lean(None)
        lower_hands(character)
        for hand in ("left", "right"):
            if hand not in character.holding:
                character.pose("hang", hand=hand)
        character.look_at(None)
