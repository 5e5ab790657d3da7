"""Torso figures of a run: does every character stay upright (issue 14, BELIEVABILITY.md)?

:class:`TorsoRecorder` watches a scene step by step and measures each character's torso
pitch - the pelvis-to-neck line's angle from the vertical (``CharacterHandle.torso_pitch``;
:func:`twig_ecs.walklab.torso_pitch` measures the same over a recorded track) - leaving
out the frames within :data:`AFTER_BLOW` seconds of a blow that hurt it (a ``pain`` event
on its body): a person knocked off balance may fold over; one walking, playing or pushing
a merry-go-round does not. ``twig run --report json`` gives the figures as its ``torso``
section.
"""

from __future__ import annotations

import math

from twig_ecs.components import Character
from twig_ecs.scene import Scene

LIMIT = 35.0  # degrees: a torso further from upright than this has fallen or folded over
AFTER_BLOW = 2.0  # s after a blow that hurt during which a fold does not count


class TorsoRecorder:
    """Largest torso pitch per character outside the moments right after a blow, and how
    many frames went beyond :data:`LIMIT`."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.last_blow: dict[int, float] = {}
        self.figures: dict[str, dict] = {}
        scene.on("pain", self._hurt)

    def _hurt(self, event) -> None:
        self.last_blow[event.body] = self.scene.time

    def step(self) -> None:
        """Measure every character's torso after one step."""
        scene = self.scene
        for entity, _ in self.scene.world.get_component(Character):
            me = scene.character_handle(entity)
            pitch = me.torso_pitch
            entry = self.figures.setdefault(
                me.name, {"max_deg": 0.0, "at_s": 0.0, "frames_over": 0, "frames_over_after_blows": 0}
            )
            if scene.time - self.last_blow.get(entity, -math.inf) <= AFTER_BLOW:
                entry["frames_over_after_blows"] += pitch > LIMIT
                continue
            entry["frames_over"] += pitch > LIMIT
            if pitch > entry["max_deg"]:
                entry["max_deg"], entry["at_s"] = pitch, scene.time

    def report(self) -> dict:
        """JSON-ready: the limit, the window after a blow, and per character the largest
        pitch outside those windows (``max_deg``, at ``at_s``), the frames beyond the limit
        outside them (``frames_over``) and inside them (``frames_over_after_blows``)."""
        return {
            "limit_deg": LIMIT,
            "after_blow_s": AFTER_BLOW,
            "characters": {
                name: {**entry, "max_deg": round(entry["max_deg"], 1), "at_s": round(entry["at_s"], 2)}
                for name, entry in sorted(self.figures.items())
            },
        }
