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

import esper
import numpy as np

from twig_ecs.components import Attachment, Character, Memory, Perception
from twig_ecs.system import System

FOCUS_BONUS = 0.15  # salience bonus of the current focus


class AttentionSystem(System):
    """Updates each perceiving character's memory and focus of attention."""

    name = "attention"

    def process(self, dt: float) -> None:
        """Perceive, fade, appraise and pick a focus for every perceiving character."""
        scene = self.scene
        perceivers = esper.get_components(Character, Perception, Memory)
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
        row_of = {int(bodies.entity[b]): b for b in range(bodies.count)}
        centres: dict[str, np.ndarray] = {}
        speeds: dict[str, float] = {}
        for name in scene.entity_names:
            b = row_of.get(scene._names[name])
            if b is not None:
                centres[name], speeds[name] = mean_pos[b], float(speed[b])
        fade = 0.5 ** (dt / 1.0)
        for entity, (_, perception, memory) in perceivers:
            me = scene.character_handle(entity)
            head = me.node("head")
            face = me.head_direction
            cos_half = math.cos(math.radians(perception.view_angle / 2))
            decay = fade ** (1.0 / perception.memory_half_life)
            anxiety = 0.0
            attachment = esper.try_component(entity, Attachment)
            if attachment is not None:
                anxiety = attachment.anxiety
            for name, where in centres.items():
                if name == me.name:
                    continue
                off = where - head
                dist = float(np.linalg.norm(off))
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
                me.look_at(
                    memory.focus, node="head" if "head" in scene.entity(memory.focus).node_names else None
                )
