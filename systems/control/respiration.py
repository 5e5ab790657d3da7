"""respiration: the shoulders rise and fall with each breath (SPEC 3).

Reads each character's pelvis speed; writes its breathing phase and the rest lengths
of its two shoulder-to-spine links, which lengthen and shorten sinusoidally so the
shoulders shrug up and down. Breaths come faster and deeper with speed.
"""

from __future__ import annotations

import math

from numba import njit

from twig_ecs.kernelmath import PELVIS, clamp
from twig_ecs.step import StepContext
from twig_ecs.system import System

REST_HZ = 0.25  # breaths per second at rest
HZ_PER_SPEED = 0.35  # more per m/s
REST_DEPTH = 0.006  # m of shoulder travel at rest (1.75 m tall)
RUN_DEPTH = 0.014  # m at 3 m/s and faster


# fmt: off
@njit(cache=True, nogil=True)
def breathe(pos, prev, rest, nodes, breath_links, breath_rest, breath_phase, scale, n_chars, dt):
    """Advance every character's breath and set its shoulder link lengths."""
    for c in range(n_chars):
        p = nodes[c, PELVIS]
        vx = (pos[p, 0] - prev[p, 0]) / dt
        vz = (pos[p, 2] - prev[p, 2]) / dt
        speed = math.sqrt(vx * vx + vz * vz)
        breath_phase[c] += 2.0 * math.pi * (REST_HZ + HZ_PER_SPEED * speed) * dt
        f = clamp(speed / 3.0, 0.0, 1.0)
        depth = scale[c] * (REST_DEPTH + f * (RUN_DEPTH - REST_DEPTH))
        for k in range(2):
            j = breath_links[c, k]
            if j >= 0:
                rest[j] = breath_rest[c, k] + depth * math.sin(breath_phase[c])
# fmt: on


class RespirationSystem(System):
    """Breathing: shoulders rise and fall, faster and deeper when moving."""

    name = "respiration"

    def run(self, ctx: StepContext) -> None:
        """Advance every character's breathing."""
        dt = ctx.dt
        s = ctx.state
        ch = s.characters
        if ch.count == 0:
            return
        breathe(s.nodes.pos, s.nodes.prev, s.links.rest, ch.nodes, ch.breath_links, ch.breath_rest,
                ch.breath_phase, ch.scale, ch.count, dt)  # fmt: skip
