"""Typed world events: dataclass messages queued during a step, and the bus that carries them.

Systems append events with ``scene.emit(event)``; the queue holds the events of the
latest step only (it is cleared when the next step begins), and ``scene.event_counts``
keeps running totals by ``kind``. Handlers registered with ``scene.on(kind, fn)`` are
called as events are emitted. A scene keeps all of this in one :class:`EventBus`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar


@dataclass(slots=True, frozen=True)
class Event:
    """Base of all events; ``kind`` is the short name used for counts and subscriptions."""

    kind: ClassVar[str] = "event"


@dataclass(slots=True, frozen=True)
class Contact(Event):
    """Two bodies' colliders met with an impact energy above the contact threshold."""

    kind: ClassVar[str] = "contact"
    body: int  # entity of the struck body
    link: str  # name of its struck link ("a-b" from its node names), or of the node of a sphere
    other_body: int
    other_link: str
    energy: float  # J, along the contact normal


@dataclass(slots=True, frozen=True)
class Pain(Event):
    """An impact on a body with a pain sensor exceeded its threshold."""

    kind: ClassVar[str] = "pain"
    body: int
    link: str  # name of the struck link ("a-b"), or of the node of a sphere
    source_body: int  # entity of the body that delivered the blow
    energy: float  # J
    level: float  # pain level after the blow


@dataclass(slots=True, frozen=True)
class Grabbed(Event):
    """A grab joint was made: ``holder``'s node now holds ``held``'s node."""

    kind: ClassVar[str] = "grab"
    joint: int  # entity of the GrabJoint
    holder: int
    held: int
    node: str  # the holder's node (a hand)


@dataclass(slots=True, frozen=True)
class Released(Event):
    """A grab joint was removed."""

    kind: ClassVar[str] = "release"
    joint: int
    holder: int
    held: int


@dataclass
class EventBus:
    """This step's events, running counts by kind, and the handlers subscribed to each kind."""

    events: list[Event] = field(default_factory=list)
    counts: Counter[str] = field(default_factory=Counter)
    handlers: dict[str, list[Callable[[Event], None]]] = field(default_factory=dict)

    def emit(self, event: Event) -> None:
        """Queue ``event`` for this step, count it and call its handlers (in subscription order)."""
        self.events.append(event)
        self.counts[event.kind] += 1
        for handler in self.handlers.get(event.kind, ()):
            handler(event)

    def on(self, kind: str, handler: Callable[[Event], None]) -> None:
        """Call ``handler(event)`` for every event of ``kind`` from now on."""
        self.handlers.setdefault(kind, []).append(handler)

    def next_step(self) -> None:
        """Forget the last step's events (the counts run on)."""
        self.events.clear()
