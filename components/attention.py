"""Attention and memory, and the attachment to a caregiver that attention weighs: components of a mind."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Memory:
    """What a character has seen lately: one entry per entity name."""

    strength: dict[str, float] = field(default_factory=dict)  # 1 when seen, decaying after
    where: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # last seen at
    focus: str | None = None  # the focus of attention this step
    salience: dict[str, float] = field(default_factory=dict)  # appraisal of the last step


@dataclass(slots=True)
class Perception:
    """How a character sees and what it cares about (SPEC 4, attention and memory).

    ``valence`` (how much it likes each thing, -1..1) and ``priority`` (how much it
    must keep an eye on each thing, 0..1) are by entity name; others count as 0.
    """

    view_angle: float = 120.0  # degrees, the whole cone
    view_distance: float = 15.0  # m
    memory_half_life: float = 4.0  # s
    valence: dict[str, float] = field(default_factory=dict)
    priority: dict[str, float] = field(default_factory=dict)


@dataclass(slots=True)
class Attachment:
    """A small child's tie to its caregiver: anxiety grows away from it, a hug soothes it."""

    caregiver: str = "parent"
    safe_distance: float = 2.5  # m: closer than this, anxiety fades
    per_metre: float = 0.012  # anxiety per second per metre beyond the safe distance
    per_second: float = 0.006  # anxiety per second just for being away
    fade: float = 0.15  # per second, when near
    look_back_at: float = 0.35  # anxiety at which it glances back now and then
    return_at: float = 0.75  # anxiety at which it runs back for a hug
    anxiety: float = 0.0
    finishing_until: float = -1e9  # s: an action about to end (a kick) holds off the run home till then
    hugs: int = 0
    look_backs: int = 0
