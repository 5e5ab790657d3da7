"""Picking: what is under the mouse cursor, in the world.

A cursor position becomes a ray from the camera's eye (:func:`cursor_ray`); the ray
meets a body part (:func:`pick_node`: the node whose sphere, or whose link's capsule,
the ray passes through first) or the ground (:func:`ground_point`). Every body can be
picked, fixed ones (a bench, a fence post) too: they are command targets (``sit(on)``),
though the mouse spring cannot move them (:func:`is_fixed`). Cursor positions are
pyglet's: window pixels from the bottom-left corner.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.store import LINK_VISIBLE, NODE_LOCKED

#: Extra radius (m) a node or link counts as having for the cursor: thin arms are hard to hit.
PICK_SLACK = 0.04
#: A press whose ray passes this close (m) to a movable part without hitting it was aimed at
#: that part (a grab that missed: easy on the jerky picture of 4-6 fps), not at the ground:
#: its drag must not turn the view. About half a body's width.
NEAR_MISS = 0.4


@dataclass(frozen=True)
class Pick:
    """A body part under the cursor: the body's name, the node's name and row, the hit point."""

    body: str
    node: str
    row: int
    point: np.ndarray  # where the ray met the part (m)
    distance: float  # along the ray from the eye (m)


def cursor_ray(camera, x: float, y: float, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The eye and the unit direction of the ray through window pixel ``(x, y)`` (y up)."""
    width, height = max(1, size[0]), max(1, size[1])
    inverse = np.linalg.inv(camera.view_projection(width / height))
    ndc_x, ndc_y = 2.0 * x / width - 1.0, 2.0 * y / height - 1.0
    ends = []
    for depth in (-1.0, 1.0):
        p = inverse @ np.array([ndc_x, ndc_y, depth, 1.0])
        ends.append(p[:3] / p[3])
    direction = ends[1] - ends[0]
    return camera.eye.copy(), direction / np.linalg.norm(direction)


def ground_point(eye: np.ndarray, direction: np.ndarray) -> np.ndarray | None:
    """Where the ray meets the ground plane y = 0 in front of the eye (None: it looks up)."""
    if direction[1] >= -1e-6:
        return None
    t = -eye[1] / direction[1]
    return eye + t * direction


def _segment_hits(eye, direction, a, b, radius) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per segment ab: the ray parameter and segment parameter of their closest approach,
    and the gap between them (arrays; the standard two-line closest-point formulas)."""
    d2 = b - a
    r = eye - a
    aa = 1.0
    bb = d2 @ direction
    cc = np.einsum("ij,ij->i", d2, d2)
    dd = r @ direction
    ee = np.einsum("ij,ij->i", d2, r)
    denom = aa * cc - bb * bb
    s = np.where(cc > 1e-12, np.clip((bb * dd - aa * ee) / np.where(np.abs(denom) > 1e-12, denom, 1.0),
                                     0.0, 1.0), 0.0)  # fmt: skip
    s = np.where(np.abs(denom) > 1e-12, s, 0.0)
    t = np.maximum(0.0, bb * s - dd)
    gap = np.linalg.norm(eye + t[:, None] * direction - (a + s[:, None] * d2), axis=1) - radius
    return t, s, gap


def pick_node(scene, eye: np.ndarray, direction: np.ndarray, movable_only: bool = False,
              slack: float = PICK_SLACK) -> Pick | None:  # fmt: skip
    """The body part the ray meets first: a node, or the nearer end of a link it passes through.

    Every node counts, locked ones (a fence post, a bench) included: what the cursor is on
    is what a click chose. With ``movable_only`` locked nodes are skipped (the parts a mouse
    spring could move). ``slack``: extra radius (m) every part counts as having.
    """
    state = scene.state
    n, lk = state.nodes, state.links
    count = n.count
    if count == 0:
        return None
    pos = n.pos[:count]
    free = (n.flags[:count] & NODE_LOCKED) == 0 if movable_only else np.ones(count, bool)
    best: tuple[float, int, np.ndarray] | None = None
    t, _, gap = _segment_hits(eye, direction, pos, pos, n.radius[:count] + slack)
    hit = np.flatnonzero((gap <= 0.0) & free)
    if len(hit):
        k = hit[np.argmin(t[hit])]
        best = (float(t[k]), int(k), eye + t[k] * direction)
    if lk.count:
        a, b = lk.a[: lk.count], lk.b[: lk.count]
        visible = (lk.flags[: lk.count] & LINK_VISIBLE) != 0  # not stiffeners or grab joints
        t, s, gap = _segment_hits(eye, direction, pos[a], pos[b], lk.radius[: lk.count] + slack)
        node = np.where(s < 0.5, a, b)
        ok = (gap <= 0.0) & visible & free[node]
        hit = np.flatnonzero(ok)
        if len(hit):
            k = hit[np.argmin(t[hit])]
            if best is None or t[k] < best[0]:
                best = (float(t[k]), int(node[k]), eye + t[k] * direction)
    if best is None:
        return None
    distance, row, point = best
    body_entity = int(state.bodies.entity[n.body[row]])
    name = scene.name_of(body_entity)
    handle = scene.entity(name)
    node_name = handle.node_names[row - handle.body.node_start]
    return Pick(name, node_name, row, point, distance)


def is_fixed(scene, pick: Pick) -> bool:
    """Is the picked node locked in place (a bench, a fence post: no spring can move it)?"""
    return bool(scene.state.nodes.flags[pick.row] & NODE_LOCKED)


def near_miss(scene, eye: np.ndarray, direction: np.ndarray) -> Pick | None:
    """The movable part the ray passes within :data:`NEAR_MISS` of, when it hits none."""
    return pick_node(scene, eye, direction, movable_only=True, slack=NEAR_MISS)
