"""The mouse spring: a damped spring from a grabbed body part to the cursor.

:class:`MouseSpring` is a system the play window adds to its scene. It lives here, in
the physics layer, rather than beside the window: it is part of the scene's schedule, so
scene snapshots (the server's checkpoints under ``twig serve --window``) hold it, and a
snapshot loads only classes outside the input/output modules such as ``twig_ecs.graphics``.

While the mouse holds a node it pulls that node towards ``target`` every step, before
the Verlet step, as a force: the rest of the body follows through the constraints and
the behaviours react as they would to any push. Letting go simply stops the pull, so
the part keeps the velocity the drag gave it: a throw.

The spring is stiffer for a light part of a heavy body (a hand of a child), so that
pulling a hand moves the child, not just the hand; its stiffness is capped for stability.

A yank hurts. A blow's energy, to the pain sensor, is the kinetic energy of the impact;
a yank's is the kinetic energy of the held part moving against the rest of its body,
1/2 m |v_part - v_body|^2 (J). When that reaches the sensor's threshold it counts as a
blow with the sensor's own gain and a ``pain`` event - at most one every
PAIN_EVENT_EVERY s while the yank goes on - so the characters react as to a blow (the
withdraw reflex). A pull that moves the whole body along hurts less than one that moves
the part against it (and holding the hand of a child who runs off is a yank too).
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.events import Pain
from twig_ecs.step import StepContext
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
        self.yank_energy = 0.0  # J: the held part's kinetic energy against its body, last step
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
        self.force = self.yank_energy = 0.0

    def move(self, target: np.ndarray) -> None:
        """Move the cursor end of the spring (m)."""
        self.target = np.asarray(target, dtype=np.float64).copy()

    def let_go(self) -> None:
        """Stop pulling: the part keeps its velocity (a throw)."""
        self._next_pain_event = -math.inf
        self.row, self.body, self.part = None, None, ""
        self.force = self.yank_energy = 0.0

    def run(self, ctx: StepContext) -> None:
        """Add the spring's acceleration to the held node; a yank is felt as a blow."""
        dt = ctx.dt
        if self.row is None:
            return
        if not self.scene.has_entity(self.body):  # removed while held
            self.let_go()
            return
        n, i = ctx.state.nodes, self.row
        stretch = self.target - n.pos[i]
        velocity = (n.pos[i] - n.prev[i]) / dt
        w = self.omega
        acc = w * w * stretch - 2.0 * DAMPING * w * velocity
        n.acc[i] += acc
        mass = float(n.mass[i])
        self.force = mass * float(np.linalg.norm(acc))
        handle = self.scene.entity(self.body)
        relative = velocity - handle.velocity  # against the body's centre of mass
        self.yank_energy = 0.5 * mass * float(relative @ relative)
        self._feel(handle, self.yank_energy)

    def _feel(self, handle, energy: float) -> None:
        """A yank at or above the pain threshold as a blow (sense.feel_impacts' rule)."""
        bodies = self.scene.state.bodies
        b = handle.body.index
        threshold = float(bodies.pain_threshold[b])
        now = self.scene.time
        if not math.isfinite(threshold) or energy < threshold or now < self._next_pain_event:
            return
        self._next_pain_event = now + PAIN_EVENT_EVERY
        bodies.pain[b] += bodies.pain_gain[b] * energy
        # no body's hand pulled: the body is its own source (withdraw backs off where it faces from)
        self.scene.emit(Pain(handle.entity, self.part, handle.entity, energy, float(bodies.pain[b])))
