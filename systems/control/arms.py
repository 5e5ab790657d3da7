"""arms: reach, poses and gestures by pulling the hands to Cartesian targets (SPEC 3).

Reads the character table (``arm_mode``, ``arm_point``, ``arm_node``, gesture phase)
and shoulder/elbow/hand positions; writes hand and elbow ``acc``. A controlled arm
carries its own weight and its hand is pulled to its target by a spring-damper
(proportional control plus damping); an arm in ``HANG`` mode is left to gravity and
the gait's swing impulses. Grabbing is a zero-length link made by the Python API.

Targets, with S the shoulder, F the shoulders' forward, L the arm's length:
REACH a point or node; GRAPPLE S + 0.55 L F, a little low and in; HUG S + 0.7 L F,
0.45 L out (arms open wide ahead, near full extension); WAVE above the shoulder,
swaying; POINT S + L towards the target; CARRY S + 0.45 L F, 0.55 L down.
"""

from __future__ import annotations

import math

from numba import njit

from twig_ecs.kernelmath import (
    CARRY,
    GRAPPLE,
    HANG,
    HUG,
    L_ELBOW,
    L_HAND,
    L_SHOULDER,
    POINT,
    R_SHOULDER,
    REACH,
    WAVE,
    clamp,
    forward_xz,
    kernel_helper,
)
from twig_ecs.step import StepContext
from twig_ecs.system import System

HAND_GAIN, HAND_DAMP = 150.0, 24.0  # 1/s^2, 1/s
ELBOW_DAMP = 10.0
ELBOW_MOST = math.radians(145.0)  # the most an elbow folds (a person's: about 145-150 degrees)
WAVE_HZ = 1.6
MAX_ACC = 120.0


@kernel_helper(nogil=True)
def unfold(pos, prev, s, e, w):
    """Keep the elbow of shoulder ``s``, elbow ``e``, hand ``w`` from folding past ELBOW_MOST.

    The hinge limit (the body's ``joint_limits``) only keeps the elbow pointing back and
    down; how far it folds is left to the hand. A hand nearer its shoulder than a human
    elbow allows (a blow rebounding off a chest, a pose held in close) is moved out along
    the shoulder-hand line, ``pos`` and ``prev`` together: its inward speed is dropped
    with it, so it does not spring back and forth (the wobble of a grapple's elbows).
    """
    u = math.sqrt((pos[e, 0] - pos[s, 0]) ** 2 + (pos[e, 1] - pos[s, 1]) ** 2 + (pos[e, 2] - pos[s, 2]) ** 2)
    f = math.sqrt((pos[w, 0] - pos[e, 0]) ** 2 + (pos[w, 1] - pos[e, 1]) ** 2 + (pos[w, 2] - pos[e, 2]) ** 2)
    # the shoulder-hand distance with the elbow folded ELBOW_MOST (interior angle 180 - that)
    least = math.sqrt(max(0.0, u * u + f * f + 2.0 * u * f * math.cos(ELBOW_MOST)))
    dx = pos[w, 0] - pos[s, 0]
    dy = pos[w, 1] - pos[s, 1]
    dz = pos[w, 2] - pos[s, 2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d >= least or d < 1e-9:
        return
    k = (least - d) / d
    for q, v in ((0, dx), (1, dy), (2, dz)):
        pos[w, q] += k * v
        prev[w, q] += k * v


# fmt: off
@njit(cache=True, nogil=True)
def control_arms(pos, prev, acc, nodes, arm_mode, arm_point, arm_node, gesture_phase, n_chars, gravity,
                 dt):
    """Add arm accelerations for every character with a controlled arm."""
    for c in range(n_chars):
        nd = nodes[c]
        gesture_phase[c] += 2.0 * math.pi * WAVE_HZ * dt
        fx, fz = forward_xz(pos, nd[L_SHOULDER], nd[R_SHOULDER])
        for h in range(2):
            mode = arm_mode[c, h]
            s = nd[L_SHOULDER + h]
            e = nd[L_ELBOW + h]
            w = nd[L_HAND + h]
            if mode == HANG:
                continue
            if mode == GRAPPLE:
                # fists thrown and rebounding off a chest fold the elbows up (to 164-177
                # degrees before); a reaching or carrying hand keeps to the hinge alone
                unfold(pos, prev, s, e, w)
            length = 0.0
            for a, b in ((s, e), (e, w)):
                length += math.sqrt((pos[a, 0] - pos[b, 0]) ** 2 + (pos[a, 1] - pos[b, 1]) ** 2
                                    + (pos[a, 2] - pos[b, 2]) ** 2)
            side = 1.0 if h == 0 else -1.0  # left is +x when facing +z: (fz, 0, -fx) * side
            ox = fz * side
            oz = -fx * side
            tx = pos[s, 0]
            ty = pos[s, 1]
            tz = pos[s, 2]
            if mode == REACH:
                j = arm_node[c, h]
                if j >= 0:
                    tx, ty, tz = pos[j, 0], pos[j, 1], pos[j, 2]
                else:
                    tx, ty, tz = arm_point[c, h, 0], arm_point[c, h, 1], arm_point[c, h, 2]
            elif mode == GRAPPLE:
                tx += 0.55 * length * fx - 0.15 * length * ox
                ty -= 0.15 * length
                tz += 0.55 * length * fz - 0.15 * length * oz
            elif mode == HUG:  # arms open wide, ready to close round someone
                tx += 0.7 * length * fx + 0.45 * length * ox
                tz += 0.7 * length * fz + 0.45 * length * oz
            elif mode == WAVE:
                sway = 0.3 * length * math.sin(gesture_phase[c])
                tx += 0.15 * length * fx + (0.2 * length + sway) * ox
                ty += 0.8 * length
                tz += 0.15 * length * fz + (0.2 * length + sway) * oz
            elif mode == POINT:
                j = arm_node[c, h]
                px, py, pz = (pos[j, 0], pos[j, 1], pos[j, 2]) if j >= 0 else (
                    arm_point[c, h, 0], arm_point[c, h, 1], arm_point[c, h, 2])
                dx, dy, dz = px - tx, py - ty, pz - tz
                dn = math.sqrt(dx * dx + dy * dy + dz * dz) + 1e-9
                tx += length * dx / dn
                ty += length * dy / dn
                tz += length * dz / dn
            elif mode == CARRY:
                tx += 0.45 * length * fx - 0.1 * length * ox
                ty -= 0.55 * length
                tz += 0.45 * length * fz - 0.1 * length * oz
            target = (tx, ty, tz)
            for k in range(3):
                v = (pos[w, k] - prev[w, k]) / dt
                a = HAND_GAIN * (target[k] - pos[w, k]) - HAND_DAMP * v
                acc[w, k] += clamp(a, -MAX_ACC, MAX_ACC) - gravity[k]
                ve = (pos[e, k] - prev[e, k]) / dt
                acc[e, k] += -ELBOW_DAMP * ve - gravity[k]
# fmt: on


class ArmsSystem(System):
    """Pulls controlled hands to their reach, pose or gesture targets."""

    name = "arms"

    def run(self, ctx: StepContext) -> None:
        """Add this step's arm accelerations."""
        dt = ctx.dt
        s = ctx.state
        ch, n = s.characters, s.nodes
        if ch.count == 0:
            return
        control_arms(n.pos, n.prev, n.acc, ch.nodes, ch.arm_mode, ch.arm_point, ch.arm_node, ch.gesture_phase,
                     ch.count, ctx.settings.gravity, dt)  # fmt: skip
