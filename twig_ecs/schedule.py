"""The named system schedule: stages in order, with before=/after= insertion.

:data:`PIPELINE` is the one place the order of a step is written (SPEC, DESIGN)::

    integrate -> constrain -> collide -> sense              (physics plugin)
    -> attention -> behaviours -> select_behavior -> patrol
    -> gait -> gaze -> posture -> arms -> respiration        (control and behaviour plugins)
    -> render

Plugins (:mod:`twig_ecs.plugins`) fill these stages with their systems; a stage no
system has filled stays as an anchor that user systems can order against. A *set*
stage (:data:`BEHAVIOURS`) takes any number of systems: a system whose class names it
as its ``stage`` joins it when added without ``before``/``after`` (every behaviour
proposes its activations there, before ``select_behavior`` picks the winners).
The order is resolved once (a topological sort that keeps insertion order where the
constraints allow) and run in that order; a cycle or an unknown
stage name is a :class:`~twig_ecs.errors.ScheduleError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from twig_ecs.errors import ScheduleError
from twig_ecs.system import System
from twig_ecs.validate import suggest

#: The stage where behaviours propose activations: a set of any number of systems.
BEHAVIOURS = "behaviours"

#: The built-in stages, in order: the order of one step, written once.
PIPELINE = (
    "integrate",  # physics: Verlet step of every node
    "constrain",  # physics: links, limits and grab joints
    "collide",  # physics: capsule contacts, ground and props
    "sense",  # physics: impacts become contact and pain events
    "attention",  # control: what each character notices and remembers
    BEHAVIOURS,  # behaviours: every behaviour proposes its activation
    "select_behavior",  # control: each character's winner acts (writes the motor targets)
    "patrol",  # control: scripted walking routes
    "gait",  # control: stepping feet towards the walk vector
    "glance",  # control: idle characters glance about (before gaze turns the face)
    "gaze",  # control: head and eyes (before posture turns the shoulders after the face)
    "posture",  # control: pelvis, spine and balance
    "arms",  # control: reaching hands
    "respiration",  # control: breathing
    "render",  # anchor for drawing and recording systems
)

#: Where a user system with no ``before``/``after`` (and no ``stage``) goes: after the controllers.
DEFAULT_AFTER = "posture"


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
        stage ordered by ``before``/``after``. Without either, a system whose class names a
        set ``stage`` (a behaviour: :data:`BEHAVIOURS`) joins that set, and any other goes
        after :data:`DEFAULT_AFTER`.
        """
        name = name or system.name or type(system).__name__
        if before is None and after is None and getattr(system, "stage", None) and name not in self.stages:
            after, before = system.stage, _next_stage(system.stage)
        for ref in (before, after):
            if ref is not None and ref not in self.stages:
                raise ScheduleError(f"unknown stage '{ref}'" + suggest(ref, self.stages))
        saved = {k: (v.system, set(v.after)) for k, v in self.stages.items()}
        stage = self.stages.get(name)
        if stage is None:
            stage = Stage(name)
            if before is None and after is None:
                after = DEFAULT_AFTER
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


def _next_stage(stage: str) -> str | None:
    """The built-in stage after ``stage`` (the end of a set stage), or None."""
    if stage not in PIPELINE:
        raise ScheduleError(f"unknown stage '{stage}'" + suggest(stage, PIPELINE))
    at = PIPELINE.index(stage) + 1
    return PIPELINE[at] if at < len(PIPELINE) else None


def _cycle(stages: dict[str, Stage]) -> str:
    """A readable 'a -> b -> a' for one cycle among the stages left."""
    start = next(iter(stages))
    path = [start]
    while True:
        nxt = next(iter(sorted(stages[path[-1]].after & stages.keys())))
        if nxt in path:
            return " -> ".join(reversed(path[path.index(nxt) :] + [nxt]))
        path.append(nxt)
