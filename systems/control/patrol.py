"""patrol: walk characters round a loop of waypoints (a starting command for demos).

Reads each patrolling character's route (on its Character component) and pelvis
position; writes its walk vector - unless a behaviour other than idle is winning, which
then has the character to itself. Per-character Python: meant for a handful of scripted
walkers in a scene, not crowds (behaviours do the real steering).
"""

from __future__ import annotations

import numpy as np

from twig_ecs.components import Character
from twig_ecs.kernelmath import PELVIS
from twig_ecs.mind import Mind
from twig_ecs.step import StepContext
from twig_ecs.system import System

ARRIVED = 0.35  # m from a waypoint counts as there


class PatrolSystem(System):
    """Walks characters that have a route from waypoint to waypoint, round and round."""

    name = "patrol"

    def run(self, ctx: StepContext) -> None:
        """Point each patrolling character's walk vector at its next waypoint."""
        ch, pos = ctx.state.characters, ctx.state.nodes.pos
        for entity, character in ctx.world.get_component(Character):
            if not character.route:
                continue
            mind = ctx.world.try_component(entity, Mind)
            if mind is not None and (mind.winner != "idle" or not mind.autonomous):
                continue  # a behaviour is in charge, or the character is scripted: it waits
            row = character.index
            here = pos[ch.nodes[row, PELVIS]][[0, 2]]
            target = np.asarray(character.route[character.waypoint])
            offset = target - here
            distance = float(np.hypot(*offset))
            if distance < ARRIVED:
                character.waypoint = (character.waypoint + 1) % len(character.route)
                continue
            ch.walk[row, 0] = offset[0] / distance * character.route_speed
            ch.walk[row, 2] = offset[1] / distance * character.route_speed
