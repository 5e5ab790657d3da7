"""gait: stepping (SPEC 3) - a human walk and run at every body size (docs/locomotion.md).

Reads the character table (walk vector, posture mode, step timers) and foot, hip and
pelvis nodes; writes foot, knee and hand velocities (through ``prev``), foot
accelerations (the swing arc's lighter gravity), node flags and move timers.

Dynamic similarity: the pace is capped at Froude 1.5, it walks below Froude 0.5 and runs
above, and the step length follows the Froude number (kernelmath), so the cadence goes
with sqrt(g / L). Walking, the feet take turns on a clock, one step per period, in the
air 80% of it; running, each foot is in the air 1.2 periods, so both are up for a while
(the flight). A planted foot is locked
(static friction); a step unlocks a foot and sends it on a flat ballistic arc to land
ahead of where its hip will be. In flight the foot is guided every frame
(:func:`guide_foot`): re-aimed as the hip moves, its landing kept within the leg's reach,
its speed bounded, and its next position never beyond the leg's reach - a kinematic foot
out of reach would drag the hip after it. The knee leads the swing, and walking, the opposite
hand swings forward with each step (running, the posture swings bent arms). Standing, a foot
steps only when it is well off from under its hip or the body is pushed.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twig_ecs.kernelmath import (
    HANG,
    L_FOOT,
    L_HAND,
    L_HIP,
    L_KNEE,
    PELVIS,
    R_HAND,
    RISE,
    STAND,
    WALK_FROUDE_MAX,
    clamp,
    forward_xz,
    kernel_helper,
    run_share,
    step_length,
    swing_share,
    walk_speed,
)
from twig_ecs.step import StepContext
from twig_ecs.store import (
    MOVE_GAIT_ARC,
    NODE_IN_CONTACT,
    NODE_LOCK_ON_CONTACT,
    NODE_LOCKED,
    NODE_MOVING,
    NODE_ON_CARRIED,
    columns,
)
from twig_ecs.system import System

STILL_STEP = 1.3  # sqrt(L / g): how long a step to keep balance takes, standing
LIFT = 0.14  # of the leg's length: the top of a foot's arc above the ground
LEAD = 0.5  # of the step length: a landing foot is this far ahead of its hip (stance spans 1.2 steps)
MOST_AHEAD = 0.45  # of the leg's length: never lands further ahead of the hip than this
SKIP = 0.08  # of the leg's length: a walking step this short is not worth taking
STANCE_SLACK = 0.12  # m: standing still, a foot this far from under its hip steps back
STRETCH = 0.998  # a planted leg behind its hip stretched to this fraction of its length steps at once
STILL_SKIP = 0.15  # of the leg's length: standing, a re-step shorter than this is not taken
STILL_PACE = 0.15  # m/s (at 1.75 m): a pelvis moving slower than this is standing still
DOWN = 0.4  # of standing height: a pelvis below it is down on the ground (told to stand, it gets up
# through a kneel: posture.py; a standing one folded from higher rises at the posture's GET_UP rate).
# 0.4, the share below which twig_ecs.rises counts a character down: at 0.3 a ragdoll stood up with
# its pelvis at 30-40% rose as from a seat, 0.8 s to full height - 0.6-0.75 s to 90% (issue 34)
WALK_HEIGHT = 1.0  # of a planted leg's length: how far its hip rides from its foot at a walk (straight)
HEEL_RISE = 0.16  # of the leg's length: the most a trailing foot's heel comes up in double support
HEEL_DROP = 1.0  # leg lengths per second: how fast a heel no longer held up comes down
PRESWING = 1.0  # of HEEL_RISE: how far the heel of the foot about to step is up by the end of double support
PUSH_FOLD = 0.3  # of the way the knee of a rising heel bends at once (the rest pushes the hip on: push-off)
HEEL_SLACK = 0.997  # of the leg's length: a trailing heel rises to keep its hip this near
GUIDE_REACH = 0.99  # of the leg's length: a swinging foot stays (and lands) this near its hip
KICK_DIP = 0.1  # of the leg's length: how much lower than now a kick reckons its hip will be
GUIDE_STEPS = 3  # a foot this few frames from landing is no longer re-aimed (only kept in reach)
HURRY = 0.99  # of the leg's length: a planted leg this straight (its foot behind or to the side)
# brings the swinging foot down now
HURRY_AWAY = 0.2  # of the leg's length: ... and its foot this far to the side of the hip
HURRY_BEHIND = 0.5  # of the leg's length: ... or this far behind it
FOOT_SPEED = 1.5  # sqrt(g L): the fastest a re-aimed swinging foot goes walking (4.4 m/s for an adult)
RUN_FOOT_SPEED = 2.5  # of the pace: running, a swinging foot may go this fast (it covers two steps
# in 1.2 step periods running, 1.7 times the pace on average)
HURRY_TIME = 0.1  # s: how soon a hurried swing lands
KNEE_FOLD = 2.5  # m/s (at 1.75 m tall, by the root of the size): the fastest a rising heel folds
# its knee forwards (a knee thrust faster is a blow to whoever stands close)
KNEE_FOLD_PACE = 4.0  # ... or this many times the walk's pace, if more (a brisk walk's push-off)
LEAD_FOLD = 0.8  # m/s (at 1.75 m tall, by the root of the size): ... and the fastest lead_knee folds it
HEEL_STEP = 0.05  # of the leg's length: the most a heel comes up in a frame for the step to come
SET_OFF = 0.5  # of HEEL_RISE: a walking step from a foot behind its hip waits for its heel this far up
KNEE_LEAD = 1.0  # of the foot's launch speed (over the knee's) given to the knee along the ground
SLIP = 1.05  # a planted foot pulled this far (fraction of the leg's length) slips free
FOOT_GAP = 1.4  # half hip widths: least sideways gap between a landing foot and the planted one
LOW_SUPPORT = 0.3  # of the leg's length: the highest support a foot plants on
STRAY = 0.02  # of the leg's length: a foot this far up after its step period is over is brought down
# (one hanging off to the side of a leaning body, out of the ground's reach, too)
STRAY_PACE = 2.0  # m/s (at 1.75 m, by the root of the size): the fastest a stray foot is brought down
CATCH = 0.88  # of standing height: a pelvis sinking below it at a run is caught by the swinging foot
RUN_PUSH = 0.55  # of the leg's length: running, a stance foot this far behind its hip pushes off
RUN_RAMP = 0.3  # sqrt(g L): a run's steps are timed for at most the pelvis's pace plus this
RUN_STEP_MOST = 1.1  # of the leg's length: the longest running step
ARM_SWING = 0.6  # m/s of hand velocity per m/s of walking, given at each step


class GaitColumns(NamedTuple):
    """The node and character-table columns the gait kernel reads and writes (named as in
    ``store.NODE_FIELDS`` and ``store.CHARACTER_FIELDS``)."""

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
    seat: np.ndarray
    stand_height: np.ndarray


@kernel_helper
def step_timing(speed, leg, g):
    """(pace, step length, step period, a foot's time in the air) when asked for ``speed``.

    Dynamic similarity: the step length over the leg's length follows the Froude number
    (kernelmath.step_length), so the cadence scales with sqrt(g / L). Past the walk's
    Froude limit it runs: a foot flies longer than a step period (kernelmath.swing_share),
    so both are in the air for a while each step (the flight phase). Standing (speed 0), a balance step takes
    STILL_STEP natural times.
    """
    v = walk_speed(speed, leg, g)
    if v < 0.01:
        t = STILL_STEP * math.sqrt(leg / g)
        return 0.0, 0.0, t, t
    # running faster, the step grows only as far as the leg reaches - a stance spanning
    # from ahead of the hip to behind it, and a short flight - then the cadence does
    step = min(step_length(v, leg, g), RUN_STEP_MOST * leg)
    period = step / v
    return v, step, period, swing_share(v, leg, g) * period


@kernel_helper
def swinging(flags, move_time, i):
    """Is foot node ``i`` flying a step's or a kick's arc (kinematic, its move not over)?"""
    return move_time[i] > 0.0 and flags[i] & NODE_MOVING and not flags[i] & NODE_LOCKED


@kernel_helper
def heel_room(y, radius, legs):
    """How much higher (m) a planted foot at height ``y`` may lift its heel: a trailing foot in
    double support rises on its toes up to HEEL_RISE leg lengths above the ground (a
    point foot: its node, the ankle, comes up), so that the leading leg carries the hips."""
    return max(0.0, radius + HEEL_RISE * legs - y)


# fmt: off
@kernel_helper(nogil=True)
def knee_between(hx, hy, hz, fx, fy, fz, thigh, shin, bx, bz):
    """Where a knee joins a ``thigh`` and a ``shin`` (m) from a hip at (hx, hy, hz) to a foot at
    (fx, fy, fz), bent towards the ground direction (``bx``, ``bz``): (x, y, z, ok) - ``ok``
    False when the leg cannot bend there (too far apart, or the bend along the leg)."""
    ax, ay, az = fx - hx, fy - hy, fz - hz
    d = math.sqrt(ax * ax + ay * ay + az * az)
    if d >= thigh + shin or d < 1e-6:
        return hx, hy, hz, False
    ax, ay, az = ax / d, ay / d, az / d
    # the bend direction, less its part along the leg: where the knee sticks out
    along = bx * ax + bz * az
    px, py, pz = bx - along * ax, -along * ay, bz - along * az
    pn = math.sqrt(px * px + py * py + pz * pz)
    if pn < 1e-6:
        return hx, hy, hz, False
    a = (thigh * thigh - shin * shin + d * d) / (2.0 * d)
    b = math.sqrt(max(0.0, thigh * thigh - a * a)) / pn
    return hx + a * ax + b * px, hy + a * ay + b * py, hz + a * az + b * pz, True


@kernel_helper
def leg_parts(pos, h, kn, i):
    """(thigh, shin) lengths (m) of the leg hip ``h``, knee ``kn``, foot ``i`` as it is now."""
    thigh = math.sqrt((pos[kn, 0] - pos[h, 0]) ** 2 + (pos[kn, 1] - pos[h, 1]) ** 2
                      + (pos[kn, 2] - pos[h, 2]) ** 2)
    shin = math.sqrt((pos[kn, 0] - pos[i, 0]) ** 2 + (pos[kn, 1] - pos[i, 1]) ** 2
                     + (pos[kn, 2] - pos[i, 2]) ** 2)
    return thigh, shin


@kernel_helper(nogil=True)
def bend_knee(pos, prev, h, kn, i, thigh, shin, bx, bz):
    """Move knee node ``kn`` part of the way (PUSH_FOLD) to where a ``thigh`` and a ``shin`` join
    hip ``h`` to foot ``i``, bent forwards (``bx``, ``bz``: the body's forward); its velocity is
    kept. A foot brought nearer its hip with the knee left straight would push the hip away
    like a rod."""
    x, y, z, ok = knee_between(pos[h, 0], pos[h, 1], pos[h, 2], pos[i, 0], pos[i, 1], pos[i, 2], thigh, shin,
                               bx, bz)
    if not ok:
        return
    for q, new in ((0, x), (1, y), (2, z)):
        move = PUSH_FOLD * (new - pos[kn, q])
        prev[kn, q] += move
        pos[kn, q] += move


@kernel_helper(nogil=True)
def lead_knee(pos, prev, h, kn, i, bx, bz, most):
    """A foot setting off: give knee node ``kn`` the velocity that keeps it where thigh and shin
    join the hip and the foot next frame (bent forwards, ``bx``, ``bz``), so a straight leg folds
    at once rather than push the hip away like a rod (a standing step would hop) - but at most
    ``most`` metres this frame beyond where the hip carries it: a knee thrust forwards faster
    is a blow to whoever stands close (a hugger stepping back from its partner hurt it)."""
    thigh, shin = leg_parts(pos, h, kn, i)
    hx, hy, hz = 2.0 * pos[h, 0] - prev[h, 0], 2.0 * pos[h, 1] - prev[h, 1], 2.0 * pos[h, 2] - prev[h, 2]
    x, y, z, ok = knee_between(hx, hy, hz, 2.0 * pos[i, 0] - prev[i, 0], 2.0 * pos[i, 1] - prev[i, 1],
                               2.0 * pos[i, 2] - prev[i, 2], thigh, shin, bx, bz)
    if ok:
        cx, cy, cz = pos[kn, 0] + hx - pos[h, 0], pos[kn, 1] + hy - pos[h, 1], pos[kn, 2] + hz - pos[h, 2]
        ex, ey, ez = x - cx, y - cy, z - cz
        far = math.sqrt(ex * ex + ey * ey + ez * ez)
        if far > most:
            ex, ey, ez = ex * most / far, ey * most / far, ez * most / far
        prev[kn, 0] = 2.0 * pos[kn, 0] - (cx + ex)
        prev[kn, 1] = 2.0 * pos[kn, 1] - (cy + ey)
        prev[kn, 2] = 2.0 * pos[kn, 2] - (cz + ez)


@kernel_helper(nogil=True)
def lift_heels(pos, prev, lock_pos, flags, radius, nd, legs, dx, dz, next_foot, progress, fold):
    """A walk's double support: a planted foot behind its hip comes up on its toes - as far as
    it must (and a little more, HEEL_SLACK) for the hip to go on along the leading leg's arc
    next frame rather than be held back by a straight leg (there is no foot to roll over), and
    the foot that steps next (``next_foot``) at least ``progress`` (0-1, of the double support
    gone) of HEEL_RISE leg lengths, so the knee is bending when it lifts (a straight leg swung
    forward would push the hip on like a rod); its knee bends forwards as it comes up. That
    rise is no faster than brings the knee ``fold`` metres further forward this frame: near
    straight, a leg a centimetre shorter has its knee 7 cm forward (setting off from standing,
    the heel came up 14 cm in a frame and the knee flew forwards at 9 m/s - a blow to anyone
    close). It stays where it is along the ground: it is still planted."""
    bx, bz = forward_xz(pos, nd[L_HIP], nd[L_HIP + 1])
    for f in range(2):
        i = nd[L_FOOT + f]
        o = nd[L_FOOT + 1 - f]
        if not (flags[i] & NODE_LOCKED and flags[o] & NODE_LOCKED):
            return
        h = nd[L_HIP + f]
        hx = 2.0 * pos[h, 0] - prev[h, 0]  # where the hip will be next frame
        hy = 2.0 * pos[h, 1] - prev[h, 1]
        hz = 2.0 * pos[h, 2] - prev[h, 2]
        ex = hx - pos[i, 0]
        ez = hz - pos[i, 2]
        if ex * dx + ez * dz <= 0.0:
            continue  # the leading foot
        reach = HEEL_SLACK * legs
        room = heel_room(pos[i, 1], radius[i], legs)
        y = hy - math.sqrt(max(0.0, reach * reach - ex * ex - ez * ez))
        kn = nd[L_KNEE + f]
        thigh, shin = leg_parts(pos, h, kn, i)
        if f == next_foot:
            pre = pos[i, 1] + room - (1.0 - PRESWING * progress) * HEEL_RISE * legs
            # the knee's reach forward (a leg of two halves) now, and a leg short enough for it
            # to be ``fold`` further forward: the foot comes up no higher than that leg reaches
            half = 0.5 * (thigh + shin)
            ey = hy - pos[i, 1]
            now = math.sqrt(ex * ex + ey * ey + ez * ez)
            bent = math.sqrt(max(0.0, half * half - 0.25 * now * now)) + fold
            short2 = 4.0 * max(0.0, half * half - bent * bent)
            if short2 > ex * ex + ez * ez:
                pre = min(pre, hy - math.sqrt(short2 - ex * ex - ez * ez))
            # and no more than HEEL_STEP a frame (setting off into a brisk walk, a child's heel
            # came up 6 cm in a frame and its shin was squeezed 4 cm)
            pre = min(pre, pos[i, 1] + HEEL_STEP * legs)
            y = max(y, pre)
        if y > pos[i, 1]:
            y = min(y, pos[i, 1] + room)
            lock_pos[i, 1] = y
            pos[i, 1] = y
            prev[i, 1] = y
            bend_knee(pos, prev, h, kn, i, thigh, shin, bx, bz)


@kernel_helper(nogil=True)
def lower_heels(pos, prev, lock_pos, flags, radius, nd, legs, walking, dt):
    """A planted foot up on its toes comes down again (HEEL_DROP) unless the walk's double
    support keeps it up: standing still, and once the walk stops, both heels are down."""
    for f in range(2):
        i = nd[L_FOOT + f]
        o = nd[L_FOOT + 1 - f]
        if not flags[i] & NODE_LOCKED or pos[i, 1] <= radius[i]:
            continue
        if walking and flags[o] & NODE_LOCKED:
            continue  # lift_heels decides
        if pos[i, 1] > radius[i] + HEEL_RISE * legs:
            continue  # planted on something, not up on its toes
        y = max(radius[i], pos[i, 1] - HEEL_DROP * legs * dt)
        lock_pos[i, 1] = y
        pos[i, 1] = y
        prev[i, 1] = y


@kernel_helper(nogil=True)
def landing_target(pos, prev, nd, f, o_planted, dx, dz, moving, v, step, legs, t_left, dt):
    """Where a gait step of foot ``f`` should come down (x, z), ``t_left`` s before it lands.

    Ahead of where the hip will be by then (going at the pelvis's actual pace along the
    walk, at most the walk's pace), LEAD steps on, beside the pelvis half a hip width out
    along the walk's (or the body's) left, and most of a hip width to the side of the
    planted foot (``o_planted``) so the shins do not knock.
    """
    p = nd[PELVIS]
    vx = (pos[p, 0] - prev[p, 0]) / dt
    vz = (pos[p, 2] - prev[p, 2]) / dt
    if moving:
        lx, lz = dz, -dx
    else:
        fx, fz = forward_xz(pos, nd[L_HIP], nd[L_HIP + 1])
        lx, lz = fz, -fx
    half = 0.5 * math.sqrt((pos[nd[L_HIP], 0] - pos[nd[L_HIP + 1], 0]) ** 2
                           + (pos[nd[L_HIP], 2] - pos[nd[L_HIP + 1], 2]) ** 2)
    side = half if f == 0 else -half
    # lead by the pelvis's actual pace along the walk only: its sideways sway is not
    # where it is going (and a pelvis running ahead of the walk must not drag the foot on)
    along = 0.0
    if moving:
        along = clamp(vx * dx + vz * dz, 0.0, v) * t_left + min(LEAD * step, MOST_AHEAD * legs)
    tx = pos[p, 0] + dx * along + side * lx
    tz = pos[p, 2] + dz * along + side * lz
    if o_planted >= 0:
        gap = (tx - pos[o_planted, 0]) * lx + (tz - pos[o_planted, 2]) * lz
        want = FOOT_GAP * half if side > 0.0 else -FOOT_GAP * half
        if gap * want < want * want:
            tx += (want - gap) * lx
            tz += (want - gap) * lz
    return tx, tz


@kernel_helper(nogil=True)
def guide_foot(pos, prev, acc, flags, move_time, move_gravity, radius, nd, f, o, tx, tz, k_arc, legs, fastest,
               gravity, dt):
    """In-flight guidance of a swinging foot (a step's or a kick's), once a frame.

    A flying foot is kinematic (NODE_MOVING: infinite mass to the constraints), so a foot
    beyond its leg's reach would drag the hip after it and fold the body. Each frame:
    a gait step (move_gravity MOVE_GAIT_ARC) is re-aimed at ``(tx, tz)`` - where it should
    land as the hip moves on - under the gait's lighter arc gravity (``k_arc`` g, the
    rest taken off through ``acc``); any move's landing is pulled in to where the leg
    reaches from where the hip will be (a kick within reach flies as launched); and the
    foot's next position is kept within GUIDE_REACH leg lengths of its hip's.
    ``o`` is the other foot's node when it is planted, else -1; ``fastest``: the top speed
    (m/s) of a re-aimed foot.
    """
    i = nd[L_FOOT + f]
    h = nd[L_HIP + f]
    t = move_time[i]
    most = GUIDE_REACH * legs
    aim = move_gravity[i] == MOVE_GAIT_ARC
    if aim:
        for q in range(3):
            acc[i, q] -= (1.0 - k_arc) * gravity[q]
    else:
        k_arc = 1.0
    if t > GUIDE_STEPS * dt:
        aim_foot(pos, prev, move_time, radius, nd, f, o, i, aim, tx, tz, k_arc, legs, fastest, gravity, dt)
    if flags[i] & NODE_MOVING:
        # a kinematic foot is not pulled back by its leg: where it goes next stays within
        # reach of where its hip goes (moving pos and prev together keeps its speed)
        ex = 2.0 * pos[i, 0] - prev[i, 0] - (2.0 * pos[h, 0] - prev[h, 0])
        ey = 2.0 * pos[i, 1] - prev[i, 1] - (2.0 * pos[h, 1] - prev[h, 1])
        ez = 2.0 * pos[i, 2] - prev[i, 2] - (2.0 * pos[h, 2] - prev[h, 2])
        d = math.sqrt(ex * ex + ey * ey + ez * ez)
        if d > most:
            k = most / d - 1.0
            for q, e in ((0, ex), (1, ey), (2, ez)):
                pos[i, q] += k * e
                prev[i, q] += k * e


@kernel_helper(nogil=True)
def aim_foot(pos, prev, move_time, radius, nd, f, o, i, aim, tx, tz, k_arc, legs, fastest, gravity, dt):
    """Set a flying foot's velocity (through ``prev``) to land in reach (see guide_foot)."""
    h = nd[L_HIP + f]
    p = nd[PELVIS]
    t = move_time[i]
    most = GUIDE_REACH * legs
    vx = (pos[i, 0] - prev[i, 0]) / dt
    vy = (pos[i, 1] - prev[i, 1]) / dt
    vz = (pos[i, 2] - prev[i, 2]) / dt
    if aim:
        lx, ly, lz = tx, radius[i], tz
    else:  # where it lands if left alone
        lx = pos[i, 0] + vx * t + 0.5 * k_arc * gravity[0] * t * t
        ly = pos[i, 1] + vy * t + 0.5 * k_arc * gravity[1] * t * t
        lz = pos[i, 2] + vz * t + 0.5 * k_arc * gravity[2] * t * t
    # then: within reach of where the hip will be (going at the pelvis's pace)
    hx = pos[h, 0] + (pos[p, 0] - prev[p, 0]) / dt * t
    hz = pos[h, 2] + (pos[p, 2] - prev[p, 2]) / dt * t
    hh = pos[h, 1] - ly
    if not aim:
        hh -= KICK_DIP * legs  # a kick: the support knee gives (posture's KICK_STANCE), the hip lower
    if aim and o >= 0:
        # the hip then rides the planted leg's arc (systems/control/posture.py): WALK_HEIGHT leg
        # lengths from that foot - lower than now if it will have passed over it
        ho = nd[L_HIP + 1 - f]
        qx = pos[ho, 0] + (pos[p, 0] - prev[p, 0]) / dt * t - pos[o, 0]
        qz = pos[ho, 2] + (pos[p, 2] - prev[p, 2]) / dt * t - pos[o, 2]
        hh = pos[o, 1] - ly + math.sqrt(max(0.0, (WALK_HEIGHT * legs) ** 2 - qx * qx - qz * qz))
    flat = math.sqrt(max(0.0, most * most - hh * hh))
    ox = lx - hx
    oz = lz - hz
    off = math.sqrt(ox * ox + oz * oz)
    if off > flat:
        lx = hx + ox * flat / off
        lz = hz + oz * flat / off
    elif not aim:
        return  # a kick within reach flies as launched
    far = math.sqrt((lx - pos[i, 0]) ** 2 + (lz - pos[i, 2]) ** 2)
    most_far = fastest * t
    if far > most_far:
        # no faster than a swinging foot goes, and on time: it lands short instead (a
        # flight stretched to follow a target that keeps moving never lands)
        lx = pos[i, 0] + (lx - pos[i, 0]) * most_far / far
        lz = pos[i, 2] + (lz - pos[i, 2]) * most_far / far
    # re-aim: v = (landing - p) / t - g' t / 2 lands on it at t under the arc's gravity
    prev[i, 0] = pos[i, 0] - ((lx - pos[i, 0]) / t - 0.5 * k_arc * gravity[0] * t) * dt
    prev[i, 1] = pos[i, 1] - ((ly - pos[i, 1]) / t - 0.5 * k_arc * gravity[1] * t) * dt
    prev[i, 2] = pos[i, 2] - ((lz - pos[i, 2]) / t - 0.5 * k_arc * gravity[2] * t) * dt


@njit(cache=True, nogil=True)
def control_gait(args, n_chars, gravity, dt):
    """Guide, plant, unlock and launch feet for every standing character (``args``:
    ``store.columns(GaitColumns, nodes, characters)``)."""
    cols = GaitColumns(*args)
    pos, prev, acc = cols.pos, cols.prev, cols.acc
    lock_pos, flags, radius = cols.lock_pos, cols.flags, cols.radius
    move_time, move_gravity = cols.move_time, cols.move_gravity
    nodes, mode, walk = cols.nodes, cols.mode, cols.walk
    swing, last_step = cols.swing, cols.last_step
    steps, arm_mode, scale = cols.steps, cols.arm_mode, cols.scale
    leg_length = cols.leg_length
    g = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2)
    for c in range(n_chars):
        nd = nodes[c]
        for f in range(2):
            swing[c, f] = max(0.0, swing[c, f] - dt)
        # getting up from the ground (posture.py): the feet step in under the body as it rises
        from_ground = mode[c] == RISE and cols.seat[c, 1] < DOWN * cols.stand_height[c]
        if (mode[c] != STAND and not from_ground) or flags[nd[PELVIS]] & NODE_LOCKED or g < 1e-6:
            continue  # sitting, limp or frozen (a locked pelvis): no stepping
        legs = leg_length[c]
        wx = walk[c, 0]
        wz = walk[c, 2]
        speed = math.sqrt(wx * wx + wz * wz)
        timed = speed
        if speed > 1e-9:
            # a run from a standstill sets off in walking steps, quickening as the pelvis
            # gathers pace: a run's long flight as the first step from standing left the body
            # nothing to stand on, and the 1.05 m child running home fell into a split
            p = nd[PELVIS]
            along = ((pos[p, 0] - prev[p, 0]) * wx + (pos[p, 2] - prev[p, 2]) * wz) / (speed * dt)
            natural = math.sqrt(g * legs)
            timed = min(speed, max(math.sqrt(WALK_FROUDE_MAX) * natural, along + RUN_RAMP * natural))
        v, step, t_step, t_fly = step_timing(timed, legs, g)
        s = scale[c]
        moving = v > 0.01
        dx = wx / speed if moving else 0.0
        dz = wz / speed if moving else 0.0
        # a flat arc: a foot in the air falls with a lighter gravity, so the top of its arc
        # is LIFT leg lengths up whatever the step's time (a full g over a child's step
        # would be a skip, over an adult's a march)
        k_arc = min(1.0, 8.0 * LIFT * legs / (t_fly * t_fly) / g)
        run = moving and t_fly > t_step
        fastest = max(FOOT_SPEED * math.sqrt(g * legs), RUN_FOOT_SPEED * v if run else 0.0)
        for f in range(2):
            i = nd[L_FOOT + f]
            if move_time[i] > 0.0 and not flags[i] & NODE_LOCKED:
                o = nd[L_FOOT + 1 - f]
                ho = nd[L_HIP + 1 - f]
                pel = nd[PELVIS]
                if (run and move_gravity[i] == MOVE_GAIT_ARC and flags[o] & NODE_LOCKED
                        and move_time[i] > HURRY_TIME and pos[pel, 1] < CATCH * cols.stand_height[c]
                        and pos[pel, 1] < prev[pel, 1]):
                    # running, the body sinking over a planted foot left behind: this foot
                    # comes down now and catches it (it hung at the end of its arc, ahead,
                    # while the 1.05 m child sank into a split)
                    move_time[i] = HURRY_TIME
                if (move_gravity[i] == MOVE_GAIT_ARC and flags[o] & NODE_LOCKED and move_time[i] > HURRY_TIME
                        and not run):  # running, the planted foot pushes off instead
                    # the planted leg nearly straight behind its hip: this step comes down
                    # now (a foot left far behind drags the hip down and back)
                    ex = pos[o, 0] - pos[ho, 0]
                    ez = pos[o, 2] - pos[ho, 2]
                    reach_o = math.sqrt(ex * ex + ez * ez + (pos[o, 1] - pos[ho, 1]) ** 2)
                    along = ex * dx + ez * dz  # a leg straight ahead is vaulting, not left behind
                    away = math.sqrt(max(0.0, ex * ex + ez * ez - along * along))
                    if (away > HURRY_AWAY * legs or -along > HURRY_BEHIND * legs) and reach_o > HURRY * legs:
                        move_time[i] = HURRY_TIME
                tx, tz = landing_target(pos, prev, nd, f, o if flags[o] & NODE_LOCKED else -1, dx, dz, moving,
                                        v, step, legs, move_time[i], dt)
                o_planted = o if flags[o] & NODE_LOCKED else -1
                guide_foot(pos, prev, acc, flags, move_time, move_gravity, radius, nd, f, o_planted, tx, tz,
                           k_arc, legs, fastest, gravity, dt)
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
                # the other foot lifts after the double support, not a step period after
                # this one lifted: a short step must not leave the rear foot down longer
                swing[c, f] = min(swing[c, f], t_step - t_fly)
            # low down only: a foot pushed up onto someone's hip in a crush must not be
            # nailed there in mid-air (it steps down again instead)
            low = pos[i, 1] <= radius[i] + LOW_SUPPORT * legs
            flying = swinging(flags, move_time, i)
            # ... nor on a thing someone carries, unless on the ground beside it (a doll swinging
            # with its carrier is no ground: a foot planted on it stood on air)
            if flags[i] & NODE_ON_CARRIED and pos[i, 1] > radius[i] + STRAY * legs:
                low = False
            if not flying and flags[i] & NODE_IN_CONTACT and not flags[i] & NODE_LOCKED and low:
                flags[i] |= NODE_LOCKED
                flags[i] &= ~np.uint32(NODE_LOCK_ON_CONTACT)
                for k in range(3):
                    prev[i, k] = pos[i, k]
                    lock_pos[i, k] = pos[i, k]  # held where it stands (not where it last stood)
        lower_heels(pos, prev, lock_pos, flags, radius, nd, legs, moving and not run, dt)
        if moving and not run:
            # how much of the double support is over (the leading foot's timer runs it out)
            ds = t_step - t_fly
            progress = 1.0 - max(swing[c, 0], swing[c, 1]) / ds if ds > 1e-6 else 1.0
            lift_heels(pos, prev, lock_pos, flags, radius, nd, legs, dx, dz, 1 - last_step[c],
                       clamp(progress, 0.0, 1.0), max(KNEE_FOLD * math.sqrt(s), KNEE_FOLD_PACE * v) * dt)
        if not run and (swinging(flags, move_time, nd[L_FOOT]) or swinging(flags, move_time, nd[L_FOOT + 1])):
            continue  # walking (or standing), one foot at a time
        # one step per step period, unless a leg is stretched (below)
        due = swing[c, 0] == 0.0 and swing[c, 1] == 0.0
        # which foot steps? walking, the other one than last time, once a step period
        # is over; standing, the one furthest from where it belongs, if any is off
        best = -1
        best_need = 0.0
        best_stray = False
        half = 0.5 * math.sqrt((pos[nd[L_HIP], 0] - pos[nd[L_HIP + 1], 0]) ** 2
                               + (pos[nd[L_HIP], 2] - pos[nd[L_HIP + 1], 2]) ** 2)
        for f in range(2):
            i = nd[L_FOOT + f]
            h = nd[L_HIP + f]
            # a foot whose step is over but which is neither planted nor flying its arc -
            # knocked off it, or held up on someone in a crush - is brought down first
            # (whatever its step clock says: a foot knocked off its arc early flew on free, and the
            # parent's backing away swung it up to its hip's height)
            stray = (not flags[i] & NODE_LOCKED and not swinging(flags, move_time, i) and move_time[i] == 0.0
                     and pos[i, 1] > radius[i] + STRAY * legs)  # fmt: skip
            if not flags[i] & NODE_LOCKED and not stray:
                continue  # mid-step
            o = nd[L_FOOT + 1 - f]
            if not stray and move_time[o] > 0.0 and not flags[o] & NODE_LOCKED and not (run and swinging(
                    flags, move_time, o)):
                # the other foot is still in the air (knocked off its arc): no support to
                # step from (running, the push-off leaves both feet in the air: the flight)
                continue
            ex = pos[i, 0] - pos[h, 0]
            ez = pos[i, 2] - pos[h, 2]
            ey = pos[i, 1] - pos[h, 1]
            if moving and flags[o] & NODE_LOCKED:
                ey += heel_room(pos[i, 1], radius[i], legs)  # not stretched while its heel can rise
            # a leg behind its hip close to straight must step whatever else: a locked
            # foot at the end of a straight leg would hold the hip back like a rope
            stretch = math.sqrt(ex * ex + ey * ey + ez * ez) - STRETCH * legs
            if moving:
                if run or ex * dx + ez * dz > -MOST_AHEAD * legs:
                    # a straight leg ahead, or not far behind, is the stance leg
                    # vaulting: the pelvis rides down its arc until the step is due
                    stretch = -1.0
                need = legs if f != last_step[c] and due else -1.0
                if run and ex * dx + ez * dz < -RUN_PUSH * legs and not flags[o] & NODE_LOCKED:
                    # running, a stance foot this far behind its hip pushes off now, whatever
                    # the step clock says: held on, the other foot landed far ahead and the
                    # 1.05 m child sank into a split between them
                    need = legs
                if (not run and flags[o] & NODE_LOCKED and ex * dx + ez * dz < 0.0
                        and pos[i, 1] < radius[i] + SET_OFF * HEEL_RISE * legs):
                    # setting off (or stepping again from a foot flat on the ground): the heel
                    # comes up first (lift_heels), so the knee is bending when the foot lifts
                    need = -1.0
            elif ex * ex + ez * ez < (STANCE_SLACK * s) ** 2:
                stretch = -1.0  # standing on a straight leg under its hip: carried, not stretched
                need = -1.0
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
                best_stray = stray
        if best < 0:
            continue
        i = nd[L_FOOT + best]
        o = nd[L_FOOT + 1 - best]
        tx, tz = landing_target(pos, prev, nd, best, o if flags[o] & NODE_LOCKED else -1, dx, dz, moving, v,
                                step, legs, t_fly, dt)
        far = (tx - pos[i, 0]) ** 2 + (tz - pos[i, 2]) ** 2
        if moving and best_need < legs and far < (SKIP * legs) ** 2:
            # already about where it would land (walking very slowly, or turning on
            # the spot): no step; the other foot gets its turn
            last_step[c] = best
            continue
        p = nd[PELVIS]
        pace = ((pos[p, 0] - prev[p, 0]) ** 2 + (pos[p, 2] - prev[p, 2]) ** 2) / (dt * dt)
        still = pace < (STILL_PACE * s) ** 2
        if not moving and best_need < legs and still and far < (STILL_SKIP * legs) ** 2:
            # standing and not pushed about, a step this short would be a fidget: the
            # foot stays planted (a body knocked or dragged still steps to catch itself)
            continue
        ty = radius[i]
        flags[i] &= ~np.uint32(NODE_LOCKED | NODE_IN_CONTACT)
        flags[i] |= NODE_LOCK_ON_CONTACT | NODE_MOVING
        # a stray foot (its flight over, not down) comes straight down: flown again for a whole
        # run's flight, the 1.05 m child's foot hung 0.65 s in the air while the body sank
        # into a split over the other, planted far behind
        fly = t_fly
        if best_stray and not run:
            # (no faster than STRAY_PACE: sent 0.5 m in 0.1 s, a foot flew on up to hip height)
            fly = min(t_fly, max(HURRY_TIME, math.sqrt(far) / (STRAY_PACE * math.sqrt(s))))
        elif best_stray:
            # running, down in the time it takes to fall from there, near where it is (a foot
            # held a few cm up at the end of its step, its leg straight under a hip still high in
            # the flight, was sent on a whole flight again to the next landing spot: every other
            # step took two flights, the adult bounded at 1.9 steps/s), and no faster than
            # STRAY_PACE
            fly = min(t_fly, max(HURRY_TIME, math.sqrt(2.0 * (pos[i, 1] - radius[i]) / g)))
            most = STRAY_PACE * math.sqrt(s) * fly
            if far > most * most:
                tx = pos[i, 0] + (tx - pos[i, 0]) * most / math.sqrt(far)
                tz = pos[i, 2] + (tz - pos[i, 2]) * most / math.sqrt(far)
        move_time[i] = fly
        move_gravity[i] = MOVE_GAIT_ARC
        # ballistic: v0 = (target - p)/T - g' T / 2 lands on target at T under the arc's gravity
        prev[i, 0] = pos[i, 0] - ((tx - pos[i, 0]) / fly - 0.5 * k_arc * gravity[0] * fly) * dt
        prev[i, 1] = pos[i, 1] - ((ty - pos[i, 1]) / fly - 0.5 * k_arc * gravity[1] * fly) * dt
        prev[i, 2] = pos[i, 2] - ((tz - pos[i, 2]) / fly - 0.5 * k_arc * gravity[2] * fly) * dt
        # the knee leads the swing: a straight leg whose foot sets off towards the hip
        # would push the hip (and the body) ahead like a rod; bent first, it folds
        kn = nd[L_KNEE + best]
        for k in range(3):
            if k != 1:
                prev[kn, k] -= KNEE_LEAD * ((pos[i, k] - prev[i, k]) - (pos[kn, k] - prev[kn, k]))
        bx, bz = forward_xz(pos, nd[L_HIP], nd[L_HIP + 1])
        if not moving or (not run and pos[i, 1] < radius[i] + 0.25 * HEEL_RISE * legs):
            # a step from standing (or from a heel that did not come up first): the straight
            # leg folds at once, else it pushes the hip up and the body pitches or hops
            lead_knee(pos, prev, nd[L_HIP + best], kn, i, bx, bz, LEAD_FOLD * math.sqrt(s) * dt)
        if best_stray and run:
            # running, a foot brought down from a step that hung in the air finishes that step:
            # counted as a new one, the other foot stepped again the moment it landed (the
            # step clock and the turn its own), a second flight - a bound every other step
            continue
        swing[c, best] = t_step
        last_step[c] = best
        steps[c] += 1
        # arm swing: the opposite hand forwards, this side's hand back - walking; a run's
        # bent arms are swung by the posture (posture.swing_arms), so the kick fades out with it
        if moving:
            walk_share = 1.0 - run_share(v, legs, g)
            for hand, sign in ((L_HAND + 1 - best, 1.0), (L_HAND + best, -0.5)):
                if arm_mode[c, hand - L_HAND] == HANG:
                    j = nd[hand]
                    prev[j, 0] -= sign * ARM_SWING * walk_share * v * dx * dt
                    prev[j, 2] -= sign * ARM_SWING * walk_share * v * dz * dt
# fmt: on


class GaitSystem(System):
    """Steps the feet of every standing character towards its walk vector."""

    name = "gait"

    def run(self, ctx: StepContext) -> None:
        """Plant, unlock and launch feet for this step."""
        dt = ctx.dt
        s = ctx.state
        ch, n = s.characters, s.nodes
        if ch.count == 0:
            return
        g = ctx.settings.gravity
        args = columns(GaitColumns, n, ch)
        control_gait(args, ch.count, g, dt)


__all__ = ["GaitSystem", "PELVIS", "R_HAND"]
