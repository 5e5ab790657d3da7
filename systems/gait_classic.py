"""gait_classic: the original stepping (SPEC 3), for characters whose ``gait`` is "classic".

The default gait until the human walk (:mod:`twig_ecs.systems.gait`) keeps every
schoolyard behaviour working; :class:`~twig_ecs.systems.gait.GaitSystem` runs both
kernels, each over its own characters.

Reads the character table (walk vector, posture mode, step timers) and foot, hip and
pelvis nodes; writes foot and hand velocities (through ``prev``), node flags and move
timers. A planted foot is locked (static friction: it never slides). When a foot has
fallen far enough from where it belongs - behind its hip while walking, or off from
under it when standing - and the other foot is planted, it is unlocked and sent on a
ballistic arc to a point ahead of its hip in the walk direction, landing when the
pelvis will be there; it locks again when it touches down. One foot steps at a time,
in alternation, and the opposite hand swings forward with each step. Knees follow
through the links and their joint limits.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twig_ecs.kernelmath import (
    CLASSIC,
    HANG,
    L_FOOT,
    L_HAND,
    L_HIP,
    PELVIS,
    STAND,
    clamp,
    forward_xz,
)
from twig_ecs.store import MOVE_ARC, NODE_IN_CONTACT, NODE_LOCK_ON_CONTACT, NODE_LOCKED, NODE_MOVING

STEP_TIME = 0.34  # s a step takes at a walk
RUN_STEP_TIME = 0.24  # s at a run (3 m/s and faster)
STRIDE = 0.10  # m (at 1.75 m tall): how far behind its hip a foot may fall, at a crawl
STRIDE_PER_SPEED = 0.12  # m more per m/s of walking speed
REACH = 0.8  # of the longest step the legs allow at the pelvis's height
STANCE_SLACK = 0.12  # m: standing still, a foot this far from under its hip steps back
STRETCH = 0.95  # a planted leg stretched to this fraction of its length steps at once (walking)
STILL_SKIP = 0.15  # of the leg's length: standing, a re-step shorter than this is not taken
STILL_PACE = 0.15  # m/s (at 1.75 m): a pelvis moving slower than this is standing still
STILL_STRETCH = 0.95  # standing: only a leg this straight forces a step (a standing leg is at 0.96)
SLIP = 1.05  # a planted foot pulled this far (fraction of the leg's length) slips free
FOOT_GAP = 1.4  # half hip widths: least sideways gap between a landing foot and the planted one
LOW_SUPPORT = 0.3  # of the leg's length: the highest support a foot plants on
STRAY = 0.1  # of the leg's length: a foot this far up after its step is over is brought down
ARM_SWING = 0.8  # m/s of hand velocity per m/s of walking, given at each step


class GaitColumns(NamedTuple):
    """The node and character-table columns the two gait kernels read and write (named as
    in ``store.NODE_FIELDS`` and ``store.CHARACTER_FIELDS``)."""

    pos: np.ndarray
    prev: np.ndarray
    acc: np.ndarray
    lock_pos: np.ndarray
    flags: np.ndarray
    move_time: np.ndarray
    move_gravity: np.ndarray
    radius: np.ndarray
    nodes: np.ndarray  # characters' node rows by role
    mode: np.ndarray
    walk: np.ndarray
    swing: np.ndarray
    last_step: np.ndarray
    steps: np.ndarray
    arm_mode: np.ndarray
    scale: np.ndarray
    leg_length: np.ndarray
    gait: np.ndarray


# fmt: off
@njit(cache=True)
def control_gait_classic(args, n_chars, gravity, dt):
    """Plant, unlock and launch feet for every standing character with the classic gait
    (``args``: ``store.columns(GaitColumns, nodes, characters)``)."""
    cols = GaitColumns(*args)
    pos, prev, lock_pos, flags, radius = cols.pos, cols.prev, cols.lock_pos, cols.flags, cols.radius
    move_time, move_gravity = cols.move_time, cols.move_gravity
    nodes, mode, walk = cols.nodes, cols.mode, cols.walk
    swing, last_step = cols.swing, cols.last_step
    steps, arm_mode, scale = cols.steps, cols.arm_mode, cols.scale
    leg_length, gait = cols.leg_length, cols.gait
    for c in range(n_chars):
        if gait[c] != CLASSIC:
            continue
        nd = nodes[c]
        for f in range(2):
            swing[c, f] = max(0.0, swing[c, f] - dt)
        if mode[c] != STAND or flags[nd[PELVIS]] & NODE_LOCKED:
            continue  # sitting, limp or frozen (a locked pelvis): no stepping
        # plant: a foot on the ground that is not mid-step locks in place; a planted
        # foot whose leg is pulled past its length slips (static friction gives way)
        for f in range(2):
            i = nd[L_FOOT + f]
            h = nd[L_HIP + f]
            if flags[i] & NODE_LOCKED:
                gap = math.sqrt((pos[i, 0] - pos[h, 0]) ** 2 + (pos[i, 1] - pos[h, 1]) ** 2
                                + (pos[i, 2] - pos[h, 2]) ** 2)  # fmt: skip
                if gap > SLIP * leg_length[c]:
                    flags[i] &= ~np.uint32(NODE_LOCKED)
                    for k in range(3):
                        prev[i, k] = pos[i, k]
                    continue
            if flags[i] & NODE_LOCKED and move_time[i] > 0.0:  # landed early
                move_time[i] = 0.0
                flags[i] &= ~np.uint32(NODE_MOVING)
            # low down only: a foot pushed up onto someone's hip in a crush must not be
            # nailed there in mid-air (it steps down again instead)
            low = pos[i, 1] <= radius[i] + LOW_SUPPORT * leg_length[c]
            if swing[c, f] == 0.0 and flags[i] & NODE_IN_CONTACT and not flags[i] & NODE_LOCKED and low:
                flags[i] |= NODE_LOCKED
                flags[i] &= ~np.uint32(NODE_LOCK_ON_CONTACT)
                for k in range(3):
                    prev[i, k] = pos[i, k]
                    lock_pos[i, k] = pos[i, k]  # held where it stands (not where it last stood)
        if swing[c, 0] > 0.0 or swing[c, 1] > 0.0:
            continue  # one foot at a time
        wx = walk[c, 0]
        wz = walk[c, 2]
        speed = math.sqrt(wx * wx + wz * wz)
        s = scale[c]
        moving = speed > 0.01
        dx = wx / speed if moving else 0.0
        dz = wz / speed if moving else 0.0
        # the longest step the legs allow: a leg of length L from a hip at height h
        # reaches sqrt(L^2 - h^2) along the ground
        hip_h = 0.5 * (pos[nd[L_HIP], 1] + pos[nd[L_HIP + 1], 1]) - radius[nd[L_FOOT]]
        most = math.sqrt(max(0.0, leg_length[c] ** 2 - hip_h * hip_h))
        reach = min(REACH * most, s * (STRIDE + STRIDE_PER_SPEED * speed))
        # shorter legs step faster: a pendulum's period goes with the root of its length
        t_step = (STEP_TIME + (RUN_STEP_TIME - STEP_TIME) * clamp(speed / 3.0, 0.0, 1.0)) * s**1.0
        half = 0.5 * math.sqrt((pos[nd[L_HIP], 0] - pos[nd[L_HIP + 1], 0]) ** 2
                               + (pos[nd[L_HIP], 2] - pos[nd[L_HIP + 1], 2]) ** 2)
        # which foot is furthest from where it belongs?
        best = -1
        best_need = 0.0
        for f in range(2):
            i = nd[L_FOOT + f]
            h = nd[L_HIP + f]
            # a foot whose step is over but which is neither planted nor flying its arc -
            # knocked off it, or held up on someone in a crush - is brought down first
            stray = (not flags[i] & NODE_LOCKED and not flags[i] & NODE_MOVING and swing[c, f] == 0.0
                     and pos[i, 1] > radius[i] + STRAY * leg_length[c])  # fmt: skip
            if not flags[i] & NODE_LOCKED and not stray:
                continue  # mid-step
            ex = pos[i, 0] - pos[h, 0]
            ez = pos[i, 2] - pos[h, 2]
            # a leg close to straight must step whatever else: a locked foot at the end
            # of a straight leg would hold the hip back like a rope
            ey = pos[i, 1] - pos[h, 1]
            # standing still, a leg at standing height is already 0.96 straight: only a
            # leg pulled really straight (leaning out of the base of support) steps, or a
            # character pointing or waving would step in place several times a second
            limit = STRETCH if moving else STILL_STRETCH
            stretch = math.sqrt(ex * ex + ey * ey + ez * ez) - limit * leg_length[c]
            if moving:
                need = -(ex * dx + ez * dz) - reach  # how far behind, past the trigger
                # a foot off to the side (a turn) must step as well
                side = abs(ex * dz - ez * dx) - STANCE_SLACK * s
                need = max(need, side)
            else:
                need = math.sqrt(ex * ex + ez * ez) - STANCE_SLACK * s
            need = max(need, stretch)
            # a foot that came down hard by the other one (knocked off its arc) steps
            # away again before the shins rub
            o = nd[L_FOOT + 1 - f]
            if flags[o] & NODE_LOCKED:
                apart = math.sqrt((pos[i, 0] - pos[o, 0]) ** 2 + (pos[i, 2] - pos[o, 2]) ** 2)
                need = max(need, FOOT_GAP * half - apart)
            if stray:
                need = max(need, leg_length[c])  # before anything else
            alternate = f != last_step[c] and need > 0.5 * best_need  # prefer the other foot
            if need > 0.0 and (best < 0 or need > best_need or alternate):
                best = f
                best_need = need
        if best < 0:
            continue
        # launch: land ahead of where the hip will be when the step ends (going at the
        # pelvis's actual pace), never further than the leg reaches from there
        # beside the pelvis, half a hip-width out along the walk's (or the body's) left
        i = nd[L_FOOT + best]
        p = nd[PELVIS]
        vx = (pos[p, 0] - prev[p, 0]) / dt
        vz = (pos[p, 2] - prev[p, 2]) / dt
        if moving:
            lx, lz = dz, -dx
        else:
            fx, fz = forward_xz(pos, nd[L_HIP], nd[L_HIP + 1])
            lx, lz = fz, -fx
        side = half if best == 0 else -half
        o = nd[L_FOOT + 1 - best]
        # lead by the pelvis's actual pace along the walk only: its sideways sway is
        # not where it is going
        along = max(0.0, vx * dx + vz * dz) * t_step + reach
        tx = pos[p, 0] + dx * along + side * lx
        tz = pos[p, 2] + dz * along + side * lz
        # land at least most of a hip width to the side of the planted foot: a pelvis
        # swaying over the stance leg would otherwise set the feet in one line, and
        # the shins would knock together
        gap = (tx - pos[o, 0]) * lx + (tz - pos[o, 2]) * lz
        want = FOOT_GAP * half if side > 0.0 else -FOOT_GAP * half
        if gap * want < want * want:
            tx += (want - gap) * lx
            tz += (want - gap) * lz
        if (tx - pos[i, 0]) ** 2 + (tz - pos[i, 2]) ** 2 < (0.5 * reach) ** 2:
            # a step that goes nowhere (twisted feet): step to the walk's side instead,
            # or the foot would hop on the spot for ever
            side = half if best == 0 else -half
            tx = pos[p, 0] + dx * along + side * lx
            tz = pos[p, 2] + dz * along + side * lz
        if (not moving and best_need < leg_length[c] and vx * vx + vz * vz < (STILL_PACE * s) ** 2
                and (tx - pos[i, 0]) ** 2 + (tz - pos[i, 2]) ** 2 < (STILL_SKIP * leg_length[c]) ** 2):
            # standing and not pushed about, a step this short would be a fidget: the
            # foot stays planted (a body knocked or dragged still steps to catch itself)
            continue
        ty = radius[i]
        flags[i] &= ~np.uint32(NODE_LOCKED | NODE_IN_CONTACT)
        flags[i] |= NODE_LOCK_ON_CONTACT | NODE_MOVING
        move_time[i] = t_step
        move_gravity[i] = MOVE_ARC
        # ballistic: v0 = (target - p)/T - g T / 2 lands on target at T under gravity
        prev[i, 0] = pos[i, 0] - ((tx - pos[i, 0]) / t_step - 0.5 * gravity[0] * t_step) * dt
        prev[i, 1] = pos[i, 1] - ((ty - pos[i, 1]) / t_step - 0.5 * gravity[1] * t_step) * dt
        prev[i, 2] = pos[i, 2] - ((tz - pos[i, 2]) / t_step - 0.5 * gravity[2] * t_step) * dt
        swing[c, best] = t_step
        last_step[c] = best
        steps[c] += 1
        # arm swing: the opposite hand forwards, this side's hand back
        if moving:
            for hand, sign in ((L_HAND + 1 - best, 1.0), (L_HAND + best, -0.5)):
                if arm_mode[c, hand - L_HAND] == HANG:
                    j = nd[hand]
                    prev[j, 0] -= sign * ARM_SWING * wx * dt
                    prev[j, 2] -= sign * ARM_SWING * wz * dt
# fmt: on
