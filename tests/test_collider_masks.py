"""The collider table's self-collision masks (twig_ecs/store.py, ``rebuild_colliders``), worked
out over every pair of a body's colliders at once: the same bits as the rule says, pair by pair.

Two colliders of one body never meet when they are one, when one of them is a loner
(LINK_NO_SELF), when both are in self-collision groups that differ, or when an end of the
other is an end of this one or linked to one (not through a grab joint). A body that does not
collide with itself, or has more than 64 colliders, has every bit set.
"""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.store import LINK_COLLIDE, LINK_GRAB, LINK_NO_SELF, NODE_SPHERE

ALL_BITS = np.uint64(0xFFFFFFFFFFFFFFFF)


def masks_pair_by_pair(state) -> tuple[np.ndarray, np.ndarray]:
    """(local, mask) of every collider, by the rule applied to one pair at a time."""
    n, lk = state.nodes, state.links
    link_rows = np.flatnonzero(lk.flags[: lk.count] & LINK_COLLIDE)
    node_rows = np.flatnonzero(n.flags[: n.count] & NODE_SPHERE)
    a = np.concatenate([lk.a[link_rows], node_rows])
    b = np.concatenate([lk.b[link_rows], node_rows])
    body = np.concatenate([lk.body[link_rows], n.body[node_rows]])
    loner = np.concatenate([(lk.flags[link_rows] & LINK_NO_SELF) != 0, np.zeros(len(node_rows), bool)])
    group = np.concatenate([lk.group[link_rows], np.zeros(len(node_rows), np.int32)])
    linked = {(int(u), int(v)) for u, v, f in zip(lk.a[: lk.count], lk.b[: lk.count], lk.flags[: lk.count],
                                                 strict=True) if not f & LINK_GRAB}  # fmt: skip
    linked |= {(v, u) for u, v in linked}

    def near(end: int, i: int) -> bool:
        return end in (a[i], b[i]) or (int(a[i]), int(end)) in linked or (int(b[i]), int(end)) in linked

    local, mask = np.zeros(len(body), np.int64), np.zeros(len(body), np.uint64)
    for owner in np.unique(body):
        members = np.flatnonzero(body == owner)
        closed = not state.bodies.self_collide[owner] or len(members) > 64
        for k, i in enumerate(members):
            local[i] = min(k, 63)
            if closed or loner[i]:
                mask[i] = ALL_BITS
                continue
            bits = 0
            for kk, j in enumerate(members):
                apart = group[i] and group[j] and group[i] != group[j]
                if kk == k or loner[j] or apart or near(a[j], i) or near(b[j], i):
                    bits |= 1 << kk
            mask[i] = np.uint64(bits)
    return local, mask


@pytest.mark.parametrize("scene_name, seconds", [("schoolyard", 0.0), ("playground", 0.0), ("melee", 3.0)])
def test_self_collision_masks_are_the_rule_pair_by_pair(scene_name, seconds):
    with Scene.load(scene_name) as scene:
        scene.run(seconds)  # (the melee's grapples hold on by grab joints by then)
        state = scene.state
        state.rebuild_colliders()
        count = state.colliders.count
        local, mask = masks_pair_by_pair(state)
        assert count > 100
        assert np.array_equal(state.colliders.local[:count], local)
        assert np.array_equal(state.colliders.mask[:count], mask)
        assert (mask != ALL_BITS).any() and (mask == ALL_BITS).any()  # both kinds are there
