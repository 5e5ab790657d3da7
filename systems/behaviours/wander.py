"""wander: roam a square, one random target after another, round everyone else (crowds).

For each character with a :class:`Wander`: its activation is the
component's ``activation`` (autonomous characters only). Winning, it walks to its
target with the approach field of SPEC 4 (:func:`~twig_ecs.kernelmath.approach_field`,
the same compiled function ``approach`` steers with), the obstacles being the nearest
node of every other body that stands higher than a step, within the cut-off. On
arrival, or when it makes no headway for ``patience`` s, it draws a new target.

A *batch* behaviour: one kernel call steers every wandering character (a node grid finds
the neighbours), so a crowd of a thousand costs one call, not a thousand. Reads node
positions and the Wander components (only when drawing targets); writes the character
table's ``walk`` and ``steer_*`` columns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Character
from twig_ecs.kernelmath import PELVIS, approach_field
from twig_ecs.steering import SteeringParams
from twig_ecs.step import StepContext
from twig_ecs.systems.control.spatial import STEP_OVER


@dataclass(slots=True)
class Wander:
    """Roams: picks a random point in a square and walks there round others, then another.

    Targets are drawn from the square of half-size ``radius`` (m) round ``centre``
    ([x, z]); a target counts as reached within ``arrive`` m, and one not got 10 cm
    closer to in ``patience`` s is given up for a new one.
    """

    radius: float = 10.0
    centre: list[float] = field(default_factory=lambda: [0.0, 0.0])
    speed: float = 1.2  # m/s
    arrive: float = 0.6  # m
    patience: float = 4.0  # s
    activation: float = 0.3  # above idle, below commanded goals
    targets: int = 0  # how many targets it has picked


#: Headway (m) that resets the patience clock, as in approach's stall test.
HEADWAY = 0.1


@njit(cache=True, inline="always")
def _cell(ix, iz, mask):
    return ((ix * 73856093) ^ (iz * 19349663)) & mask


@njit(cache=True, nogil=True)
def steer_crowd(pos, node_body, n_nodes, ch_nodes, ch_body, rows, goal, speed, best, best_at, arrive,
                now, patience, walk, redraw, head, nxt, near_d2, near_node, touched, obstacles,
                params):  # fmt: skip
    """Walk vectors for the characters ``rows``: the approach field to each one's goal.

    ``params`` = (repulsion, cutoff, min_sq, fade, step_over). Nodes above
    ``step_over`` go into a hashed ground-plane grid of cell ``cutoff`` (``head``: a
    power-of-two bucket table, ``nxt``: per-node chains); each character looks through
    the 3 x 3 cells round its pelvis for the nearest node of every other body. Sets
    ``redraw[k]`` (and stands still) where character ``rows[k]`` has arrived, has no
    target yet, or has stalled for ``patience`` s.
    """
    repulsion, cutoff, min_sq, fade, step_over = params[0], params[1], params[2], params[3], params[4]
    inv = 1.0 / cutoff
    cut_sq = cutoff * cutoff
    mask = len(head) - 1
    head[:] = -1
    for i in range(n_nodes):
        if pos[i, 1] <= step_over:
            continue  # lying low: stepped over, no obstacle
        h = _cell(int(math.floor(pos[i, 0] * inv)), int(math.floor(pos[i, 2] * inv)), mask)
        nxt[i] = head[h]
        head[h] = i
    for k in range(len(rows)):
        c = rows[k]
        p = ch_nodes[c, PELVIS]
        px = pos[p, 0]
        pz = pos[p, 2]
        gx = goal[c, 0]
        gz = goal[c, 1]
        dist = math.sqrt((gx - px) * (gx - px) + (gz - pz) * (gz - pz))
        if dist < best[c] - HEADWAY:
            best[c] = dist
            best_at[c] = now
        if speed[c] <= 0.0 or dist <= arrive[k] or now - best_at[c] > patience[k]:
            redraw[k] = 1
            walk[c, 0] = 0.0
            walk[c, 2] = 0.0
            continue
        me = ch_body[c]
        n_near = 0
        cx = int(math.floor(px * inv))
        cz = int(math.floor(pz * inv))
        for dx in range(-1, 2):
            for dz in range(-1, 2):
                i = head[_cell(cx + dx, cz + dz, mask)]
                while i >= 0:  # (a bucket met twice through a hash clash only repeats nodes)
                    b = node_body[i]
                    if b != me:
                        ox = px - pos[i, 0]
                        oz = pz - pos[i, 2]
                        d2 = ox * ox + oz * oz
                        if d2 < cut_sq:
                            if near_node[b] < 0:
                                touched[n_near] = b
                                n_near += 1
                                near_d2[b] = d2
                                near_node[b] = i
                            elif d2 < near_d2[b]:
                                near_d2[b] = d2
                                near_node[b] = i
                    i = nxt[i]
        # in body order, as approach lists its obstacles (the sum's order is then fixed)
        touched[:n_near].sort()
        for t in range(n_near):
            b = touched[t]
            for q in range(3):
                obstacles[t, q] = pos[near_node[b], q]
            near_node[b] = -1
        wx, wz = approach_field(px, pz, gx, gz, obstacles, n_near, speed[c], repulsion, cutoff, min_sq,
                                True, fade)  # fmt: skip
        walk[c, 0] = wx
        walk[c, 1] = 0.0
        walk[c, 2] = wz


@register
class WanderBehavior(Behavior):
    """Roam from random target to random target, avoiding the others."""

    name = "wander"
    component = Wander
    batch = True

    def setup(self) -> None:
        """The steering gains (the kernel's arrays are in ``self.scratch``, grown as the scene grows)."""
        field = SteeringParams()  # the approach behaviour's gains
        self._params = np.array([field.repulsion, field.cutoff, field.min_sq, field.fade, STEP_OVER])

    def run(self, ctx: StepContext) -> None:
        """Propose ``activation`` for every autonomous wandering character."""
        for _, (_, mind, wander) in ctx.world.get_components(Character, Mind, Wander):
            if mind.autonomous:
                mind.activations["wander"] = wander.activation

    def act_batch(self, rows: list[int], entities: list[int], dt: float) -> None:
        """Steer all winners in one kernel call; draw new targets for those that need one."""
        scene = self.scene
        state = scene.state
        nodes, ch = state.nodes, state.characters
        n = len(rows)
        rows_a = self.scratch.array("rows", n, np.int64)[:n]
        rows_a[:] = rows
        arrive = self.scratch.array("arrive", n, np.float64)[:n]
        patience = self.scratch.array("patience", n, np.float64)[:n]
        # per-character parameters: cached by the list of winners (they rarely change)
        key = tuple(entities)
        if self.scratch.get("key") != key:
            comps = [self.world.component_for_entity(e, Wander) for e in entities]
            arrive[:] = [w.arrive for w in comps]
            patience[:] = [w.patience for w in comps]
            self.scratch["key"] = key
        redraw = self.scratch.array("redraw", n, np.uint8)[:n]
        redraw[:] = 0
        head = self.scratch.array("head", 2 * nodes.count, np.int64)
        head = head[: 1 << int(math.log2(len(head)))]  # a power of two
        steer_crowd(
            nodes.pos, nodes.body, nodes.count, ch.nodes, ch.body, rows_a, ch.steer_goal, ch.steer_speed,
            ch.steer_best, ch.steer_best_at, arrive, scene.time, patience, ch.walk, redraw, head,
            self.scratch.array("nxt", nodes.count, np.int64),
            self.scratch.array("near_d2", state.bodies.count, np.float64),
            self.scratch.array("near_node", state.bodies.count, np.int64, fill=-1),
            self.scratch.array("touched", state.bodies.count, np.int64),
            self.scratch.array("obstacles", state.bodies.count, np.float64, width=3),
            self._params,
        )  # fmt: skip
        for k in np.flatnonzero(redraw):
            self._draw_target(entities[k], rows[k])

    def _draw_target(self, entity: int, row: int) -> None:
        """A new random target in the character's square (a rare, per-character event)."""
        wander = self.world.component_for_entity(entity, Wander)
        ch = self.scene.state.characters
        x, z = self.scene.rng.uniform(-wander.radius, wander.radius, 2)
        ch.steer_goal[row] = (wander.centre[0] + x, wander.centre[1] + z)
        ch.steer_speed[row] = wander.speed
        ch.steer_best[row] = np.inf
        ch.steer_best_at[row] = self.scene.time
        wander.targets += 1

    def stop(self, character, goal) -> None:
        """Stand still; the next wander starts with a fresh target."""
        character.stop()
        self.scene.state.characters.steer_speed[character.character.index] = 0.0
