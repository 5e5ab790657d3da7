"""Who holds goals, and goal ids: what goal-driven behaviours look up each step.

A scene's :class:`GoalBook` is a world resource (``ctx.world.resource(GoalBook)``); the
scene's ``note_goal`` / ``goal_holders`` / ``goal_holders_of`` / ``end_goal`` /
``new_goal_id`` are its methods under their old names.
"""

from __future__ import annotations

from collections.abc import Callable

from twig_ecs.events import Event
from twig_ecs.mind import Goal, GoalDone, GoalFailed, Mind
from twig_ecs.world import World


class GoalBook:
    """The characters that were given goals (entity -> Mind), an index of them by the
    behaviour of their current goal, and the scene's goal-id counter.

    Goal-driven behaviours look only at the holders, so a step costs as many characters as
    hold goals, not all of them: characters join when given a goal (:meth:`note`) and leave
    once their goals have run out.

    A mind's goals change only through :meth:`note` (after the goal is queued) and
    :meth:`end`: what is made from them (the index by behaviour, a batch's goals) is kept
    until :attr:`changes` moves.
    """

    def __init__(self, world: World, emit: Callable[[Event], None]) -> None:
        self.world = world
        self.emit = emit
        self.made = 0  # goal ids count per scene, so a restored or replayed scene numbers alike
        self._holders: dict[int, Mind] = {}
        self._changes = 0
        # holders by the behaviour of their current goal, rebuilt when a goal is given or ends
        # (holders_of)
        self._index: tuple[int, dict[str, list[tuple[int, Mind]]]] = (-1, {})

    def new_id(self) -> int:
        """A fresh goal id, unique within this scene (1, 2, 3...)."""
        self.made += 1
        return self.made

    def note(self, entity: int, mind: Mind) -> None:
        """Record that a character was given a goal."""
        self._holders[entity] = mind
        self._changes += 1

    def forget(self, entity: int) -> None:
        """A character is gone: it holds nothing."""
        self._holders.pop(entity, None)
        self._changes += 1

    @property
    def changes(self) -> int:
        """How many times a goal was given or ended, or a holder went: a key for what is
        made from the goals (a batch's goals, kept while it is unchanged)."""
        return self._changes

    def holders(self) -> list[tuple[int, Mind]]:
        """(entity, mind) of the characters holding goals, in the order they were given them."""
        holders = self._holders
        for entity in [e for e, mind in holders.items() if not mind.goals]:
            del holders[entity]
        return list(holders.items())

    def holders_of(self, behavior: str, frame: int) -> list[tuple[int, Mind]]:
        """The :meth:`holders` whose current goal is for ``behavior``, in the same order (a
        list kept until a goal is given or ends: not to be changed).

        One pass over the holders serves every goal behaviour of every step until the goals
        change, instead of one pass each. (``frame``: the step asking, unused.)
        """
        key = self._changes
        if self._index[0] != key:
            index: dict[str, list[tuple[int, Mind]]] = {}
            for entity, mind in self.holders():
                index.setdefault(mind.goals[0].behavior, []).append((entity, mind))
            self._index = (key, index)
        return self._index[1].get(behavior, [])

    def end(self, entity: int, goal: Goal, ok: bool = True, reason: str = "") -> None:
        """Finish a character's goal: mark it, drop it from the queue, report it."""
        if goal.finished:
            return
        self._changes += 1
        goal.status, goal.reason = ("done" if ok else "failed"), reason
        mind = self.world.component_for_entity(entity, Mind)
        if goal in mind.goals:
            mind.goals.remove(goal)
        if ok:
            self.emit(GoalDone(entity, goal.id, goal.behavior))
        else:
            self.emit(GoalFailed(entity, goal.id, goal.behavior, reason))
        if goal.on_end is not None:
            goal.on_end(goal)
