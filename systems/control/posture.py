"""posture: hold each character up, upright and turned the right way (SPEC 3).

Reads the character table (mode, walk vector, seat, gaze direction) and node
positions/velocities; writes node ``acc``. Proportional control on Cartesian targets,
with a velocity term standing in for node damping:

- standing: pelvis at standing height (y) and over the feet midpoint (x/z), or at the
  walk velocity while walking; sitting: pelvis onto the seat; rising ("sitting up"):
  shoulders over the feet while the pelvis climbs back to standing height; a ragdoll told
  to stand up from the ground: rising too, through a kneel;
- upright: the shoulder centre over the pelvis, leaning a little into the walk; a torso
  tipped past the most it leans is caught the harder the further it tips (a righting reflex);
- a run's arms: a hanging arm bends about 90 degrees at the elbow and swings from the shoulder
  opposite the legs, the more the faster (:func:`swing_arms`);
- yaw: opposite forces on the two sides of the pelvis turn it to the walk direction,
  and on the two shoulders turn them to the gaze, at most 85 degrees from the pelvis.

The torso, head and knees carry their own weight (gravity compensation, as muscles
would); arms hang unless the arm controller holds them (or a run swings them).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twig_ecs.kernelmath import (
    CARRY,
    HANG,
    HEAD,
    L_ELBOW,
    L_FOOT,
    L_HAND,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    LIMP,
    NECK,
    PELVIS,
    R_FOOT,
    R_HAND,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    REACH,
    RISE,
    SIT,
    SPINE,
    STAND,
    WALK_FROUDE_MAX,
    clamp,
    forward_xz,
    kernel_helper,
    run_share,
    walk_speed,
    yaw_error,
)
from twig_ecs.step import StepContext
from twig_ecs.store import LINK_GRAB, MOVE_GAIT_ARC, NODE_LOCKED, NODE_MOVING, columns
from twig_ecs.system import System
from twig_ecs.systems.control.gait import DOWN, LEAD, MOST_AHEAD, heel_room, step_timing

HEIGHT_GAIN, HEIGHT_DAMP = 120.0, 22.0  # 1/s^2, 1/s: pelvis height
BALANCE_GAIN, BALANCE_DAMP = 40.0, 12.0  # pelvis over the feet when standing still
WALK_GAIN = 9.0  # 1/s: pelvis velocity towards the walk vector
KEEP_PACE_GAIN = 30.0  # 1/s: ... along the walk, while slower than it but already going
KEEP_PACE_FROM = 0.7  # ... at least this share of the pace its way, at a brisk walk:
KEEP_PACE_FROUDE = 0.12  # above this Froude number (slower, the landings brake it by 2% or less)
KEEP_PACE_MOST = 2.5  # m/s^2: the most that extra push adds (it makes up a few per cent, no sprint)
UPRIGHT_GAIN, UPRIGHT_DAMP = 80.0, 14.0  # shoulders over the pelvis
YAW_GAIN, YAW_DAMP = 900.0, 60.0  # rad/s^2 per rad, per rad/s
LEAN = 0.06  # s: the shoulders lead the pelvis by LEAN * walk velocity (at 1.75 m tall; by scale)
LANDING = 0.4  # of a step's time in the air: the pelvis lowers for the landing over its end
LANDING_REACH = 0.98  # of the leg's length: ... so that the landing leg reaches the ground this straight
WALK_LIFT = 0.5  # g: the most the pelvis is pushed up (beyond its weight) at a walk ...
WALK_LIFT_FROUDE = 2.0  # ... and this much more per Froude number (the arcs turn up faster at speed)
KNEE_SINK = 2.0  # m/s: the fastest a sinking pelvis folds a planted knee forwards ...
SINK_LEAST = 0.03  # of the leg's length: ... reckoned from at least this much knee bend
GET_UP = 0.5  # standing heights per second: the fastest a pelvis below GET_UP_TO rises ...
GET_UP_TO = 0.8  # ... of its standing height (from a fall at 40%: ~0.9 s to 90%; a run dips to 0.85)
KICK_STANCE = 0.96  # of standing height: the pelvis while a foot swings a kick (the support knee bent)
CARRY_OVER = 0.02  # of the leg's length: the pelvis aims this far above where straight planted legs
# hold it, so they carry it (taut: straight knees) rather than the height control (the arms' weight
# alone sags it ~1 cm)
RUN_LOWEST = 0.92  # of standing height: the lowest the pelvis aims for in a run's flight
WALK_LOWEST = 0.92  # of standing height: the lowest the pelvis aims for at a walk
WALK_ACC = 1.0  # g: the most the pelvis speeds up or slows down at a walk (no lurches in a turn)
SPEED_UP = 0.4  # g: the most it speeds up along the walk to a run (a person sets off at a fraction of g: at
# a whole g the 1.05 m child set off at a run with its pelvis 1.1 m/s ahead of its feet in 0.2 s,
# the stance leg left far behind, and sank into a split)
HELD = 0.6  # of the leg's length: a planted foot behind its hip this far (along the ground) slows
HELD_SPAN = 0.1  # the walk, to a stop this much further (a straight trailing leg, heel up, at full stretch)
TURN_SLOW = 0.3  # of the walk speed kept while the pelvis faces the other way (a U-turn)
MAX_PITCH = math.radians(25.0)  # the most the upright control leans the torso from the vertical
# a run's arms (swing_arms): bent RUN_ELBOW at the elbow, the upper arm RUN_ARM_BACK back from
# hanging on average and swung RUN_ARM_SWING either way at the walk-run transition, RUN_ARM_MORE more
# per Froude number above it (at most RUN_ARM_MOST): forward with the opposite leg
RUN_ELBOW = math.radians(90.0)
RUN_ARM_BACK = math.radians(10.0)
RUN_ARM_SWING = math.radians(30.0)
RUN_ARM_MORE = math.radians(15.0)
RUN_ARM_MOST = math.radians(45.0)
RUN_ARM_IN = 0.15  # of the forearm's length: the hand swings this far in towards the midline
ARM_GAIN, ARM_DAMP = 300.0, 30.0  # 1/s^2, 1/s: hand and elbow to the run's arm pose
ARM_MOST = 120.0  # m/s^2 (as systems/control/arms.py)
# a righting reflex: the upright gain grows by RIGHTING times itself over the first 10 degrees
# (in sine) a torso tips past MAX_PITCH, and on at that rate beyond
RIGHTING = 8.0
RIGHTING_MOST = 16.0  # times the upright gain at most (from 45 degrees): a stiffer spring than this
# would be near the edge of what a 1/60 s step integrates stably
RIGHTING_SPAN = math.sin(MAX_PITCH + math.radians(10.0)) - math.sin(MAX_PITCH)
MAX_TWIST = math.radians(85.0)  # shoulders' largest turn from the pelvis
RISE_TIME = 0.8  # s to stand up from sitting
# getting up from the ground (a ragdoll told to stand, its pelvis below DOWN of its standing
# height, or going below it while it rises) rises through a kneel as a person does - up to
# KNEEL of standing in KNEEL_TIME, a pause there, then up in STAND_UP_TIME - not the 0.2 s pop
# of the height control pulling straight to standing (issue 34). (A standing character that
# falls does not yet: with that, the goal melee's kneeling adults pressed into dolls on the
# ground, 12.9 cm - branch i34-fights-getup; it rises at the GET_UP rate instead)
KNEEL = 0.55
KNEEL_TIME, KNEEL_HOLD, STAND_UP_TIME = 0.5, 0.3, 0.8
RISE_LAG = 0.15  # of standing height: a pelvis this far below the rise's target holds its clock
HANDS_GAIN, HANDS_DAMP = 60.0, 12.0  # free hands pressed to the thighs as it gets up (not flung up)
GETUP_TIME = KNEEL_TIME + KNEEL_HOLD + STAND_UP_TIME
MAX_ACC = 80.0  # m/s^2: no controller pushes harder
MAX_YAW_ACC = 600.0  # rad/s^2
MAX_TURN_ERROR = 0.35  # rad of heading error the pelvis turns on at most: about 5 rad/s
FOLDED = 0.3  # chest lower than this many torso lengths above the pelvis: folded over

TORSO = (PELVIS, SPINE, NECK, HEAD, L_HIP, R_HIP, L_SHOULDER, R_SHOULDER)
LOWER = (PELVIS, SPINE, NECK, L_HIP, R_HIP)
UPPER = (L_SHOULDER, R_SHOULDER, HEAD)


class PostureColumns(NamedTuple):
    """The node and character-table columns the posture kernel reads and writes (named as in
    ``store.NODE_FIELDS`` and ``store.CHARACTER_FIELDS``)."""

    pos: np.ndarray
    prev: np.ndarray
    acc: np.ndarray
    mass: np.ndarray
    radius: np.ndarray
    flags: np.ndarray
    move_time: np.ndarray
    move_gravity: np.ndarray
    nodes: np.ndarray  # characters' node rows by role
    mode: np.ndarray
    mode_time: np.ndarray
    walk: np.ndarray
    seat: np.ndarray
    head_dir: np.ndarray
    stand_height: np.ndarray
    crouch: np.ndarray
    lean: np.ndarray
    scale: np.ndarray
    leg_length: np.ndarray
    arm_mode: np.ndarray


# fmt: off
@kernel_helper(nogil=True)
def carried_height(pos, flags, radius, nd, legs, vpx, vpz, wx, wz, walking):
    """(pelvis height, its rate of change, the carrying leg's direction from foot to hip x, y,
    z) at which the planted legs, straight, hold the hips:
    the lowest of their arcs over their feet (1e9 with no foot planted). Walking, a planted
    foot behind its hip while the other is down too (double support) reaches HEEL_RISE leg
    lengths higher (its heel comes up: the gait lifts it), so the leading leg carries the
    hips. The rate is how fast that height changes as the pelvis moves (``vpx``, ``vpz``):
    fed forward, so the pelvis keeps to the arc rather than lag above it."""
    top = 1e9
    rate = 0.0
    ux, uy, uz = 0.0, 1.0, 0.0
    both = flags[nd[L_FOOT]] & NODE_LOCKED and flags[nd[R_FOOT]] & NODE_LOCKED
    for f in range(2):
        i = nd[L_FOOT + f]
        if flags[i] & NODE_LOCKED:
            h = nd[L_HIP + f]
            ex = pos[h, 0] - pos[i, 0]
            ez = pos[h, 2] - pos[i, 2]
            rise = math.sqrt(max(1e-6, legs * legs - ex * ex - ez * ez))
            y = pos[i, 1] + rise + pos[nd[PELVIS], 1] - pos[h, 1]  # the pelvis, with that hip there
            if walking and both and ex * wx + ez * wz > 0.0:
                y += heel_room(pos[i, 1], radius[i], legs)
            if y < top:
                top = y
                rate = -(ex * vpx + ez * vpz) / rise
                ux, uy, uz = ex / legs, rise / legs, ez / legs
    return top, rate, ux, uy, uz


@kernel_helper(nogil=True)
def sink_speed(pos, flags, nd, legs):
    """How fast (m/s) a standing pelvis may go down: no faster than folds the straighter planted
    leg's knee forwards at KNEE_SINK m/s (a leg of two halves ``legs`` long: near straight, the
    knee moves out far faster than the hip comes down; at least SINK_LEAST of a bend)."""
    most = 1e9
    for f in range(2):
        i = nd[L_FOOT + f]
        if not flags[i] & NODE_LOCKED:
            continue
        h = nd[L_HIP + f]
        dx, dy, dz = pos[h, 0] - pos[i, 0], pos[h, 1] - pos[i, 1], pos[h, 2] - pos[i, 2]
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        half = 0.5 * legs
        e = max(math.sqrt(max(0.0, half * half - 0.25 * d * d)), SINK_LEAST * legs)
        # d = 2 sqrt(half^2 - e^2): the hip comes down d' = 4 e e' / d for a knee moving out at e'
        most = min(most, KNEE_SINK * 4.0 * e / max(d, 1e-6))
    return most


@njit(cache=True, nogil=True)
def swing_arms(pos, prev, acc, mass, nd, side, share, froude, step, gravity, dt):
    """A run's arm on ``side`` (0 left, 1 right): bent about RUN_ELBOW and swung from the
    shoulder opposite the legs - forward as the other foot goes forward - the more the faster.

    ``share``: how much of a run the pace is (``kernelmath.run_share``; the pose and its
    gains fade in with it), ``froude`` its Froude number, ``step`` its step length. The phase
    is read off the feet (the other foot's lead over this side's, in steps), so the arms keep
    time with whatever the legs do; its rate is fed forward, so the swing does not lag.
    Hand and elbow are pulled to the pose relative to the shoulder and held up against gravity
    by the shoulders: the push on them is taken off the upper torso (a muscle's pull, no net
    push on the body; held up from outside, as ``arms.py`` holds a pose, their weight would be
    taken off the runner and lighten its flight).
    """
    s, e, w = nd[L_SHOULDER + side], nd[L_ELBOW + side], nd[L_HAND + side]
    sx, sz = forward_xz(pos, nd[L_SHOULDER], nd[R_SHOULDER])
    fx, fz = forward_xz(pos, nd[L_HIP], nd[R_HIP])
    me, other = nd[L_FOOT + side], nd[L_FOOT + 1 - side]
    lead = ((pos[other, 0] - pos[me, 0]) * fx + (pos[other, 2] - pos[me, 2]) * fz) / step
    rate = (((pos[other, 0] - prev[other, 0]) - (pos[me, 0] - prev[me, 0])) * fx
            + ((pos[other, 2] - prev[other, 2]) - (pos[me, 2] - prev[me, 2])) * fz) / (step * dt)
    if abs(lead) >= 1.0:
        rate = 0.0
    lead = clamp(lead, -1.0, 1.0)
    amp = min(RUN_ARM_SWING + RUN_ARM_MORE * max(0.0, froude - WALK_FROUDE_MAX), RUN_ARM_MOST)
    # the upper arm's angle forwards from hanging, and the forearm's (the elbow bent RUN_ELBOW)
    phi = share * (amp * lead - RUN_ARM_BACK)
    phi_rate = share * amp * rate
    a = phi + share * RUN_ELBOW
    upper = math.sqrt((pos[e, 0] - pos[s, 0]) ** 2 + (pos[e, 1] - pos[s, 1]) ** 2
                      + (pos[e, 2] - pos[s, 2]) ** 2)
    fore = math.sqrt((pos[w, 0] - pos[e, 0]) ** 2 + (pos[w, 1] - pos[e, 1]) ** 2
                     + (pos[w, 2] - pos[e, 2]) ** 2)
    inward = -1.0 if side == 0 else 1.0  # towards the midline: left is +x when facing +z
    ix, iz = inward * sz * RUN_ARM_IN * fore * share, -inward * sx * RUN_ARM_IN * fore * share
    # elbow E = S + upper (sin phi F - cos phi up); hand H = E + fore (sin a F - cos a up)
    ef, ey = upper * math.sin(phi), -upper * math.cos(phi)
    hf, hy = ef + fore * math.sin(a), ey - fore * math.cos(a)
    ef_rate, ey_rate = upper * math.cos(phi) * phi_rate, upper * math.sin(phi) * phi_rate
    hf_rate = ef_rate + fore * math.cos(a) * phi_rate
    hy_rate = ey_rate + fore * math.sin(a) * phi_rate
    aim_e = (pos[s, 0] + ef * sx, pos[s, 1] + ey, pos[s, 2] + ef * sz)
    aim_h = (pos[s, 0] + hf * sx + ix, pos[s, 1] + hy, pos[s, 2] + hf * sz + iz)
    rate_e = (ef_rate * sx, ey_rate, ef_rate * sz)
    rate_h = (hf_rate * sx, hy_rate, hf_rate * sz)
    gain, damp = share * ARM_GAIN, share * ARM_DAMP
    m_up = mass[nd[NECK]] + mass[nd[L_SHOULDER]] + mass[nd[R_SHOULDER]] + mass[nd[HEAD]]
    for k in range(3):
        vs = (pos[s, k] - prev[s, k]) / dt
        ve = (pos[e, k] - prev[e, k]) / dt - vs
        vw = (pos[w, k] - prev[w, k]) / dt - vs
        a_e = clamp(gain * (aim_e[k] - pos[e, k]) - damp * (ve - rate_e[k]), -ARM_MOST, ARM_MOST)
        a_e -= share * gravity[k]
        a_w = clamp(gain * (aim_h[k] - pos[w, k]) - damp * (vw - rate_h[k]), -ARM_MOST, ARM_MOST)
        a_w -= share * gravity[k]
        acc[e, k] += a_e
        acc[w, k] += a_w
        back = (mass[e] * a_e + mass[w] * a_w) / m_up  # equal and opposite, on the upper torso
        for role in (NECK, L_SHOULDER, R_SHOULDER, HEAD):
            acc[nd[role], k] -= back


@njit(cache=True, nogil=True)
def control_posture(args, n_chars, gravity, dt, holding):
    """Add posture accelerations for every character (see the module docstring; ``args``:
    ``store.columns(PostureColumns, nodes, characters)``)."""
    cols = PostureColumns(*args)
    pos, prev, acc, mass, radius, flags = cols.pos, cols.prev, cols.acc, cols.mass, cols.radius, cols.flags
    move_time, nodes, mode, mode_time, walk = cols.move_time, cols.nodes, cols.mode, cols.mode_time, cols.walk
    seat, head_dir = cols.seat, cols.head_dir
    stand_height, crouch, lean = cols.stand_height, cols.crouch, cols.lean
    scale, leg_length = cols.scale, cols.leg_length
    g = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2)
    for c in range(n_chars):
        if mode[c] == LIMP:
            continue
        mode_time[c] += dt
        nd = nodes[c]
        p = nd[PELVIS]
        from_ground = seat[c, 1] < DOWN * stand_height[c]  # (rising: from the ground, not a seat)
        if mode[c] == RISE and not from_ground and pos[p, 1] < DOWN * stand_height[c]:
            # told to stand while still falling (a ragdoll stood up mid-fall): the "seat" was the
            # pelvis in the air, and the seat's 0.8 s rise from there popped it up off the ground
            # in 0.6 s (issue 34). Down on the ground now: it gets up from here, through a kneel
            for k in range(3):
                seat[c, k] = pos[p, k]
            mode_time[c] = 0.0
            from_ground = True
        if mode[c] == RISE and mode_time[c] > (GETUP_TIME if from_ground else RISE_TIME):
            mode[c] = STAND
            mode_time[c] = 0.0
        # gravity compensation: the torso, head and knees hold themselves up
        for role in TORSO:
            for k in range(3):
                acc[nd[role], k] -= gravity[k]
        for role in (L_KNEE, R_KNEE):
            for k in range(3):
                acc[nd[role], k] -= gravity[k]

        vpx = (pos[p, 0] - prev[p, 0]) / dt
        vpy = (pos[p, 1] - prev[p, 1]) / dt
        vpz = (pos[p, 2] - prev[p, 2]) / dt
        lf = nd[L_FOOT]
        rf = nd[R_FOOT]
        feet_x = 0.5 * (pos[lf, 0] + pos[rf, 0])
        feet_z = 0.5 * (pos[lf, 2] + pos[rf, 2])
        wx = walk[c, 0]
        wz = walk[c, 2]
        moving = wx * wx + wz * wz > 1e-4
        fx, fz = forward_xz(pos, nd[L_HIP], nd[R_HIP])
        step = 0.0
        t_fly = 1.0
        target_vy = 0.0
        lift_most = MAX_ACC
        push_x, push_y, push_z = 0.0, 0.0, 0.0
        running = 0.0  # how much of a run the pace asked for is (kernelmath.run_share) ...
        froude = 0.0  # ... and its Froude number
        if moving and g > 1e-6:
            # the gait decides the top speed per body size (kernelmath.walk_speed); the
            # pelvis slows into a sharp turn, down to TURN_SLOW of it facing the other way
            sp = math.sqrt(wx * wx + wz * wz)
            v = walk_speed(sp, leg_length[c], g)
            v, step, _, t_fly = step_timing(v, leg_length[c], g)
            running = run_share(v, leg_length[c], g)
            froude = v * v / (g * leg_length[c])
            turn = yaw_error(fx, fz, wx / sp, wz / sp)
            v *= TURN_SLOW + (1.0 - TURN_SLOW) * min(1.0, 1.0 + math.cos(turn))  # slower past 90 deg
            # a planted foot left far behind or to the side holds the pelvis back: it waits
            # for the step rather than run away from its support (a crowd, a sharp turn)
            for f in range(2):
                i = nd[L_FOOT + f]
                if flags[i] & NODE_LOCKED:
                    h = nd[L_HIP + f]
                    ex = pos[i, 0] - pos[h, 0]
                    ez = pos[i, 2] - pos[h, 2]
                    d = math.sqrt(ex * ex + ez * ez) / leg_length[c]
                    if d > HELD and ex * wx + ez * wz < 0.0:
                        v *= max(0.1, 1.0 - (d - HELD) / HELD_SPAN)
            wx *= v / sp
            wz *= v / sp

        # -- pelvis height and ground position
        if mode[c] == SIT:
            target_y = seat[c, 1]
        elif mode[c] == RISE and from_ground:
            kneel = max(seat[c, 1], KNEEL * stand_height[c])
            t = mode_time[c]
            if t < KNEEL_TIME:
                target_y = seat[c, 1] + t / KNEEL_TIME * (kneel - seat[c, 1])
            else:
                f = min(1.0, max(0.0, t - KNEEL_TIME - KNEEL_HOLD) / STAND_UP_TIME)
                target_y = kneel + f * (stand_height[c] - kneel)
            if pos[p, 1] < target_y - RISE_LAG * stand_height[c]:
                mode_time[c] -= dt  # held down (pinned, under someone): the rise waits for the body
        elif mode[c] == RISE:
            f = min(1.0, mode_time[c] / RISE_TIME)
            target_y = seat[c, 1] + f * (stand_height[c] - seat[c, 1])
        else:
            # standing or walking, the pelvis is carried by straight planted legs (an inverted
            # pendulum: highest over the foot, lowest with the feet spread - the walk's bob):
            # it aims a little above where they hold it (CARRY_OVER), so they stay taut and
            # straight and hold it up, rather than the height control (a half squat reads as
            # sneaking). In a walk's double support the trailing heel rises (the gait lifts
            # it), so the leading leg carries it
            target_y = stand_height[c]
            walking = step > 0.0
            top, top_rate, ux, uy, uz = carried_height(pos, flags, radius, nd, leg_length[c], vpx, vpz,
                                                       wx, wz, walking)
            if top < 1e8:
                target_y = min(target_y, top)
                # coming down: low enough that a swinging foot reaches the ground LEAD steps
                # ahead (else it hangs in the air, or the landing foot drags the hip), and a
                # foot knocked off its arc (neither planted nor flying) where it is: straight
                # legs hold the hips too high for a foot out to the side to reach the ground
                reach = LANDING_REACH * leg_length[c]
                for f in range(2):
                    i = nd[L_FOOT + f]
                    if flags[i] & NODE_LOCKED:
                        continue
                    if flags[i] & NODE_MOVING and move_time[i] > 0.0:
                        if cols.move_gravity[i] != MOVE_GAIT_ARC:
                            # a kick: the standing knee gives, as a person's does, so the
                            # swing reaches out (and the kick's own aim stays in reach)
                            target_y = min(target_y, KICK_STANCE * stand_height[c])
                        if not (walking and move_time[i] < LANDING * t_fly):
                            continue
                        ahead = LEAD * step
                    else:
                        h = nd[L_HIP + f]
                        ahead = math.sqrt((pos[i, 0] - pos[h, 0]) ** 2 + (pos[i, 2] - pos[h, 2]) ** 2)
                    landing = radius[i] + math.sqrt(max(0.0, reach * reach - ahead * ahead))
                    landing += pos[p, 1] - pos[nd[L_HIP + f], 1]
                    if landing < target_y:
                        target_y = landing
                        top_rate = 0.0
                if walking:
                    target_y = max(WALK_LOWEST * stand_height[c], target_y)
                    target_vy = top_rate
                    # the hip's fall along the trailing leg's arc turns into a rise along the
                    # leading one's gently (the landing knee gives a little, and straightens
                    # over the stance): pushed up a taut leg faster, the body is thrown on
                    lift_most = (WALK_LIFT + WALK_LIFT_FROUDE * v * v / (g * leg_length[c])) * g
                    # the carrying leg pushes its hip away from its foot, along the leg (a push
                    # straight up would also drive the hip along the leg's arc: forwards before
                    # it passes over the foot, back after - a surge and a stall every step)
                    carry = HEIGHT_GAIN * CARRY_OVER * leg_length[c]
                    push_x, push_y, push_z = carry * ux, carry * uy, carry * uz
                else:
                    target_y += CARRY_OVER * leg_length[c]
            elif step > 0.0 and t_fly * v > step:
                # a run's flight (no foot planted): the pelvis aims no higher than lets the landing
                # leg reach the ground LEAD steps ahead (at most MOST_AHEAD), nor lower than
                # RUN_LOWEST. Aimed at standing height, it rose in the flight out of the swinging
                # foot's reach, the foot hung in the air past its step and the run bounded
                # (asked 2.2-2.4 m/s, the adult airborne 0.41-0.46 of the time)
                reach = LANDING_REACH * leg_length[c]
                ahead = min(LEAD * step, MOST_AHEAD * leg_length[c])
                landing = radius[nd[L_FOOT]] + math.sqrt(max(0.0, reach * reach - ahead * ahead))
                landing += pos[p, 1] - 0.5 * (pos[nd[L_HIP], 1] + pos[nd[R_HIP], 1])
                target_y = min(target_y, max(RUN_LOWEST * stand_height[c], landing))
            if cols.arm_mode[c, 0] == REACH or cols.arm_mode[c, 1] == REACH:
                # reaching for something (a hug's arms round a partner, a grab), the knees give
                # a little, as they do for a kick
                target_y = min(target_y, KICK_STANCE * stand_height[c])
            target_y -= crouch[c]  # stooping to reach something low
        ay = min(HEIGHT_GAIN * (target_y - pos[p, 1]) - HEIGHT_DAMP * (vpy - target_vy), lift_most)
        if mode[c] == STAND and not moving:
            # sinking from straight legs (a stoop, a crouch), gently at first: near straight,
            # a pelvis going down puts the knees forwards many times as fast - they shot
            # into whoever stood close (two stooping to one doll knocked knees, 5 J)
            ay = max(ay, HEIGHT_DAMP * (-sink_speed(pos, flags, nd, leg_length[c]) - vpy))
        if mode[c] == STAND and pos[p, 1] < GET_UP_TO * stand_height[c]:
            # getting up from low (a fall, a deep stoop): the pelvis rises at most GET_UP
            # standing heights a second - over most of a second, not a pop (before: from the
            # ground to 90% of standing height in 0.2 s)
            ay = min(ay, HEIGHT_DAMP * (GET_UP * stand_height[c] - vpy))
        if mode[c] == SIT:
            ax = BALANCE_GAIN * (seat[c, 0] - pos[p, 0]) - BALANCE_DAMP * vpx
            az = BALANCE_GAIN * (seat[c, 2] - pos[p, 2]) - BALANCE_DAMP * vpz
        elif moving and mode[c] == STAND:
            ax = WALK_GAIN * (wx - vpx)
            az = WALK_GAIN * (wz - vpz)
            # cruising a little behind the pace (each landing brakes the hip), the stance leg
            # pushes on harder, so the pace is reached; setting off, slowing, stopping and
            # turning stay as gentle as they were (a stiffer response there feeds the
            # to-and-fro of two approachers matching each other's steps)
            sp = math.sqrt(wx * wx + wz * wz)
            along = (vpx * wx + vpz * wz) / max(sp, 1e-9)
            lag = sp - along
            brisk = sp * sp > KEEP_PACE_FROUDE * g * leg_length[c] and t_fly * sp < step  # a walk, not a run
            if 0.0 < lag and along > KEEP_PACE_FROM * sp and brisk:
                more = min((KEEP_PACE_GAIN - WALK_GAIN) * lag, KEEP_PACE_MOST)
                ax += more * wx / max(sp, 1e-9)
                az += more * wz / max(sp, 1e-9)
            # no lurches: a person changes pace at a fraction of g, and sets off at a run slower still
            push = (ax * wx + az * wz) / max(sp, 1e-9)
            asked = walk[c, 0] ** 2 + walk[c, 2] ** 2  # (the pace asked: turning, the pelvis is slower)
            if push > SPEED_UP * g and asked > WALK_FROUDE_MAX * g * leg_length[c]:  # at a run
                ax -= (push - SPEED_UP * g) * wx / max(sp, 1e-9)
                az -= (push - SPEED_UP * g) * wz / max(sp, 1e-9)
            most = WALK_ACC * g
            a = math.sqrt(ax * ax + az * az)
            if a > most:
                ax *= most / a
                az *= most / a
        else:
            ax = BALANCE_GAIN * (feet_x - pos[p, 0]) - BALANCE_DAMP * vpx
            az = BALANCE_GAIN * (feet_z - pos[p, 2]) - BALANCE_DAMP * vpz
        ax = clamp(ax + push_x, -MAX_ACC, MAX_ACC)
        ay = clamp(ay + push_y, -MAX_ACC, MAX_ACC)
        az = clamp(az + push_z, -MAX_ACC, MAX_ACC)
        # a torso already bent further than the upright control leans it (the hips held
        # back: legs caught on a bar, in a crush) is not pushed on further the way it
        # leans: pushing the chest after the walk folds the body over the held hips
        n = nd[NECK]
        bx = pos[n, 0] - pos[p, 0]
        bz = pos[n, 2] - pos[p, 2]
        bent = math.sqrt(bx * bx + bz * bz)
        if bent > math.sin(MAX_PITCH) * math.sqrt(bent * bent + (pos[n, 1] - pos[p, 1]) ** 2):
            along = (ax * bx + az * bz) / bent
            if along > 0.0:
                ax -= along * bx / bent
                az -= along * bz / bent
        for role in TORSO:
            i = nd[role]
            acc[i, 0] += ax
            acc[i, 1] += ay
            acc[i, 2] += az

        if mode[c] == RISE and from_ground:
            # a hand not holding or doing anything pushes on its thigh, as a person's does
            for side in range(2):
                if cols.arm_mode[c, side] != HANG or holding[c, side]:
                    continue
                hand, hip, knee = nd[L_HAND + side], nd[L_HIP + side], nd[L_KNEE + side]
                for k in range(3):
                    aim = 0.6 * pos[hip, k] + 0.4 * pos[knee, k]
                    v = (pos[hand, k] - prev[hand, k]) / dt
                    pull = HANDS_GAIN * (aim - pos[hand, k]) - HANDS_DAMP * v
                    acc[hand, k] += clamp(pull, -MAX_ACC, MAX_ACC)

        if running > 0.0 and mode[c] == STAND:
            # a run's arms: bent, swung opposite the legs. A hand that holds something, or an arm
            # a behaviour holds in a pose (a carried doll), is left as it is; so is the free arm
            # of a body led by its other hand (a bar held running round a merry-go-round: one arm
            # pumping beside it twisted the rider's shoulders, and a foot came over the rim)
            for side in range(2):
                other = cols.arm_mode[c, 1 - side]
                if (cols.arm_mode[c, side] == HANG and not holding[c, side]
                        and (other == HANG or other == CARRY)):
                    swing_arms(pos, prev, acc, mass, nd, side, running, froude, step, gravity, dt)

        # -- upright: shoulder centre over the pelvis (over the feet when rising)
        n = nd[NECK]
        if mode[c] == RISE and not from_ground:
            tx, tz = feet_x, feet_z
        else:  # (getting up from the ground: upright over the pelvis - the feet may be far yet)
            # into the walk by as much for every body size at the same Froude number
            tx = LEAN * scale[c] * wx + lean[c, 0]
            tz = LEAN * scale[c] * wz + lean[c, 2]
            # a lean into the walk or towards something (a stoop, a hug) bends the torso
            # at most MAX_PITCH: further and a person would be falling, not leaning
            most = math.sin(MAX_PITCH) * math.sqrt((pos[n, 0] - pos[p, 0]) ** 2 + (pos[n, 1] - pos[p, 1]) ** 2
                                                   + (pos[n, 2] - pos[p, 2]) ** 2)
            off = math.sqrt(tx * tx + tz * tz)
            if off > most:
                tx *= most / off
                tz *= most / off
            tx += pos[p, 0]
            tz += pos[p, 2]
        vnx = (pos[n, 0] - prev[n, 0]) / dt - vpx
        vny = (pos[n, 1] - prev[n, 1]) / dt - vpy
        vnz = (pos[n, 2] - prev[n, 2]) / dt - vpz
        uy = 0.0
        torso = math.sqrt((pos[n, 0] - pos[p, 0]) ** 2 + (pos[n, 1] - pos[p, 1]) ** 2
                          + (pos[n, 2] - pos[p, 2]) ** 2)
        if pos[n, 1] < pos[p, 1] + FOLDED * torso:
            # folded over or hanging upside down (pulled down by something held, say):
            # holding the chest over the pelvis horizontally would hold it just as well
            # straight below, so lift it and swing it up in front
            hfx, hfz = forward_xz(pos, nd[L_HIP], nd[R_HIP])
            tx = pos[p, 0] + 0.5 * torso * hfx
            tz = pos[p, 2] + 0.5 * torso * hfz
            uy = clamp(UPRIGHT_GAIN * (pos[p, 1] + torso - pos[n, 1]) - UPRIGHT_DAMP * vny, -MAX_ACC, MAX_ACC)
        # a torso tipped past the most it ever leans is being thrown over (legs dragged from
        # under it in a sharp turn, a kick's swing, a run's landing): a person catches that,
        # bending back at the hip, the harder the further it tips. The stiffer spring keeps
        # its damping ratio. Leans up to MAX_PITCH, and the walk, are as before
        tip = max(0.0, bent / (torso + 1e-9) - math.sin(MAX_PITCH))
        k_up = min(1.0 + RIGHTING * tip / RIGHTING_SPAN, RIGHTING_MOST)
        d_up = math.sqrt(k_up)
        ux = clamp(k_up * UPRIGHT_GAIN * (tx - pos[n, 0]) - d_up * UPRIGHT_DAMP * vnx, -MAX_ACC, MAX_ACC)
        uz = clamp(k_up * UPRIGHT_GAIN * (tz - pos[n, 2]) - d_up * UPRIGHT_DAMP * vnz, -MAX_ACC, MAX_ACC)
        m_up = mass[n] + mass[nd[L_SHOULDER]] + mass[nd[R_SHOULDER]] + mass[nd[HEAD]]
        m_low = mass[p] + mass[nd[L_HIP]] + mass[nd[R_HIP]]
        for role in (NECK, L_SHOULDER, R_SHOULDER, HEAD):
            acc[nd[role], 0] += ux
            acc[nd[role], 1] += uy
            acc[nd[role], 2] += uz
        for role in (PELVIS, L_HIP, R_HIP):  # equal and opposite: a torque, no net push
            acc[nd[role], 0] -= ux * m_up / m_low
            acc[nd[role], 1] -= uy * m_up / m_low
            acc[nd[role], 2] -= uz * m_up / m_low

        # -- pelvis yaw to the walk direction (else hold still)
        width = math.sqrt((pos[nd[L_HIP], 0] - pos[nd[R_HIP], 0]) ** 2
                          + (pos[nd[L_HIP], 2] - pos[nd[R_HIP], 2]) ** 2) + 1e-9
        omega = (((pos[nd[R_HIP], 0] - prev[nd[R_HIP], 0]) - (pos[nd[L_HIP], 0] - prev[nd[L_HIP], 0])) * fx
                 + ((pos[nd[R_HIP], 2] - prev[nd[R_HIP], 2]) - (pos[nd[L_HIP], 2] - prev[nd[L_HIP], 2])) * fz
                 ) / (dt * width)
        theta = 0.0
        if moving and mode[c] == STAND:
            sp = math.sqrt(wx * wx + wz * wz)
            # turn at a bounded rate (about YAW_GAIN * MAX_TURN_ERROR / YAW_DAMP): hips
            # spun round over planted feet faster than the feet can step twist the legs
            # through each other
            theta = clamp(yaw_error(fx, fz, wx / sp, wz / sp), -MAX_TURN_ERROR, MAX_TURN_ERROR)
        alpha = clamp(YAW_GAIN * theta - YAW_DAMP * omega, -MAX_YAW_ACC, MAX_YAW_ACC)
        for role in LOWER:
            i = nd[role]
            acc[i, 0] += alpha * (pos[i, 2] - pos[p, 2])
            acc[i, 2] -= alpha * (pos[i, 0] - pos[p, 0])

        # -- shoulder yaw towards the gaze, within MAX_TWIST of the pelvis
        sx, sz = forward_xz(pos, nd[L_SHOULDER], nd[R_SHOULDER])
        gx = head_dir[c, 0]
        gz = head_dir[c, 2]
        gn = math.sqrt(gx * gx + gz * gz)
        want = 0.0
        if gn > 1e-6:
            want = clamp(yaw_error(fx, fz, gx / gn, gz / gn), -MAX_TWIST, MAX_TWIST)
        twist = yaw_error(fx, fz, sx, sz)
        ls = nd[L_SHOULDER]
        rs = nd[R_SHOULDER]
        swidth = math.sqrt((pos[ls, 0] - pos[rs, 0]) ** 2 + (pos[ls, 2] - pos[rs, 2]) ** 2) + 1e-9
        somega = (((pos[rs, 0] - prev[rs, 0]) - (pos[ls, 0] - prev[ls, 0])) * sx
                  + ((pos[rs, 2] - prev[rs, 2]) - (pos[ls, 2] - prev[ls, 2])) * sz) / (dt * swidth)
        salpha = clamp(YAW_GAIN * (want - twist) - YAW_DAMP * (somega - omega), -MAX_YAW_ACC, MAX_YAW_ACC)
        for role in UPPER:
            i = nd[role]
            acc[i, 0] += salpha * (pos[i, 2] - pos[n, 2])
            acc[i, 2] -= salpha * (pos[i, 0] - pos[n, 0])
# fmt: on


class PostureSystem(System):
    """Standing, sitting and rising; upright torso; pelvis and shoulder yaw."""

    name = "posture"

    def run(self, ctx: StepContext) -> None:
        """Add this step's posture accelerations."""
        dt = ctx.dt
        s = ctx.state
        ch, n = s.characters, s.nodes
        if ch.count == 0:
            return
        g = ctx.settings.gravity
        # which hands hold something (a grab joint from the hand): not put on a thigh as it
        # gets up, nor swung in a run (the nodes that hold, found again only when the layout changes)
        gripping = self.scratch.keyed("gripping", (s.version, s.links.count, n.count), lambda: _gripping(s))
        holding = gripping[ch.nodes[: ch.count, L_HAND : R_HAND + 1]]
        control_posture(columns(PostureColumns, n, ch), ch.count, g, dt, holding)


def _gripping(state) -> np.ndarray:
    """Per node: does a grab joint start at it (a hand that holds something)?"""
    links = state.links
    gripping = np.zeros(state.nodes.count, dtype=np.bool_)
    gripping[links.a[: links.count][(links.flags[: links.count] & LINK_GRAB) != 0]] = True
    return gripping
