"""glance: idle characters standing or sitting with nothing to look at glance about (issue 34).

A person waiting is not a statue: every few seconds the eyes go somewhere - to one side, a
little down - and come back. Reads each character's posture mode, gaze mode and walk vector;
writes its ``glance`` (a yaw and a pitch, radians) and ``glance_left`` (seconds until it
changes), by which the gaze controller (``gaze.py``) turns the face the character is drawn
with (``face_dir``, also what ``twig export`` turns the head bone by) away from where its
head points. A glance moves nothing: the shoulders, and what the character notices, go by
the head's direction, so no behaviour, contact or state hash changes with glances. Walking,
watching something, reaching, a glance ends at once, and a character that has just stopped
waits a while before its first.

The glances' sizes and times are drawn from a generator seeded by the frame and the
character's row - not the scene's RNG, whose sequence the behaviours share: a glance never
moves another draw, and a snapshot restores the same glances without a state to keep.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.components import Character
from twig_ecs.kernelmath import GAZE_AHEAD, SIT, STAND
from twig_ecs.mind import Mind
from twig_ecs.step import StepContext
from twig_ecs.system import System

FIRST_WAIT = 1.5  # s standing still before the first glance
LOOK_AHEAD = (2.0, 5.0)  # s between glances (uniform)
GLANCE = (0.8, 2.0)  # s a glance lasts (uniform)
YAW = (math.radians(15.0), math.radians(40.0))  # to the left or right of the hips' facing
PITCH = (math.radians(-12.0), math.radians(4.0))  # mostly a little down
STILL = 1e-4  # (m/s)^2: a walk vector below this is standing still
SALT = 0x61A7CE  # keeps these draws apart from any other seeded by (frame, row)


class GlanceSystem(System):
    """Small glances about for idle characters standing or sitting still and looking ahead."""

    name = "glance"

    def run(self, ctx: StepContext) -> None:
        """Count every character's glance down; start or end glances whose time is up."""
        ch = ctx.state.characters
        n = ch.count
        if n == 0:
            return
        walk = ch.walk[:n]
        mode = ch.mode[:n]
        still = ((mode == STAND) | (mode == SIT)) & (ch.gaze_mode[:n] == GAZE_AHEAD)
        still &= walk[:, 0] ** 2 + walk[:, 2] ** 2 < STILL
        # only the idle: a behaviour or a goal that stands still a moment (turning to face a
        # seat, reaching for a wrist, waiting its turn) is looking at what it does
        if still.any():  # (a walking crowd: no loop over its minds)
            busy_rows = [character.index for _, (character, mind) in ctx.world.get_components(Character, Mind)
                         if mind.winner != "idle" or mind.goals]  # fmt: skip
            still[busy_rows] = False
        glance, left = ch.glance[:n], ch.glance_left[:n]
        busy = ~still
        glance[busy] = 0.0
        left[busy] = FIRST_WAIT
        left[still] -= ctx.dt
        for c in np.flatnonzero(still & (left <= 0.0)):
            draw = np.random.default_rng((SALT, ctx.frame, int(c)))
            if glance[c, 0] == 0.0:  # looking ahead: glance to one side
                side = 1.0 if draw.random() < 0.5 else -1.0
                glance[c] = side * draw.uniform(*YAW), draw.uniform(*PITCH)
                left[c] = draw.uniform(*GLANCE)
            else:  # back to looking ahead
                glance[c] = 0.0
                left[c] = draw.uniform(*LOOK_AHEAD)
