"""constrain: rigid links, grab joints, joint limits, axles and the ground, by projection.

Reads and writes node ``pos`` (and ``flags``/``lock_pos`` for lock-on-contact);
reads links, limits and axle data. Several Gauss-Seidel relaxation passes per step
(SPEC 2): each violated constraint moves its nodes straight onto it, mass-weighted so
that equal and opposite corrections keep the total momentum.
"""

from __future__ import annotations

import math
import threading
from typing import NamedTuple

import numba
import numpy as np
from numba import njit, prange

from twig_ecs.kernelmath import clamp, kernel_helper
from twig_ecs.step import StepContext
from twig_ecs.store import (
    LINK_GRAB,
    LINK_OFF,
    LINK_ROPE,
    NODE_IN_CONTACT,
    NODE_LOCK_ON_CONTACT,
    NODE_LOCKED,
    NODE_MOVING,
    LayoutCache,
    columns,
    gripped_nodes,
)
from twig_ecs.system import System
from twig_ecs.threads import PARALLEL_BODIES

#: Speed (m/s) at which a new grab joint draws its two nodes together.
GRAB_CLOSING = 0.6
#: Distance (m) within which a node counts as touching the ground.
CONTACT_SLOP = 1e-3
#: Depth (m) in the ground that a step may leave for the next step's ground passes
#: (:func:`lift_out_of_ground`). The schoolyard's nodes end a step at most a millimetre or two
#: under (feet after its first step, a knee now and then): for them nothing changes.
GROUND_SLOP = 0.01
# PARALLEL_BODIES (imported above): bodies from which the link and limit passes split by body
# across threads. A body's rows touch only its own nodes, so bodies can be projected at once
# and come out to the last bit as one after the other would leave them. Fewer bodies are done
# on one thread; above it each scene measures whether threads pay (twig_ecs.threads).


# -- what the kernels take: named views of the store's columns (the arrays themselves, not
# copies; numba takes a NamedTuple of arrays as one argument, so a kernel and its call site
# name the columns they use instead of passing 20-odd arrays in an order both must keep)


class NodeColumns(NamedTuple):
    """The node columns the constraint passes read and write."""

    pos: np.ndarray  # (n, 3) m
    prev: np.ndarray  # (n, 3) m, position one step ago
    inv_mass: np.ndarray
    flags: np.ndarray  # NODE_* bits
    radius: np.ndarray  # contact radius against the ground (m)
    lock_pos: np.ndarray  # (n, 3) where a locked node is held
    count: int  # live rows


class LinkColumns(NamedTuple):
    """Rigid links and grab joints: node rows ``a``-``b`` held ``rest`` apart."""

    a: np.ndarray
    b: np.ndarray
    rest: np.ndarray  # m
    flags: np.ndarray  # LINK_* bits
    count: int


class LimitColumns(NamedTuple):
    """Hinge limits (knees, elbows); see ``store.LIMIT_FIELDS``."""

    root: np.ndarray
    mid: np.ndarray
    tip: np.ndarray
    frame: np.ndarray  # (n, 4) node rows: left, right, low, up
    side: np.ndarray
    ref: np.ndarray  # (n, 2)
    arc_min: np.ndarray  # rad
    arc_max: np.ndarray  # rad
    edges: np.ndarray  # (n, 4) inward normals of the arc's edges
    count: int


class AxleColumns(NamedTuple):
    """Per node: the fixed axle (node rows ``axle_a``-``axle_b``, or -1) it spins about, and where on it."""

    axle_a: np.ndarray
    axle_b: np.ndarray
    axle_radius: np.ndarray  # m from the axle line
    axle_height: np.ndarray  # m along the axle from ``axle_a``


class BodyPlan(NamedTuple):
    """How the link and limit passes split by body (:func:`body_plan`): ``*_chunks`` are row
    ranges each moving one body's nodes only; ``*_groups`` the starts (and end) of runs of
    chunks of different bodies, which may be projected at once. A row that joins two bodies
    (a grab joint) is a chunk and a run of its own, in its place in the order."""

    link_chunks: np.ndarray  # (n, 2) int64: first row, end row
    link_groups: np.ndarray  # (runs + 1,) int64: first chunk of each run, then the chunk count
    limit_chunks: np.ndarray
    limit_groups: np.ndarray
    parallel: bool  # split across threads at all (enough bodies, more than one thread)
    # (links,) int64: the link rows in the order a pass projects them; the chunks are ranges of
    # it. On one thread (:func:`interleaved`) a run's bodies LINK_LANES at a time, row by row
    link_order: np.ndarray


class Constraints(NamedTuple):
    """Everything one relaxation pass projects (:func:`relax_once`)."""

    nodes: NodeColumns
    links: LinkColumns
    limits: LimitColumns
    axles: AxleColumns
    plan: BodyPlan
    gripped: np.ndarray  # (nodes,) bool: an end of a grab joint (:func:`~twig_ecs.store.gripped_nodes`)


def constraints_of(state) -> tuple:
    """The store's constraint columns for :func:`solve_constraints` and the collide kernel, as
    plain tuples in the field order of :class:`NodeColumns`, :class:`LinkColumns`,
    :class:`LimitColumns`, :class:`AxleColumns` and :class:`BodyPlan` (see
    :func:`~twig_ecs.store.columns`), then the :func:`~twig_ecs.store.gripped_nodes`;
    :func:`named_constraints` names them again. Made once for both systems of a step, and
    again only when rows come or go or a grab joint is made (arrays are replaced only then)."""
    n, links, limits = state.nodes, state.links, state.limits
    # threads only from the main thread: numba's default thread pool must not be entered by two
    # threads at once (it ends the process), and a scene stepped elsewhere may not be the only one
    main = threading.current_thread() is threading.main_thread()
    threads = numba.get_num_threads()
    key = (state.version, n.count, links.count, limits.count, state.bodies.count, threads, main)

    def made() -> tuple:
        return (columns(NodeColumns, n), columns(LinkColumns, links), columns(LimitColumns, limits),
                columns(AxleColumns, n), body_plan(state, parallel=main and threads > 1),
                gripped_nodes(state))  # fmt: skip

    return _KNOWN.get(state, key, made)


#: Per store: its :func:`constraints_of` tuple, by layout.
_KNOWN = LayoutCache()


def body_plan(state, parallel: bool = True) -> tuple:
    """The :class:`BodyPlan` fields of a store's links and limits; split across threads when
    ``parallel`` and the store has PARALLEL_BODIES bodies."""
    links, limits, node_body = state.links, state.limits, state.nodes.body
    a, b = links.a[: links.count], links.b[: links.count]
    link_body = node_body[a]
    link_chunks, link_groups = _chunks(link_body, link_body != node_body[b])
    mid = limits.mid[: limits.count]
    limit_body = node_body[mid]
    others = [limits.root[: limits.count], limits.tip[: limits.count]]
    others += [limits.frame[: limits.count, k] for k in range(4)]
    limit_cross = np.zeros(limits.count, dtype=bool)
    for rows in others:
        limit_cross |= node_body[rows] != limit_body
    limit_chunks, limit_groups = _chunks(limit_body, limit_cross)
    parallel = bool(parallel and state.bodies.count >= PARALLEL_BODIES)
    link_order = np.arange(links.count) if parallel else interleaved(link_chunks, link_groups, LINK_LANES)
    return link_chunks, link_groups, limit_chunks, limit_groups, parallel, link_order


#: Bodies whose link rows one pass on one thread takes side by side (:func:`interleaved`).
LINK_LANES = 4


def interleaved(chunks: np.ndarray, groups: np.ndarray, lanes: int) -> np.ndarray:
    """The rows of ``chunks`` (a :class:`BodyPlan`'s), up to ``lanes`` chunks of a run with as many
    rows at a time, row by row: first rows of each, then second rows, and so on.

    Each link pulls on nodes the one before it has just moved (a body's links share its
    nodes), so one body's rows wait on each other; the rows of different bodies do not, and
    side by side the CPU overlaps them: the pile's link pass 262 -> 200 us, the hugging
    crowd's 221 -> 184 (one thread). A run's bodies touch none of each other's nodes, so the
    order among them changes nothing (as on threads); each body's rows keep their order.
    """
    count = int(chunks[-1, 1]) if len(chunks) else 0
    length = chunks[:, 1] - chunks[:, 0]
    # chunk p may share a block with the one before it: same run, as many rows
    joins = np.zeros(len(chunks), dtype=bool)
    joins[1:] = length[1:] == length[:-1]
    joins[groups[:-1]] = False
    joins, length = joins.tolist(), length.tolist()
    offset = np.empty(len(chunks), dtype=np.int64)  # where a chunk's block starts in the order
    width = np.empty(len(chunks), dtype=np.int64)  # chunks in its block
    lane = np.empty(len(chunks), dtype=np.int64)  # its place among them
    q, at = 0, 0
    while q < len(chunks):
        take = 1
        while take < lanes and q + take < len(chunks) and joins[q + take]:
            take += 1
        offset[q : q + take], width[q : q + take], lane[q : q + take] = at, take, np.arange(take)
        at += take * length[q]
        q += take
    chunk = np.repeat(np.arange(len(chunks)), length)  # each row's chunk
    along = np.arange(count) - chunks[chunk, 0]
    order = np.empty(count, dtype=np.int64)
    order[offset[chunk] + along * width[chunk] + lane[chunk]] = np.arange(count)
    return order


def _chunks(body: np.ndarray, cross: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``0..len(body)`` (of body ``body[k]``; ``cross``: it joins two bodies) as chunks of
    consecutive rows of one body, grouped into runs in which no body comes twice."""
    n = len(body)
    if n == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(1, dtype=np.int64)
    begins = np.ones(n, dtype=bool)
    begins[1:] = (body[1:] != body[:-1]) | cross[1:] | cross[:-1]
    starts = np.flatnonzero(begins)
    chunks = np.stack([starts, np.append(starts[1:], n)], axis=1).astype(np.int64)
    groups, seen = [0], set()
    for q, (first, is_cross) in enumerate(zip(body[starts].tolist(), cross[starts].tolist(), strict=True)):
        if is_cross or first in seen:
            if q > groups[-1]:
                groups.append(q)  # a run ends before a joint, or before a body it has had
            seen = set()
        if is_cross:
            groups.append(q + 1)  # the joint alone
        else:
            seen.add(first)
    if groups[-1] != len(chunks):
        groups.append(len(chunks))
    return chunks, np.array(groups, dtype=np.int64)


@njit(cache=True, inline="always")  # (trivial to inline; called with int32 and int64 rows)
def row(i):
    """A node row read from an index column, as an unsigned integer: numba then indexes with
    it directly, without the test for a negative index (from the end) it makes for a signed one
    - about a quarter of a link's instructions; the link pass 7% faster, the limits 4-9%."""
    return np.uint64(i)


@njit(cache=True, inline="always")
def node_weight(inv_mass, flags, i):
    """Inverse mass of node i as constraints see it (0 while locked or on a ballistic move)."""
    f = flags[i]
    if f & (NODE_LOCKED | NODE_MOVING):
        return 0.0
    return inv_mass[i]


@njit(cache=True, inline="always")
def line_offset(pos, a, b, p):
    """Where node p lies relative to the line from node a to node b.

    Returns (length of a-b, unit axis x, y, z, distance of p along the axis from a,
    and p's perpendicular offset from the line x, y, z); the axis is zero when a = b.
    """
    ax = pos[b, 0] - pos[a, 0]
    ay = pos[b, 1] - pos[a, 1]
    az = pos[b, 2] - pos[a, 2]
    an = math.sqrt(ax * ax + ay * ay + az * az)
    if an > 0.0:
        ax /= an
        ay /= an
        az /= an
    vx = pos[p, 0] - pos[a, 0]
    vy = pos[p, 1] - pos[a, 1]
    vz = pos[p, 2] - pos[a, 2]
    along = vx * ax + vy * ay + vz * az
    return an, ax, ay, az, along, vx - along * ax, vy - along * ay, vz - along * az


@njit(cache=True, inline="always")
def nudge(pos, i, f, dx, dy, dz):
    """Move node i by f times (dx, dy, dz)."""
    pos[i, 0] += f * dx
    pos[i, 1] += f * dy
    pos[i, 2] += f * dz


@njit(cache=True, inline="always")  # (in both the serial and the threaded pass: compiled once each)
def project_link_rows(nodes, links, order, start, end):
    """One pass over the link rows ``order[start:end]``: pi -= wi (|o|-d)/(|o| (wi+wj)) o,
    pj += wj (...) o. Ropes are only pulled back when longer than their length.
    """
    pos, inv_mass, flags = nodes.pos, nodes.inv_mass, nodes.flags
    la, lb, rest, lflags = links.a, links.b, links.rest, links.flags
    for q in range(start, end):
        k = row(order[q])
        if lflags[k] & LINK_OFF:
            continue  # (first: a switched-off brace costs no square root)
        i = row(la[k])
        j = row(lb[k])
        wi = node_weight(inv_mass, flags, i)
        wj = node_weight(inv_mass, flags, j)
        w = wi + wj
        if w == 0.0:
            continue
        ox = pos[i, 0] - pos[j, 0]
        oy = pos[i, 1] - pos[j, 1]
        oz = pos[i, 2] - pos[j, 2]
        length = math.sqrt(ox * ox + oy * oy + oz * oz)
        if length < 1e-12 or (lflags[k] & LINK_ROPE and length <= rest[k]):
            continue
        f = (length - rest[k]) / (length * w)
        pos[i, 0] -= wi * f * ox
        pos[i, 1] -= wi * f * oy
        pos[i, 2] -= wi * f * oz
        pos[j, 0] += wj * f * ox
        pos[j, 1] += wj * f * oy
        pos[j, 2] += wj * f * oz


@kernel_helper(nogil=True)
def project_links(nodes, links, order):
    """One pass over all links, in ``order`` (:func:`project_link_rows`)."""
    project_link_rows(nodes, links, order, 0, links.count)


#: Passes over a held loose thing's own links at the end of each step (:func:`settle_shape`).
SETTLE_PASSES = 80


@kernel_helper(nogil=True)
def settle_shape(nodes, links, held, passes):
    """Restore the shape of each thing a hand holds: ``passes`` passes over its own links.

    ``held``: rows of (first node, end node, first link, end link), one per held body. A
    carried doll's links are a few cm long and its nodes light; the hand that swings it
    and the carrier's body it lies against move them by more than the shared passes over
    every constraint put right (errors of 20-40 %). So, after the contacts, its links
    alone are projected until they hold. The nodes count as equally heavy here: with the
    doll's heavy middle weighted as it is, the passes converge many times more slowly.
    Then the body is moved back as a whole so that its centre of mass stays where the
    step left it, and every node's previous position moves with it: a change of shape,
    not a push (no node's velocity changes). The hand, the arm and the grab joint are
    left as the contacts left them.
    """
    pos, prev, inv_mass, flags = nodes.pos, nodes.prev, nodes.inv_mass, nodes.flags
    for h in range(held.shape[0]):
        n0, n1, l0, l1 = held[h, 0], held[h, 1], held[h, 2], held[h, 3]
        before = pos[n0:n1].copy()
        com = np.zeros(3)
        mass = 0.0
        for i in range(n0, n1):
            if inv_mass[i] > 0.0:
                m = 1.0 / inv_mass[i]
                mass += m
                for q in range(3):
                    com[q] += m * pos[i, q]
        for _ in range(passes):
            for k in range(l0, l1):
                if links.flags[k] & (LINK_OFF | LINK_GRAB):
                    continue
                i = row(links.a[k])  # (unsigned rows, as the passes index)
                j = row(links.b[k])
                wi = 0.0 if flags[i] & (NODE_LOCKED | NODE_MOVING) else 1.0
                wj = 0.0 if flags[j] & (NODE_LOCKED | NODE_MOVING) else 1.0
                if wi + wj == 0.0:
                    continue
                ox = pos[i, 0] - pos[j, 0]
                oy = pos[i, 1] - pos[j, 1]
                oz = pos[i, 2] - pos[j, 2]
                length = math.sqrt(ox * ox + oy * oy + oz * oz)
                if length < 1e-12 or (links.flags[k] & LINK_ROPE and length <= links.rest[k]):
                    continue
                f = (length - links.rest[k]) / (length * (wi + wj))
                nudge(pos, i, -wi * f, ox, oy, oz)
                nudge(pos, j, wj * f, ox, oy, oz)
        moved = np.zeros(3)
        for i in range(n0, n1):
            if inv_mass[i] > 0.0:
                for q in range(3):
                    moved[q] += pos[i, q] / inv_mass[i]
        for q in range(3):
            shift = (com[q] - moved[q]) / mass if mass > 0.0 else 0.0
            for i in range(n0, n1):
                if not flags[i] & (NODE_LOCKED | NODE_MOVING):
                    pos[i, q] += shift
        # prev moves with pos: the shape is put right without a push, so the doll does not
        # gain the speeds of its corrections, which it carried into the next step's error
        for i in range(n0, n1):
            for q in range(3):
                prev[i, q] += pos[i, q] - before[i - n0, q]


#: A limb bent the wrong way by more than this (offset from its root-tip line, as a
#: fraction of that line) is folded back round rather than straightened.
REVERSED = 0.15
#: A limb past one edge of its arc by more than this (as a fraction of its root-tip line) is
#: repaired rather than stopped: its mid node alone is turned about the limb line back onto
#: the edge, without gaining speed.
FOLDED = 0.25


@njit(cache=True, inline="always")
def _angle_gap(a, b):
    """Unsigned angle (rad) between two directions given as angles."""
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


@njit(cache=True, inline="always")
def stop_lag(pos, prev, m, r, t, alpha, dx, dy, dz):
    """Share of a stop's move (dx, dy, dz) of mid node m that must not become velocity.

    The stop may cancel the speed at which m approaches the fault relative to the point at
    ``alpha`` along the root r - tip t line, and no more (it does not bounce).
    """
    dn = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dn < 1e-12:
        return 0.0
    vrel = 0.0
    for q, d in ((0, dx), (1, dy), (2, dz)):
        vrel += d * ((pos[m, q] - prev[m, q]) - (1.0 - alpha) * (pos[r, q] - prev[r, q])
                     - alpha * (pos[t, q] - prev[t, q]))  # fmt: skip
    approach = max(0.0, -vrel / dn)  # how far m moved into the fault this step
    return 1.0 - min(dn, approach) / dn


# A helper, not inlined: numba typed and lowered these rows once in each pass that inlined them,
# the serial and the threaded (2.8-3.4 s of CPU each in a first run's compile), and the call
# costs nothing measurable (the 1000-hug crowd's limit pass, both forms taking turns in one
# process: 240.7 against 242.1 us). The link rows stay inlined: as a call they were 2% slower.
@kernel_helper(nogil=True)
def project_limit_rows(nodes, limits, gripped, start, end):
    """One pass over hinge limits (knees, elbows) ``start``..``end``.

    The mid node's bend (its offset from the root-tip line) must point within the arc
    [arc_min, arc_max] (at most 180 degrees wide) around the reference direction.

    A limit's moves change ``prev`` too (:func:`stop_lag`, the repairs): they are meant to
    stay. A limb's middle held by a grab joint (``gripped``: a knee, an elbow in someone's
    hand) is put back by its joint every pass, so whatever the limit moved of it came back
    as speed, pass after pass (the goal melee: a doll held by its knee and its pelvis in two
    hands, the knee bent the wrong way, 70 m/s in one step; a child's elbow in a grown-up's
    hand, 82 m/s). So the hand bends that joint, and its limit lets it. (Kept still, with
    the stop on the limb's ends, a hip was moved 27 cm against the links that tie it to the
    pelvis: 1 kJ in one pass. A held root or tip is moved as any other: counted as fixed,
    it pushed from nowhere - a grown-up holding hands was flung 1 m at 6 m/s.)
    """
    pos, prev, inv_mass, flags = nodes.pos, nodes.prev, nodes.inv_mass, nodes.flags
    root, mid, tip, frame = limits.root, limits.mid, limits.tip, limits.frame
    side, ref, arc_min, arc_max, edges = limits.side, limits.ref, limits.arc_min, limits.arc_max, limits.edges
    for k in range(start, end):
        r = row(root[k])
        m = row(mid[k])
        t = row(tip[k])
        if gripped[m]:
            continue
        # body frame: L points to the body's left, U up, F = L x U forward
        left, right, low, up = row(frame[k, 0]), row(frame[k, 1]), row(frame[k, 2]), row(frame[k, 3])
        lx = pos[left, 0] - pos[right, 0]
        ly = pos[left, 1] - pos[right, 1]
        lz = pos[left, 2] - pos[right, 2]
        ux = pos[up, 0] - pos[low, 0]
        uy = pos[up, 1] - pos[low, 1]
        uz = pos[up, 2] - pos[low, 2]
        fx = ly * uz - lz * uy
        fy = lz * ux - lx * uz
        fz = lx * uy - ly * ux
        fn = math.sqrt(fx * fx + fy * fy + fz * fz)
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        if fn < 1e-9 or un < 1e-9:
            continue
        # reference (0-angle) direction
        rx = ref[k, 0] * fx / fn + ref[k, 1] * ux / un
        ry = ref[k, 0] * fy / fn + ref[k, 1] * uy / un
        rz = ref[k, 0] * fz / fn + ref[k, 1] * uz / un
        an, ax, ay, az, va, px, py, pz = line_offset(pos, r, t, m)
        if an < 1e-9:
            continue
        ra = rx * ax + ry * ay + rz * az
        rx -= ra * ax
        ry -= ra * ay
        rz -= ra * az
        rn = math.sqrt(rx * rx + ry * ry + rz * rz)
        if rn < 1e-6:
            continue  # reference along the limb: no preferred side
        rx /= rn
        ry /= rn
        rz /= rn
        # outward axis S = a x R, flipped towards the limb's side
        sx = ay * rz - az * ry
        sy = az * rx - ax * rz
        sz = ax * ry - ay * rx
        if (sx * lx + sy * ly + sz * lz) * side[k] < 0.0:
            sx = -sx
            sy = -sy
            sz = -sz
        # The allowed bends form a wedge around the limb line, between the half-planes
        # through its edges at arc_min and arc_max. A bend past one edge is projected
        # back onto that edge's plane: the correction is in proportion to the fault,
        # so nearly straight limbs settle instead of flipping about.
        pr = px * rx + py * ry + pz * rz
        ps = px * sx + py * sy + pz * sz
        n0r = edges[k, 0]  # inward normals of the two edges
        n0s = edges[k, 1]
        n1r = edges[k, 2]
        n1s = edges[k, 3]
        in0 = pr * n0r + ps * n0s
        in1 = pr * n1r + ps * n1s
        if in0 >= 0.0 and in1 >= 0.0:
            continue
        both = in0 < 0.0 and in1 < 0.0  # bent the wrong way round
        plen = math.sqrt(pr * pr + ps * ps)
        # a slight wrong-way bend goes straight (the nearest allowed shape); a deep one
        # (a knee folded backwards) is turned about the limb line onto the nearer edge,
        # keeping both link lengths - a repair of an old fault rather than a stop, so
        # it moves prev too and adds no velocity
        teleport = both and plen > REVERSED * an
        folded = not both and max(-in0, -in1) > FOLDED * an
        if teleport:
            phi = math.atan2(ps, pr)
            edge = arc_min[k] if _angle_gap(phi, arc_min[k]) < _angle_gap(phi, arc_max[k]) else arc_max[k]
            dr = plen * math.cos(edge) - pr
            ds = plen * math.sin(edge) - ps
        elif both:
            dr = -pr
            ds = -ps
        elif folded:
            # past one edge by far: turned about the limb line back onto that edge, keeping
            # the bend's size and so both link lengths
            edge = arc_min[k] if in0 < 0.0 else arc_max[k]
            dr = plen * math.cos(edge) - pr
            ds = plen * math.sin(edge) - ps
        elif in0 < 0.0:
            # past one edge: back onto its plane, a move in proportion to the fault (the
            # nearest allowed shape: a nearly straight limb settles instead of flipping about)
            dr = -in0 * n0r
            ds = -in0 * n0s
        else:
            dr = -in1 * n1r
            ds = -in1 * n1s
        dx = dr * rx + ds * sx
        dy = dr * ry + ds * sy
        dz = dr * rz + ds * sz
        # Far past one edge (a folded leg turned sideways, a swing foot brought down from
        # above a folded leg as the body turns about it): a repair, not a stop. Moved
        # straight onto the edge's plane, the knee was pulled in towards the hip-foot line,
        # the links pushed it out again, and the two fought pass after pass - up to 35 m/s
        # of knee speed within one step (the 300-crowd soak). So only the mid node moves,
        # turned about the limb line (link lengths kept, nothing else shaken), and its
        # motion further into the fault stops (inelastic).
        if folded:
            if not flags[m] & (NODE_LOCKED | NODE_MOVING):
                dn = math.sqrt(dx * dx + dy * dy + dz * dz)
                vn = ((pos[m, 0] - prev[m, 0]) * dx + (pos[m, 1] - prev[m, 1]) * dy
                      + (pos[m, 2] - prev[m, 2]) * dz) / dn  # fmt: skip
                keep = min(vn, 0.0) / dn  # the part of its step that went into the fault
                for q, d in ((0, dx), (1, dy), (2, dz)):
                    pos[m, q] += d
                    prev[m, q] += d + keep * d
            continue
        if teleport:
            # a repair: the mid node is turned into place and keeps its velocity
            if not flags[m] & (NODE_LOCKED | NODE_MOVING):
                for q, d in ((0, dx), (1, dy), (2, dz)):
                    pos[m, q] += d
                    prev[m, q] += d
            continue
        # A stop, as a constraint between the mid node and the point of the root-tip
        # line beside it (at alpha along it): the mid node moves one way, root and tip
        # the other in proportion to alpha, all weighted by inverse mass - the moves are
        # equal and opposite, so momentum is kept, and local, so nothing else is shaken.
        alpha = min(1.0, max(0.0, va / an))
        wm = node_weight(inv_mass, flags, m)
        wr = node_weight(inv_mass, flags, r)
        wt = node_weight(inv_mass, flags, t)
        w = wm + (1.0 - alpha) ** 2 * wr + alpha**2 * wt
        if w == 0.0:
            continue
        fm = wm / w
        fr = (1.0 - alpha) * wr / w
        ft = alpha * wt / w
        lag = stop_lag(pos, prev, m, r, t, alpha, dx, dy, dz)  # (measured before the move)
        nudge(pos, m, fm, dx, dy, dz)
        nudge(pos, r, -fr, dx, dy, dz)
        nudge(pos, t, -ft, dx, dy, dz)
        # An inelastic stop, never a source of energy: of the move, only the part that stops
        # the mid node's approach into the fault (its speed towards the fault relative to
        # the root-tip line) turns into velocity. The rest - a fault older than this step,
        # or one that links and contacts keep pushing it back into, pass after pass - moves
        # prev along with pos (by the same equal and opposite shares: momentum is kept).
        # As a plain stop it turned such faults into knee speeds of 25 m/s (300-crowd soak).
        if lag > 0.0:
            nudge(prev, m, fm * lag, dx, dy, dz)
            nudge(prev, r, -fr * lag, dx, dy, dz)
            nudge(prev, t, -ft * lag, dx, dy, dz)


@kernel_helper(nogil=True)
def project_limits(nodes, limits, gripped):
    """One pass over all hinge limits (:func:`project_limit_rows`)."""
    project_limit_rows(nodes, limits, gripped, 0, limits.count)


# A call, not inlined: numba analyses a threaded loop's body statement by statement, and with
# the rows inlined project_by_body took 11.9 s of a first run's 41 s of compiling (now 3.3 s).
@kernel_helper(nogil=True)
def _project_chunk(nodes, links, limits, gripped, chunks, q, of_links, link_order):
    """Chunk ``q`` of a :class:`BodyPlan`: its link (``of_links``) or limit rows."""
    if of_links:
        project_link_rows(nodes, links, link_order, chunks[q, 0], chunks[q, 1])
    else:
        project_limit_rows(nodes, limits, gripped, chunks[q, 0], chunks[q, 1])


#: Of numba's parallel passes, only the explicit loop (``prange``): the others look for array
#: expressions and comprehensions to run in parallel, and project_by_body has none. Over a quarter of
#: its own compile (1.4 -> 1.0 s of CPU); the threaded loop is the same.
_PRANGE_ONLY = {"prange": True, "comprehension": False, "reduction": False, "inplace_binop": False,
                "setitem": False, "numpy": False, "stencil": False, "fusion": False}  # fmt: skip


@kernel_helper(parallel=_PRANGE_ONLY, nogil=True)
def project_by_body(nodes, links, limits, gripped, chunks, groups, of_links, link_order):
    """One pass over the link (``of_links``) or limit rows of a :class:`BodyPlan`: each run's
    chunks at once, across threads, the runs one after the other."""
    for g in range(len(groups) - 1):
        lo, hi = groups[g], groups[g + 1]
        if hi - lo == 1:  # (a grab joint, or a lone body: no threads to start)
            _project_chunk(nodes, links, limits, gripped, chunks, lo, of_links, link_order)
            continue
        for q in prange(lo, hi):
            _project_chunk(nodes, links, limits, gripped, chunks, q, of_links, link_order)


@kernel_helper(nogil=True)
def links_pass(c):
    """One pass over every link of the :class:`Constraints` ``c`` (split by body when planned).
    (``bool(True)``, not ``True``: numba compiles a literal as another specialisation.)"""
    plan = c.plan
    if plan.parallel:
        chunks, groups = plan.link_chunks, plan.link_groups
        project_by_body(c.nodes, c.links, c.limits, c.gripped, chunks, groups, bool(True), plan.link_order)  # noqa: UP018
    else:
        project_links(c.nodes, c.links, plan.link_order)


@kernel_helper(nogil=True)
def limits_pass(c):
    """One pass over every joint limit of ``c`` (split by body when planned)."""
    plan = c.plan
    if plan.parallel:
        chunks, groups = plan.limit_chunks, plan.limit_groups
        project_by_body(c.nodes, c.links, c.limits, c.gripped, chunks, groups, bool(False), plan.link_order)  # noqa: UP018
    else:
        project_limits(c.nodes, c.limits, c.gripped)


@kernel_helper(nogil=True)
def project_axles(nodes, axles):
    """Keep axle-mounted nodes on their circle: fixed height along and distance from the axle."""
    pos, flags = nodes.pos, nodes.flags
    axle_a, axle_b = axles.axle_a, axles.axle_b
    axle_radius, axle_height = axles.axle_radius, axles.axle_height
    for i in range(nodes.count):
        a = axle_a[i]
        if a < 0 or flags[i] & NODE_LOCKED:
            continue
        # unsigned rows, as the limits pass passes them
        _, ax, ay, az, _, px, py, pz = line_offset(pos, row(a), row(axle_b[i]), row(i))
        plen = math.sqrt(px * px + py * py + pz * pz)
        if plen < 1e-9:
            continue
        f = axle_radius[i] / plen
        hh = axle_height[i]
        pos[i, 0] = pos[a, 0] + hh * ax + f * px
        pos[i, 1] = pos[a, 1] + hh * ay + f * py
        pos[i, 2] = pos[a, 2] + hh * az + f * pz


@njit(cache=True, nogil=True)
def project_ground(nodes):
    """Ground plane y = 0: no node sinks below its radius; mark contacts, lock on contact."""
    pos, radius, flags, lock_pos = nodes.pos, nodes.radius, nodes.flags, nodes.lock_pos
    # Without branches (every node's height and flags written back, most unchanged; the heights
    # through a flat view, whose stride the compiler knows): in a pile, nodes lie on and off the
    # ground in no order and the branches went either way at random - 0.07 -> 0.015 ms a pass,
    # 16 passes a step in the 1000-ragdoll pile. The same results; the rare lock, after.
    flat = pos.reshape(-1)
    locking = False
    for i in range(nodes.count):
        f = flags[i]
        y = flat[3 * i + 1]
        r = radius[i]
        touching = ((f & NODE_LOCKED) == 0) & (y < r + CONTACT_SLOP)
        flat[3 * i + 1] = max(y, r) if touching else y
        flags[i] = f | (np.uint32(NODE_IN_CONTACT) * touching)
        locking |= touching & ((f & NODE_LOCK_ON_CONTACT) != 0)
    if locking:  # each node that touched just now and locks on contact: locked where it stands
        for i in range(nodes.count):
            f = flags[i]
            if f & NODE_LOCK_ON_CONTACT and not f & NODE_LOCKED and pos[i, 1] < radius[i] + CONTACT_SLOP:
                flags[i] = f | NODE_LOCKED
                for k in range(3):
                    lock_pos[i, k] = pos[i, k]


@kernel_helper(nogil=True)
def lift_out_of_ground(nodes):
    """Every free node more than GROUND_SLOP in the ground up onto it: the last word of a step
    (the collide system's; the passes after the last ground pass may push nodes in).

    It comes up at rest (``prev`` with it), as a node the ground stops: lifted with ``prev``
    left below, it would fly out next step with the whole depth as speed. It marks no
    contact and locks nothing (the ground passes do that)."""
    pos, prev, radius, flags = nodes.pos, nodes.prev, nodes.radius, nodes.flags
    for i in range(nodes.count):
        r = radius[i]
        if pos[i, 1] < r - GROUND_SLOP and not flags[i] & NODE_LOCKED:
            pos[i, 1] = r
            prev[i, 1] = max(prev[i, 1], r)


@kernel_helper(nogil=True)
def relax_once(c):
    """One relaxation pass over the :class:`Constraints` ``c``: limits, axles, the ground, then
    links (and grab joints)."""
    # links last: they are the constraints we most want exact after a pass
    limits_pass(c)
    project_axles(c.nodes, c.axles)
    project_ground(c.nodes)
    links_pass(c)


@kernel_helper(nogil=True)
def named_constraints(args) -> Constraints:
    """The :class:`Constraints` of :func:`constraints_of`'s plain tuples. (A helper: its entry point
    for Python, unboxing some forty arrays, was two thirds of its 0.8 s compile.)"""
    return Constraints(
        NodeColumns(*args[0]),
        LinkColumns(*args[1]),
        LimitColumns(*args[2]),
        AxleColumns(*args[3]),
        BodyPlan(*args[4]),
        args[5],
    )


@njit(cache=True, nogil=True)
def solve_constraints(iterations, args):
    """Gauss-Seidel relaxation of every constraint (``args``: :func:`constraints_of`), ``iterations``
    times."""
    c = named_constraints(args)
    for _ in range(iterations):
        relax_once(c)


@njit(cache=True, nogil=True)
def ease_grabs(flags, rest, min_rest, count, step):
    """Move each grab joint's length towards its standoff (``min_rest``) by at most ``step`` m,
    from either side: a hand that took hold nearer than its standoff (inside a doll it
    carries) eases back out of it. (np.clip's arithmetic, without a mask over every link.)"""
    for k in range(count):
        if flags[k] & LINK_GRAB:
            rest[k] = rest[k] + clamp(min_rest[k] - rest[k], -step, step)


class ConstrainSystem(System):
    """Projects links, grab joints, joint limits, axles and the ground plane."""

    name = "constrain"

    def run(self, ctx: StepContext) -> None:
        """Move grab joints a little towards their standoffs, then relax all constraints
        ``settings.iterations`` times."""
        dt = ctx.dt
        links = ctx.state.links
        ease_grabs(links.flags, links.rest, links.min_rest, links.count, GRAB_CLOSING * dt)
        solve_constraints(ctx.settings.iterations, constraints_of(ctx.state))
