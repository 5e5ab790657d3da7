"""sense: tactile sensing and pain (SPEC 2).

Reads the colliders' tactile record written by collide (``hit_energy``, ``hit_by``)
and the bodies' pain parameters. Writes ``bodies.pain`` (decayed exponentially with
each body's half-life, raised by impacts above its threshold) and emits
:class:`~twig_ecs.events.Contact` and :class:`~twig_ecs.events.Pain` events.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from twig_ecs.components import Body
from twig_ecs.events import Contact, Pain
from twig_ecs.step import StepContext
from twig_ecs.system import System


@njit(cache=True, nogil=True)
def feel_impacts(
    hit_energy, hit_by, col_body, n_col, pain, pain_threshold, pain_half_life, pain_gain, n_bodies, dt, gentle
):
    """Decay every pain level, then add each impact at or above its body's threshold, but
    one from a thing the body holds or has just let go of (``gentle``: (holder, thing) body
    rows, ``state.gentle``): what a child carries does not hurt it."""
    for b in range(n_bodies):
        pain[b] *= math.exp(-math.log(2.0) * dt / pain_half_life[b])
    for c in range(n_col):
        e = hit_energy[c]
        if e <= 0.0 or hit_by[c] < 0:
            continue
        b = col_body[c]
        ob = col_body[hit_by[c]]
        if ob != b and e >= pain_threshold[b] and not is_gentle(gentle, b, ob):
            pain[b] += pain_gain[b] * e


@njit(cache=True, inline="always")
def is_gentle(gentle, holder, thing):
    """Is ``thing`` a body that ``holder`` holds or just let go of (a row of ``gentle``)?"""
    for k in range(gentle.shape[0]):
        if gentle[k, 0] == holder and gentle[k, 1] == thing:
            return True
    return False


#: :func:`is_gentle` as plain Python, for the per-contact check made from Python: an inline
#: kernel is never built ahead, so its first compiled call compiled mid-play (1.5 s under load).
_is_gentle_in_python = getattr(is_gentle, "py_func", is_gentle)  # (no py_func with the JIT off)


class SenseSystem(System):
    """Turns impacts into pain levels and contact/pain events."""

    name = "sense"

    def run(self, ctx: StepContext) -> None:
        """Update pain; emit events for impacts above the contact threshold."""
        dt = ctx.dt
        s = ctx.state
        col, bodies = s.colliders, s.bodies
        feel_impacts(
            col.hit_energy,
            col.hit_by,
            col.body,
            col.count,
            bodies.pain,
            bodies.pain_threshold,
            bodies.pain_half_life,
            bodies.pain_gain,
            bodies.count,
            dt,
            s.gentle,
        )
        # Events are rare (only real impacts), so building them in Python is cheap.
        struck = np.flatnonzero(col.hit_energy[: col.count] >= ctx.settings.contact_energy)
        for c in struck:
            other = int(col.hit_by[c])
            b, ob = int(col.body[c]), int(col.body[other])
            if b == ob:
                continue
            energy = float(col.hit_energy[c])
            body_e, other_e = int(bodies.entity[b]), int(bodies.entity[ob])
            part, other_part = self._part(c, body_e), self._part(other, other_e)
            # one contact event per pair: the side with the lower index reports it
            if c < other or int(col.hit_by[other]) != c:
                ctx.emit(Contact(body_e, part, other_e, other_part, energy))
            if energy >= bodies.pain_threshold[b] and not _is_gentle_in_python(s.gentle, b, ob):
                level = float(bodies.pain[b])
                ctx.emit(Pain(body_e, part, other_e, energy, level))

    def _part(self, c: int, body_entity: int) -> str:
        """The name of collider ``c`` on its body: its link's "a-b", or a sphere's node name."""
        s = self.scene.state
        body = self.world.component_for_entity(body_entity, Body)
        link = int(s.colliders.link[c])
        if link >= 0:
            return body.link_name(link, s.links)
        return body.node_names[int(s.colliders.a[c]) - body.node_start]
