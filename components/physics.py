"""Physical components: names, bodies and grab joints; and a body's pain-sensor parameters.

Nodes and links are not entities: they are rows of the store (``PhysicsState.nodes`` and
``links``), owned by a :class:`Body` (its contiguous rows) and addressed as (body, node
name) - no system queries them one by one, so an entity per node (14,700 of the 15,000
entities of a 300-crowd) only cost spawn time and memory.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Name:
    """A unique, human-readable name for an entity (``scene.entity(name)`` finds it)."""

    value: str


@dataclass(slots=True)
class GrabJoint:
    """A zero-length link from a hand node to a node of another body (a ball joint)."""

    index: int  # row in PhysicsState.links
    holder: int  # entity of the grabbing body
    held: int  # entity of the grabbed body


@dataclass(slots=True)
class Body:
    """A spawned body template: the contiguous node and link rows it owns.

    ``node_names[k]`` names row ``node_start + k``; rows stay contiguous when other
    bodies are removed (compaction keeps order), only the starts move.
    """

    template: str
    index: int  # row in PhysicsState.bodies
    node_start: int
    node_names: tuple[str, ...]
    link_start: int
    link_count: int
    height: float
    params: dict = field(default_factory=dict)

    @property
    def rows(self) -> slice:
        """Its node rows in the store (``PhysicsState.nodes``), in ``node_names`` order."""
        return slice(self.node_start, self.node_start + len(self.node_names))

    def link_name(self, row: int, links) -> str:
        """The name ("a-b", from its node names) of this body's link at store row ``row``."""
        a, b = int(links.a[row]) - self.node_start, int(links.b[row]) - self.node_start
        return f"{self.node_names[a]}-{self.node_names[b]}"

    def node_index(self, name: str) -> int:
        """Row in ``PhysicsState.nodes`` of the named node (KeyError if unknown)."""
        try:
            return self.node_start + self.node_names.index(name)
        except ValueError:
            raise KeyError(
                f"body '{self.template}' has no node '{name}' (nodes: {', '.join(self.node_names)})"
            ) from None


@dataclass(slots=True)
class PainSensor:
    """Tactile pain (SPEC 2): impacts above ``threshold`` joules hurt; pain decays.

    The parameters a template or scene gives a body (``pain:``). They are not a
    component: spawning writes them into the store's body columns (``pain_threshold``,
    ``pain_half_life``, ``pain_gain``), which the sense kernel reads and which are the
    truth from then on; ``BodyHandle.pain_sensor`` reads them back. The live pain level
    is ``PhysicsState.bodies.pain[body.index]``.
    """

    threshold: float = 2.0  # J of impact energy before it hurts
    half_life: float = 1.0  # s for the pain level to halve
    gain: float = 1.0  # pain added per joule above nothing
