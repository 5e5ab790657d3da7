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
        """Caches of names, body rows and head nodes, refreshed when the store changes."""
        self._key: tuple[int, int] = (-1, -1)
        self._rows: list[tuple[str, int]] = []
        self._head_nodes: dict[str, int] = {}

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
        self._head_nodes = {}
        for name, entity in entities:
            body = self.world.try_component(entity, Body)
            if body is not None and "head" in body.node_names:
                self._head_nodes[name] = body.node_index("head")
        self._key = key

    def _body_rows(self) -> list[tuple[str, int]]:
        """(name, body row) of every named entity with a body, in spawn order."""
        self._refresh()
        return self._rows

    def _heads(self) -> dict[str, int]:
        """Head node row of every named entity that has a head."""
        self._refresh()
        return self._head_nodes

    def run(self, ctx: StepContext) -> None:
        """Perceive, fade, appraise and pick a focus for every perceiving character."""
        dt = ctx.dt
        scene = self.scene
        perceivers = ctx.world.get_components(Character, Perception, Memory)
        if not perceivers:
            return
        state = scene.state
        nodes, bodies = state.nodes, state.bodies
        # where every body is and how fast it goes (mean of its nodes), in one pass
        n = nodes.count
        counts = np.maximum(np.bincount(nodes.body[:n], minlength=bodies.count), 1)
        mean_pos = np.stack(
            [np.bincount(nodes.body[:n], nodes.pos[:n, k], bodies.count) for k in range(3)], 1
        )
        mean_vel = np.stack(
            [
                np.bincount(nodes.body[:n], nodes.pos[:n, k] - nodes.prev[:n, k], bodies.count)
                for k in range(3)
            ],
            1,
        )
        mean_pos /= counts[:, None]
        speed = np.linalg.norm(mean_vel / counts[:, None], axis=1) / dt
        centres: dict[str, np.ndarray] = {}
        speeds: dict[str, float] = {}
        for name, b in self._body_rows():
            centres[name], speeds[name] = mean_pos[b], float(speed[b])
        fade = 0.5 ** (dt / 1.0)
        ch = state.characters
        for entity, (character, perception, memory) in perceivers:
            me = scene.character_handle(entity)
            row = character.index
            head = nodes.pos[ch.nodes[row, HEAD]].copy()
            face = ch.head_dir[row].copy()
            cos_half = math.cos(math.radians(perception.view_angle / 2))
            decay = fade ** (1.0 / perception.memory_half_life)
            anxiety = 0.0
            attachment = ctx.world.try_component(entity, Attachment)
            if attachment is not None:
                anxiety = attachment.anxiety
            for name, where in centres.items():
                if name == me.name:
                    continue
                off = where - head
                dist = math.sqrt(off.dot(off))  # = np.linalg.norm(off), without its checks
                seen = dist < perception.view_distance and (dist < 0.5 or off @ face / dist >= cos_half)
                if seen:
                    memory.strength[name] = 1.0
                    memory.where[name] = tuple(where)
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
                head_node = self._heads().get(memory.focus)
                if head_node is not None:  # a character: its head, as look_at(name, node="head")
                    ch.gaze_node[row] = head_node
                    ch.gaze_mode[row] = GAZE_NODE
                else:
                    me.look_at(memory.focus)
