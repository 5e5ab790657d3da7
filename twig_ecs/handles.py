"""Handles: the Python API's view of one entity (``scene.entity(name)``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from twig_ecs.components import Body, PainSensor
from twig_ecs.errors import TwigError
from twig_ecs.store import NODE_LOCK_ON_CONTACT, NODE_LOCKED
from twig_ecs.validate import suggest

if TYPE_CHECKING:
    from twig_ecs.step import SceneView
    from twig_ecs.world import World


class PassiveBodyError(TwigError, AttributeError):
    """A character command (``walk``, ``hug``...) asked of a body spawned without ``character=True``."""


class BodyHandle:
    """A spawned body: read its nodes, pain and motion; nudge its nodes.

    Positions are metres, velocities m/s. Reads return copies, never views into the store.
    """

    def __init__(self, scene: SceneView, entity: int, name: str) -> None:
        self.scene = scene
        self.entity = entity
        self.name = name

    def __repr__(self) -> str:
        return f"<{type(self).__name__} '{self.name}' ({self.body.template})>"

    def __getattr__(self, attr: str):
        """Only for names a body lacks: a character's command gets an answer saying what to do."""
        # a command of a handle subclass (CharacterHandle): found without importing it upwards
        if attr.startswith("_") or not any(hasattr(kind, attr) for kind in type(self).__subclasses__()):
            raise AttributeError(f"'{type(self).__name__}' object has no attribute '{attr}'")
        name = self.__dict__.get("name", "?")
        template = self.__dict__.get("scene") and self.body.template
        raise PassiveBodyError(
            f"'{name}' is a passive body, not a character, so it has no '{attr}'. Spawn it as one: "
            f"scene.spawn({template or 'humanoid'!r}, name={name!r}, character=True) "
            "(in a scene file: 'character: true')"
        )

    @property
    def world(self) -> World:
        """The scene's entities and components."""
        return self.scene.world

    @property
    def body(self) -> Body:
        """The Body component (template name, rows)."""
        self.scene.check_open()
        # looked up once per handle (behaviours read nodes by name many times a step); the
        # component is updated in place when rows move, and a removed entity stays an error
        found = self.__dict__.get("_body")
        if found is None or not self.world.entity_exists(self.entity):
            found = self.__dict__["_body"] = self.world.component_for_entity(self.entity, Body)
        return found

    @property
    def template(self) -> str:
        """Name of the template it was spawned from."""
        return self.body.template

    @property
    def node_names(self) -> tuple[str, ...]:
        """Names of its nodes, in row order."""
        return self.body.node_names

    def _rows(self) -> slice:
        b = self.body
        return b.rows

    def node_row(self, node: str) -> int:
        """The store row of one of this body's nodes (KeyError with suggestions if it has none)."""
        b = self.body
        if node not in b.node_names:
            raise KeyError(f"'{self.name}' has no node '{node}'" + suggest(node, b.node_names))
        return b.node_index(node)

    def node(self, name: str) -> np.ndarray:
        """Position (m) of the named node."""
        return self.scene.state.nodes.pos[self.node_row(name)].copy()

    def node_velocity(self, name: str) -> np.ndarray:
        """Velocity (m/s) of the named node over the last step."""
        i, n = self.node_row(name), self.scene.state.nodes
        return (n.pos[i] - n.prev[i]) / self.scene.dt

    @property
    def node_positions(self) -> np.ndarray:
        """(n, 3) positions of all its nodes, in ``node_names`` order."""
        return self.scene.state.nodes.pos[self._rows()].copy()

    @property
    def position(self) -> np.ndarray:
        """Centre of mass (m)."""
        n, rows = self.scene.state.nodes, self._rows()
        m = float(n.mass[rows.start]) if rows.stop - rows.start == 1 else 0.0
        if m != 0.0:  # a ball: numpy's arithmetic on its one row, in plain floats (a fifth of the time)
            return np.array([x * m / m for x in n.pos[rows.start].tolist()])
        m = n.mass[rows]
        return (n.pos[rows] * m[:, None]).sum(axis=0) / m.sum()

    @property
    def velocity(self) -> np.ndarray:
        """Mass-weighted mean velocity (m/s) over the last step."""
        n, rows = self.scene.state.nodes, self._rows()
        dt = self.scene.dt
        m = float(n.mass[rows.start]) if rows.stop - rows.start == 1 else 0.0
        if m != 0.0:  # (as position)
            now, before = n.pos[rows.start].tolist(), n.prev[rows.start].tolist()
            return np.array([(x - x0) / dt * m / m for x, x0 in zip(now, before, strict=True)])
        m = n.mass[rows]
        v = (n.pos[rows] - n.prev[rows]) / dt
        return (v * m[:, None]).sum(axis=0) / m.sum()

    @property
    def mass(self) -> float:
        """Total mass (kg)."""
        return float(self.scene.state.nodes.mass[self._rows()].sum())

    @property
    def pain(self) -> float:
        """Current pain level (0 without a pain sensor)."""
        return float(self.scene.state.bodies.pain[self.body.index])

    @property
    def pain_sensor(self) -> PainSensor | None:
        """Its pain sensor's parameters, read from the store (None: it feels no pain)."""
        bodies, row = self.scene.state.bodies, self.body.index
        if not np.isfinite(bodies.pain_threshold[row]):
            return None
        return PainSensor(float(bodies.pain_threshold[row]), float(bodies.pain_half_life[row]),
                          float(bodies.pain_gain[row]))  # fmt: skip

    def set_node_velocity(self, node: str, velocity: tuple[float, float, float]) -> None:
        """Give one node a velocity (m/s) from now on (Verlet: moves its previous position)."""
        i = self.node_row(node)
        n = self.scene.state.nodes
        n.prev[i] = n.pos[i] - np.asarray(velocity, dtype=np.float64) * self.scene.dt

    def apply_force(self, node: str, force: tuple[float, float, float]) -> None:
        """Push one node with ``force`` (N) during the next step (adds force/mass to its acceleration)."""
        i = self.node_row(node)
        n = self.scene.state.nodes
        n.acc[i] += np.asarray(force, dtype=np.float64) / n.mass[i]

    def set_velocity(self, velocity: tuple[float, float, float]) -> None:
        """Give every free node of the body the same velocity (m/s)."""
        n, rows = self.scene.state.nodes, self._rows()
        free = (n.flags[rows] & NODE_LOCKED) == 0
        v = np.asarray(velocity, dtype=np.float64) * self.scene.dt
        idx = np.arange(rows.start, rows.stop)[free]
        n.prev[idx] = n.pos[idx] - v

    def translate(self, offset: tuple[float, float, float]) -> None:
        """Move the whole body rigidly by ``offset`` (m), keeping its velocity."""
        n, rows = self.scene.state.nodes, self._rows()
        d = np.asarray(offset, dtype=np.float64)
        n.pos[rows] += d
        n.prev[rows] += d
        n.lock_pos[rows] += d

    def lock(self, node: str) -> None:
        """Hold a node where it is (static friction, a fixed pivot) until :meth:`unlock`."""
        i = self.node_row(node)
        n = self.scene.state.nodes
        n.flags[i] |= NODE_LOCKED
        n.lock_pos[i] = n.pos[i]
        n.prev[i] = n.pos[i]

    def lock_on_contact(self, node: str, enabled: bool = True) -> None:
        """Make a node lock itself the moment it touches the ground (or stop doing so)."""
        i = self.node_row(node)
        n = self.scene.state.nodes
        if enabled:
            n.flags[i] |= NODE_LOCK_ON_CONTACT
        else:
            n.flags[i] &= np.uint32(~NODE_LOCK_ON_CONTACT & 0xFFFFFFFF)

    def unlock(self, node: str) -> None:
        """Free a locked node; it starts at rest."""
        i = self.node_row(node)
        n = self.scene.state.nodes
        n.flags[i] &= np.uint32(~(NODE_LOCKED | NODE_LOCK_ON_CONTACT) & 0xFFFFFFFF)
        n.prev[i] = n.pos[i]

    def is_locked(self, node: str) -> bool:
        """Is the node held in place?"""
        return bool(self.scene.state.nodes.flags[self.node_row(node)] & NODE_LOCKED)
