"""Knock figures of a run: does a child's kick or bump move its caregiver as if they weighed the same?

:class:`KnockRecorder` watches every caregiver (the ``caregiver`` of an ``attachment``
behaviour) and the charges that name it. Each contact event between a caregiver and one of
its charges (either way round, above the scene's ``contact_energy``) opens a window of
:data:`WINDOW` s; the figure is the furthest the caregiver's pelvis gets along the ground in
that window from where it stood the step before the touch. What the caregiver does on its own
is not a knock: a window stops counting once the caregiver walks on purpose - asked to walk
faster than :data:`SHUFFLE` (at 1.75 m tall, by the root of its size; the steps on the spot
that turn it to a hugger are slower) by anything but its pain reflex (``withdraw``, the
answer to the blow itself) - such as its step back to a social gap after a hug. Issue 34: a
caregiver is never moved more than :data:`MOST` m. ``twig run --report json`` gives the
figures as its ``knocks`` section.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.components import Attachment, Character
from twig_ecs.scene import Scene

WINDOW = 1.0  # s after a touch in which the caregiver's shift counts
SHUFFLE = 0.3  # m/s (at 1.75 m tall): asked to walk faster than this, it moves on purpose
MOST = 0.5  # m: the furthest a charge's kick or bump should move its caregiver (issue 34)
REFLEX = "withdraw"  # the pain reflex: a retreat the blow set off counts as the blow's


class KnockRecorder:
    """Per caregiver: how many touches by its charges, and the furthest one moved it."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.touches: dict[str, int] = {}
        self.worst: dict[str, dict] = {}
        self._last: dict[int, np.ndarray] = {}  # caregiver entity -> pelvis (x, z) the step before
        self._open: list[list] = []  # [caregiver entity, start (x, z), ends at, the touch's figures]
        self._carers = self._pairs()  # as of the last step (contact events come during a step)
        scene.on("contact", self._contact)

    def _pairs(self) -> dict[int, set[int]]:
        """Caregiver entity -> the entities of its charges (the characters whose attachment names it)."""
        scene = self.scene
        pairs: dict[int, set[int]] = {}
        for entity, attachment in scene.world.get_component(Attachment):
            if scene.has_entity(attachment.caregiver):
                carer = scene.entity(attachment.caregiver).entity
                if scene.world.has_component(carer, Character):  # (one named may be no character)
                    pairs.setdefault(carer, set()).add(entity)
        return pairs

    def _contact(self, event) -> None:
        pairs = self._carers
        if not pairs:
            return
        for carer, other in ((event.body, event.other_body), (event.other_body, event.body)):
            if other in pairs.get(carer, ()):
                scene = self.scene
                name = scene.name_of(carer)
                self.touches[name] = self.touches.get(name, 0) + 1
                start = self._last.get(carer)
                if start is None:
                    start = scene.character_handle(carer).position[[0, 2]]
                touch = {"at_s": round(scene.time, 3), "by": scene.name_of(other),
                         "energy_j": round(event.energy, 3)}  # fmt: skip
                self._open.append([carer, start, scene.time + WINDOW, touch])

    def step(self) -> None:
        """Measure every caregiver after one step (call it after :meth:`Scene.step`)."""
        scene = self.scene
        now = scene.time
        still = []
        for window in self._open:
            carer, start, ends, touch = window
            me = scene.character_handle(carer)
            pace = float(np.hypot(*me.walk_velocity[[0, 2]]))
            if pace > SHUFFLE * math.sqrt(me.scale) and me.behaviour != REFLEX:
                continue  # it walks off on purpose: the knock's window closes
            shift = float(np.hypot(*(me.position[[0, 2]] - start)))
            name = me.name
            if shift > self.worst.get(name, {}).get("moved_m", -1.0):
                self.worst[name] = {"moved_m": round(shift, 3), **touch}
            if now < ends:
                still.append(window)
        self._open = still
        self._carers = self._pairs()
        self._last = {carer: scene.character_handle(carer).position[[0, 2]] for carer in self._carers}

    def report(self) -> dict:
        """JSON-ready: the window, and per caregiver touched the touches and the furthest knock."""
        return {
            "window_s": WINDOW,
            "most_expected_m": MOST,
            "caregivers": {
                name: {"touches": count, "furthest": self.worst.get(name)}
                for name, count in sorted(self.touches.items())
            },
        }
