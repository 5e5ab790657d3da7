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
        self._key: tuple[int, ...] = (-1,)

    def _refresh(self) -> None:
        """Make the caches again if bodies were spawned or removed: the free bodies' names
        and rows, the bincount bins of every node coordinate and the nodes per body, and the
        node looked at on each named entity."""
        state, scene = self.scene.state, self.scene
        names = scene.entity_names
        bodies, nodes = state.bodies, state.nodes
        key = (state.version, len(names), nodes.count, bodies.count)
        if key == self._key:
            return
        # static scenery (a fence: every node locked) is walked round, never looked at; a
        # yard of fence panels would otherwise cost every perceiver a pass per panel
        free = np.bincount(nodes.body[: nodes.count], (nodes.flags[: nodes.count] & NODE_LOCKED) == 0,
                           bodies.count)  # fmt: skip
        row_of = {int(bodies.entity[b]): b for b in range(bodies.count) if free[b] > 0}
        entities = [(name, scene.entity_id(name)) for name in names]
        rows = [(name, row_of[entity]) for name, entity in entities if entity in row_of]
        self._names = [name for name, _ in rows]
        self._rows = np.array([b for _, b in rows], dtype=np.int64)
        # body x 3 + axis of every node coordinate (one bincount sums all three axes)
        body = nodes.body[: nodes.count]
        self._bins = (body[:, None] * 3 + np.arange(3)).ravel()
        self._counts = np.maximum(np.bincount(body, minlength=bodies.count), 1)
        self._look_nodes = {}
        for name, entity in entities:
            found = self.world.try_component(entity, Body)
            # a character's head (look_at(name, node="head")); a thing's node that
            # look_at(name) picks by name; a thing with neither is looked at through look_at
            picked = [n for n in ("head", "centre", "spine") if found is not None and n in found.node_names]
            if picked:
                self._look_nodes[name] = found.node_index(picked[0])
        self._key = key

    def run(self, ctx: StepContext) -> None:
        """Perceive, fade, appraise and pick a focus for every perceiving character."""
        dt = ctx.dt
        scene = self.scene
        perceivers = ctx.world.get_components(Character, Perception, Memory)
        if not perceivers:
            return
        self._refresh()
        state = scene.state
        nodes, n_bodies = state.nodes, state.bodies.count
        n, bins, counts = nodes.count, self._bins, self._counts
        # where every body is and how fast it goes (mean of its nodes), in one pass: one
        # bincount over every coordinate adds each body's nodes in node order, as one per axis did
        size = 3 * n_bodies
        mean_pos = np.bincount(bins, nodes.pos[:n].ravel(), size).reshape(n_bodies, 3)
        mean_vel = np.bincount(bins, (nodes.pos[:n] - nodes.prev[:n]).ravel(), size).reshape(n_bodies, 3)
        mean_pos /= counts[:, None]
        speed = np.linalg.norm(mean_vel / counts[:, None], axis=1) / dt
        # plain floats for the view-cone arithmetic (numpy's per-call cost on 3-vectors was
        # most of this system); the numpy rows kept for what memory records
        at = mean_pos[self._rows]
        kept = [tuple(where) for where in at]  # (numpy's floats, as memory always kept them)
        centres = dict(zip(self._names, zip(at.tolist(), kept, strict=True), strict=True))
        speeds = dict(zip(self._names, speed[self._rows].tolist(), strict=True))
        fade = 0.5 ** (dt / 1.0)
        ch = state.characters
        look_nodes = self._look_nodes
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
