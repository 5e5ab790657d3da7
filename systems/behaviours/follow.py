"""follow: walk after another character and keep near it - a drama manager's "go with her".

A goal behaviour written the way a new built-in one is: this module (its schema, its
system) and its test; the registry finds it, and the handle method
(``character.follow("parent")``), the RPC method (``goal.follow``) and the docs tables come
from the schema.
"""

from __future__ import annotations

from twig_ecs.arguments import Param
from twig_ecs.behavior import Behavior, Goal, Mind
from twig_ecs.goals import GoalSchema, metres, seconds
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.approach import steer_to

#: m/s: a leader slower than this is standing; only then does a follower that gets no
#: closer count as stuck (one walking behind a walking leader keeps its distance, rightly).
LEADER_STILL = 0.2


class Follow(Behavior):
    """Keep within `distance` m of a character, walking after it when it leaves."""

    schema = GoalSchema(
        "follow",
        "Walk after a character and keep within `distance` m of it for `duration` s.",
        (
            Param("target", "name", figure=True, doc="whom to follow"),
            metres("distance", 1.5, "how near to keep (m, ground distance)"),
            seconds("duration", None, "how long to follow (unset: until another goal is queued)"),
        ),
    )

    def act(self, character, mind: Mind, goal: Goal, dt: float) -> None:
        """Close in when further than the distance, stand and watch when near; done after the
        duration or when another goal waits. Fails if the leader is gone or cannot be reached."""
        p = goal.params
        scene = character.scene
        if not scene.has_entity(p["target"]):
            character.stop()
            self.finish(character, goal, False, f"'{p['target']}' is gone")
            return
        duration = p["duration"]
        if (duration is not None and scene.time - goal.started >= duration) or len(mind.goals) > 1:
            character.stop()
            self.finish(character, goal)
            return
        leader = scene.entity(p["target"])
        character.look_at(leader.name)
        if ground_distance(leader.velocity, (0.0, 0.0, 0.0)) > LEADER_STILL:
            goal.memory["best_at"] = scene.time  # a moving leader: keeping pace is no stall
            goal.memory["best"] = ground_distance(character.position, leader.position)
        steer_to(character, goal, leader.name, p["distance"])
