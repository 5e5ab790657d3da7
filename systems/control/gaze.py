"""gaze: turn each character's face towards what it looks at (SPEC 3).

Reads the character table (gaze mode, point or node, walk vector) and head, shoulder
and hip nodes; writes ``head_dir``, the unit vector the face points along (the head
is a single point mass, so its facing is controller state, drawn as the face). The
face turns at a limited rate towards the gaze target - or the direction of motion,
or straight ahead - at most 75 degrees left or right of the shoulders and 60 degrees
up or down. The posture controller turns the shoulders after the face.
"""

from __future__ import annotations

import math

from numba import njit

from twig_ecs.kernelmath import (
    GAZE_AHEAD,
    GAZE_NODE,
    GAZE_POINT,
    HEAD,
    L_SHOULDER,
    R_SHOULDER,
    clamp,
    forward_xz,
    kernel_helper,
    yaw_error,
)
from twig_ecs.step import StepContext
from twig_ecs.system import System

TURN_RATE = 8.0  # rad/s
MAX_YAW = math.radians(75.0)  # from the shoulders
MAX_PITCH = math.radians(60.0)


@kernel_helper
def _turn_towards(direction, c, want_x, want_y, want_z, most, ox, oy, oz):
    """Turn unit vector ``direction[c]`` towards the unit (want_x, want_y, want_z) by at most
    ``most`` radians; one exactly opposite turns to (ox, oy, oz) instead."""
    cx, cy, cz = direction[c, 0], direction[c, 1], direction[c, 2]
    angle = math.acos(clamp(cx * want_x + cy * want_y + cz * want_z, -1.0, 1.0))
    t = 1.0 if angle <= most else most / angle
    nx = cx + t * (want_x - cx)
    ny = cy + t * (want_y - cy)
    nz = cz + t * (want_z - cz)
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if nn < 1e-9:
        nx, ny, nz, nn = ox, oy, oz, 1.0
    direction[c, 0] = nx / nn
    direction[c, 1] = ny / nn
    direction[c, 2] = nz / nn


# fmt: off
@njit(cache=True, nogil=True)
def control_gaze(pos, nodes, gaze_mode, gaze_point, gaze_node, walk, glance, head_dir, face_dir, n_chars, dt):
    """Turn every character's ``head_dir`` towards its gaze target, and the face it is drawn
    with, ``face_dir``, towards ``head_dir`` turned by its idle ``glance`` (``glance.py``)."""
    for c in range(n_chars):
        nd = nodes[c]
        hd = nd[HEAD]
        sx, sz = forward_xz(pos, nd[L_SHOULDER], nd[R_SHOULDER])
        dx, dy, dz = sx, 0.0, sz
        mode = gaze_mode[c]
        if mode == GAZE_NODE and gaze_node[c] < 0:
            mode = GAZE_AHEAD  # the node it watched is gone
        if mode == GAZE_POINT:
            dx = gaze_point[c, 0] - pos[hd, 0]
            dy = gaze_point[c, 1] - pos[hd, 1]
            dz = gaze_point[c, 2] - pos[hd, 2]
        elif mode == GAZE_NODE:
            j = gaze_node[c]
            dx = pos[j, 0] - pos[hd, 0]
            dy = pos[j, 1] - pos[hd, 1]
            dz = pos[j, 2] - pos[hd, 2]
        elif walk[c, 0] * walk[c, 0] + walk[c, 2] * walk[c, 2] > 1e-4:
            dx, dy, dz = walk[c, 0], 0.0, walk[c, 2]
        # limits relative to the shoulders: yaw, then pitch
        flat = math.sqrt(dx * dx + dz * dz)
        if flat < 1e-9:
            dx, dz, flat = sx, sz, 1.0
        yaw = clamp(yaw_error(sx, sz, dx / flat, dz / flat), -MAX_YAW, MAX_YAW)
        pitch = clamp(math.atan2(dy, flat), -MAX_PITCH, MAX_PITCH)
        base = math.atan2(sx, sz)
        want_x = math.sin(base + yaw) * math.cos(pitch)
        want_y = math.sin(pitch)
        want_z = math.cos(base + yaw) * math.cos(pitch)
        # turn at most TURN_RATE * dt towards it (exactly opposite: via the shoulders' forward)
        _turn_towards(head_dir, c, want_x, want_y, want_z, TURN_RATE * dt, sx, 0.0, sz)
        # the drawn face: the head's direction, or a glance away from it - only drawn (and
        # exported): the shoulders and what the character notices go by head_dir
        want_x, want_y, want_z = head_dir[c, 0], head_dir[c, 1], head_dir[c, 2]
        if glance[c, 0] != 0.0 or glance[c, 1] != 0.0:
            turn = math.atan2(want_x, want_z) + glance[c, 0]
            up = clamp(math.asin(clamp(want_y, -1.0, 1.0)) + glance[c, 1], -MAX_PITCH, MAX_PITCH)
            want_x = math.sin(turn) * math.cos(up)
            want_y = math.sin(up)
            want_z = math.cos(turn) * math.cos(up)
        _turn_towards(face_dir, c, want_x, want_y, want_z, TURN_RATE * dt, want_x, want_y, want_z)
# fmt: on


class GazeSystem(System):
    """Turns faces towards gaze targets or the direction of motion."""

    name = "gaze"

    def run(self, ctx: StepContext) -> None:
        """Update every character's face direction."""
        dt = ctx.dt
        s = ctx.state
        ch = s.characters
        if ch.count == 0:
            return
        control_gaze(s.nodes.pos, ch.nodes, ch.gaze_mode, ch.gaze_point, ch.gaze_node, ch.walk, ch.glance,
                     ch.head_dir, ch.face_dir, ch.count, dt)  # fmt: skip
