"""Steering: one kernel walks every steering character of a step to its target round obstacles.

:func:`steer_rows` is the one implementation of "walk towards a point or a body round what
is in the way, stop at a distance, give up when no headway is made": the approach goals
of a step (``approach``'s batch), one character at a time (``approach.steer_to``: hug,
grapple, carry, follow, sit... a one-row batch) and a wandering crowd (``wander``) call it.
A row says where its character is going and how (:class:`Walkers`); what is round them
comes from the world's spatial index (:class:`Around`, :func:`around`): the ground grid of
every node, walls and wide bodies, what each character holds. The walk vector is SPEC 4's
approach field (:func:`~twig_ecs.kernelmath.approach_field`).
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import intrinsic, overload

from twig_ecs.kernelmath import SIT, approach_field, kernel_helper
from twig_ecs.steering import SteeringParams
from twig_ecs.systems.control.spatial import STEER_CELL, STEP_OVER, SpatialIndex, nearest_obstacle_nodes

#: Status of a row after :func:`steer_rows`: walking; stopped there (the goal is done); stopped
#: stalled (no headway for its stall time); walking, but it sits and must stand up; a walk
#: vector it cannot do (not finite, or over its top speed: left for the Python to refuse).
WALKING, ARRIVED, STUCK, SAT, CHECK = 0, 1, 2, 3, 4
#: What a row's target is (``Walkers.target[k, 0]``): a point (``Walkers.point``); a body's
#: centre of mass; a character's pelvis. A target that is a body or a character is pursued:
#: its velocity is added to the walk vector (while not squeezing).
POINT, BODY, CHARACTER = 0, 1, 2
#: How a row arrives (``Walkers.direction[k, 3]``): from where it is; along the direction
#: given (made unit here); along the unit direction given (made unit by the caller already).
FROM_HERE, ALONG, ALONG_UNIT = 0.0, 1.0, 2.0


class Gains(NamedTuple):
    """The field's gains and the thresholds every row shares (metres, seconds)."""

    repulsion: float  # c: an obstacle's push (m^2/s)
    cutoff: float  # m: obstacles further off are no obstacle
    min_sq: float  # d_min (m^2)
    fade: float  # m from the goal within which the push fades
    step_over: float  # m: nodes this low are stepped over
    squeeze_after: float  # s without headway after which a squeezing row squeezes
    squeeze: float  # the push's factor while squeezing
    squeeze_hold: float  # s a squeeze lasts


class Around(NamedTuple):
    """What is round the walkers this step (:func:`around` builds it), and the kernel's scratch."""

    pos: np.ndarray  # node positions
    prev: np.ndarray  # node positions a step ago (a target's velocity)
    mass: np.ndarray
    node_body: np.ndarray
    n_nodes: int
    grid_start: np.ndarray  # the spatial index's ground grid (bucket h: entries[start[h]:start[h + 1]])
    grid_entries: np.ndarray
    cell: float
    cx: np.ndarray  # each body's ground centre (x, z) and squared spread
    cz: np.ndarray
    spread: np.ndarray
    wide: np.ndarray  # rows of the bodies steered round as discs
    blocked: np.ndarray  # per body: steered round as a disc or a wall (not by its nearest node)
    wall_body: np.ndarray  # static bodies (fences): their collidable links, CSR
    wall_start: np.ndarray
    wall_links: np.ndarray
    link_a: np.ndarray
    link_b: np.ndarray
    grab_holder: np.ndarray  # body rows: holder g holds grab_held[g]
    grab_held: np.ndarray
    slot: np.ndarray  # scratch of nearest_obstacle_nodes
    scratch: np.ndarray
    found: np.ndarray
    obstacles: np.ndarray  # (n, 3) scratch: one row's obstacle points
    skip: np.ndarray  # scratch: one row's bodies that are no obstacle


class Walkers(NamedTuple):
    """One row per steering character (:func:`walkers` makes the arrays)."""

    crows: np.ndarray  # its character-table row (the walk vector written, its mode read)
    pelvis: np.ndarray  # its pelvis node: where it is
    me: np.ndarray  # its body row
    target: np.ndarray  # (kind, pelvis node, first node, node count, body) - kind: POINT, BODY, CHARACTER
    point: np.ndarray  # (x, y, z) of a POINT target
    stop: np.ndarray  # m from the target it stops at
    arrive: np.ndarray  # m: within this of the target it has arrived (the stop distance and some slack)
    direction: np.ndarray  # (x, y, z, how): FROM_HERE, ALONG or ALONG_UNIT
    curl: np.ndarray  # steer sideways round obstacles
    speed: np.ndarray  # m/s: its pace
    max_speed: np.ndarray  # m/s: a faster walk vector is CHECKed
    stall: np.ndarray  # s without 10 cm of headway: STUCK
    squeeze: np.ndarray  # squeeze past obstacles after ``Gains.squeeze_after`` s without headway
    skip_bodies: np.ndarray  # bodies that are no obstacle to it besides itself and what it holds (CSR)
    skip_start: np.ndarray
    skip_count: np.ndarray
    best: np.ndarray  # the stall clock: nearest it has been (m), since when (s)
    best_at: np.ndarray
    squeeze_until: np.ndarray  # s: a squeeze lasts until then
    status: np.ndarray  # out: WALKING, ARRIVED...
    distance: np.ndarray  # out: to the target on the ground (m)
    improved: np.ndarray  # out: the stall clock or the squeeze changed


#: The approach field's gains (SteeringParams) with the step-over height and the squeeze's
#: figures left to the caller.
_FIELD = SteeringParams()


def gains(squeeze_after: float = np.inf, squeeze: float = 1.0, squeeze_hold: float = 0.0) -> Gains:
    """The usual field gains (:class:`~twig_ecs.steering.SteeringParams`) and a squeeze's figures."""
    return Gains(_FIELD.repulsion, _FIELD.cutoff, _FIELD.min_sq, _FIELD.fade, STEP_OVER, squeeze_after,
                 squeeze, squeeze_hold)  # fmt: skip


def walkers(n: int) -> Walkers:
    """The arrays of ``n`` rows, every one a point target reached from where it is, no extras
    skipped, a fresh stall clock; the caller fills in what its rows need (or replaces a
    field with its own array: ``walkers(n)._replace(stop=...)``)."""
    # (a character steering alone makes a one-row batch per call: copies of one made once)
    blocks = [block.copy() for block in _ONE_ROW] if n == 1 else _blocks(n)
    f, i, u, target, point, direction = blocks
    return Walkers(i[0], i[1], i[2], target, point, f[0], f[1], direction, u[0], f[6], f[7], f[8], u[1],
                   np.zeros(0, np.int64), i[3], i[4], f[9], f[10], f[11], i[5], f[2], u[2])  # fmt: skip


def _blocks(n: int) -> list[np.ndarray]:
    """:func:`walkers`' arrays: a block per dtype for the 1-d fields (few allocations), then the
    target, point and direction."""
    f = np.zeros((12, n))
    i = np.zeros((8, n), np.int64)
    u = np.zeros((3, n), np.uint8)
    f[6:10] = np.array([_FIELD.speed, np.inf, np.inf, np.inf])[:, None]  # speed, max speed, stall, best
    f[11] = -np.inf  # squeeze_until
    u[0] = 1  # curl
    return [f, i, u, np.zeros((n, 5), np.int64), np.zeros((n, 3)), np.zeros((n, 4))]


_ONE_ROW = _blocks(1)


def around(scene, holds: tuple[np.ndarray, np.ndarray] | None = None, shapes: bool = True,
           extra_skip: int = 0) -> Around:  # fmt: skip
    """What is round the walkers this step, from the world's spatial index (built once a step).

    ``holds``: (holder, held) body rows of the grab joints (what a character holds is no
    obstacle to it, nor what its target holds); None: nothing held counts. ``shapes``:
    walls and wide bodies are steered round by their shape (False: by their nearest node,
    as any body). ``extra_skip``: the most bodies a row skips besides itself and holdings.
    """
    index = SpatialIndex.of(scene)
    # one per step for each kind of call: a character or two steering one at a time made it
    # again for every call (its parts are the index's, built once a step, and scratch); the
    # key holds the id of ``holds``, which the kept value keeps alive for the step
    return index.per_step(scene, ("around", shapes, extra_skip, id(holds)),
                          lambda: (holds, _around(scene, index, holds, shapes, extra_skip)))[1]  # fmt: skip


def _around(scene, index: SpatialIndex, holds: tuple[np.ndarray, np.ndarray] | None, shapes: bool,
            extra_skip: int) -> Around:  # fmt: skip
    """:func:`around`, made afresh."""
    state = scene.state
    nodes, links = state.nodes, state.links
    start, entries, slot, scratch, found = index.grid(scene)
    cx, cz, spread, wide, walls, blocked = index.footprints(scene)
    if shapes:
        wall_body, wall_start, wall_links = index.wall_links(scene)
    else:
        wide, walls, blocked = np.zeros_like(wide), {}, np.zeros_like(blocked)
        wall_body, wall_start, wall_links = (np.zeros(0, np.int64), np.zeros(1, np.int64),
                                             np.zeros(0, np.int64))  # fmt: skip
    holder, held = holds if holds is not None else (np.zeros(0, np.int64), np.zeros(0, np.int64))
    obstacles = np.empty((len(walls) + int(wide.sum()) + state.bodies.count, 3))
    skip = np.empty(1 + extra_skip + 2 * len(holder), dtype=np.int64)
    return Around(nodes.pos, nodes.prev, nodes.mass, nodes.body, nodes.count, start, entries, STEER_CELL,
                  cx, cz, spread, np.flatnonzero(wide), blocked, wall_body, wall_start, wall_links, links.a,
                  links.b, holder, held, slot, scratch, found, obstacles, skip)  # fmt: skip


def fused_multiply_add(a: float, b: float, c: float) -> float:
    """``a * b + c`` rounded once (IEEE 754's fma), the same in a kernel (LLVM's fma) and in
    plain Python (a kernel run before it is compiled: exact fractions)."""
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
        return a * b + c
    try:
        return float(Fraction(a) * Fraction(b) + Fraction(c))
    except OverflowError:
        return math.copysign(math.inf, a * b + c)


@intrinsic
def _fma(typingctx, a, b, c):
    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@overload(fused_multiply_add)
def _fused_multiply_add_compiled(a, b, c):
    return lambda a, b, c: _fma(a, b, c)


@kernel_helper(nogil=True)
def _skipped(skip, n_skip, b):
    for s in range(n_skip):
        if skip[s] == b:
            return True
    return False


@njit(cache=True, nogil=True)
def row_obstacles(at: Around, hx, hy, hz, me, skip_bodies, cutoff, step_over):
    """Row k's obstacles into ``at.obstacles``; returns how many. The order is fixed: walls,
    wide bodies (the rim point nearest; from inside, the centre), then the nearest node of
    every other body higher than a step (bodies in the order of their first node)."""
    skip, obstacles, pos = at.skip, at.obstacles, at.pos
    # what is no obstacle: itself, its extras (a target), what it holds, and what those hold
    skip[0] = me
    n_skip = 1
    for s in range(len(skip_bodies)):
        skip[n_skip] = skip_bodies[s]
        n_skip += 1
    n_grabs = len(at.grab_holder)
    for g in range(n_grabs):
        if at.grab_holder[g] == me:
            skip[n_skip] = at.grab_held[g]
            n_skip += 1
    excluded = n_skip  # skip[1:excluded]: the extras and what it holds; what those hold goes too
    for g in range(n_grabs):
        for s in range(1, excluded):
            if skip[s] == at.grab_holder[g]:
                skip[n_skip] = at.grab_held[g]
                n_skip += 1
                break
    n_obs = 0
    for w in range(len(at.wall_body)):  # a fence: the nearest point of its links
        b = at.wall_body[w]
        if _skipped(skip, n_skip, b):
            continue
        if math.hypot(hx - at.cx[b], hz - at.cz[b]) - math.sqrt(at.spread[b]) > cutoff:
            continue
        near = np.inf
        nx = nz = 0.0
        for e in range(at.wall_start[w], at.wall_start[w + 1]):
            j = at.wall_links[e]
            a0, a2 = pos[at.link_a[j], 0], pos[at.link_a[j], 2]
            bx, bz = pos[at.link_b[j], 0] - a0, pos[at.link_b[j], 2] - a2
            t = ((hx - a0) * bx + (hz - a2) * bz) / max(bx * bx + bz * bz, 1e-12)
            t = min(max(t, 0.0), 1.0)
            qx, qz = a0 + t * bx, a2 + t * bz
            d = math.sqrt((qx - hx) ** 2 + (qz - hz) ** 2)
            if d < near:
                near, nx, nz = d, qx, qz
        if near < cutoff:
            obstacles[n_obs, 0], obstacles[n_obs, 1], obstacles[n_obs, 2] = nx, hy, nz
            n_obs += 1
    for b in at.wide:  # a wide body (a merry-go-round's deck): a disc to go round
        if _skipped(skip, n_skip, b):
            continue
        ox, oz = hx - at.cx[b], hz - at.cz[b]
        # |p - c| on the ground with the last multiply-add fused: to the bit what numpy's norm of
        # (x, 0, z) gave play's and ride's steering before they were rows here (OpenBLAS's dot
        # fuses it), and the same on every machine (LLVM's fma is exact where there is none)
        reach = math.sqrt(fused_multiply_add(oz, oz, ox * ox))
        radius = math.sqrt(at.spread[b])
        if reach - radius < cutoff:
            if reach > radius:
                ox, oz = ox * (radius / reach), oz * (radius / reach)
            else:
                ox = oz = 0.0
            obstacles[n_obs, 0], obstacles[n_obs, 2] = at.cx[b] + ox, at.cz[b] + oz
            obstacles[n_obs, 1] = hy
            n_obs += 1
    count = nearest_obstacle_nodes(pos, at.node_body, at.n_nodes, at.grid_start, at.grid_entries, at.cell,
                                   hx, hz, cutoff, step_over, at.blocked, skip[:n_skip], at.slot, at.scratch,
                                   at.found)  # fmt: skip
    for e in range(count):
        i = at.found[e]
        obstacles[n_obs, 0], obstacles[n_obs, 1], obstacles[n_obs, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
        n_obs += 1
    return n_obs


def steer_rows(at: Around, rows: Walkers, gains: Gains, walk, mode, now, dt) -> None:
    """Walk every row towards its target round obstacles; write its walk vector into ``walk``
    (by character row) and its status (WALKING, ARRIVED, STUCK, SAT, CHECK) into ``rows.status``.

    Row k aims at the target's point ``stop[k]`` m off it along its direction, with the
    approach field (speed ``speed[k]``); it has arrived within ``arrive[k]`` m of the
    target and is stuck after ``stall[k]`` s without getting 10 cm nearer (the stall clock
    ``best``/``best_at``, updated here: ``improved[k]`` says so, as it does when a squeezing
    row begins a squeeze). A BODY or CHARACTER target is pursued: its velocity is added,
    the sum capped at the row's speed (not while squeezing).
    """
    # plain tuples: numba types a plain tuple's arrays in C, a NamedTuple's in Python (some
    # 0.3 us an array: half the call of a character steering alone)
    steer_tuples(tuple(at), tuple(rows), tuple(gains), walk, mode, now, dt)


@njit(cache=True, nogil=True)
def steer_tuples(at, rows, gains, walk, mode, now, dt):
    """:func:`steer_rows` over its three structures as plain tuples."""
    at, rows, gains = Around(*at), Walkers(*rows), Gains(*gains)
    for k in range(len(rows.crows)):
        c = rows.crows[k]
        p = rows.pelvis[k]
        hx, hy, hz = at.pos[p, 0], at.pos[p, 1], at.pos[p, 2]
        kind = rows.target[k, 0]
        vx = 0.0
        vz = 0.0
        if kind == POINT:
            wx0, wz0 = rows.point[k, 0], rows.point[k, 2]
        else:  # its centre of mass and velocity: sum m x / sum m over its nodes
            first, count = rows.target[k, 2], rows.target[k, 3]
            msum = 0.0
            sx = sz = 0.0
            ux = uz = 0.0
            for i in range(first, first + count):
                m = at.mass[i]
                msum += m
                sx += at.pos[i, 0] * m
                sz += at.pos[i, 2] * m
                ux += (at.pos[i, 0] - at.prev[i, 0]) / dt * m
                uz += (at.pos[i, 2] - at.prev[i, 2]) / dt * m
            vx, vz = ux / msum, uz / msum
            if kind == CHARACTER:
                q = rows.target[k, 1]
                wx0, wz0 = at.pos[q, 0], at.pos[q, 2]
            else:
                wx0, wz0 = sx / msum, sz / msum
        how = rows.direction[k, 3]
        if how != FROM_HERE:
            dx, dz = rows.direction[k, 0], rows.direction[k, 2]
        else:
            dx, dz = hx - wx0, hz - wz0
        if how != ALONG_UNIT:
            norm = math.sqrt(dx * dx + dz * dz)
            if norm > 1e-9:
                dx, dz = dx / norm, dz / norm
            else:
                dx = dz = 0.0
        stop = rows.stop[k]
        ax = wx0 + stop * dx
        az = wz0 + stop * dz
        dist = math.hypot(hx - wx0, hz - wz0)
        rows.distance[k] = dist
        rows.improved[k] = 0
        if dist <= rows.arrive[k]:
            walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
            rows.status[k] = ARRIVED
            continue
        if dist < rows.best[k] - 0.1:
            rows.best[k] = dist
            rows.best_at[k] = now
            rows.improved[k] = 1
        elif now - rows.best_at[k] > rows.stall[k]:
            walk[c, 0] = walk[c, 1] = walk[c, 2] = 0.0
            rows.status[k] = STUCK
            continue
        if rows.squeeze[k] and now - rows.best_at[k] > gains.squeeze_after:
            rows.squeeze_until[k] = now + gains.squeeze_hold
            rows.improved[k] = 1
        squeezing = rows.squeeze[k] != 0 and now < rows.squeeze_until[k]
        push = gains.repulsion * gains.squeeze if squeezing else gains.repulsion
        lo = rows.skip_start[k]
        n_obs = row_obstacles(at, hx, hy, hz, rows.me[k], rows.skip_bodies[lo : lo + rows.skip_count[k]],
                           gains.cutoff, gains.step_over)  # fmt: skip
        speed = rows.speed[k]
        gx, gz = approach_field(hx, hz, ax, az, at.obstacles, n_obs, speed, push, gains.cutoff, gains.min_sq,
                                rows.curl[k] != 0, gains.fade)  # fmt: skip
        if kind != POINT and not squeezing:  # pursuit: match a moving target's pace on top of closing in
            gx += vx
            gz += vz
            pace = math.sqrt(gx * gx + gz * gz)
            if pace > speed:
                gx *= speed / pace
                gz *= speed / pace
        if not (math.isfinite(gx) and math.isfinite(gz)) or math.sqrt(gx * gx + gz * gz) > rows.max_speed[k]:
            walk[c, 0], walk[c, 2] = gx, gz
            rows.status[k] = CHECK
            continue
        walk[c, 0] = gx
        walk[c, 1] = 0.0
        walk[c, 2] = gz
        rows.status[k] = SAT if mode[c] == SIT else WALKING
