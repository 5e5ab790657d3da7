"""The named system schedule: stages in order, with before=/after= insertion.

The default pipeline (SPEC, DESIGN) is::

    integrate -> constrain -> collide -> sense -> select_behavior -> gait -> posture -> render

Built-in stages without a system yet are anchors that user systems can order against.
The order is resolved once (a topological sort that keeps insertion order where the
constraints allow) and mapped onto esper processor priorities; a cycle or an unknown
stage name is a :class:`~twig_ecs.errors.ScheduleError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from twig_ecs.errors import ScheduleError
from twig_ecs.system import System
from twig_ecs.validate import suggest

#: The built-in stages, in order.
PIPELINE = ("integrate", "constrain", "collide", "sense", "select_behavior", "gait", "posture", "render")


@dataclass
class Stage:
    """A named place in the schedule, holding at most one system."""

    name: str
    system: System | None = None
    after: set[str] = field(default_factory=set)  # stages that must run before this one


class Schedule:
    """Stages and their ordering constraints."""

    def __init__(self) -> None:
        self.stages: dict[str, Stage] = {}
        previous = None
        for name in PIPELINE:
            self.stages[name] = Stage(name, after={previous} if previous else set())
            previous = name
        self._order: list[Stage] | None = None

    def add(
        self, system: System, name: str | None = None, before: str | None = None, after: str | None = None
    ) -> None:
        """Put ``system`` in the stage ``name`` (default: ``system.name``).

        A built-in anchor stage of that name takes the system; a new name becomes a new
        stage ordered by ``before``/``after`` (default: after ``posture``).
        """
        name = name or system.name or type(system).__name__
        for ref in (before, after):
            if ref is not None and ref not in self.stages:
                raise ScheduleError(f"unknown stage '{ref}'" + suggest(ref, self.stages))
        saved = {k: (v.system, set(v.after)) for k, v in self.stages.items()}
        stage = self.stages.get(name)
        if stage is None:
            stage = Stage(name)
            if before is None and after is None:
                after = "posture"
            self.stages[name] = stage
        elif stage.system is not None:
            raise ScheduleError(
                f"stage '{name}' already has a system "
                f"({type(stage.system).__name__}); give yours another name"
            )
        stage.system = system
        if after is not None:
            stage.after.add(after)
        if before is not None:
            self.stages[before].after.add(name)
        self._order = None
        try:
            self.order()  # fail now, at the call that made the cycle
        except ScheduleError:
            self.stages = {k: v for k, v in self.stages.items() if k in saved}
            for k, (sys_, after_) in saved.items():
                self.stages[k].system, self.stages[k].after = sys_, after_
            self._order = None
            raise

    def order(self) -> list[Stage]:
        """Stages in run order (cached until the schedule changes)."""
        if self._order is not None:
            return self._order
        remaining = dict(self.stages)
        order: list[Stage] = []
        while remaining:
            ready = [s for s in remaining.values() if not (s.after & remaining.keys())]
            if not ready:
                raise ScheduleError("the system order has a cycle: " + _cycle(remaining))
            stage = ready[0]  # insertion order breaks ties: stable and readable
            order.append(stage)
            del remaining[stage.name]
        self._order = order
        return order

    def systems(self) -> list[System]:
        """Systems in run order."""
        return [s.system for s in self.order() if s.system is not None]

    def names(self) -> list[str]:
        """Stage names in run order (anchors included)."""
        return [s.name for s in self.order()]


def _cycle(stages: dict[str, Stage]) -> str:
    """A readable 'a -> b -> a' for one cycle among the stages left."""
    start = next(iter(stages))
    path = [start]
    while True:
        nxt = next(iter(sorted(stages[path[-1]].after & stages.keys())))
        if nxt in path:
            return " -> ".join(reversed(path[path.index(nxt) :] + [nxt]))
        path.append(nxt)
