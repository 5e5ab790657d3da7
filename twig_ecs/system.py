"""The base class of every system in a scene's schedule."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from twig_ecs.step import SceneView, StepContext
    from twig_ecs.world import World


class Scratch(dict):
    """A system's caches and scratch arrays by name: made again from the world when needed.

    Written once for every system: a snapshot never holds it (:meth:`System.__getstate__`),
    and a restored system starts with an empty one and rebuilds what it asks for.
    """

    def keyed(self, name: str, key: Any, build: Callable[[], Any]) -> Any:
        """What ``build()`` made for ``key``, kept under ``name`` until asked for another key
        (a cache invalidated by the goal ids, the store's layout version...)."""
        entry = self.get(name)
        if entry is None or entry[0] != key:
            entry = self[name] = (key, build())
        return entry[1]

    def array(self, name: str, rows: int, dtype, width: int = 0, fill: Any = None) -> np.ndarray:
        """A reusable array of at least ``rows`` rows (``width`` columns if given), doubling
        when it must grow - no allocation per step; ``fill`` initialises a new one."""
        found = self.get(name)
        if found is None or found.shape[0] < rows:
            size = max(16, 2 * rows)
            found = self[name] = np.empty((size, width) if width else size, dtype=dtype)
            if fill is not None:
                found[:] = fill
        return found


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

    def __getstate__(self) -> dict[str, Any]:
        """What a snapshot keeps of a system: its attributes but its :class:`Scratch`."""
        return {key: value for key, value in self.__dict__.items() if key != "_scratch"}

    @property
    def scratch(self) -> Scratch:
        """This system's caches and scratch arrays (never saved; see :class:`Scratch`)."""
        found = self.__dict__.get("_scratch")
        if found is None:
            found = self.__dict__["_scratch"] = Scratch()
        return found

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
