"""The base class of every system in a scene's schedule."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import esper

if TYPE_CHECKING:
    from twig_ecs.scene import Scene


class System(esper.Processor):
    """An esper processor that knows its scene.

    Subclasses set ``name`` (the stage name others order against) and implement
    :meth:`process`, which is called once per fixed step with ``dt`` in seconds.
    :meth:`setup` runs once when the scene adds the system (after ``self.scene`` is set).
    A class may name a set ``stage`` of the schedule (like ``"behaviours"``) that its
    systems join when they are added without ``before``/``after``.
    """

    name: str = ""
    #: The set stage this kind of system joins by default (see :mod:`twig_ecs.schedule`).
    stage: ClassVar[str | None] = None
    scene: Scene

    def setup(self) -> None:
        """Prepare caches; called once when added to a scene."""

    def process(self, dt: float) -> None:  # noqa: D401 - esper's signature
        """Advance this system by one fixed step of ``dt`` seconds."""
        raise NotImplementedError
