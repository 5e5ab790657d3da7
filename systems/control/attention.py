"""attention: perceive, remember, appraise, focus - and look at the focus (SPEC 4).

For each character with a :class:`~twig_ecs.components.Perception`, every step:
things in its view cone (around its face direction, within view distance; no
occlusion) are seen (memory strength 1, position noted); everything else fades with the
memory half-life. Each remembered thing is appraised: salience = strength x (0.2 +
|valence| + monitoring priority + how fast it moves); an attached child's caregiver
gains priority with the child's anxiety. The most salient thing is the focus of
attention (the current focus gets a small bonus, so the eyes do not dart), and the
character looks at it - until a winning behaviour points the eyes elsewhere.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.components import Attachment, Body, Character, Memory, Perception
from twig_ecs.kernelmath import GAZE_NODE, HEAD
from twig_ecs.step import StepContext
from twig_ecs.store import NODE_LOCKED
from twig_ecs.system import System

FOCUS_BONUS = 0.15  # salience bonus of the current focus


class AttentionSystem(System):
    """Updates each perceiving character's memory and focus of attention."""

    name = "attention"

    def setup(self) -> None:
        """Caches of names, body rows and the nodes looked at, refreshed when the store changes."""
        self._key: tuple[int, int] = (-1, -1)
        self._rows: list[tuple[str, int]] = []
        self._look_nodes: dict[str, int] = {}

    def _refresh(self) -> None:
        state, scene = self.scene.state, self.scene
        names = scene.entity_names
        key = (state.version, len(names))  # bodies spawned or removed
        if key == self._key:
            return
        bodies, nodes = state.bodies, state.nodes
        # static scenery (a fence: every node locked) is walked round, never looked at; a
        # yard of fence panels would otherwise cost every perceiver a pass per panel
        free = np.bincount(nodes.body[: nodes.count], (nodes.flags[: nodes.count] & NODE_LOCKED) == 0,
                           bodies.count)  # fmt: skip
        row_of = {int(bodies.entity[b]): b for b in range(bodies.count) if free[b] > 0}
        entities = [(name, scene.entity_id(name)) for name in names]
        self._rows = [(name, row_of[entity]) for name, entity in entities if entity in row_of]
        self._look_nodes = {}
        for name, entity in entities:
            body = self.world.try_component(entity, Body)
            # a character's head (look_at(name, node="head")); a thing's node that
            # look_at(name) picks by name; a thing with neither is looked at through look_at
            found = [n for n in ("head", "centre", "spine") if body is not None and n in body.node_names]
            if found:
                self._look_nodes[name] = body.node_index(found[0])
        self._key = key

    def _body_rows(self) -> list[tuple[str, int]]:
        """(name, body row) of every named entity with a body, in spawn order."""
        self._refresh()
        return self._rows

    def _look_nodes_by_name(self) -> dict[str, int]:
        """The node row a character looks at on an entity it attends to (a character's head),
        where a name decides it."""
        self._refresh()
        return self._look_nodes

    def _sums_index(self, n: int, n_bodies: int) -> tuple[np.ndarray, np.ndarray]:
        """(body x 3 + axis of every node coordinate, nodes per body at least 1), per layout."""
        key = (self.scene.state.version, n, n_bodies)
        cached = self.__dict__.get("_sums")
        if cached is None or cached[0] != key:
            body = self.scene.state.nodes.body[:n]
            bins = (body[:, None] * 3 + np.arange(3)).ravel()
            counts = np.maximum(np.bincount(body, minlength=n_bodies), 1)
            cached = self._sums = (key, (bins, counts))
        return cached[1]

    def run(self, ctx: StepContext) -> None:
        """Perceive, fade, appraise and pick a focus for every perceiving character."""
        dt = ctx.dt
        scene = self.scene
        perceivers = ctx.world.get_components(Character, Perception, Memory)
        if not perceivers:
            return
        state = scene.state
        nodes, bodies = state.nodes, state.bodies
        # where every body is and how fast it goes (mean of its nodes), in one pass: one
        # bincount over every coordinate adds each body's nodes in node order, as one per axis did
        n, n_bodies = nodes.count, bodies.count
        bins, counts = self._sums_index(n, n_bodies)
        size = 3 * n_bodies
        mean_pos = np.bincount(bins, nodes.pos[:n].ravel(), size).reshape(n_bodies, 3)
        mean_vel = np.bincount(bins, (nodes.pos[:n] - nodes.prev[:n]).ravel(), size).reshape(n_bodies, 3)
        mean_pos /= counts[:, None]
        speed = np.linalg.norm(mean_vel / counts[:, None], axis=1) / dt
        rows = self._body_rows()
        # plain floats for the view-cone arithmetic (numpy's per-call cost on 3-vectors was
        # most of this system); the numpy rows kept for what memory records
        at = mean_pos[[b for _, b in rows]]
        kept = [tuple(where) for where in at]  # (numpy's floats, as memory always kept them)
        centres = dict(zip((name for name, _ in rows), zip(at.tolist(), kept, strict=True), strict=True))
        speeds = dict(zip((name for name, _ in rows), speed[[b for _, b in rows]].tolist(), strict=True))
        fade = 0.5 ** (dt / 1.0)
        ch = state.characters
        look_nodes = self._look_nodes_by_name()
        for entity, (character, perception, memory) in perceivers:
            my_name = scene.name_of(entity)
            row = character.index
            head = nodes.pos[ch.nodes[row, HEAD]]
            face = ch.head_dir[row]
            hx, hy, hz = head.tolist()
            fx, fy, fz = face.tolist()
            cos_half = math.cos(math.radians(perception.view_angle / 2))
            decay = fade ** (1.0 / perception.memory_half_life)
            anxiety = 0.0
            attachment = ctx.world.try_component(entity, Attachment)
            if attachment is not None:
                anxiety = attachment.anxiety
            for name, ((x, y, z), where) in centres.items():
                if name == my_name:
                    continue
                ox, oy, oz = x - hx, y - hy, z - hz
                dist = math.sqrt(ox * ox + oy * oy + oz * oz)
                seen = _in_view(dist, (ox * fx + oy * fy + oz * fz) / dist if dist > 0.0 else math.nan,
                                perception.view_distance, cos_half)  # fmt: skip
                if seen is None:  # too near an edge for plain sums: numpy's, as the rule is written
                    off = np.array(where) - head
                    dist = math.sqrt(off.dot(off))
                    seen = dist < perception.view_distance and (dist < 0.5 or off @ face / dist >= cos_half)
                if seen:
                    memory.strength[name] = 1.0
                    memory.where[name] = where
                elif name in memory.strength:
                    memory.strength[name] *= decay
            salience = {}
            for name, strength in memory.strength.items():
                if strength < 0.05 or name not in centres:
                    continue
                priority = perception.priority.get(name, 0.0)
                if attachment is not None and name == attachment.caregiver:
                    priority += anxiety
                motion = min(1.0, speeds.get(name, 0.0) / 2.0)
                salience[name] = strength * (
                    0.2 + abs(perception.valence.get(name, 0.0)) + priority + 0.5 * motion
                )
            if memory.focus in salience:
                salience[memory.focus] += FOCUS_BONUS
            memory.salience = salience
            memory.focus = max(salience, key=salience.__getitem__) if salience else None
            if memory.focus is not None:
                node = look_nodes.get(memory.focus)
                if node is not None:
                    ch.gaze_node[row] = node
                    ch.gaze_mode[row] = GAZE_NODE
                else:
                    scene.character_handle(entity).look_at(memory.focus)


#: How near an edge of the view cone (relative) plain float sums leave the answer to numpy's.
EDGE = 1e-9


def _in_view(dist: float, cosine: float, view_distance: float, cos_half: float) -> bool | None:
    """Whether a thing ``dist`` m off at ``cosine`` to the face direction is seen; None when
    it is within :data:`EDGE` of an edge, where the rounding of the sums could decide."""
    if abs(dist - view_distance) <= EDGE * view_distance or abs(dist - 0.5) <= EDGE:
        return None
    if dist >= view_distance:
        return False
    if dist < 0.5:
        return True
    if not abs(cosine - cos_half) > EDGE:  # (NaN too)
        return None
    return cosine >= cos_half
