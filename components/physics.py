"""Physical components: nodes, links, grab joints, bodies and tactile pain sensors."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Name:
    """A unique, human-readable name for an entity (``scene.entity(name)`` finds it)."""

    value: str


@dataclass(slots=True)
class Node:
    """A point mass: its row in ``PhysicsState.nodes`` and the body it belongs to."""

    index: int
    body: int  # entity of the owning Body
    name: str


@dataclass(slots=True)
class Link:
    """A rigid distance constraint (and capsule, when visible): its row in ``links``."""

    index: int
    body: int  # entity of the owning Body
    name: str  # "a-b" from its node names


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

    The live pain level is ``PhysicsState.bodies.pain[body.index]``; these are the
    authoring parameters, copied into the store when the body spawns.
    """

    threshold: float = 2.0  # J of impact energy before it hurts
    half_life: float = 1.0  # s for the pain level to halve
    gain: float = 1.0  # pain added per joule above nothing
