"""grapple: close to arm's length, then shove and hit the target, face to face (SPEC 4).

Goal-driven (``character.grapple(target, duration=3)``): approach with the arms up
(the grapple pose), then, standing square to the target within arm's reach, a shove
with both hands to its chest and blows at its chest and head, one hand then the other -
impacts that hurt it (its pain withdrawal may well win: it staggers back and turns
away). It steps after a target that backs off, at a walk; one that gets away (out of
reach for ``LET_GO`` seconds) ends the fight. Done after ``duration`` seconds of
fighting within reach, or when the target gets away; failed if it cannot get to it.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.approach import steer_to

ARMS_LENGTH = 0.55  # m (at 1.75 m tall): where the fight starts
PUNCH = 0.5  # s per blow or shove
THROUGH = 0.3  # m (at 1.75 m tall) beyond the struck point that a punch aims at
PUNCH_SPEED = 8.0  # m/s of a thrown fist (at 1.75 m tall; a smaller fighter throws slower)
SHOVE_SPEED = 3.0  # m/s of the two hands of a shove (at 1.75 m tall)
APPROACH = 1.4  # m/s: a fighter walks up briskly
FOLLOW = 0.9  # m/s: it steps after a target that backs off, at a walk (not a chase)
EDGE_IN = 0.4  # m/s (at 1.75 m tall): within reach but beyond arm's length, it edges in
LET_GO = 1.5  # s out of reach after which the target has got away: the fight is over


@register
class Grapple(Behavior):
    """Fight: arms bash the target in turns."""

    schema = GoalSchema(
        "grapple",
        "Close to arm's length and shove and hit the target for `duration` s.",
        (
            Param("target", "name", figure=True, doc="whom to fight"),
            seconds("duration", 3.0, "how long to fight within reach"),
        ),
    )
    batch = True

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """:meth:`act` for every grappler at once, over arrays (systems/behaviours/brawl.py);
        a step with a rare event in it (a target gone, a walk-up stalled...) a character at a time."""
        from twig_ecs.systems.behaviours.brawl import act_grapples  # (it reads this module's figures)

        if goals is None:
            goals = [self.world.component_for_entity(e, Mind).goal for e in entities]
        live = [k for k, goal in enumerate(goals) if goal is not None]
        rows, entities, goals = [rows[k] for k in live], [entities[k] for k in live], [goals[k] for k in live]
        if goals and not act_grapples(self, rows, entities, goals, dt):
            for entity, goal in zip(entities, goals, strict=True):
                mind = self.world.component_for_entity(entity, Mind)
                self.act(self.scene.character_handle(entity), mind, goal, dt)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Close in, then shove and punch in turn, square to the target (one grappler: the
        per-character form of :meth:`act_batch`)."""
        target = goal.params["target"]
        m = goal.memory
        scale = character.scale
        character.look_at(target, node="head")
        other = character.scene.entity(target)
        now = character.scene.time
        if "fighting" not in m:
            character.pose("grapple")
            if steer_to(character, goal, target, ARMS_LENGTH * scale, speed=APPROACH):
                m["fighting"] = m["in_reach"] = now
                m.pop("best", None)
            return
        gap = ground_distance(character.position, other.position)
        if gap > 1.3 * ARMS_LENGTH * scale:
            # it backed off: step after it with the arms up; blows and the fight's clock
            # wait, and if it stays out of reach it has got away
            character.pose("grapple")
            if now - m["in_reach"] > LET_GO:
                self.finish(character, goal)
                return
            toward = _unit((other.position - character.position) * np.array([1.0, 0.0, 1.0]))
            character.walk(tuple(toward * FOLLOW * scale**0.5))
            return
        m["in_reach"] = now
        if gap > ARMS_LENGTH * scale:
            # a little beyond arm's length (it stopped short, or the target leaned back):
            # edge in while the blows go on, else the fists fall short
            toward = _unit((other.position - character.position) * np.array([1.0, 0.0, 1.0]))
            character.walk(tuple(toward * EDGE_IN * scale**0.5))
        else:
            character.stop()
        m["fought"] = fought = m.get("fought", 0.0) + dt
        blow = int(fought / PUNCH)
        if m.get("blow") != blow:
            m["blow"] = blow
            if blow % 3 == 0:  # a shove: both hands to the chest
                aim = _unit(other.node("spine") - character.node("neck"))
                for node in ("l_hand", "l_elbow", "r_hand", "r_elbow"):
                    character.set_node_velocity(node, tuple(SHOVE_SPEED * scale**0.5 * aim))
            else:  # a blow, one hand then the other: it starts with a throw, hand and elbow set
                # moving (SPEC 3's "set velocity" node control)
                side = ("l_", "r_")[blow % 2]
                struck = other.node("neck" if blow % 3 == 2 else "spine")
                aim = _unit(struck - character.node(side + "shoulder"))
                for node in (side + "hand", side + "elbow"):
                    character.set_node_velocity(node, tuple(PUNCH_SPEED * scale**0.5 * aim))
        # the hands follow through past what they hit (a hit still moving when it lands)
        if blow % 3 == 0:
            chest = other.node("spine")
            through = _unit(chest - character.node("neck"))
            character.reach(tuple(chest + THROUGH * scale * through), hand="both")
        else:
            hand, spare = (("left", "right"), ("right", "left"))[blow % 2]
            side = ("l_", "r_")[hand == "right"]
            struck = other.node("neck" if blow % 3 == 2 else "spine")
            aim = _unit(struck - character.node(side + "shoulder"))
            character.reach(tuple(struck + THROUGH * scale * aim), hand=hand)
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
