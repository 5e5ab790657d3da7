"""Grab joints and store surgery: the rows and entities that must change together.

A grab joint is a link row in the store (flagged :data:`~twig_ecs.store.LINK_GRAB`) plus
a :class:`~twig_ecs.components.GrabJoint` entity. Making one, removing one and removing a
body all move store rows, so every component holding a row index is rewritten here, in
one place, right after the store moves them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twig_ecs.components import Body, Character, GrabJoint
from twig_ecs.errors import TwigError
from twig_ecs.events import Grabbed, Released
from twig_ecs.kernelmath import HANG
from twig_ecs.store import LINK_GRAB, LINK_OFF, LayoutCache, gripped_nodes

if TYPE_CHECKING:
    from twig_ecs.handles import BodyHandle
    from twig_ecs.step import SceneView
    from twig_ecs.world import World

#: Steps (1/3 s) that an arm and what it let go of keep ignoring each other in collisions.
RELEASE_GRACE_STEPS = 20
#: m a grip may be pulled beyond its length before it gives way (:func:`slip`): the grab
#: joint's, or that of a link at either end (the arm that holds, the held thing's limb). In
#: five minutes of the schoolyard (a carried doll, a merry-go-round's bars) the worst is 4.7 cm
#: (seeds 0-3).
GRIP_SLIP = 0.10


def join(scene: SceneView, h: BodyHandle, node: str, t: BodyHandle, target_node: str, standoff: float) -> int:
    """Add a closing link from ``h``'s ``node`` to ``t``'s ``target_node``; returns the joint's entity.

    See :meth:`Scene.grab <twig_ecs.scene.Scene.grab>`.
    """
    if h.entity == t.entity:
        raise TwigError(f"'{h.name}' cannot grab itself")
    state = scene.state
    a, b = h.node_row(node), t.node_row(target_node)
    links = state.links
    row = links.allocate(1).start
    links.a[row], links.b[row] = a, b
    # the joint starts at the nodes' distance and closes at GRAB_CLOSING m/s (see
    # ConstrainSystem): a hand pulls the thing in, it does not snap to it
    links.rest[row] = float(np.linalg.norm(state.nodes.pos[a] - state.nodes.pos[b]))
    links.min_rest[row] = max(0.0, float(standoff))
    links.flags[row] = LINK_GRAB
    links.body[row] = h.body.index
    entity = scene.world.create_entity(GrabJoint(row, h.entity, t.entity))
    links.entity[row] = entity
    state.version += 1
    state.colliders_dirty = True  # the hand and what it holds stop colliding
    scene.emit(Grabbed(entity, h.entity, t.entity, node))
    return entity


def release(scene: SceneView, grab: int) -> None:
    """Remove the grab joint ``grab`` (its entity): its link row, its entity and who held it."""
    joint = scene.world.try_component(grab, GrabJoint)
    if joint is None:
        raise TwigError(f"no grab joint {grab}")
    state = scene.state
    links = state.links
    # the hand slides back out of what it held without being flung off it
    state.release_grace(links.a[joint.index], links.b[joint.index], RELEASE_GRACE_STEPS)
    keep = np.ones(links.count, dtype=bool)
    keep[joint.index] = False
    remap = links.keep(keep)
    scene.emit(Released(grab, joint.holder, joint.held))
    scene.world.delete_entity(grab, immediate=True)
    for _, character in scene.world.get_component(Character):
        character.holding = {h: g for h, g in character.holding.items() if g != grab}
    for _, other in scene.world.get_component(GrabJoint):
        other.index = int(remap[other.index])
    for _, body in scene.world.get_component(Body):
        if body.link_count:
            body.link_start = int(remap[body.link_start])
    state.rebuild_colliders()


#: Per store: :func:`_grip_links`' answer, which changes only when rows are added or removed
#: (``state.version``).
_GRIPS = LayoutCache()


def _grip_links(state) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """The grab joints' link rows (ints), the other links (not grab joints) with an end at a
    gripped node, both in row order, then the two together, and every such link's two end
    nodes (a, b, a, b...: the grab joints first) as an index array and as ints; found again
    only when the store's layout changes (a pass over every link - the fence's boards too - cost
    more than the rest of :func:`slip`)."""
    links = state.links
    return _GRIPS.get(state, (state.version, links.count, state.nodes.count), lambda: _find_grip_links(state))


def _find_grip_links(state) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """:func:`_grip_links`, found afresh."""
    links = state.links
    count = links.count
    a, b, flags = links.a[:count], links.b[:count], links.flags[:count]
    rows = np.flatnonzero(flags & LINK_GRAB)
    gripped = gripped_nodes(state)
    near = np.flatnonzero((gripped[a] | gripped[b]) & ((flags & LINK_GRAB) == 0))
    both = np.concatenate([rows, near])
    ends = np.stack([a[both], b[both]], axis=1).reshape(-1).astype(np.int64)
    return rows.tolist(), near, both, ends, ends.tolist()


def _np_max(x: float, y: float) -> float:
    """``np.maximum`` of two floats: the larger, NaN if either is."""
    return x if x >= y or x != x else y


def grip_tensions(state) -> list[tuple[int, float]]:
    """(link row, tension in m) of every grab joint, in row order: how far it, or a rigid link at
    either of its ends, is pulled beyond its length, whichever is more (:func:`slip`)."""
    links = state.links
    rows, near, both, ends, nodes = _grip_links(state)
    if not rows:
        return []
    # a grip or two and the few links at its ends, in plain floats (numpy's per-call cost on
    # arrays of a few rows was most of a schoolyard step's share); the lengths are summed as
    # np.linalg.norm sums a row, ((x^2 + y^2) + z^2), so every figure is numpy's
    at = state.nodes.pos[ends].tolist()
    rest = links.rest[both].tolist()
    flags = links.flags[near].tolist()
    stretch = []
    for k in range(len(both)):
        (ax, ay, az), (bx, by, bz) = at[2 * k], at[2 * k + 1]
        dx, dy, dz = ax - bx, ay - by, az - bz
        stretch.append(math.sqrt((dx * dx + dy * dy) + dz * dz) - rest[k])
    # the worst stretch (m) of a rigid link at each held or holding node (0 with none)
    pull: dict[int, float] = {}
    for k in range(len(near)):
        j = len(rows) + k
        if flags[k] & LINK_OFF or not rest[j] > 0:
            continue
        for node in (nodes[2 * j], nodes[2 * j + 1]):
            pull[node] = _np_max(pull.get(node, 0.0), stretch[j])
    return [(row, _np_max(stretch[k], _np_max(pull.get(nodes[2 * k], 0.0), pull.get(nodes[2 * k + 1], 0.0))))
            for k, row in enumerate(rows)]  # fmt: skip


def slip(scene: SceneView, limit: float = GRIP_SLIP) -> list[int]:
    """Let go of every grip pulled more than ``limit`` m beyond its length - its grab
    joint's, or that of a link at either of its ends; returns the joints' entities, released
    as :func:`release` (a ``release`` event each).

    A grab joint is a rigid link of no strength, projected after the body's own links. Two
    hands that hold one light node (a doll's foot) and walk apart cannot both keep it:
    projected one after the other, the node jumps from one hand to the other every pass,
    and when one lets go it is flung across the gap (the goal melee: 1 m, 63 m/s). A child
    dragging a grown-up who walks off keeps hold, and its arm stretches to 2.5 times its
    length instead; a doll held by its knee against its holder's belly, pushed out by the
    contacts, is pulled back 13 cm into the torso. Hands do not hold on like that: a grip
    pulled too hard gives way.
    """
    state = scene.state
    links = state.links
    slipped = [int(links.entity[row]) for row, pulled in grip_tensions(state) if pulled > limit]
    for grab in slipped:
        for _, character in scene.world.get_component(Character):
            for hand, held in character.holding.items():
                if held == grab:  # the arm that held it relaxes, as when its owner lets go
                    state.characters.arm_mode[character.index, int(hand == "right")] = HANG
        release(scene, grab)
    return slipped


def remove_body(scene: SceneView, entity: int) -> None:
    """Remove a body's rows from the store, its entity and its grab joints' entities from the world."""
    body = scene.world.component_for_entity(entity, Body)
    doomed = {entity}
    remap = scene.state.remove_body(body.index)
    for e, grab in list(scene.world.get_component(GrabJoint)):
        if entity in (grab.holder, grab.held):
            doomed.add(e)
    for e in doomed:
        scene.world.delete_entity(e, immediate=True)
    follow_remap(scene.world, remap)


def follow_remap(world: World, remap: dict[str, np.ndarray]) -> None:
    """Follow a store compaction: rewrite every row index held by components."""
    nodes, links, bodies = remap["nodes"], remap["links"], remap["bodies"]
    for _, grab in world.get_component(GrabJoint):
        grab.index = int(links[grab.index])
    for _, body in world.get_component(Body):
        body.index = int(bodies[body.index])
        body.node_start = int(nodes[body.node_start])
        body.link_start = int(links[body.link_start]) if body.link_count else 0
    live_grabs = {e for e, _ in world.get_component(GrabJoint)}
    for _, character in world.get_component(Character):
        character.index = int(remap["characters"][character.index])
        character.holding = {h: g for h, g in character.holding.items() if g in live_grabs}
