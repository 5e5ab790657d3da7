"""integrate: Verlet integration with damping (SPEC 2).

Reads node ``pos``, ``prev``, ``acc``, damping, ``flags``; the scene's gravity.
Writes ``pos``, ``prev``, ``vel`` (the step's displacement before damping), clears
``acc`` and the IN_CONTACT flag (constrain and collide set it again this step).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twig_ecs.step import StepContext
from twig_ecs.store import (
    MOVE_LINE,
    NODE_IN_CONTACT,
    NODE_KICK,
    NODE_LOCKED,
    NODE_MOVING,
    NODE_ON_CARRIED,
    NODE_PINNED,
    columns,
)
from twig_ecs.system import System


class IntegrateColumns(NamedTuple):
    """The node columns a Verlet step reads and writes (``store.NODE_FIELDS`` names them)."""

    pos: np.ndarray
    prev: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    ctrl_acc: np.ndarray
    lock_pos: np.ndarray
    inv_mass: np.ndarray
    damp_air: np.ndarray
    damp_ground: np.ndarray
    roll_decel: np.ndarray
    damp_ref: np.ndarray
    damp_rel: np.ndarray
    move_time: np.ndarray
    move_gravity: np.ndarray
    flags: np.ndarray


# fmt: off
@njit(cache=True, nogil=True)
def integrate_nodes(args, count, gravity, dt, max_speed):
    """One Verlet step for every node, in place (``args``: ``store.columns(IntegrateColumns, nodes)``)."""
    cols = IntegrateColumns(*args)
    pos, prev, vel = cols.pos, cols.prev, cols.vel
    acc, ctrl_acc, lock_pos = cols.acc, cols.ctrl_acc, cols.lock_pos
    inv_mass, damp_air, damp_ground = cols.inv_mass, cols.damp_air, cols.damp_ground
    roll_decel = cols.roll_decel
    damp_ref, damp_rel = cols.damp_ref, cols.damp_rel
    move_time, move_gravity, flags = cols.move_time, cols.move_gravity, cols.flags
    for i in range(count):
        for k in range(3):
            vel[i, k] = pos[i, k] - prev[i, k]
    dt2 = dt * dt
    for i in range(count):
        f = flags[i]
        if f & NODE_KICK and (f & NODE_LOCKED or not f & NODE_MOVING or move_time[i] <= 0.0):
            f &= ~np.uint32(NODE_KICK)  # a kick's mark lasts as long as its move
            flags[i] = f
        if f & NODE_LOCKED:
            for k in range(3):
                pos[i, k] = lock_pos[i, k]
                prev[i, k] = lock_pos[i, k]
                acc[i, k] = 0.0
            continue
        d = damp_ground[i] if f & NODE_IN_CONTACT else damp_air[i]
        rolling = roll_decel[i] > 0.0 and (f & NODE_IN_CONTACT) != 0
        g = 1.0 if inv_mass[i] > 0.0 else 0.0
        ref = damp_ref[i]
        if move_time[i] > 0.0:
            # a ballistic move flies open-loop: no damping, constraints do not push it
            # (NODE_MOVING makes it kinematic to them); a straight one ignores gravity
            move_time[i] = max(0.0, move_time[i] - dt)
            if move_time[i] == 0.0:
                f &= ~np.uint32(NODE_MOVING | NODE_KICK)
            d = 0.0
            ref = -1
            rolling = False
            if move_gravity[i] == MOVE_LINE:
                g = 0.0
        # a speed limit: no part of a body moves faster than max_speed, so a rare
        # fight between constraints cannot fling a node across the scene
        speed = math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2) / dt
        cap = max_speed / speed if speed > max_speed else 1.0
        # rolling resistance (a rolling body touching a support, not in a move): the ground
        # speed |v_xz| drops by a dt each step, to rest and no further
        roll = 1.0
        if rolling:
            flat = math.sqrt(vel[i, 0] ** 2 + vel[i, 2] ** 2) * cap
            roll = max(0.0, flat - roll_decel[i] * dt2) / flat if flat > 0.0 else 1.0
        for k in range(3):
            v = vel[i, k] * cap * (roll if k != 1 else 1.0)
            if ref >= 0:
                # "muscle" damping: remove part of the velocity relative to ref
                v -= damp_rel[i] * (v - vel[ref, k])
            # p(t+dt) = p(t) + (1-d)(p(t) - p(t-dt)) + a dt^2
            a = acc[i, k] + ctrl_acc[i, k] + g * gravity[k]
            new = pos[i, k] + (1.0 - d) * v + a * dt2
            prev[i, k] = pos[i, k]
            pos[i, k] = new
            acc[i, k] = 0.0
        flags[i] = f & ~np.uint32(NODE_IN_CONTACT | NODE_ON_CARRIED | NODE_PINNED)
# fmt: on


class IntegrateSystem(System):
    """Moves every node by Verlet integration with air/ground and muscle damping."""

    name = "integrate"

    def run(self, ctx: StepContext) -> None:
        """Integrate all nodes one step."""
        dt = ctx.dt
        s = ctx.state
        n = s.nodes
        settings = ctx.settings
        integrate_nodes(columns(IntegrateColumns, n), n.count, settings.gravity, dt, settings.max_speed)
