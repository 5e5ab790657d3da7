"""collide: capsule/sphere contacts as constraints, with a grid broad phase (SPEC 2).

Reads node ``pos``/``prev``/``inv_mass`` and the collider table. Once per step a
two-level broad phase finds candidate pairs whose padded boxes overlap: a uniform grid
(spatial hash) over the boxes of whole bodies finds bodies that may touch, and only
their colliders, and those within one body, are compared (linear in the scene's size,
and its arrays small enough to stay in cache); then each
relaxation round separates every penetrating pair along the contact normal and
re-projects links and the ground, so contacts and rigid links settle together.
Writes node ``pos`` and IN_CONTACT flags, and the tactile record of each collider
(``hit_energy``, ``hit_by``: the impact kinetic energy along the normal and who hit it).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from twig_ecs.kernelmath import kernel_helper
from twig_ecs.step import StepContext
from twig_ecs.store import (
    NODE_CARRIED,
    NODE_IN_CONTACT,
    NODE_KICK,
    NODE_LOCKED,
    NODE_MOVING,
    NODE_ON_CARRIED,
    NODE_PINNED,
    NODE_SPHERE,
    columns,
)
from twig_ecs.system import System
from twig_ecs.systems.physics.constrain import (
    SETTLE_PASSES,
    NodeColumns,
    constraints_of,
    lift_out_of_ground,
    limits_pass,
    links_pass,
    named_constraints,
    nudge,
    relax_once,
    row,
    settle_shape,
)

#: Padding (m) added to every box in the broad phase so that pairs closing in during
#: the step's relaxation are still found.
BROAD_MARGIN = 0.05
#: A contact pass looks only at candidate pairs this near touching (m), measured again as their
#: nodes move (:func:`repick_moved`). 2 cm balances the passes' pairs against the measuring (5 cm:
#: 1800 near pairs in the 1000-ragdoll pile, 240 touching; 2 cm: 950 and 0.5 ms a step less; the
#: 1000 hugging: 11 500 -> 8000, 2 ms less). In exact arithmetic any margin gives the same contacts;
#: measured, 2 cm steps the 1000 pile and the 1000 hugging to the same bits as passes over every
#: candidate (NEAR_FROM above their pairs), but 1 cm does not (the pile's hash after 210 steps
#: differs): check the state hashes before changing it. (Likely why: the room counted is at the
#: start of a pass, but a contact resolved earlier in the same pass may push a node of a pair
#: left out further than that - up to half a capsule's radius - and the pair is then resolved a
#: pass later; at 1 cm there is half the room. A gate that skipped near pairs by their room at
#: the start of the pass moved the hashes of the pile and of brawl-100: docs/performance.md.)
CONTACT_MARGIN = 0.02
#: A node this far (m) from where it stood when its candidate pairs were last measured has
#: them measured again: a quarter of the margin, so that none left out can touch (:func:`repick_moved`).
REPICK_MOVE = 0.25 * CONTACT_MARGIN
#: Candidate pairs from which the contact passes pick the near ones (fewer: all of them).
NEAR_FROM = 2048
#: Closing passes of only joint limits and links after the contact rounds.
FINAL_PASSES = 4
#: Rounds of a contact pass and a held thing's shape (``settle_shape``) after those.
SETTLE_ROUNDS = 4
#: A contact is resolved only where the contact points can move: their mobility (inverse mass
#: seen through the lever s, 1 - s) must be at least this share of the nodes' own - a lever of
#: 0.1 - else the free end would be swung depth / lever per pass.
MIN_LEVER = 0.0025
#: Share of its closing speed a loose ball keeps, back out, when it meets a fixed body (a
#: fence, a post, the bench): a playground ball off boards. Other contacts end the closing
#: motion (Verlet projection); so did this one, and a kicked ball lay where it hit the fence.
BALL_BOUNCE = 0.5
#: m/s: a ball meeting a fixed body slower than this does not bounce (a ball at rest against
#: a fence, or rolled up to it, stays there instead of trembling)
BOUNCE_FROM = 0.5
#: Broad-phase grid cell edge (m), for the boxes of whole bodies: about a body's width
#: and a half, so a standing body sits in a few cells and a lying one in a row of them.
CELL_SIZE = 1.0


class ContactColumns(NamedTuple):
    """The collider columns the contact passes read, and the tactile record they write."""

    a: np.ndarray  # node rows of each capsule's ends (a == b: a sphere)
    b: np.ndarray
    radius: np.ndarray  # m
    hit_energy: np.ndarray  # J: the largest impact this step (written)
    hit_by: np.ndarray  # the collider that delivered it (written)
    body: np.ndarray  # the collider's body row
    count: int


def contacts_of(state) -> tuple:
    """The store's collider columns for :func:`solve_collisions` (``store.columns``)."""
    return columns(ContactColumns, state.colliders)


@njit(cache=True, inline="always")
def cell_hash(ix, iy, iz, mask):
    h = (ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)
    return h & mask


@njit(cache=True, inline="always")
def _boxes_overlap(lo, hi, i, lo2, hi2, j):
    """Does box i of (lo, hi) overlap box j of (lo2, hi2)?"""
    # `&`, not `and`: without the short-circuit branches numba's code is ~15x faster here
    # (the broad phase's tests go either way at random; same answers)
    return ((lo[i, 0] <= hi2[j, 0]) & (lo2[j, 0] <= hi[i, 0]) & (lo[i, 1] <= hi2[j, 1])
            & (lo2[j, 1] <= hi[i, 1]) & (lo[i, 2] <= hi2[j, 2]) & (lo2[j, 2] <= hi[i, 2]))  # fmt: skip


@njit(cache=True, nogil=True)
def collider_boxes(pos, flags, col_a, col_b, col_r, col_body, n_col, n_bodies, margin, lo, hi, body_lo,
                   body_hi, body_start, order, still):  # fmt: skip
    """Level zero of the broad phase: every collider's padded box, and each body's.

    Also groups the colliders by body: ``order[body_start[b]:body_start[b + 1]]`` are
    body b's, in collider order. A body without colliders gets an empty box (lo > hi).
    ``still[b]`` is set where every node of body b's colliders is locked (a fence panel).
    """
    for b in range(n_bodies):
        for k in range(3):
            body_lo[b, k] = np.inf
            body_hi[b, k] = -np.inf
        body_start[b + 1] = 0
        still[b] = True
    body_start[0] = 0
    for c in range(n_col):
        a = col_a[c]
        b = col_b[c]
        body = col_body[c]
        if not (flags[a] & flags[b] & NODE_LOCKED):
            still[body] = False
        pad = col_r[c] + margin
        for k in range(3):
            lo[c, k] = min(pos[a, k], pos[b, k]) - pad
            hi[c, k] = max(pos[a, k], pos[b, k]) + pad
            body_lo[body, k] = min(body_lo[body, k], lo[c, k])
            body_hi[body, k] = max(body_hi[body, k], hi[c, k])
        body_start[body + 1] += 1
    for b in range(n_bodies):
        body_start[b + 1] += body_start[b]
    for c in range(n_col):  # place each, moving its body's start on; then shift back
        body = col_body[c]
        order[body_start[body]] = c
        body_start[body] += 1
    for b in range(n_bodies, 0, -1):
        body_start[b] = body_start[b - 1]
    body_start[0] = 0


#: Bits of the hash sorted at once by :func:`sort_by_hash` (a count table that stays in cache).
RADIX_BITS = 11


@njit(cache=True, nogil=True)
def sort_by_hash(keys, bits):
    """The order of ``keys`` (each below ``2**bits``), equal keys in index order: a stable
    LSD radix sort, ``RADIX_BITS`` at a time. Returns (the indices, the keys in that order).

    Counting the entries straight into ``2**bits`` buckets needs a table of that many (at
    10 000 bodies 4 MB, zeroed, summed and walked every step, and every entry a cache miss
    into it); a table of 2048 per pass stays in L1, and the passes read and write in order.
    """
    n = len(keys)
    idx = np.arange(n)
    key = keys.copy()
    idx2 = np.empty(n, np.int64)
    key2 = np.empty(n, np.int64)
    count = np.empty((1 << RADIX_BITS) + 1, np.int64)
    shift = 0
    while shift < bits:
        width = min(RADIX_BITS, bits - shift)
        mask = (1 << width) - 1
        count[: mask + 2] = 0
        for e in range(n):
            count[((key[e] >> shift) & mask) + 1] += 1
        for r in range(mask + 1):
            count[r + 1] += count[r]
        for e in range(n):
            d = (key[e] >> shift) & mask
            at = count[d]
            idx2[at] = idx[e]
            key2[at] = key[e]
            count[d] = at + 1
        idx, idx2 = idx2, idx
        key, key2 = key2, key
        shift += width
    return idx, key


@njit(cache=True, nogil=True)
def body_pairs(lo, hi, n, cell, cl, ch, bits, entry_box, entry_cell, out, still):
    """Pairs of overlapping boxes among ``n`` (the bodies), via a spatial hash grid of
    ``2**bits`` buckets; none of two ``still`` bodies (all their contact points pinned:
    no contact of theirs can move anything, and fence panels meeting at a post would be 39
    pairs each, nine in ten of the schoolyard's).

    ``cl``/``ch`` (n x 3), ``entry_box``, ``entry_cell`` are scratch arrays (the entries at
    least as many as box-cells). Writes up to ``len(out)`` pairs (i < j) and returns how many
    there are in all, or -1 when the entry arrays are too short; the caller grows and calls
    again. The pairs come bucket by bucket, and within one in the order the boxes entered it
    (box by box, cell by cell): the entries sorted by bucket (:func:`sort_by_hash`).
    """
    n_entries = 0
    for c in range(n):
        if lo[c, 0] > hi[c, 0]:  # an empty box: no cells
            for k in range(3):
                cl[c, k] = 0
                ch[c, k] = -1
            continue
        for k in range(3):
            cl[c, k] = int(math.floor(lo[c, k] / cell))
            ch[c, k] = int(math.floor(hi[c, k] / cell))
        n_entries += (ch[c, 0] - cl[c, 0] + 1) * (ch[c, 1] - cl[c, 1] + 1) * (ch[c, 2] - cl[c, 2] + 1)
    if n_entries > len(entry_box):
        return -1
    hmask = (1 << bits) - 1
    keys = np.empty(n_entries, np.int64)
    cells = np.empty((n_entries, 3), np.int64)
    boxes = np.empty(n_entries, np.int64)
    e = 0
    for c in range(n):
        for ix in range(cl[c, 0], ch[c, 0] + 1):
            for iy in range(cl[c, 1], ch[c, 1] + 1):
                for iz in range(cl[c, 2], ch[c, 2] + 1):
                    keys[e] = cell_hash(ix, iy, iz, hmask)
                    boxes[e] = c
                    cells[e, 0] = ix
                    cells[e, 1] = iy
                    cells[e, 2] = iz
                    e += 1
    # (no n_entries argument: an integer counted up from a literal 0 had numba compile
    # sort_by_hash twice, for the literal and for an integer)
    by_bucket, bucket = sort_by_hash(keys, bits)
    for e in range(n_entries):  # the entries in bucket order
        f = by_bucket[e]
        entry_box[e] = boxes[f]
        entry_cell[e, 0] = cells[f, 0]
        entry_cell[e, 1] = cells[f, 1]
        entry_cell[e, 2] = cells[f, 2]
    n_out = 0
    cap = out.shape[0]
    first = 0
    while first < n_entries:  # one bucket: entries first..last - 1
        last = first + 1
        while last < n_entries and bucket[last] == bucket[first]:
            last += 1
        for e1 in range(first, last):
            i = entry_box[e1]
            for e2 in range(e1 + 1, last):
                j = entry_box[e2]
                if (i == j) | (still[i] & still[j]) or not _boxes_overlap(lo, hi, i, lo, hi, j):
                    continue
                # count each pair once: in the cell holding the low corner of the overlap
                # (both entries must be that very cell, not another one sharing the bucket)
                ox = max(cl[i, 0], cl[j, 0])
                oy = max(cl[i, 1], cl[j, 1])
                oz = max(cl[i, 2], cl[j, 2])
                if not (
                    (entry_cell[e1, 0] == ox)
                    & (entry_cell[e1, 1] == oy)
                    & (entry_cell[e1, 2] == oz)
                    & (entry_cell[e2, 0] == ox)
                    & (entry_cell[e2, 1] == oy)
                    & (entry_cell[e2, 2] == oz)
                ):
                    continue  # fmt: skip
                if n_out < cap:
                    out[n_out, 0] = min(i, j)
                    out[n_out, 1] = max(i, j)
                n_out += 1
        first = last
    return n_out


@njit(cache=True, nogil=True)
def collider_pairs(col_local, col_mask, col_ignore, n_bodies, lo, hi, body_lo, body_hi, body_start, order,
                   bpairs, n_bpairs, pairs):  # fmt: skip
    """Level two of the broad phase: collider pairs whose padded boxes overlap.

    Looks only inside each body (its non-adjacent links) and between the body pairs
    ``bpairs[:n_bpairs]`` found by :func:`body_pairs`, and there only at colliders
    reaching into the other body's box. ``lo``/``hi`` hold the collider boxes,
    ``order`` the colliders grouped by body from ``body_start``. Writes up to
    ``len(pairs)`` pairs and returns how many there are in all.
    """
    n_pairs = 0
    cap = pairs.shape[0]
    for b in range(n_bodies):  # within one body: masks say which pairs are joints
        for e1 in range(body_start[b], body_start[b + 1]):
            i = order[e1]
            if col_mask[i] == np.uint64(0xFFFFFFFFFFFFFFFF):
                continue  # collides with nothing of its own body
            for e2 in range(e1 + 1, body_start[b + 1]):
                j = order[e2]
                if (col_mask[i] >> np.uint64(col_local[j])) & np.uint64(1):
                    continue
                if _boxes_overlap(lo, hi, i, lo, hi, j):
                    if n_pairs < cap:
                        pairs[n_pairs, 0] = min(i, j)
                        pairs[n_pairs, 1] = max(i, j)
                    n_pairs += 1
    most = 0
    for b in range(n_bodies):
        most = max(most, body_start[b + 1] - body_start[b])
    reach_p = np.empty(most, dtype=np.int64)  # q's colliders that reach into p's box, in order
    for k in range(n_bpairs):
        p = bpairs[k, 0]
        q = bpairs[k, 1]
        # only q's colliders reaching into p's box can overlap one of p's: pick them once
        # per body pair (each i of p below met all of q's before; the pairs and their order
        # are the same)
        n_reach = 0
        for e2 in range(body_start[q], body_start[q + 1]):
            j = order[e2]
            held_by_p = col_ignore[j, 0] == p or col_ignore[j, 1] == p
            if not held_by_p and _boxes_overlap(lo, hi, j, body_lo, body_hi, p):
                reach_p[n_reach] = j
                n_reach += 1
        if n_reach == 0:
            continue
        for e1 in range(body_start[p], body_start[p + 1]):
            i = order[e1]
            if col_ignore[i, 0] == q or col_ignore[i, 1] == q:
                continue  # it holds (or is held by) that body
            if not _boxes_overlap(lo, hi, i, body_lo, body_hi, q):
                continue
            for e2 in range(n_reach):
                j = reach_p[e2]
                if not _boxes_overlap(lo, hi, i, lo, hi, j):
                    continue
                if col_ignore[j, 0] == -2 - i or col_ignore[j, 1] == -2 - i:
                    continue  # one capsule of what a hand holds and that arm's (see ignore_collider)
                if col_ignore[i, 0] == -2 - j or col_ignore[i, 1] == -2 - j:
                    continue
                if n_pairs < cap:
                    pairs[n_pairs, 0] = min(i, j)
                    pairs[n_pairs, 1] = max(i, j)
                n_pairs += 1
    return n_pairs


@njit(cache=True, nogil=True)
def closest_segment_params(p1, q1, p2, q2):
    """Parameters (s, t) of the closest points of segments p1q1 and p2q2 (Ericson 5.1.9)."""
    d1x = q1[0] - p1[0]
    d1y = q1[1] - p1[1]
    d1z = q1[2] - p1[2]
    d2x = q2[0] - p2[0]
    d2y = q2[1] - p2[1]
    d2z = q2[2] - p2[2]
    return _closest_params(d1x, d1y, d1z, d2x, d2y, d2z, p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2])


# The contact passes call this, not closest_segment_params: a row of pos handed to a call is a
# new array view, and each (with its reference counting) cost more than the arithmetic - the
# hugging crowd's collide step 14.4 -> 8.5 ms with the rows read here instead (same bits).
@njit(cache=True, inline="always")
def closest_rows(pos, a, b, c, d):
    """:func:`closest_segment_params` of the segments from node rows ``a``-``b`` and ``c``-``d``."""
    d1x = pos[b, 0] - pos[a, 0]
    d1y = pos[b, 1] - pos[a, 1]
    d1z = pos[b, 2] - pos[a, 2]
    d2x = pos[d, 0] - pos[c, 0]
    d2y = pos[d, 1] - pos[c, 1]
    d2z = pos[d, 2] - pos[c, 2]
    return _closest_params(d1x, d1y, d1z, d2x, d2y, d2z, pos[a, 0] - pos[c, 0], pos[a, 1] - pos[c, 1],
                           pos[a, 2] - pos[c, 2])  # fmt: skip


@njit(cache=True, inline="always")
def _closest_params(d1x, d1y, d1z, d2x, d2y, d2z, rx, ry, rz):
    """(s, t) of :func:`closest_segment_params` from the segments' directions d1, d2 and the
    offset r = p1 - p2 of their starts."""
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-12
    if a <= eps and e <= eps:
        return 0.0, 0.0
    if a <= eps:
        return 0.0, min(max(f / e, 0.0), 1.0)
    c = d1x * rx + d1y * ry + d1z * rz
    if e <= eps:
        return min(max(-c / a, 0.0), 1.0), 0.0
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > eps else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@njit(cache=True, nogil=True)
def capsule_gaps(pa, qa, ra, pb, qb, rb):
    """Surface distances (m) between every capsule a (rows of pa, qa, ra) and every capsule
    b (pb, qb, rb), an (a, b) table; < 0 overlaps. The contact solver's closest points, for
    measuring how deep one body sinks into another."""
    out = np.empty((pa.shape[0], pb.shape[0]))
    for i in range(pa.shape[0]):
        for j in range(pb.shape[0]):
            s, t = closest_segment_params(pa[i], qa[i], pb[j], qb[j])
            dx = (pa[i, 0] + s * (qa[i, 0] - pa[i, 0])) - (pb[j, 0] + t * (qb[j, 0] - pb[j, 0]))
            dy = (pa[i, 1] + s * (qa[i, 1] - pa[i, 1])) - (pb[j, 1] + t * (qb[j, 1] - pb[j, 1]))
            dz = (pa[i, 2] + s * (qa[i, 2] - pa[i, 2])) - (pb[j, 2] + t * (qb[j, 2] - pb[j, 2]))
            out[i, j] = math.sqrt(dx * dx + dy * dy + dz * dz) - ra[i] - rb[j]
    return out


@njit(cache=True, inline="always")
def _felt_weight(inv_mass, flags, i):
    """Inverse mass for impact energy: 0 only when locked (a moving node has its mass)."""
    return 0.0 if flags[i] & NODE_LOCKED else inv_mass[i]


#: Rounding allowance (m) of :func:`_segments_apart`: the contact solver's closest points are
#: interpolated between the nodes, a few ulps of a position (1e-13 m at 100 m) off their box.
APART_SLACK = 1e-6


@njit(cache=True, inline="always")
def _segments_apart(pos, a, b, c, d, gap):
    """Are the boxes of segments a-b and c-d (node rows) more than ``gap`` (m) apart along an
    axis? Then so are the segments (by ``gap`` less :data:`APART_SLACK`): the cheap test that
    spares the near-pair measures the closest points of most candidate pairs (the broad phase's
    boxes are loose: the 1000 hugging, 28 000 candidates a step, 4600 near)."""
    gap = gap + APART_SLACK
    out = False
    for k in range(3):
        lo_1 = min(pos[a, k], pos[b, k])
        hi_1 = max(pos[a, k], pos[b, k])
        lo_2 = min(pos[c, k], pos[d, k])
        hi_2 = max(pos[c, k], pos[d, k])
        out |= (lo_2 - hi_1 > gap) | (lo_1 - hi_2 > gap)
    return out


@kernel_helper(nogil=True)
def resolve_contacts(nodes: NodeColumns, cols: ContactColumns, pairs, n_pairs, record, dt):
    """One pass over candidate pairs: separate penetrating capsules along the normal.

    Each capsule's end nodes move in proportion to their share of the contact point
    (s, 1-s) and inverse mass, so the correction is equal and opposite (momentum kept).
    With ``record`` set, the impact energy 1/2 mu u^2 (u: closing speed along the normal,
    mu: reduced mass at the contact) is written to the tactile record of the struck side
    (the one that contributed less of the closing speed). Returns the
    largest penetration (m) met in this pass.
    """
    pos, prev, inv_mass, flags = nodes.pos, nodes.prev, nodes.inv_mass, nodes.flags
    col_a, col_b, col_r, hit_energy, hit_by = cols.a, cols.b, cols.radius, cols.hit_energy, cols.hit_by
    body = cols.body
    worst = 0.0
    for k in range(n_pairs):
        i = row(pairs[k, 0])  # (unsigned: see constrain.row)
        j = row(pairs[k, 1])
        a = row(col_a[i])
        b = row(col_b[i])
        c = row(col_a[j])
        d = row(col_b[j])
        # (no box test first, as the near-pair measures make: of the near pairs it passes one in
        # ten - the 1000 hugging: 700 of 7500 - and costs the others more than it spares those;
        # a pair it would pass lies further apart than its reach at these points too)
        s, t = closest_rows(pos, a, b, c, d)
        px = pos[a, 0] + s * (pos[b, 0] - pos[a, 0])
        py = pos[a, 1] + s * (pos[b, 1] - pos[a, 1])
        pz = pos[a, 2] + s * (pos[b, 2] - pos[a, 2])
        qx = pos[c, 0] + t * (pos[d, 0] - pos[c, 0])
        qy = pos[c, 1] + t * (pos[d, 1] - pos[c, 1])
        qz = pos[c, 2] + t * (pos[d, 2] - pos[c, 2])
        nx = px - qx
        ny = py - qy
        nz = pz - qz
        dist = math.sqrt(nx * nx + ny * ny + nz * nz)
        depth = col_r[i] + col_r[j] - dist
        if depth <= 0.0:
            continue
        if depth > worst:
            worst = depth
        if dist > 1e-9:
            nx /= dist
            ny /= dist
            nz /= dist
        else:
            nx = 0.0
            ny = 1.0
            nz = 0.0
        # a foot mid-step is kinematic to its links but not to what it bumps into
        wa = _felt_weight(inv_mass, flags, a)
        wb = _felt_weight(inv_mass, flags, b) if b != a else 0.0
        wc = _felt_weight(inv_mass, flags, c)
        wd = _felt_weight(inv_mass, flags, d) if d != c else 0.0
        # ... except a loose ball met by a kick: the kicking foot drives on through it, the
        # leg's muscles behind it, and the ball takes the whole correction (0.65 kg of a
        # child's foot sharing it with a 0.4 kg ball sent it off at under half the foot's speed)
        ball_i = a == b and (flags[a] & NODE_SPHERE) != 0 and (flags[a] & NODE_LOCKED) == 0
        ball_j = c == d and (flags[c] & NODE_SPHERE) != 0 and (flags[c] & NODE_LOCKED) == 0
        # ... unless the ball is pressed against something fixed (a fence corner, a bench): a foot
        # driving on through it there squeezed it out upwards, the foot's whole push turned into
        # the one way left open (seed 0's ball left a fence corner at 14 m/s and rose 7 m)
        kick_i = ball_j and ((flags[a] | flags[b]) & NODE_KICK) != 0 and (flags[c] & NODE_PINNED) == 0
        kick_j = ball_i and ((flags[c] | flags[d]) & NODE_KICK) != 0 and (flags[a] & NODE_PINNED) == 0
        # a loose ball against a fixed body (every node of the other capsule locked)
        fixed_i = ball_i and (flags[c] & flags[d] & NODE_LOCKED) != 0
        fixed_j = ball_j and (flags[a] & flags[b] & NODE_LOCKED) != 0
        if fixed_i:
            flags[a] |= NODE_PINNED
        if fixed_j:
            flags[c] |= NODE_PINNED
        if kick_i:
            wa = 0.0 if flags[a] & NODE_KICK else wa
            wb = 0.0 if flags[b] & NODE_KICK else wb
        if kick_j:
            wc = 0.0 if flags[c] & NODE_KICK else wc
            wd = 0.0 if flags[d] & NODE_KICK else wd
        sa = 1.0 - s if b != a else 1.0
        tc = 1.0 - t if d != c else 1.0
        wi = sa * sa * wa + s * s * wb
        wj = tc * tc * wc + t * t * wd
        w = wi + wj
        if w <= MIN_LEVER * (wa + wb + wc + wd):
            # both contact points sit (almost) on pinned nodes - two planted feet crossed: only
            # a free end far off could move them, by depth / lever, pass after pass, and the
            # links would fling it back - energy from nowhere (the 300-crowd blow-up, frame
            # 1159). Leave that overlap until a foot lifts.
            continue
        if record:
            # closing speed of the two contact points along n
            ux = (
                sa * (pos[a, 0] - prev[a, 0])
                + s * (pos[b, 0] - prev[b, 0])
                - tc * (pos[c, 0] - prev[c, 0])
                - t * (pos[d, 0] - prev[d, 0])
            )
            uy = (
                sa * (pos[a, 1] - prev[a, 1])
                + s * (pos[b, 1] - prev[b, 1])
                - tc * (pos[c, 1] - prev[c, 1])
                - t * (pos[d, 1] - prev[d, 1])
            )
            uz = (
                sa * (pos[a, 2] - prev[a, 2])
                + s * (pos[b, 2] - prev[b, 2])
                - tc * (pos[c, 2] - prev[c, 2])
                - t * (pos[d, 2] - prev[d, 2])
            )
            closing = -(ux * nx + uy * ny + uz * nz) / dt
            if closing > 0.0:
                # energy with real masses: a foot mid-step is kinematic to the solver
                # (weight 0) but weighs what it weighs when it kicks something
                we = (
                    sa * sa * _felt_weight(inv_mass, flags, a)
                    + s * s * _felt_weight(inv_mass, flags, b)
                    + tc * tc * _felt_weight(inv_mass, flags, c)
                    + t * t * _felt_weight(inv_mass, flags, d)
                )
                if b == a:
                    we -= s * s * _felt_weight(inv_mass, flags, b)
                if d == c:
                    we -= t * t * _felt_weight(inv_mass, flags, d)
                energy = 0.5 * closing * closing / we if we > 0.0 else 0.0
                # the blow is felt by the side that was struck: the one that moved less
                # towards the other (a fist lands on a face, not the face on the fist)
                vi = -(
                    (sa * (pos[a, 0] - prev[a, 0]) + s * (pos[b, 0] - prev[b, 0])) * nx
                    + (sa * (pos[a, 1] - prev[a, 1]) + s * (pos[b, 1] - prev[b, 1])) * ny
                    + (sa * (pos[a, 2] - prev[a, 2]) + s * (pos[b, 2] - prev[b, 2])) * nz
                )
                struck, striker = (j, i) if vi * 2.0 > closing * dt else (i, j)
                if energy > hit_energy[struck]:
                    hit_energy[struck] = energy
                    hit_by[struck] = striker
                if closing > BOUNCE_FROM:
                    # a loose ball off a fixed body: its next step starts with part of the
                    # closing speed turned back along the normal (the pass moves it out of the
                    # body, which ends the closing part; its old position moved back gives the rest)
                    if fixed_i:
                        nudge(prev, a, -BALL_BOUNCE * closing * dt, nx, ny, nz)
                    elif fixed_j:
                        nudge(prev, c, BALL_BOUNCE * closing * dt, nx, ny, nz)
        # resolve at most half the thinner radius per pass: a limb found deep inside
        # another (fast motion, crossed segments with an unreliable normal) is eased
        # out over a few passes instead of being flung out in one
        cap = 0.5 * min(col_r[i], col_r[j])
        if kick_i or kick_j:
            # ... but a ball a kick drives through is eased out by half its own radius a pass:
            # it has no links to fling, and eased out 2 cm a pass (half the foot's), a 7 m/s
            # foot ended 11.7 cm inside it
            cap = 0.5 * max(col_r[i], col_r[j])
        lam = min(depth, cap) / w
        # and no node moves further than that either: a contact right by a capsule's
        # pinned end (a planted foot) would otherwise swing its free end by depth/s -
        # metres as s -> 0 - and drag the whole body after it (scaling lam keeps the
        # correction equal and opposite)
        most = max(sa * wa, s * wb, tc * wc, t * wd) * lam
        if most > cap:
            lam *= cap / most
        fa = lam * sa * wa
        fb = lam * s * wb
        fc = lam * tc * wc
        fd = lam * t * wd
        nudge(pos, a, fa, nx, ny, nz)
        nudge(pos, b, fb, nx, ny, nz)
        nudge(pos, c, -fc, nx, ny, nz)
        nudge(pos, d, -fd, nx, ny, nz)
        # a foot knocked off its ballistic path stops being kinematic to its leg's links,
        # or the leg would stretch after it - but not by a loose ball it swings through (a
        # kick goes on through a ball: stopped at the first touch, the leg gave a 0.4 kg
        # ball under 2 m/s)
        if not kick_i:
            flags[a] &= ~np.uint32(NODE_MOVING)
            flags[b] &= ~np.uint32(NODE_MOVING)
        if not kick_j:
            flags[c] &= ~np.uint32(NODE_MOVING)
            flags[d] &= ~np.uint32(NODE_MOVING)
        # a contact pushing a capsule upwards supports it: high (ground) damping, and a foot
        # may plant there. Only another body's: a knee resting on its own other thigh, or one
        # shin crossed over the other in a turn, marked the foot as standing on something and
        # it planted in mid-air. Resting on a thing a hand carries is marked too
        # (NODE_ON_CARRIED): it swings with its carrier, and a foot planted on it was left
        # standing on air (the gait plants no foot there)
        apart = body[i] != body[j]
        if ny > 0.5 and apart:
            on = NODE_IN_CONTACT | (NODE_ON_CARRIED if (flags[c] | flags[d]) & NODE_CARRIED else 0)
            flags[a] |= on
            flags[b] |= on
        elif ny < -0.5 and apart:
            on = NODE_IN_CONTACT | (NODE_ON_CARRIED if (flags[a] | flags[b]) & NODE_CARRIED else 0)
            flags[c] |= on
            flags[d] |= on
    return worst


@njit(cache=True, inline="always")
def segment_gap2(pos, a, b, c, d):
    """Squared distance between the closest points of segments ``a``-``b`` and ``c``-``d`` (node rows)."""
    s, t = closest_rows(pos, a, b, c, d)
    dist2 = 0.0
    for q in range(3):
        e = pos[a, q] + s * (pos[b, q] - pos[a, q]) - pos[c, q] - t * (pos[d, q] - pos[c, q])
        dist2 += e * e
    return dist2


@njit(cache=True, inline="always")
def _within(pos, a, b, c, d, reach):
    """Are segments a-b and c-d (node rows) closer than ``reach`` (m)?"""
    return not _segments_apart(pos, a, b, c, d, reach) and segment_gap2(pos, a, b, c, d) < reach * reach


@njit(cache=True, inline="always")
def _capsules_near(pos, col_a, col_b, col_r, i, j, margin):
    """Are colliders ``i`` and ``j`` within ``margin`` of touching (a box test first: most
    candidate pairs are surely apart)?"""
    reach = col_r[i] + col_r[j] + margin
    return _within(pos, row(col_a[i]), row(col_b[i]), row(col_a[j]), row(col_b[j]), reach)


@njit(cache=True, nogil=True)
def mark_near(pos, col_a, col_b, col_r, pairs, n_pairs, margin, is_near, near):
    """Marks in ``is_near`` the candidate pairs (first ``n_pairs`` of ``pairs``) whose capsules
    are within ``margin`` of touching and lists them in ``near``, in order; returns how many.
    The broad phase's boxes overlap for many more (a capsule's box is much wider than it; a
    crowd's bodies stand side by side): a contact pass needs to look only at these
    (:func:`repick_moved` keeps the list true as nodes move)."""
    n = 0
    for k in range(n_pairs):
        i = row(pairs[k, 0])
        j = row(pairs[k, 1])
        is_near[k] = _capsules_near(pos, col_a, col_b, col_r, i, j, margin)
        if is_near[k]:
            near[n, 0] = i
            near[n, 1] = j
            n += 1
    return n


@njit(cache=True, nogil=True)
def near_pairs(pos, col_a, col_b, col_r, pairs, n_pairs, margin):
    """The candidate pairs (first ``n_pairs`` of ``pairs``, in order) whose capsules are
    within ``margin`` of touching, and how many (:func:`mark_near` into new arrays)."""
    near = np.empty((n_pairs, 2), dtype=pairs.dtype)
    n = mark_near(pos, col_a, col_b, col_r, pairs, n_pairs, margin, np.empty(n_pairs, np.bool_), near)
    return near, n


class NearWatch(NamedTuple):
    """What :func:`repick_moved` keeps between contact passes: which candidates are near, where
    each node stood when its pairs were last measured, and scratch flags."""

    is_near: np.ndarray  # per candidate pair
    anchor: np.ndarray  # per node (n x 3)
    moved: np.ndarray  # per node, scratch
    col_moved: np.ndarray  # per collider, scratch


@njit(cache=True, nogil=True)
def repick_moved(nodes: NodeColumns, cols: ContactColumns, pairs, n_pairs, near, n_near, watch):
    """Keeps ``near`` (from :func:`mark_near`) true as nodes move; returns its new count.

    A node further than ``REPICK_MOVE`` from its ``anchor`` is anchored where it is now,
    and every candidate pair of a collider on it is measured again (the others keep their
    mark; the list stays in the candidates' order). Between two measurements of a pair no
    node of it is anchored again, so each stays within ``REPICK_MOVE`` of the anchor it had
    then and moves at most ``2 * REPICK_MOVE`` = half the margin from where it was measured:
    the gap of a pair left out closes by at most the margin by the start of a contact pass, so
    it does not touch then, and the pass does what a pass over all candidates would (a pair
    apart is skipped) unless its own contacts push a node of a pair left out further than the
    room it had (see ``CONTACT_MARGIN``).
    """
    if n_near == n_pairs:
        return n_near  # all of them are listed: nothing can be missing
    is_near, anchor, moved, col_moved = NearWatch(*watch)
    pos = nodes.pos
    limit2 = REPICK_MOVE * REPICK_MOVE
    any_moved = False
    for i in range(nodes.count):
        dx = pos[i, 0] - anchor[i, 0]
        dy = pos[i, 1] - anchor[i, 1]
        dz = pos[i, 2] - anchor[i, 2]
        moved[i] = dx * dx + dy * dy + dz * dz > limit2
        if moved[i]:
            any_moved = True
            anchor[i, 0] = pos[i, 0]
            anchor[i, 1] = pos[i, 1]
            anchor[i, 2] = pos[i, 2]
    if not any_moved:
        return n_near
    col_a, col_b, col_r = cols.a, cols.b, cols.radius
    for c in range(cols.count):
        col_moved[c] = moved[col_a[c]] | moved[col_b[c]]
    n = 0
    for k in range(n_pairs):
        i = row(pairs[k, 0])
        j = row(pairs[k, 1])
        if col_moved[i] | col_moved[j]:
            is_near[k] = _capsules_near(pos, col_a, col_b, col_r, i, j, CONTACT_MARGIN)
        if is_near[k]:
            near[n, 0] = i
            near[n, 1] = j
            n += 1
    return n


@kernel_helper(nogil=True)
def contact_pass(nodes: NodeColumns, cols: ContactColumns, pairs, n_pairs, near, n_near, watch, record, dt):
    """:func:`resolve_contacts` over the pairs :func:`repick_moved` keeps near: it does exactly
    what a pass over every candidate would. Returns how many it visited."""
    n_near = repick_moved(nodes, cols, pairs, n_pairs, near, n_near, watch)
    resolve_contacts(nodes, cols, near, n_near, record, dt)
    return n_near


@njit(cache=True, nogil=True)
def solve_collisions(contacts, pairs, n_pairs, iterations, dt, constraints, held):
    """Relaxation rounds of contacts (``contacts``: :func:`contacts_of`) then all other
    constraints (``constraints``: :func:`~twig_ecs.systems.physics.constrain.constraints_of`), then
    the shapes of the loose things hands hold (``held``: ``state.held``, see
    :func:`~twig_ecs.systems.physics.constrain.settle_shape`); returns the residual penetration."""
    cols = ContactColumns(*contacts)
    c = named_constraints(constraints)
    nodes = c.nodes
    pos, flags = nodes.pos, nodes.flags
    col_a, col_b, col_r = cols.a, cols.b, cols.radius
    for k in range(cols.count):
        cols.hit_energy[k] = 0.0
        cols.hit_by[k] = -1
    # every contact pass visits only the candidate pairs near enough to touch (a crowd's
    # candidates are mostly further apart: a hugging crowd's, five in six), and does what a
    # pass over all of them would: a pair further apart is skipped by each pass anyway
    if n_pairs >= NEAR_FROM:
        near = np.empty((n_pairs, 2), dtype=pairs.dtype)
        is_near = np.empty(n_pairs, dtype=np.bool_)
        n_near = mark_near(pos, col_a, col_b, col_r, pairs, n_pairs, CONTACT_MARGIN, is_near, near)
        anchor = pos[: nodes.count].copy()
    else:  # a small scene: a pass over them all costs less than watching for moves
        near, n_near = pairs, n_pairs
        is_near = np.ones(0, dtype=np.bool_)  # (never read: no pair is left out)
        anchor = pos[:0].copy()
    watch = (is_near, anchor, np.empty(anchor.shape[0], np.bool_), np.empty(cols.count, np.bool_))
    for it in range(iterations):
        n_near = contact_pass(nodes, cols, pairs, n_pairs, near, n_near, watch, it == 0, dt)
        relax_once(c)
    for _ in range(FINAL_PASSES):
        # limits and links once more, last: the shape constraints we most want exact;
        # a contact pass before each, so that what they undo of a contact is redone
        # (bool(False), not False: numba would compile resolve_contacts again for a literal)
        n_near = contact_pass(nodes, cols, pairs, n_pairs, near, n_near, watch, bool(False), dt)  # noqa: UP018
        limits_pass(c)
        links_pass(c)
    limits_pass(c)  # limits have the last word
    # ... but for a carried doll: its shape, settled between contact passes, so that it
    # neither stretches (a few cm links on light nodes) nor sinks into its carrier
    for _ in range(SETTLE_ROUNDS if held.shape[0] else 0):
        n_near = contact_pass(nodes, cols, pairs, n_pairs, near, n_near, watch, bool(False), dt)  # noqa: UP018
        settle_shape(nodes, c.links, held, SETTLE_PASSES)
    # and the ground the very last: the passes since its last pass push nodes into it - the
    # contacts of a body lying on a held doll pressed the doll's neck 5 cm under (goal melee);
    # the final limits pass pressed a folded knee 6 cm under
    lift_out_of_ground(nodes)
    n_near = repick_moved(nodes, cols, pairs, n_pairs, near, n_near, watch)
    # measure only: the deepest overlap left after this step's relaxation
    worst = 0.0
    for k in range(n_near):
        i = near[k, 0]
        j = near[k, 1]
        if flags[col_a[i]] & flags[col_b[i]] & flags[col_a[j]] & flags[col_b[j]] & NODE_LOCKED:
            continue  # two fixed things (fence panels meeting at a post) overlap by design
        gap2 = segment_gap2(pos, row(col_a[i]), row(col_b[i]), row(col_a[j]), row(col_b[j]))  # (one type)
        depth = col_r[i] + col_r[j] - math.sqrt(gap2)
        if depth > worst:
            worst = depth
    return worst


class CollideSystem(System):
    """Finds and resolves capsule/sphere contacts; records impacts for sensing."""

    name = "collide"

    def _array(self, key: str, shape: tuple[int, ...], dtype) -> np.ndarray:
        """A reusable scratch array with at least ``shape[0]`` rows (doubling to grow)."""
        return self.scratch.array(key, shape[0], dtype, *shape[1:2])

    def broad_phase(self) -> int:
        """Candidate collider pairs into ``state.pairs``: boxes, then body pairs, then colliders."""
        s = self.scene.state
        n, col = s.nodes, s.colliders
        nb = s.bodies.count
        lo, hi = self._array("lo", (col.count, 3), np.float64), self._array("hi", (col.count, 3), np.float64)
        body_lo, body_hi = self._array("blo", (nb, 3), np.float64), self._array("bhi", (nb, 3), np.float64)
        body_start, order = (
            self._array("bstart", (nb + 1,), np.int64),
            self._array("order", (col.count,), np.int64),
        )
        still = self._array("still", (nb,), np.bool_)
        collider_boxes(n.pos, n.flags, col.a, col.b, col.radius, col.body, col.count, nb, BROAD_MARGIN, lo,
                       hi, body_lo, body_hi, body_start, order, still)  # fmt: skip
        cl, ch = self._array("cl", (nb, 3), np.int64), self._array("ch", (nb, 3), np.int64)
        entries = 8 * nb
        while True:
            entry_box = self._array("ebox", (entries,), np.int64)
            entry_cell = self._array("ecell", (entries, 3), np.int64)
            bits = max(4, int(2 * len(entry_box) - 1).bit_length())  # 2**bits >= 2 x entries
            bpairs = self._array("bpairs", (4 * nb, 2), np.int64)
            n_bp = body_pairs(
                body_lo, body_hi, nb, CELL_SIZE, cl, ch, bits, entry_box, entry_cell, bpairs, still
            )
            if n_bp < 0:
                entries = 2 * len(entry_box)
            elif n_bp > len(bpairs):
                self._array("bpairs", (n_bp, 2), np.int64)
            else:
                break
        args = (col.local, col.mask, col.ignore, nb, lo, hi, body_lo, body_hi, body_start, order, bpairs,
                n_bp)  # fmt: skip
        n_pairs = collider_pairs(*args, s.pairs)
        if n_pairs > len(s.pairs):
            s.pairs = np.zeros((2 * n_pairs, 2), dtype=np.int32)
            n_pairs = collider_pairs(*args, s.pairs)
        return n_pairs

    def run(self, ctx: StepContext) -> None:
        """Broad phase once, then ``settings.iterations`` contact relaxation rounds."""
        dt = ctx.dt
        s = ctx.state
        col = s.colliders
        if col.count < 2:
            s.stats[0] = 0.0
        else:
            n_pairs = self.broad_phase()
            iterations = ctx.settings.iterations
            s.stats[0] = solve_collisions(contacts_of(s), s.pairs, n_pairs, iterations, dt, constraints_of(s),
                                          s.held)  # fmt: skip
            s.n_pairs = n_pairs
