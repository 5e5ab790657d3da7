"""sit, stand, freeze and gesture as goals (SPEC 4): posture and arm modes on command.

Reads each character's current goal; writes its posture mode, arm modes or node locks.
``sit`` walks to the seat first when it is more than a step away; ``freeze`` locks every
node of the body where it is until the goal ends (after ``duration`` seconds, or when
another goal is queued).
"""

from __future__ import annotations

from twig_ecs.behavior import Behavior, Goal, Mind, register
from twig_ecs.character import GESTURES
from twig_ecs.goals import GoalSchema, Param, seconds
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.approach import steer_to

SEATED = 0.08  # m: pelvis this close to the seat height counts as seated
STOOD = 0.05  # fraction of standing height


@register
class SitDown(Behavior):
    """Sit on the ground, or walk to a seat and sit on it."""

    schema = GoalSchema(
        "sit",
        "Sit on the ground, or walk to a seat entity and sit on it.",
        (Param("on", "name", None, doc="the seat (unset: the ground where it stands)"),),
        handle_method=False,  # handle.sit is the immediate control: do("sit", ...) queues the goal
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Approach the seat if needed, then sit; done once the pelvis rests."""
        seat = goal.params["on"]
        m = goal.memory
        if "seat" not in m:
            if (
                seat is not None
                and ground_distance(character.position, character.scene.entity(seat).position) > 0.7
            ):
                if not steer_to(character, goal, seat, 0.45):
                    return
            character.sit(on=seat)
            m["seat"] = character.seat[1]
        if abs(character.position[1] - m["seat"]) < SEATED:
            self.finish(character, goal)


@register
class StandUp(Behavior):
    """Stand up (from sitting, or from limp)."""

    schema = GoalSchema("stand", "Stand up (from sitting, or from limp).", handle_method=False)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Rise; done once standing at full height."""
        if "started" not in goal.memory:
            goal.memory["started"] = True
            character.stand()
        if character.posture == "stand" and abs(character.position[1] - character.stand_height) < (
            STOOD * character.stand_height
        ):
            self.finish(character, goal)


@register
class Freeze(Behavior):
    """Hold perfectly still: every node of the body locked where it is."""

    schema = GoalSchema(
        "freeze",
        "Hold every node still for `duration` s, or until the next goal.",
        (seconds("duration", None, "how long to hold still (unset: until another goal is queued)"),),
    )

    def start(self, character, goal: Goal | None) -> None:
        """Lock every node."""
        for node in character.node_names:
            character.lock(node)

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Stay locked; done after the duration, or when another goal waits."""
        duration = goal.params["duration"]
        waited = character.scene.time - goal.started
        if (duration is not None and waited >= duration) or len(mind.goals) > 1:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Unlock every node; the feet plant again on their own."""
        for node in character.node_names:
            character.unlock(node)


@register
class Gesture(Behavior):
    """Wave or point for a while."""

    schema = GoalSchema(
        "gesture",
        "Wave, or point at a target, for `duration` s.",
        (
            Param("name", "choice", choices=GESTURES, doc="the gesture"),
            Param("target", "target", None, doc="what to point at (an entity or a point)"),
            seconds("duration", 2.0, "how long to keep it up"),
        ),
        handle_method=False,  # handle.gesture is the immediate control: do("gesture", ...) is the goal
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Hold the gesture; done after the duration."""
        p = goal.params
        if "started" not in goal.memory:
            goal.memory["started"] = True
            character.gesture(p["name"], p["target"])
        if character.scene.time - goal.started >= p["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal: Goal | None) -> None:
        """Arms down."""
        character.gesture(None)
