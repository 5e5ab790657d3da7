"""A character's mind: its goals, this step's proposals and the winning behaviour.

The data behaviour selection works on (:mod:`twig_ecs.systems.control.select_behavior`)
and the events it reports. The behaviours themselves - the systems that propose and act
- are :class:`twig_ecs.behavior.Behavior` s, a layer above.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

from twig_ecs.events import Event
from twig_ecs.goals import GoalSchema

#: Activation of a commanded goal: above idle play, below reflexes like pain.
GOAL_ACTIVATION = 0.8
_goal_ids = itertools.count(1)


@dataclass(slots=True, frozen=True)
class GoalDone(Event):
    """A goal finished as asked."""

    kind: ClassVar[str] = "goal.done"
    character: int
    goal: int
    behavior: str


@dataclass(slots=True, frozen=True)
class GoalFailed(Event):
    """A goal could not be finished (``reason`` says why)."""

    kind: ClassVar[str] = "goal.failed"
    character: int
    goal: int
    behavior: str
    reason: str


@dataclass(slots=True, frozen=True)
class BehaviorChanged(Event):
    """A character's winning behaviour changed."""

    kind: ClassVar[str] = "behavior.changed"
    character: int
    old: str
    new: str


@dataclass
class Goal:
    """A command to one character: run behaviour ``behavior`` with ``params`` until done."""

    behavior: str
    params: dict[str, Any]
    id: int = field(default_factory=lambda: next(_goal_ids))
    status: str = "pending"  # pending, active, done, failed
    reason: str = ""
    started: float = -1.0  # simulated time it became active
    on_end: Callable[[Goal], None] | None = None
    memory: dict[str, Any] = field(default_factory=dict)  # the behaviour's working state

    @property
    def finished(self) -> bool:
        """Done or failed."""
        return self.status in ("done", "failed")


@dataclass(slots=True)
class Mind:
    """A character's behaviour state: its goals, activations and the current winner."""

    goals: list[Goal] = field(default_factory=list)  # queued goals, the first is current
    activations: dict[str, float] = field(default_factory=dict)  # this step's proposals
    last: dict[str, float] = field(default_factory=dict)  # the proposals of the last selection
    winner: str = "idle"
    since: float = 0.0  # simulated time the winner won
    switches: int = 0
    autonomous: bool = True  # False: only goals (and reflexes) move it - scripted by a drama manager

    @property
    def goal(self) -> Goal | None:
        """The current goal, if any."""
        return self.goals[0] if self.goals else None


#: The schema of every goal behaviour class defined so far, by goal name.
GOAL_SCHEMAS: dict[str, GoalSchema] = {}
_goal_schema_listeners: list[Callable[[GoalSchema], None]] = []


def on_goal_schema(listener: Callable[[GoalSchema], None]) -> None:
    """Call ``listener(schema)`` for every goal schema, those defined so far and those to come.

    How a higher layer (the character handle's goal methods) follows the goal behaviours
    without this module importing it.
    """
    _goal_schema_listeners.append(listener)
    for schema in list(GOAL_SCHEMAS.values()):
        listener(schema)
