"""A plug-in behaviour: characters with a DanceMood dance when nothing else matters more.

It shows the whole recipe of docs/authoring-behaviours.md: a component (the
per-character parameters), a component for what it is in the middle of (its dance
floor: state lives on the character, not in a dict on the system), and a Behavior
system that proposes an activation and, when it wins, writes the character's motor
vector through the CharacterHandle API.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind


@dataclass(slots=True)
class DanceMood:
    """How much a character wants to dance, and how fast."""

    joy: float = 0.5  # activation: above idle (0.1), below commanded goals (0.8)
    tempo: float = 1.0  # sways per second
    sway: float = 0.5  # m/s of the side-to-side steps


@dataclass(slots=True)
class DanceFloor:
    """Where a dancing character started dancing: it sways round that spot."""

    at: np.ndarray


class Dance(Behavior):
    """Sway from side to side, arms up in turns, while the mood lasts."""

    name = "dance"
    component = DanceMood

    def activation(self, character, mind, goal) -> float:
        """As joyful as the character's mood, unless it has something to do."""
        return 0.0 if mind.goals else self.settings(character).joy

    def start(self, character, goal) -> None:
        """Remember where the dance floor is (on the character: the scene's inspector and
        snapshots see it, and it goes when the character does)."""
        self.world.add_component(character.entity, DanceFloor(character.position.copy()))

    def act(self, character, mind, goal, dt: float) -> None:
        """Step left and right round the spot, waving one arm and then the other."""
        mood = self.settings(character)
        phase = 2 * math.pi * mood.tempo * character.scene.time
        side = character.facing[[2, 0]] * [1, -1]  # the character's left, on the ground
        drift = self.world.component_for_entity(character.entity, DanceFloor).at - character.position
        vx = side[0] * mood.sway * math.sin(phase) + 0.5 * drift[0]
        vz = side[1] * mood.sway * math.sin(phase) + 0.5 * drift[2]
        character.walk((vx, 0.0, vz))
        up, down = ("left", "right") if math.sin(phase) > 0 else ("right", "left")
        character.gesture("wave", hand=up)
        character.pose("hang", hand=down)

    def stop(self, character, goal) -> None:
        """Stand still, arms down; the dance floor is forgotten."""
        self.world.remove_component(character.entity, DanceFloor)
        character.stop()
        character.gesture(None, hand="both")


class CrowdDance(Behavior):
    """The same dance written over arrays (docs/authoring-behaviours.md, "A behaviour over
    arrays"): `propose_crowd` and `act_crowd` instead of `activation` and `act`, a few numpy
    calls a step for a whole floor; `start` and `stop` stay per character (they run only
    when one starts or stops). Its dancers move as those of :class:`Dance` do."""

    name = "crowd_dance"
    component = DanceMood
    start = Dance.start
    stop = Dance.stop

    def propose_crowd(self, crowd) -> np.ndarray:
        """As joyful as each one's mood, unless it has something to do."""
        busy = np.array([bool(self.world.component_for_entity(e, Mind).goals) for e in crowd.entities])
        return np.where(busy, 0.0, crowd.settings("joy"))

    def act_crowd(self, crowd) -> None:
        """Step left and right round each one's spot, waving one arm and then the other."""
        tempo, sway = crowd.settings("tempo"), crowd.settings("sway")
        phase = 2 * np.pi * tempo * self.scene.time
        here = crowd.positions
        side = crowd.facing[:, [2, 0]] * [1, -1]  # each one's left, on the ground
        drift = np.array([self.world.component_for_entity(e, DanceFloor).at for e in crowd.entities]) - here
        swing = np.sin(phase)
        vx = side[:, 0] * sway * swing + 0.5 * drift[:, 0]
        vz = side[:, 1] * sway * swing + 0.5 * drift[:, 2]
        crowd.walk(np.stack([vx, np.zeros(len(crowd)), vz], axis=1))
        left_up = swing > 0
        crowd.wave(np.where(left_up, "left", "right"))
        crowd.pose("hang", np.where(left_up, "right", "left"))
