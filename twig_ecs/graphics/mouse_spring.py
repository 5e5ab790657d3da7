"""The mouse spring: a damped spring from a grabbed body part to the cursor.

:class:`MouseSpring` is a system the window adds to its scene. While the mouse holds a
node it pulls that node towards ``target`` every step, before the Verlet step, as a
force: the rest of the body follows through the constraints and the behaviours react as
they would to any push. Letting go simply stops the pull, so the part keeps the velocity
the drag gave it: a throw.

The spring is stiffer for a light part of a heavy body (a hand of a child), so that
pulling a hand moves the child, not just the hand; its pull is capped for stability.

A yank hurts: the spring's stretch energy (1/2 k d^2, J) goes to the body's pain sensor
as a blow of that energy would, with the sensor's own threshold and gain, for as long as
the stretch lasts (gain x energy per second while it is above the threshold) and with a
``pain`` event (at most every PAIN_EVENT_EVERY s), so the characters' pain reactions
(the withdraw reflex) follow as from a blow. A gentle drag stays under the threshold.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.events import Pain
from twig_ecs.system import System

#: Natural frequency (rad/s) of the spring on a part that is the whole body (the ball).
BASE_OMEGA = 14.0
#: The most a spring's frequency may reach (rad/s): Verlet with explicit damping needs omega dt < 1.
MAX_OMEGA = 36.0
#: Damping ratio: just under critical, so a dragged part follows without ringing.
DAMPING = 0.9
#: While a yank goes on hurting, a ``pain`` event at most this often (s): the reflexes restart
#: on each, as after a fresh blow, without an event every step.
PAIN_EVENT_EVERY = 0.25


class MouseSpring(System):
    """Pulls one held node towards a target point each step (see the module docstring)."""

    name = "mouse_spring"

    def setup(self) -> None:
        self.row: int | None = None  # the held node's row in the node table
        self.body: str | None = None
        self.part: str = ""
        self.target = np.zeros(3)
        self.force = 0.0  # N: the pull of the last step (the window shows it)
        self.stretch_energy = 0.0  # J: 1/2 k d^2 of the last step
        self.omega = BASE_OMEGA
        self._next_pain_event = -math.inf  # simulated time

    @property
    def holding(self) -> bool:
        """Is a body part held?"""
        return self.row is not None

    def hold(self, body: str, part: str, row: int, target: np.ndarray) -> None:
        """Start pulling node ``row`` (``part`` of ``body``) towards ``target``."""
        handle = self.scene.entity(body)
        node_mass = float(self.scene.state.nodes.mass[row])
        # stiffer for a light part of a heavy body: the pull on the body scales with its mass
        ratio = max(1.0, handle.mass / max(node_mass, 1e-6))
        self.omega = min(MAX_OMEGA, BASE_OMEGA * ratio**0.25)
        self.row, self.body, self.part = row, body, part
        self.target = np.asarray(target, dtype=np.float64).copy()
        self.force = self.stretch_energy = 0.0

    def move(self, target: np.ndarray) -> None:
        """Move the cursor end of the spring (m)."""
        self.target = np.asarray(target, dtype=np.float64).copy()

    def let_go(self) -> None:
        """Stop pulling: the part keeps its velocity (a throw)."""
        self._next_pain_event = -math.inf
        self.row, self.body, self.part = None, None, ""
        self.force = self.stretch_energy = 0.0

    def process(self, dt: float) -> None:
        """Add the spring's acceleration to the held node; feel the stretch as pain."""
        if self.row is None:
            return
        if not self.scene.has_entity(self.body):  # removed while held
            self.let_go()
            return
        n, i = self.scene.state.nodes, self.row
        stretch = self.target - n.pos[i]
        velocity = (n.pos[i] - n.prev[i]) / dt
        w = self.omega
        acc = w * w * stretch - 2.0 * DAMPING * w * velocity
        n.acc[i] += acc
        mass = float(n.mass[i])
        self.force = mass * float(np.linalg.norm(acc))
        self.stretch_energy = 0.5 * mass * w * w * float(stretch @ stretch)
        self._feel(self.stretch_energy)

    def _feel(self, energy: float) -> None:
        """The stretch as an impact on the held body's pain sensor (sense.feel_impacts' rule)."""
        bodies = self.scene.state.bodies
        handle = self.scene.entity(self.body)
        b = handle.body.index
        threshold = float(bodies.pain_threshold[b])
        if not math.isfinite(threshold) or energy < threshold:
            return
        # a held stretch is a blow of that energy every second: the pain grows while it lasts
        bodies.pain[b] += bodies.pain_gain[b] * energy * self.scene.dt
        now = self.scene.time
        if now >= self._next_pain_event:
            self._next_pain_event = now + PAIN_EVENT_EVERY
            # no body's hand pulled: the body is its own source (withdraw backs off where it faces from)
            self.scene.emit(Pain(handle.entity, self.part, handle.entity, energy, float(bodies.pain[b])))
