"""The spatial index: where every body is on the ground this step, for every query of it.

One :class:`SpatialIndex` per world (a resource, ``SpatialIndex.of(scene)``), built at
most once a step on its first query and shared by every behaviour that asks: a hashed
grid of the ground cells of every node (:func:`ground_grid`), each body's footprint
(:func:`body_footprints`: centre, spread, static or not) and the collidable links of the
static bodies (fences, walls). Queries: the nearest node of each obstacle round a point
(steering: :func:`nearest_obstacle_nodes`) and the bodies within a distance of a point
(:meth:`SpatialIndex.bodies_near`: "who is within 2 m" without a loop over everyone).

Nothing here is world state: a snapshot keeps none of it and a restored world builds it
again on its first query.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np
from numba import njit

from twig_ecs.kernelmath import kernel_helper
from twig_ecs.store import LINK_COLLIDE, NODE_LOCKED
from twig_ecs.systems.physics.collide import cell_hash

STEP_OVER = 0.3  # m: bodies with no node higher than this are no obstacle
WIDE = 1.0  # m: a body whose nodes spread further than this from its centre is steered round as a disc


@njit(cache=True, nogil=True)
def body_footprints(pos, body, flags, n, locked, cx, cz, spread, free):
    """Per body, from its first ``n`` nodes: ground centre (``cx``, ``cz``: the mean of its
    nodes), squared spread (the furthest node from it on the ground) and how many of its
    nodes are not ``locked``. Sums in node order, as numpy's bincount does."""
    count = np.zeros(len(cx))
    cx[:] = 0.0
    cz[:] = 0.0
    spread[:] = 0.0
    free[:] = 0.0
    for i in range(n):
        b = body[i]
        count[b] += 1.0
        cx[b] += pos[i, 0]
        cz[b] += pos[i, 2]
        if flags[i] & locked == 0:
            free[b] += 1.0
    for b in range(len(cx)):
        m = max(count[b], 1.0)
        cx[b] /= m
        cz[b] /= m
    for i in range(n):
        b = body[i]
        d = (pos[i, 0] - cx[b]) ** 2 + (pos[i, 2] - cz[b]) ** 2
        if spread[b] == spread[b] and not d <= spread[b]:  # a NaN sticks, as in np.maximum
            spread[b] = d


#: Edge (m) of the ground grid steering finds obstacles in: above the usual cut-off
#: (1.8 m), so a character's disc spans at most 2 x 2 cells.
STEER_CELL = 2.0
#: The most buckets of the ground grid (a power of two, 2**16: two a node up to 2000 characters).
GRID_BITS = 16
#: A disc spanning more cells than this (a cut-off much longer than the cell) scans every node.
MAX_CELLS = 16


@kernel_helper
def _ground_bucket(x, z, cell, mask):
    """The hash bucket of the ground cell holding (x, z); a lost (non-finite) node goes in bucket 0."""
    if not (math.isfinite(x) and math.isfinite(z)):
        return 0
    return cell_hash(int(math.floor(x / cell)), 0, int(math.floor(z / cell)), mask)


@njit(cache=True, nogil=True)
def ground_grid(pos, n, cell, start, entries):
    """Bin the first ``n`` nodes by their ground cell (x, z) in a spatial hash.

    ``start`` is a power of two plus one long: bucket h holds the node rows
    ``entries[start[h]:start[h + 1]]``, in ascending order. Built once per step and
    shared by every character that steers (:func:`nearest_obstacle_nodes`).
    """
    mask = len(start) - 2
    start[:] = 0
    for i in range(n):
        h = _ground_bucket(pos[i, 0], pos[i, 2], cell, mask)
        start[h + 1] += 1
    for h in range(mask + 1):
        start[h + 1] += start[h]
    fill = start[:-1].copy()
    for i in range(n):
        h = _ground_bucket(pos[i, 0], pos[i, 2], cell, mask)
        entries[fill[h]] = i
        fill[h] += 1


@kernel_helper
def disc_buckets(x, z, radius, cell, mask, buckets):
    """The grid's buckets that the disc of ``radius`` round (x, z) touches, each once, into
    ``buckets`` (``MAX_CELLS`` long); returns how many, or 0 when the disc spans more cells
    than that (or is not finite): then scan every node."""
    lo_x, hi_x = int(math.floor((x - radius) / cell)), int(math.floor((x + radius) / cell))
    lo_z, hi_z = int(math.floor((z - radius) / cell)), int(math.floor((z + radius) / cell))
    if (hi_x - lo_x + 1) * (hi_z - lo_z + 1) > MAX_CELLS or not (math.isfinite(x) and math.isfinite(z)):
        return 0
    nb = 0
    for ix in range(lo_x, hi_x + 1):
        for iz in range(lo_z, hi_z + 1):
            h = cell_hash(ix, 0, iz, mask)
            seen = False
            for k in range(nb):  # two cells can share a bucket: take its nodes once
                if buckets[k] == h:
                    seen = True
            if not seen:
                buckets[nb] = h
                nb += 1
    return nb


@njit(cache=True, nogil=True)
def nearest_obstacle_nodes(pos, body, n, start, entries, cell, x, z, cutoff, step_over, blocked, skip,
                           best, scratch, out):  # fmt: skip
    """The nearest node of every body within ``cutoff`` of (x, z) on the ground that stands
    higher than ``step_over``, into ``out``; returns how many.

    Bodies flagged in ``blocked`` (steered round another way) and those in ``skip`` are
    left out. The candidates come from the grid cells the disc touches, in bucket order;
    the result is nevertheless the one a scan of every node in ascending order gives: of
    equally near nodes the lower row wins, and the bodies come in the order of their
    first node in reach (``scratch`` keeps it per body found; an insertion sort of the
    few bodies found replaces sorting every candidate, which cost half the query).
    ``best`` (one slot per body) must hold -1 and is left so; ``scratch`` holds as many
    as ``out``.
    """
    buckets = np.empty(MAX_CELLS, dtype=np.int64)
    nb = disc_buckets(x, z, cutoff, cell, len(start) - 2, buckets)
    full = nb == 0  # a full scan: one run of every row
    if full:
        nb = 1
    reach = cutoff**2
    count = 0
    for kb in range(nb):
        lo, hi = (0, n) if full else (start[buckets[kb]], start[buckets[kb] + 1])
        for e in range(lo, hi):
            i = e if full else entries[e]
            d2 = (pos[i, 0] - x) ** 2 + (pos[i, 2] - z) ** 2
            if not d2 < reach:
                continue
            b = body[i]
            if blocked[b] or pos[i, 1] <= step_over:
                continue
            skipped = False
            for k in range(len(skip)):
                if skip[k] == b:
                    skipped = True
            if skipped:
                continue
            j = best[b]
            if j < 0:
                best[b] = i
                out[count] = b
                scratch[count] = i
                count += 1
                continue
            dj = (pos[j, 0] - x) ** 2 + (pos[j, 2] - z) ** 2
            if d2 < dj or (d2 == dj and i < j):
                best[b] = i
            for k in range(count):  # the body's first node in reach: its lowest row
                if out[k] == b:
                    if i < scratch[k]:
                        scratch[k] = i
                    break
    for k in range(1, count):  # bodies by their first node in reach (the scan's order)
        key, b = scratch[k], out[k]
        m = k - 1
        while m >= 0 and scratch[m] > key:
            scratch[m + 1] = scratch[m]
            out[m + 1] = out[m]
            m -= 1
        scratch[m + 1] = key
        out[m + 1] = b
    for k in range(count):  # bodies to their nearest nodes; the slots back to -1
        b = out[k]
        out[k] = best[b]
        best[b] = -1
    return count


@njit(cache=True, nogil=True)
def bodies_within(pos, body, n, start, entries, cell, x, z, radius, seen, out):
    """The bodies having a node within ``radius`` of (x, z) on the ground, into ``out``
    (in the order of their first such node met); returns how many. ``seen`` (a flag per
    body) must be all False and is left so."""
    buckets = np.empty(MAX_CELLS, dtype=np.int64)
    nb = disc_buckets(x, z, radius, cell, len(start) - 2, buckets)
    full = nb == 0
    if full:
        nb = 1
    reach = radius**2
    count = 0
    for kb in range(nb):
        lo, hi = (0, n) if full else (start[buckets[kb]], start[buckets[kb] + 1])
        for e in range(lo, hi):
            i = e if full else entries[e]
            b = body[i]
            if seen[b] or not (pos[i, 0] - x) ** 2 + (pos[i, 2] - z) ** 2 < reach:
                continue
            seen[b] = True
            out[count] = b
            count += 1
    for k in range(count):
        seen[out[k]] = False
    return count


class SpatialIndex:
    """A world's spatial index (see the module docstring): built once a step, on demand."""

    def __getstate__(self) -> dict[str, Any]:
        """Nothing: every part is made again from the store on the first query."""
        return {}

    @classmethod
    def of(cls, scene) -> SpatialIndex:
        """The index of ``scene``'s world."""
        return scene.world.resource(cls)

    def per_step(self, scene, key: Hashable, make: Callable[[], Any]) -> Any:
        """``make()``, made once a step for each ``key`` (and again when the store's layout
        changes): a value several characters steering one at a time share."""
        step = (scene.frame, scene.state.version)
        kept = self.__dict__.get("_per_step")
        if kept is None or kept[0] != step:
            kept = self._per_step = (step, {})
        found = kept[1].get(key)
        if found is None:
            found = kept[1][key] = make()
        return found

    def grid(self, scene) -> tuple:
        """This step's ground grid of the nodes and the scratch arrays of a query: (start,
        entries, a -1 slot per body, scratch, out). Built on the first call of a step and shared
        by every character; nodes stand still from the collide pass until gait, which is
        when behaviours steer."""
        state = scene.state
        n = state.nodes.count
        key = (scene.frame, n, state.bodies.count)
        cached = self.__dict__.get("_grid")
        if cached is not None and cached[0] == key:
            return cached[1]
        # a power of two >= 2 x nodes, up to GRID_BUCKETS: a body's nodes share a cell or two, and
        # more buckets (4 MB at 10 000 characters) cost more to clear and sum than the queries save
        # (the answers do not depend on it: nodes of cells sharing a bucket are measured and left out)
        size = 1 << min(GRID_BITS, max(4, int(2 * n - 1).bit_length()))
        start = np.empty(size + 1, dtype=np.int64)
        entries = np.empty(max(n, 1), dtype=np.int64)
        ground_grid(state.nodes.pos, n, STEER_CELL, start, entries)
        best = np.full(state.bodies.count, -1, dtype=np.int64)
        grid = (
            start,
            entries,
            best,
            np.empty(max(n, 1), dtype=np.int64),
            np.empty(max(n, 1), dtype=np.int64),
        )
        self._grid = (key, grid)
        return grid

    def footprints(self, scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict, np.ndarray]:
        """Each body's ground centre (x, z), squared spread, whether it is WIDE, and, for a
        static body (every node locked: a fence, a wall), its collidable links, and which
        bodies are either (steered round by their shape, not their nearest node); computed
        once per step however many characters steer."""
        cached = self.__dict__.get("_footprints")
        if cached is not None and cached[0] == scene.frame:
            return cached[1]
        state = scene.state
        n_bodies = state.bodies.count
        cx, cz, spread, free = np.empty(n_bodies), np.empty(n_bodies), np.empty(n_bodies), np.empty(n_bodies)
        body_footprints(state.nodes.pos, state.nodes.body, state.nodes.flags, state.nodes.count, NODE_LOCKED,
                        cx, cz, spread, free)  # fmt: skip
        static = (free == 0) & (np.sqrt(spread) > WIDE)
        links = state.links
        walls = {}
        if static.any():  # (a crowd has none: no pass over every link)
            bodies = tuple(np.flatnonzero(static).tolist())
            # static bodies do not move and their links change only with the store's layout
            known = self.__dict__.get("_walls")
            if known is not None and known[0] == state.version and known[1] == bodies:
                walls = known[2]
            else:
                collide = (links.flags[: links.count] & LINK_COLLIDE) != 0
                walls = {b: np.flatnonzero(collide & (links.body[: links.count] == b)) for b in bodies}
                self._walls = (state.version, bodies, walls)
        wide = (np.sqrt(spread) > WIDE) & ~static
        # bodies steered round as discs or walls, not by their nearest node
        blocked = wide | static
        result = (cx, cz, spread, wide, walls, blocked)
        self._footprints = (scene.frame, result)
        return result

    def wall_links(self, scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The static bodies of :meth:`footprints` as arrays for a kernel: their rows, offsets
        into their links and the collidable links (CSR); made again only when the walls change."""
        walls = self.footprints(scene)[4]
        cached = self.__dict__.get("_wall_links")
        if cached is not None and cached[0] is walls:
            return cached[1]
        bodies = np.array(list(walls), dtype=np.int64)
        start = np.zeros(len(bodies) + 1, dtype=np.int64)
        start[1:] = np.cumsum([len(rows) for rows in walls.values()])
        links = np.concatenate([np.zeros(0, dtype=np.int64), *walls.values()]).astype(np.int64)
        self._wall_links = (walls, (bodies, start, links))
        return bodies, start, links

    def bodies_near(self, scene, point, radius: float) -> np.ndarray:
        """Body rows (``scene.state.bodies``) with a node within ``radius`` m of ``point`` on
        the ground, in the order of their first such node."""
        state = scene.state
        start, entries, *_ = self.grid(scene)
        seen = np.zeros(state.bodies.count, dtype=np.bool_)
        out = np.empty(state.bodies.count, dtype=np.int64)
        nodes = state.nodes
        count = bodies_within(nodes.pos, nodes.body, nodes.count, start, entries, STEER_CELL,
                              float(point[0]), float(point[2]), float(radius), seen, out)  # fmt: skip
        return out[:count]
