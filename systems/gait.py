"""gait: stepping (SPEC 3).

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

import numpy as np
from numba import njit

from twig_ecs.kernelmath import (
    L_FOOT,
    L_HAND,
    L_HIP,
    PELVIS,
    R_HAND,
    STAND,
    clamp,
    forward_xz,
    step_length,
    walk_speed,
)
from twig_ecs.store import NODE_IN_CONTACT, NODE_LOCK_ON_CONTACT, NODE_LOCKED, NODE_MOVING
from twig_ecs.system import System

STILL_STEP = 1.3  # sqrt(L / g): how long a step to keep balance takes, standing
SWING_SHARE = 0.8  # of the step period a foot is in the air: both feet are down the rest (~20%)
LIFT = 0.14  # of the leg's length: the top of a foot's arc above the ground
LEAD = 0.6  # of the step length: a landing foot is this far ahead of its hip (stance spans 1.2 steps)
MOST_AHEAD = 0.45  # of the leg's length: never lands further ahead of the hip than this
CATCH = 0.12  # of the leg's length: a foot this far off its stance range steps at once
SKIP = 0.08  # of the leg's length: a walking step this short is not worth taking
STANCE_SLACK = 0.12  # m: standing still, a foot this far from under its hip steps back
STRETCH = 0.998  # a planted leg behind its hip stretched to this fraction of its length steps at once
SLIP = 1.05  # a planted foot pulled this far (fraction of the leg's length) slips free
FOOT_GAP = 1.4  # half hip widths: least sideways gap between a landing foot and the planted one
LOW_SUPPORT = 0.3  # of the leg's length: the highest support a foot plants on
STRAY = 0.1  # of the leg's length: a foot this far up after its step is over is brought down
ARM_SWING = 0.8  # m/s of hand velocity per m/s of walking, given at each step


@njit(cache=True, inline="always")
def step_timing(speed, leg, g):
    """(walk speed, step length, step period, time in the air) for a walk of ``speed``.

    Dynamic similarity: the step length over the leg's length follows the Froude number
    (kernelmath.step_length), so the cadence scales with sqrt(g / L); standing (speed 0),
    a balance step takes STILL_STEP natural times.
    """
    v = walk_speed(speed, leg, g)
    if v < 0.01:
        t = STILL_STEP * math.sqrt(leg / g)
        return 0.0, 0.0, t, t
    step = step_length(v, leg, g)
    period = step / v
    return v, step, period, SWING_SHARE * period


# fmt: off
@njit(cache=True)
def control_gait(pos, prev, acc, lock_pos, flags, move_time, move_gravity, radius, nodes, mode, walk, swing,
                 last_step, steps, arm_mode, scale, leg_length, n_chars, gravity, dt):
    """Plant, unlock and launch feet for every standing character."""
    g = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2)
    for c in range(n_chars):
        nd = nodes[c]
        for f in range(2):
            swing[c, f] = max(0.0, swing[c, f] - dt)
        if mode[c] != STAND or flags[nd[PELVIS]] & NODE_LOCKED or g < 1e-6:
            continue  # sitting, limp or frozen (a locked pelvis): no stepping
        legs = leg_length[c]
        wx = walk[c, 0]
        wz = walk[c, 2]
        speed = math.sqrt(wx * wx + wz * wz)
        v, step, t_step, t_fly = step_timing(speed, legs, g)
        # a flat arc: a foot in the air falls with a lighter gravity, so the top of its arc
        # is LIFT leg lengths up whatever the step's time (a full g over a child's step
        # would be a skip, over an adult's a march)
        g_arc = min(g, 8.0 * LIFT * legs / (t_fly * t_fly))
        for f in range(2):
            i = nd[L_FOOT + f]
            if flags[i] & NODE_MOVING and move_time[i] > 0.0 and move_gravity[i] == 1:
                for k in range(3):
                    acc[i, k] -= (1.0 - g_arc / g) * gravity[k]
        # plant: a foot on the ground that is not mid-step locks in place; a planted
        # foot whose leg is pulled past its length slips (static friction gives way)
        for f in range(2):
            i = nd[L_FOOT + f]
            h = nd[L_HIP + f]
            if flags[i] & NODE_LOCKED:
                gap = math.sqrt((pos[i, 0] - pos[h, 0]) ** 2 + (pos[i, 1] - pos[h, 1]) ** 2
                                + (pos[i, 2] - pos[h, 2]) ** 2)  # fmt: skip
                if gap > SLIP * legs:
                    flags[i] &= ~np.uint32(NODE_LOCKED)
                    for k in range(3):
                        prev[i, k] = pos[i, k]
                    continue
            if flags[i] & NODE_LOCKED and move_time[i] > 0.0:  # landed early
                move_time[i] = 0.0
                flags[i] &= ~np.uint32(NODE_MOVING)
            # low down only: a foot pushed up onto someone's hip in a crush must not be
            # nailed there in mid-air (it steps down again instead)
            low = pos[i, 1] <= radius[i] + LOW_SUPPORT * legs
            flying = flags[i] & NODE_MOVING and move_time[i] > 0.0
            if not flying and flags[i] & NODE_IN_CONTACT and not flags[i] & NODE_LOCKED and low:
                flags[i] |= NODE_LOCKED
                flags[i] &= ~np.uint32(NODE_LOCK_ON_CONTACT)
                for k in range(3):
                    prev[i, k] = pos[i, k]
                    lock_pos[i, k] = pos[i, k]  # held where it stands (not where it last stood)
        if flags[nd[L_FOOT]] & NODE_MOVING or flags[nd[L_FOOT + 1]] & NODE_MOVING:
            continue  # one foot at a time
        # one step per step period, unless a leg is stretched (below)
        due = swing[c, 0] == 0.0 and swing[c, 1] == 0.0
        s = scale[c]
        moving = v > 0.01
        dx = wx / speed if moving else 0.0
        dz = wz / speed if moving else 0.0
        half = 0.5 * math.sqrt((pos[nd[L_HIP], 0] - pos[nd[L_HIP + 1], 0]) ** 2
                               + (pos[nd[L_HIP], 2] - pos[nd[L_HIP + 1], 2]) ** 2)
        # which foot steps? walking, the other one than last time, once a step period
        # is over; standing, the one furthest from where it belongs, if any is off
        best = -1
        best_need = 0.0
        for f in range(2):
            i = nd[L_FOOT + f]
            h = nd[L_HIP + f]
            # a foot whose step is over but which is neither planted nor flying its arc -
            # knocked off it, or held up on someone in a crush - is brought down first
            stray = (not flags[i] & NODE_LOCKED and not flags[i] & NODE_MOVING and swing[c, f] == 0.0
                     and pos[i, 1] > radius[i] + STRAY * legs)  # fmt: skip
            if not flags[i] & NODE_LOCKED and not stray:
                continue  # mid-step
            ex = pos[i, 0] - pos[h, 0]
            ez = pos[i, 2] - pos[h, 2]
            ey = pos[i, 1] - pos[h, 1]
            # a leg behind its hip close to straight must step whatever else: a locked
            # foot at the end of a straight leg would hold the hip back like a rope
            stretch = math.sqrt(ex * ex + ey * ey + ez * ez) - STRETCH * legs
            if moving:
                if ex * dx + ez * dz > -MOST_AHEAD * legs:
                    # a straight leg ahead, or not far behind, is the stance leg
                    # vaulting: the pelvis rides down its arc until the step is due
                    stretch = -1.0
                need = legs if f != last_step[c] and due else -1.0
                # off the stance's range (pushed, or turning): a catching step whatever the
                # rhythm - far behind its hip, or far out to the side
                behind = -(ex * dx + ez * dz) - (LEAD * step + CATCH * legs)
                side = abs(ex * dz - ez * dx) - (half + CATCH * legs)
                need = max(need, behind, side)
            elif due:
                need = math.sqrt(ex * ex + ez * ez) - STANCE_SLACK * s
            else:
                need = -1.0
            need = max(need, stretch)
            # a foot that came down hard by the other one (knocked off its arc) steps
            # away again before the shins rub
            o = nd[L_FOOT + 1 - f]
            if flags[o] & NODE_LOCKED:
                apart = math.sqrt((pos[i, 0] - pos[o, 0]) ** 2 + (pos[i, 2] - pos[o, 2]) ** 2)
                need = max(need, FOOT_GAP * half - apart)
            if stray:
                need = max(need, 2.0 * legs)  # before anything else
            if need > 0.0 and (best < 0 or need > best_need):
                best = f
                best_need = need
        if best < 0:
            continue
        # launch: land LEAD steps ahead of where the hip will be when the foot comes
        # down (going at the pelvis's actual pace), beside the pelvis, half a hip-width
        # out along the walk's (or the body's) left
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
        # not where it is going; and never further ahead than the leg reaches
        # (at most the walk's pace: a foot placed ahead of a pelvis running fast would
        # drag it on faster still)
        along = clamp(vx * dx + vz * dz, 0.0, v) * t_fly + min(LEAD * step, MOST_AHEAD * legs)
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
        if best_need < legs and (tx - pos[i, 0]) ** 2 + (tz - pos[i, 2]) ** 2 < (SKIP * legs) ** 2:
            # already about where it would land (walking very slowly, or turning on
            # the spot): no step; the other foot gets its turn
            last_step[c] = best
            continue
        ty = radius[i]
        flags[i] &= ~np.uint32(NODE_LOCKED | NODE_IN_CONTACT)
        flags[i] |= NODE_LOCK_ON_CONTACT | NODE_MOVING
        move_time[i] = t_fly
        move_gravity[i] = 1
        # ballistic: v0 = (target - p)/T - g' T / 2 lands on target at T under the arc's gravity
        k_arc = g_arc / g
        prev[i, 0] = pos[i, 0] - ((tx - pos[i, 0]) / t_fly - 0.5 * k_arc * gravity[0] * t_fly) * dt
        prev[i, 1] = pos[i, 1] - ((ty - pos[i, 1]) / t_fly - 0.5 * k_arc * gravity[1] * t_fly) * dt
        prev[i, 2] = pos[i, 2] - ((tz - pos[i, 2]) / t_fly - 0.5 * k_arc * gravity[2] * t_fly) * dt
        swing[c, best] = t_step
        last_step[c] = best
        steps[c] += 1
        # arm swing: the opposite hand forwards, this side's hand back
        if moving:
            for hand, sign in ((L_HAND + 1 - best, 1.0), (L_HAND + best, -0.5)):
                if arm_mode[c, hand - L_HAND] == 0:
                    j = nd[hand]
                    prev[j, 0] -= sign * ARM_SWING * v * dx * dt
                    prev[j, 2] -= sign * ARM_SWING * v * dz * dt
# fmt: on


class GaitSystem(System):
    """Steps the feet of every standing character towards its walk vector."""

    name = "gait"

    def process(self, dt: float) -> None:
        """Plant, unlock and launch feet for this step."""
        s = self.scene.state
        ch, n = s.characters, s.nodes
        if ch.count == 0:
            return
        control_gait(n.pos, n.prev, n.acc, n.lock_pos, n.flags, n.move_time, n.move_gravity, n.radius,
                     ch.nodes, ch.mode, ch.walk, ch.swing, ch.last_step, ch.steps, ch.arm_mode, ch.scale,
                     ch.leg_length, ch.count, self.scene.settings.gravity, dt)  # fmt: skip


__all__ = ["GaitSystem", "PELVIS", "R_HAND"]
