"""Attention, memory and the schoolyard's motives: components of a character's mind."""

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
    hugs: int = 0
    look_backs: int = 0


@dataclass(slots=True)
class Playful:
    """Loves a toy: approaches it and kicks it about."""

    toy: str = "ball"
    joy: float = 0.5  # activation of play
    speed: float = 2.0  # m/s running after it
    touches: int = 0


@dataclass(slots=True)
class Feisty:
    """Picks a fight with a rival now and then, when it is near."""

    rival: str = ""
    temper: float = 0.06  # chance per second of starting a fight when within reach
    reach: float = 2.5  # m
    fights: int = 0


@dataclass(slots=True)
class Rider:
    """Likes to spin the merry-go-round now and then."""

    ride: str = "merry_go_round"
    whim: float = 0.03  # chance per second of going for a spin
    push: float = 220.0  # N of push on a handle
    spins: int = 0


@dataclass(slots=True)
class Watchful:
    """A caregiver: keeps its eyes on its charges, the one furthest away first."""

    charges: list[str] = field(default_factory=list)


@dataclass(slots=True)
class Wander:
    """Roams: picks a random point in a square and walks there round others, then another.

    Targets are drawn from the square of half-size ``radius`` (m) round ``centre``
    ([x, z]); a target counts as reached within ``arrive`` m, and one not got 10 cm
    closer to in ``patience`` s is given up for a new one.
    """

    radius: float = 10.0
    centre: list[float] = field(default_factory=lambda: [0.0, 0.0])
    speed: float = 1.2  # m/s
    arrive: float = 0.6  # m
    patience: float = 4.0  # s
    activation: float = 0.3  # above idle, below commanded goals
    targets: int = 0  # how many targets it has picked
