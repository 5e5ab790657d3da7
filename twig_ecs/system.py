"""The base class of every system in a scene's schedule."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:
    from twig_ecs.step import SceneView, StepContext
    from twig_ecs.world import World


class System:
    """A step of a scene's schedule that knows its scene.

    Subclasses set ``name`` (the stage name others order against) and implement
    :meth:`run`, called once per fixed step with that step's
    :class:`~twig_ecs.step.StepContext` (dt, time, world, store, RNG, events) - or the
    simpler :meth:`process`, called with ``dt`` alone.
    :meth:`setup` runs once when the scene adds the system (after ``self.scene`` is set).
    A class may name a set ``stage`` of the schedule (like ``"behaviours"``) that its
    systems join when they are added without ``before``/``after``.
    """

    name: str = ""
    #: The set stage this kind of system joins by default (see :mod:`twig_ecs.schedule`).
    stage: ClassVar[str | None] = None
    scene: SceneView

    @property
    def world(self) -> World:
        """The scene's entities and components."""
        return self.scene.world

    def setup(self) -> None:
        """Prepare caches; called once when added to a scene."""

    def run(self, ctx: StepContext) -> None:
        """Advance this system by one fixed step (the default calls :meth:`process`)."""
        self.process(ctx.dt)

    def process(self, dt: float) -> None:
        """Advance this system by one fixed step of ``dt`` seconds (or override :meth:`run`)."""
        raise NotImplementedError
