"""select_behavior: each character's highest activation wins and acts (SPEC 4).

Reads the activations the behaviour systems proposed this step (on each character's
:class:`~twig_ecs.mind.Mind`); writes the winner and calls its ``act``, which sets
the character's controller targets. Switching is stable: the current winner gets a
bonus (``STICKINESS``) and keeps the floor for at least ``MIN_DWELL`` seconds unless
a rival beats it by ``URGENT`` (a reflex such as pain withdrawal), so two behaviours
with near-equal activations cannot trade places every frame.
"""

from __future__ import annotations

from twig_ecs.components import Character
from twig_ecs.mind import BehaviorChanged, Mind
from twig_ecs.step import StepContext
from twig_ecs.system import System

STICKINESS = 0.05  # activation bonus of the current winner
MIN_DWELL = 0.25  # s a winner keeps the floor against ordinary rivals
URGENT = 0.3  # a rival this much stronger takes over at once
IDLE = 0.1  # activation of doing nothing in particular


class SelectBehaviorSystem(System):
    """Picks each character's winning behaviour and lets it act."""

    name = "select_behavior"

    def run(self, ctx: StepContext) -> None:
        """Select, switch (with hysteresis) and act, for every character."""
        dt = ctx.dt
        scene = self.scene
        now = scene.time
        behaviors = scene.behaviors
        batches: dict[str, tuple[list[int], list[int], list]] = {}
        for entity, (character, mind) in ctx.world.get_components(Character, Mind):
            proposals = mind.activations
            was = mind.winner
            if len(proposals) == 1 and proposals.get(was, -1.0) >= IDLE:
                # the one proposal is the winner's, above idle: it carries on (a crowd's usual step)
                proposals["idle"] = IDLE
                best = was
            else:
                proposals.setdefault("idle", IDLE)
                best = max(proposals, key=proposals.__getitem__)
            if best != was and was in proposals:
                held = now - mind.since < MIN_DWELL
                margin = proposals[best] - (proposals[was] + STICKINESS)
                if margin <= 0.0 or (held and margin < URGENT):
                    best = was
            goals = mind.goals
            goal = goals[0] if goals else None
            handle = None  # made only when needed: most steps most characters just carry on
            if best != was:
                handle = scene.character_handle(entity)
                old = behaviors.get(was)
                if old is not None:
                    old.stop(handle, goal if goal is not None and goal.behavior == was else None)
                scene.emit(BehaviorChanged(entity, was, best))
                mind.winner, mind.since = best, now
                mind.switches += 1
                new = behaviors.get(best)
                if new is not None:
                    new.start(handle, goal if goal is not None and goal.behavior == best else None)
            # this step's proposals become `last`; last step's dict is reused for the next
            mind.last, mind.activations = proposals, mind.last
            mind.activations.clear()
            winner = behaviors.get(best)
            if winner is None:
                continue
            own_goal = goal if goal is not None and goal.behavior == best else None
            if own_goal is not None and own_goal.status == "pending":
                own_goal.status, own_goal.started = "active", now
            if winner.batch:
                batch = batches.get(best)
                if batch is None:
                    batch = batches[best] = ([], [], [])
                batch[0].append(character.index)
                batch[1].append(entity)
                batch[2].append(own_goal)
                continue
            winner.act(handle or scene.character_handle(entity), mind, own_goal, dt)
        # batch behaviours act once for all the characters they won, after the others
        for name, (rows, entities, goals) in batches.items():
            behavior = behaviors[name]
            if behavior.goal_driven:  # each one's goal too (None where it has none)
                behavior.act_batch(rows, entities, dt, goals=goals)
            else:
                behavior.act_batch(rows, entities, dt)
