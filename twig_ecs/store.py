"""The structure-of-arrays physics store: every hot number of every node and link.

Nodes, links, joint limits, colliders and bodies each live in a block of numpy arrays
with one row per item (nodes and links are rows, not entities: a ``Body`` component holds
its contiguous rows). Components hold row indices into these arrays; the numba
kernels in ``twig_ecs.systems`` loop over them directly. Capacity grows by doubling;
removing a body compacts the rows and returns an index remap so components can follow.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from operator import itemgetter
from typing import Any

import numpy as np

# Node flags (bit masks in PhysicsState.node_flags).
NODE_LOCKED = 1  # held at node_lock_pos (static friction, fixed pivots)
NODE_LOCK_ON_CONTACT = 2  # becomes LOCKED when it touches the ground
NODE_IN_CONTACT = 4  # touched a supporting surface during the last step
NODE_SPHERE = 8  # collides as a sphere of node_radius (balls)
NODE_MOVING = 16  # on a ballistic move: kinematic (constraints do not push it) until it ends
NODE_KICK = 32  # the move is a kick's swing: it drives on through a loose ball it meets (collide)
NODE_CARRIED = 64  # of a loose thing a hand holds: no foot plants on it (collide, gait)
NODE_ON_CARRIED = 128  # rested on a carried thing during the last step (a foot does not plant there)
NODE_PINNED = 256  # a loose ball pressed on a fixed body this step: no kick drives through it (collide)

# Link flags (bit masks in PhysicsState.link_flags).
LINK_VISIBLE = 1  # drawn by the renderer
LINK_COLLIDE = 2  # collides as a capsule of link_radius
LINK_GRAB = 4  # a grab joint: zero-length link created at run time
LINK_NO_SELF = 8  # never collides with its own body (torso parts that touch by design)
LINK_ROPE = 16  # only resists stretching: a maximum distance (a rope), slack when shorter
LINK_BRACE = 32  # a stiffener that holds only while its body is passive (not controlled)
LINK_OFF = 64  # switched off: the solver ignores it (a brace of a controlled character)

# Kinds of ballistic move (NODE_FIELDS["move_gravity"]): how a node flies while move_time lasts.
MOVE_LINE = 0  # a straight line at constant velocity (no gravity)
MOVE_ARC = 1  # an arc under gravity (a kick, a classic step)
MOVE_GAIT_ARC = (
    2  # an arc under the human gait's lighter gravity, re-aimed in flight (systems/control/gait.py)
)

#: Array names of each block, with (dtype, trailing shape, fill value for new rows).
NODE_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "pos": (np.float64, (3,), 0.0),
    "prev": (np.float64, (3,), 0.0),
    "acc": (np.float64, (3,), 0.0),  # accumulated acceleration for the next step (m/s^2)
    "vel": (np.float64, (3,), 0.0),  # displacement of the last step (m), scratch of integrate
    "lock_pos": (np.float64, (3,), 0.0),
    "ctrl_acc": (np.float64, (3,), 0.0),  # acceleration held until changed (set_acceleration)
    "move_time": (np.float64, (), 0.0),  # s left in a ballistic move: flies undamped meanwhile
    "move_gravity": (np.uint8, (), 1),  # how a move flies: MOVE_LINE, MOVE_ARC or MOVE_GAIT_ARC
    "inv_mass": (np.float64, (), 0.0),
    "mass": (np.float64, (), 0.0),
    "radius": (np.float64, (), 0.0),  # contact radius against the ground and as a sphere
    "damp_air": (np.float64, (), 0.0),  # d of SPEC 2 when not touching a support
    "damp_ground": (np.float64, (), 0.0),  # d of SPEC 2 while touching a support
    "roll_decel": (np.float64, (), 0.0),  # m/s^2 taken off the ground speed while touching a support
    "damp_ref": (np.int32, (), -1),  # node this one is damped relative to ("muscle"), or -1
    "damp_rel": (np.float64, (), 0.0),  # fraction of relative velocity removed per step
    "axle_a": (np.int32, (), -1),  # fixed axle (two locked nodes) this node spins about
    "axle_b": (np.int32, (), -1),
    "axle_radius": (np.float64, (), 0.0),  # distance from the axle line, kept constant
    "axle_height": (np.float64, (), 0.0),  # coordinate along the axle, kept constant
    "flags": (np.uint32, (), 0),
    "body": (np.int32, (), -1),
    "color": (np.float32, (4,), 1.0),
}

LINK_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "a": (np.int32, (), -1),
    "b": (np.int32, (), -1),
    "rest": (np.float64, (), 0.0),
    "min_rest": (np.float64, (), 0.0),  # a grab joint closes down to this length (its standoff)
    "radius": (np.float64, (), 0.0),
    "flags": (np.uint32, (), 0),
    "group": (np.int32, (), 0),  # self-collision group (0: collides with any link of its body)
    "body": (np.int32, (), -1),
    "entity": (np.int64, (), -1),  # world entity of the grab joint on this row (-1: a body's own link)
    "color": (np.float32, (4,), 1.0),
}

#: Hinge limits (knees, elbows): ``mid`` may only bend away from the ``root``-``tip`` line
#: in directions within [arc_min, arc_max] (radians) around a reference direction built
#: from the body frame given by four nodes (left, right, low, up):
#: 0 = ref[0] * forward + ref[1] * up, +pi/2 = outward (towards ``side``, +1 left).
LIMIT_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "root": (np.int32, (), -1),
    "mid": (np.int32, (), -1),
    "tip": (np.int32, (), -1),
    "frame": (np.int32, (4,), -1),
    "side": (np.float64, (), 1.0),
    "ref": (np.float64, (2,), 0.0),  # 0-direction = ref[0] * forward + ref[1] * up
    "arc_min": (np.float64, (), 0.0),
    "arc_max": (np.float64, (), 0.0),
    # inward normals of the arc's two edges, (-sin min, cos min, sin max, -cos max): set
    # with the arc, so the solver's passes need no trigonometry (see set_arc)
    "edges": (np.float64, (4,), 0.0),
    "body": (np.int32, (), -1),
}

#: Colliders are derived from links (capsules) and sphere nodes; rebuilt on every spawn.
COLLIDER_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "a": (np.int32, (), -1),
    "b": (np.int32, (), -1),  # == a for a sphere
    "radius": (np.float64, (), 0.0),
    "link": (np.int32, (), -1),  # source link, or -1 for a sphere node
    "body": (np.int32, (), -1),
    "local": (np.int32, (), 0),  # index among its body's colliders (0..63)
    "mask": (np.uint64, (), 0),  # bit k set: never collide with local collider k of own body
    "ignore": (np.int32, (2,), -1),  # two bodies it never meets (what it holds), or -2-k: collider k
    # Tactile sensing written by the collide kernel each step (SPEC 2):
    "hit_energy": (np.float64, (), 0.0),  # largest impact kinetic energy this step (J)
    "hit_by": (np.int32, (), -1),  # collider that delivered it
}

#: Body roles of a character's nodes, in the order of ``CHARACTER_FIELDS["nodes"]``.
ROLES = ("pelvis", "spine", "neck", "head", "l_hip", "r_hip", "l_knee", "r_knee", "l_foot", "r_foot",
         "l_shoulder", "r_shoulder", "l_elbow", "r_elbow", "l_hand", "r_hand")  # fmt: skip

#: One row per character: node indices by role and the controllers' state.
CHARACTER_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "body": (np.int32, (), -1),
    "entity": (np.int64, (), -1),
    "nodes": (np.int32, (len(ROLES),), -1),
    "breath_links": (np.int32, (2,), -1),  # l_shoulder-spine, r_shoulder-spine link rows
    "breath_rest": (np.float64, (2,), 0.0),  # their rest lengths without breathing
    "scale": (np.float64, (), 1.0),  # body height / 1.75 m
    "stand_height": (np.float64, (), 0.0),  # pelvis height when standing (m)
    "leg_length": (np.float64, (), 0.0),  # hip to foot, straight (m)
    "mode": (np.int32, (), 0),  # posture: kernelmath.STAND, SIT, RISE (sitting up) or LIMP
    "mode_time": (np.float64, (), 0.0),  # s spent in the current mode
    "walk": (np.float64, (3,), 0.0),  # desired ground velocity of the pelvis (m/s)
    "crouch": (np.float64, (), 0.0),  # m the pelvis is lowered from standing height (stooping)
    "lean": (np.float64, (3,), 0.0),  # m the shoulder centre leads the pelvis (stooping)
    "seat": (np.float64, (3,), 0.0),  # where the pelvis goes when sitting
    "gaze_mode": (np.int32, (), 0),  # kernelmath.GAZE_AHEAD, GAZE_POINT or GAZE_NODE
    "gaze_point": (np.float64, (3,), 0.0),
    "gaze_node": (np.int32, (), -1),
    "head_dir": (np.float64, (3,), 0.0),  # unit vector the face points along
    "face_dir": (np.float64, (3,), 0.0),  # unit vector the drawn face points along: head_dir and a glance
    "glance": (np.float64, (2,), 0.0),  # an idle glance's yaw and pitch (rad) from head_dir (0: none)
    "glance_left": (np.float64, (), 1.5),  # s until the glance or look ahead changes (glance.FIRST_WAIT)
    "arm_mode": (
        np.int32,
        (2,),
        0,
    ),  # per hand (left, right): kernelmath.HANG, REACH... (systems/control/arms.py)
    "arm_point": (np.float64, (2, 3), 0.0),
    "arm_node": (np.int32, (2,), -1),
    # where a hand gliding round a body in a hug or an embrace has got to (systems/behaviours/embrace.py
    # glide_hand): its reach point moves a little towards its goal each step; NaN: not gliding
    "hand_aim": (np.float64, (2, 3), np.nan),
    "swing": (np.float64, (2,), 0.0),  # s left in each foot's step (0: planted)
    "last_step": (np.int32, (), 1),  # foot that stepped last (0 left, 1 right)
    "steps": (np.int64, (), 0),
    "breath_phase": (np.float64, (), 0.0),
    "gesture_phase": (np.float64, (), 0.0),
}

BODY_FIELDS: dict[str, tuple[type, tuple[int, ...], float]] = {
    "pain": (np.float64, (), 0.0),  # current pain level (J-equivalent), decays
    "pain_threshold": (np.float64, (), np.inf),  # impact energy (J) that hurts; inf = no sensor
    "pain_half_life": (np.float64, (), 1.0),  # seconds
    "pain_gain": (np.float64, (), 1.0),
    "alive": (np.uint8, (), 0),
    "entity": (np.int64, (), -1),  # world entity carrying the Body component
    "self_collide": (np.uint8, (), 1),  # may its own non-adjacent links collide?
}


@dataclass
class Block:
    """Rows of equally long numpy arrays, grown by doubling.

    ``count`` rows are in use; arrays are longer (capacity). Access arrays as
    attributes (``block.pos``) and slice ``[:count]`` for the live part.
    """

    fields: dict[str, tuple[type, tuple[int, ...], float]]
    count: int = 0
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        assert not {"count", "arrays", "fields"} & self.fields.keys(), "reserved field name"
        for name, (dtype, shape, fill) in self.fields.items():
            self._set(name, np.full((4, *shape), fill, dtype=dtype))

    def _set(self, name: str, array: np.ndarray) -> None:
        # also an instance attribute: ``block.pos`` is then a plain attribute read, which
        # hot Python paths do thousands of times a step (a __getattr__ costs ~5x more)
        self.arrays[name] = array
        self.__dict__[name] = array

    def __getattr__(self, name: str) -> np.ndarray:
        try:
            return self.__dict__["arrays"][name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def capacity(self) -> int:
        """Rows allocated."""
        return len(next(iter(self.arrays.values())))

    def allocate(self, n: int) -> slice:
        """Reserve ``n`` new rows filled with defaults; return their slice."""
        start, stop = self.count, self.count + n
        if stop > self.capacity:
            new_cap = self.capacity
            while new_cap < stop:
                new_cap *= 2
            for name, (dtype, shape, fill) in self.fields.items():
                grown = np.full((new_cap, *shape), fill, dtype=dtype)
                grown[: self.count] = self.arrays[name][: self.count]
                self._set(name, grown)
        for name, (_dtype, _shape, fill) in self.fields.items():
            self.arrays[name][start:stop] = fill
        self.count = stop
        return slice(start, stop)

    def keep(self, mask: np.ndarray) -> np.ndarray:
        """Drop rows where ``mask`` is False, compacting in place.

        Returns the remap array: ``remap[old] = new`` index, or -1 for dropped rows.
        """
        assert len(mask) == self.count
        remap = np.full(self.count, -1, dtype=np.int32)
        kept = np.flatnonzero(mask)
        remap[kept] = np.arange(len(kept), dtype=np.int32)
        for name, (_dtype, _shape, fill) in self.fields.items():
            arr = self.arrays[name]
            arr[: len(kept)] = arr[kept]
            arr[len(kept) : self.count] = fill
        self.count = len(kept)
        return remap

    def clear(self) -> None:
        """Drop every row."""
        self.keep(np.zeros(self.count, dtype=bool))

    def set_arc(self, row: int, arc_min: float, arc_max: float) -> None:
        """Set a joint limit's arc (radians) and the edge normals derived from it."""
        self.arc_min[row], self.arc_max[row] = arc_min, arc_max
        self.edges[row] = (-math.sin(arc_min), math.cos(arc_min), math.sin(arc_max), -math.cos(arc_max))


#: How :func:`columns` fills each kind of view from each kind of blocks: per block, a getter
#: of its fields' arrays (the fields of one block are consecutive), and whether ``count`` ends it.
_PLANS: dict[tuple, tuple[list[tuple[int, Callable]], bool]] = {}


def columns(view: type, *blocks: Block) -> tuple:
    """A kernel argument: the columns of ``blocks`` that ``view`` (a NamedTuple class whose
    fields are store column names, ending with ``count``, the first block's live rows, if it
    needs that) names, each from the first block that has it, in ``view``'s field order.

    A kernel takes one such structure instead of a score of positional arrays, and names it
    again with ``view(*args)`` (in compiled code too); since the columns are looked up by
    the view's field names, a call site cannot hand a kernel the wrong column in the right
    place. It is a plain tuple because numba types a plain tuple in C but a NamedTuple in
    Python, at ~0.5 us per array per call; building it costs about as much as writing the
    arrays out (~1.5 us for 14).
    """
    key = (view, len(blocks), id(blocks[0].fields), id(blocks[-1].fields))
    plan = _PLANS.get(key)
    if plan is None:
        plan = _PLANS[key] = _plan(view, blocks)
    segments, counted = plan
    out = ()
    for k, get in segments:
        out += get(blocks[k].arrays)
    return out + (blocks[0].count,) if counted else out


def _plan(view: type, blocks: tuple[Block, ...]) -> tuple[list[tuple[int, Callable]], bool]:
    """How :func:`columns` gathers ``view`` from ``blocks`` (KeyError naming what is missing)."""
    names = list(view._fields)
    counted = names[-1:] == ["count"]
    names = names[:-1] if counted else names
    missing = [f for f in names if not any(f in b.fields for b in blocks)]
    if missing or "count" in names:
        raise KeyError(f"{view.__name__}: no store column named {', '.join(missing or ['count'])} "
                       f"(count may only be the last field)")  # fmt: skip
    owners = [next(k for k, b in enumerate(blocks) if f in b.fields) for f in names]
    segments: list[tuple[int, Callable]] = []
    start = 0
    for end in range(1, len(names) + 1):
        if end == len(names) or owners[end] != owners[start]:
            run = names[start:end]
            get = itemgetter(*run) if len(run) > 1 else (lambda d, f=run[0]: (d[f],))
            segments.append((owners[start], get))
            start = end
    return segments, counted


def _self_masks(a: np.ndarray, b: np.ndarray, body: np.ndarray, loner: np.ndarray, group: np.ndarray,
                self_collide: np.ndarray, lk: Block, node_body: np.ndarray) -> tuple:  # fmt: skip
    """Each collider's index among its body's colliders (``local``, at most 63) and its
    self-collision ``mask`` (bit k: never meets local collider k of its own body).

    Colliders ``i`` and ``j`` of one body never meet when they are one, when ``j`` is a
    loner, when both are in self-collision groups and the groups differ, or when an end of
    ``j`` is an end of ``i`` or a neighbour of one (through any link but a grab joint). A
    loner, and every collider of a body that does not collide with itself or has more
    than 64 colliders, has every bit set.

    By node, not by pair: each node's bits (the colliders ending there), each node's bits
    with its neighbours' (``near``), and a collider's mask is ``near`` at its two ends - so
    a world of 1000 humanoids (169 000 pairs, 78 ms in a Python loop) takes 4 ms.
    """
    total = len(body)
    all_bits = np.uint64(0xFFFFFFFFFFFFFFFF)
    body = body.astype(np.int64)
    a, b = a.astype(np.int64), b.astype(np.int64)
    assert (node_body[a] == body).all() and (node_body[b] == body).all(), "a collider ends in another body"
    # local: the collider's place among its body's colliders, in row order
    order = np.argsort(body, kind="stable")
    first = np.flatnonzero(np.r_[True, body[order][1:] != body[order][:-1]]) if total else np.zeros(0, int)
    size = np.diff(np.r_[first, total])
    local, members = np.empty(total, dtype=np.int64), np.empty(total, dtype=np.int64)
    local[order] = np.arange(total) - np.repeat(first, size)
    members[order] = np.repeat(size, size)  # how many colliders its body has
    local = np.minimum(local, 63)
    bit = np.left_shift(np.uint64(1), local.astype(np.uint64))
    ends = np.zeros(len(node_body), dtype=np.uint64)  # per node: the colliders that end there
    np.bitwise_or.at(ends, a, bit)
    np.bitwise_or.at(ends, b, bit)
    near = ends.copy()  # and those that end at a neighbour (links within one body, no grab joints)
    keep = (lk.flags[: lk.count] & LINK_GRAB) == 0
    la, lb = lk.a[: lk.count][keep].astype(np.int64), lk.b[: lk.count][keep].astype(np.int64)
    same = node_body[la] == node_body[lb]
    la, lb = la[same], lb[same]
    np.bitwise_or.at(near, la, ends[lb])
    np.bitwise_or.at(near, lb, ends[la])
    mask = near[a] | near[b]  # (itself included: its ends are its own)
    n_bodies = int(body.max()) + 1 if total else 0
    loners = np.zeros(n_bodies, dtype=np.uint64)
    np.bitwise_or.at(loners, body[loner], bit[loner])
    mask |= loners[body]
    grouped = group != 0  # a collider in a group never meets one in another group of its body
    if grouped.any():
        in_any = np.zeros(n_bodies, dtype=np.uint64)
        np.bitwise_or.at(in_any, body[grouped], bit[grouped])
        g = group[grouped].astype(np.int64) - int(group.min())  # (body, group) as one key
        key, slot = np.unique(body[grouped] * (int(g.max()) + 1) + g, return_inverse=True)
        in_own = np.zeros(len(key), dtype=np.uint64)
        np.bitwise_or.at(in_own, slot, bit[grouped])
        mask[grouped] |= in_any[body[grouped]] & ~in_own[slot]
    closed = (self_collide[body] == 0) | (members > 64)
    mask[closed | loner] = all_bits
    return local, mask


def _ignore(ignore: np.ndarray, collider: int, body: int) -> None:
    """Add ``body`` to a collider's (two) ignored bodies; a third replaces the second. A
    value ``-2 - k`` ignores collider ``k`` alone (a carried thing's capsule at the hand)."""
    slots = ignore[collider]
    if body in slots:
        return
    free = np.flatnonzero(slots == -1)
    slots[free[0] if len(free) else 1] = body


#: Farthest a node of a restored store may be from the origin on any axis (m): grids sized
#: by the world's extent (the yard, the broad phase) must not be asked for a continent.
MAX_COORDINATE = 1.0e5
#: The blocks of a store and their fields (what a restored store is checked against).
BLOCKS: dict[str, dict[str, tuple[type, tuple[int, ...], float]]] = {
    "nodes": NODE_FIELDS, "links": LINK_FIELDS, "limits": LIMIT_FIELDS, "colliders": COLLIDER_FIELDS,
    "bodies": BODY_FIELDS, "characters": CHARACTER_FIELDS,
}  # fmt: skip
#: Row-index columns: (block, column) -> (block its values index, lowest value allowed). The
#: kernels index with them unchecked, so a store from a file must keep them in range.
INDEX_COLUMNS: dict[tuple[str, str], tuple[str, int]] = {
    ("nodes", "damp_ref"): ("nodes", -1), ("nodes", "axle_a"): ("nodes", -1),
    ("nodes", "axle_b"): ("nodes", -1), ("nodes", "body"): ("bodies", -1),
    ("links", "a"): ("nodes", 0), ("links", "b"): ("nodes", 0), ("links", "body"): ("bodies", -1),
    ("limits", "root"): ("nodes", 0), ("limits", "mid"): ("nodes", 0), ("limits", "tip"): ("nodes", 0),
    ("limits", "frame"): ("nodes", -1), ("limits", "body"): ("bodies", -1),
    ("colliders", "a"): ("nodes", 0), ("colliders", "b"): ("nodes", 0), ("colliders", "link"): ("links", -1),
    ("colliders", "body"): ("bodies", -1), ("colliders", "hit_by"): ("colliders", -1),
    ("characters", "body"): ("bodies", 0), ("characters", "nodes"): ("nodes", 0),
    ("characters", "breath_links"): ("links", -1), ("characters", "gaze_node"): ("nodes", -1),
    ("characters", "arm_node"): ("nodes", -1),
}  # fmt: skip


def mode_columns() -> dict[tuple[str, str], int]:
    """Columns of named modes, and how many there are: (block, column) -> count."""
    from twig_ecs import kernelmath  # here: the store is read by `twig --help`, which loads no numba

    return {
        ("characters", "mode"): kernelmath.LIMP + 1, ("characters", "gaze_mode"): kernelmath.GAZE_NODE + 1,
        ("characters", "arm_mode"): len(kernelmath.ARM_MODES), ("characters", "last_step"): 2,
        ("nodes", "move_gravity"): MOVE_GAIT_ARC + 1,
    }  # fmt: skip


def check_store(state: PhysicsState) -> None:
    """Check that a store read from a file is one the kernels may walk (ValueError saying what is not).

    Every block has exactly its fields, as arrays of the declared type and shape, of one
    capacity holding ``count`` rows; every row index is in range; positions are finite; the
    broad phase's pairs and the held and released tables point at rows that exist. The
    blocks' field tables are set back to the module's own (kernels' column plans are cached
    by them).
    """
    counts = {}
    for name, fields in BLOCKS.items():
        block = getattr(state, name, None)
        if type(block) is not Block or not isinstance(getattr(block, "arrays", None), dict):
            raise ValueError(f"the store has no {name} block")
        if set(block.arrays) != set(fields):  # its own field table is replaced by the module's below
            raise ValueError(f"the store's {name} block does not have the {name} fields")
        count, capacity = block.count, None
        for column, (dtype, shape, _fill) in fields.items():
            array = block.arrays[column]
            if type(array) is not np.ndarray or array.dtype != dtype or array.shape[1:] != shape:
                raise ValueError(
                    f"{name}.{column} is not an array of {np.dtype(dtype)} rows of shape {shape}"
                )
            capacity = len(array) if capacity is None else capacity
            if len(array) != capacity or block.__dict__.get(column) is not array:
                raise ValueError(f"the {name} block's arrays differ in length")
        if type(count) is not int or not 0 <= count <= capacity or capacity < 1:
            raise ValueError(f"the {name} block's row count {count!r} does not fit its arrays")
        block.fields = fields
        counts[name] = count
    for (name, column), (target, lowest) in INDEX_COLUMNS.items():
        rows = getattr(state, name).arrays[column][: counts[name]]
        _check_rows(rows, lowest, counts[target], f"{name}.{column}")
    ignore = state.colliders.ignore[: counts["colliders"]]
    bodies = ignore[ignore >= -1]
    colliders = -2 - ignore[ignore <= -2]
    if np.any(bodies >= counts["bodies"]) or np.any(colliders >= counts["colliders"]):
        raise ValueError("colliders.ignore names a body or collider that does not exist")
    _check_rows(state.colliders.local[: counts["colliders"]], 0, 64, "colliders.local")
    for (name, column), choices in mode_columns().items():  # modes the controllers look up by value
        _check_rows(getattr(state, name).arrays[column][: counts[name]], 0, choices, f"{name}.{column}")
    nodes = state.nodes
    for column in ("pos", "prev", "lock_pos"):
        if not (np.abs(nodes.arrays[column][: counts["nodes"]]) <= MAX_COORDINATE).all():  # NaN fails too
            raise ValueError(f"nodes.{column} holds a position that is not a number within "
                             f"{MAX_COORDINATE:g} m of the origin")  # fmt: skip
    pairs, n_pairs = state.pairs, state.n_pairs
    if type(pairs) is not np.ndarray or pairs.dtype != np.int32 or pairs.ndim != 2 or pairs.shape[1] != 2:
        raise ValueError("the broad phase's pairs are not an (n, 2) int32 array")
    if type(n_pairs) is not int or not 0 <= n_pairs <= len(pairs):
        raise ValueError(f"the broad phase's pair count {n_pairs!r} does not fit its array")
    _check_rows(pairs[:n_pairs], 0, counts["colliders"], "the broad phase's pairs")
    tables = (("held", 4, ("nodes", "nodes", "links", "links")), ("gentle", 2, ("bodies", "bodies")))
    for table, width, bounds in tables:
        array = getattr(state, table)
        if type(array) is not np.ndarray or array.dtype != np.int64 or array.shape[1:] != (width,):
            raise ValueError(f"the store's {table} table is not an (n, {width}) int64 array")
        for k, target in enumerate(bounds):  # held rows are [first, end) ranges: end may equal the count
            _check_rows(array[:, k], 0, counts[target] + (table == "held"), f"{table}[:, {k}]")
    released = state.released
    if type(released) is not list or not all(
        type(r) is list and len(r) == 3 and all(type(v) is int for v in r) for r in released
    ):
        raise ValueError("the store's released table is not a list of [node, node, steps]")
    _check_rows(np.array([r[:2] for r in released], dtype=np.int64), 0, counts["nodes"], "released")
    stats = state.stats
    if type(stats) is not np.ndarray or stats.dtype != np.float64 or stats.shape != (4,):
        raise ValueError("the store's stats are not 4 floats")


def _check_rows(values: np.ndarray, lowest: int, count: int, what: str) -> None:
    if values.size and (values.min() < lowest or values.max() >= count):
        raise ValueError(f"{what} holds a row outside 0..{count - 1}")


class LayoutCache:
    """One value per store, made again only when its key (the store's layout: ``version``,
    row counts...) changes; the stores are held weakly."""

    def __init__(self) -> None:
        self._kept: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    def get(self, state: PhysicsState, key: Any, make: Callable[[], Any]) -> Any:
        """The value kept for ``state`` under ``key``, or ``make()``'s, kept from now on."""
        kept = self._kept.get(state)
        if kept is None or kept[0] != key:
            kept = self._kept[state] = (key, make())
        return kept[1]


def gripped_nodes(state: PhysicsState) -> np.ndarray:
    """Per node row: is it an end of a grab joint (a hand that holds, or the node it holds)?

    The joint welds the two into one point: a joint limit whose middle node is held leaves
    the bending to the hand (``systems/physics/constrain.py``), and a grip pulled too hard gives way
    (:func:`twig_ecs.grabs.slip`).
    """
    nodes, links = state.nodes, state.links
    gripped = np.zeros(nodes.count, dtype=np.bool_)
    grabs = np.flatnonzero(links.flags[: links.count] & LINK_GRAB)
    gripped[links.a[grabs]] = True
    gripped[links.b[grabs]] = True
    return gripped


def _remap(indices: np.ndarray, remap: np.ndarray) -> None:
    """Rewrite an index array in place through ``remap`` (negative entries stay)."""
    valid = indices >= 0
    indices[valid] = remap[indices[valid]]


class PhysicsState:
    """All node, link, limit, collider and body data of one scene, as arrays.

    The arrays are public and read directly by kernels and the renderer:
    ``state.nodes.pos[:state.nodes.count]`` are node positions (m), and so on.
    ``version`` increases whenever rows are added or removed, so caches of indices
    (renderer buffers, per-character index tables) know to refresh.
    """

    def __init__(self) -> None:
        self.nodes = Block(NODE_FIELDS)
        self.links = Block(LINK_FIELDS)
        self.limits = Block(LIMIT_FIELDS)
        self.colliders = Block(COLLIDER_FIELDS)
        self.bodies = Block(BODY_FIELDS)
        self.characters = Block(CHARACTER_FIELDS)
        self.version = 0
        #: Set when bodies spawn; the scene rebuilds the collider table before stepping.
        self.colliders_dirty = False
        self.n_pairs = 0
        #: Broad-phase output (candidate collider pairs), reused between steps.
        self.pairs = np.zeros((64, 2), dtype=np.int32)
        #: Per-step statistics written by the kernels: [max residual penetration (m)].
        self.stats = np.zeros(4, dtype=np.float64)
        #: Grab joints let go of lately, as [node a, node b, steps left]: the arm and what
        #: it held keep ignoring each other for a moment while the arm draws back out
        self.released: list[list[int]] = []
        #: The loose things hands hold (a doll; not a character, nothing fixed), as rows of
        #: (first node, end node, first link, end link); the collide system settles their
        #: shape last (``constrain.settle_shape``)
        self.held = np.zeros((0, 4), dtype=np.int64)
        #: (holder body, thing body): a loose thing held or just let go of, which cannot
        #: hurt its holder (the sense system feels no pain from it)
        self.gentle = np.zeros((0, 2), dtype=np.int64)

    # -- growth -----------------------------------------------------------------

    def add_body(self) -> int:
        """Reserve a body row and return its index."""
        row = self.bodies.allocate(1).start
        self.bodies.alive[row] = 1
        self.version += 1
        return row

    def remove_body(self, body: int) -> dict[str, np.ndarray]:
        """Remove a body with its nodes, links and limits; compact all blocks.

        Returns remaps by block name (``"nodes"``, ``"links"``, ``"bodies"``) so
        components holding indices can follow (``remap[old] = new`` or -1).
        """
        n, lk, lim = self.nodes, self.links, self.limits
        node_keep = n.body[: n.count] != body
        # A grab joint touching any removed node goes too.
        link_keep = lk.body[: lk.count] != body
        link_keep &= node_keep[lk.a[: lk.count]] & node_keep[lk.b[: lk.count]]
        limit_keep = lim.body[: lim.count] != body
        body_keep = np.ones(self.bodies.count, dtype=bool)
        body_keep[body] = False

        node_map = n.keep(node_keep)
        link_map = lk.keep(link_keep)
        lim.keep(limit_keep)
        body_map = self.bodies.keep(body_keep)

        _remap(n.damp_ref[: n.count], node_map)
        _remap(n.axle_a[: n.count], node_map)
        _remap(n.axle_b[: n.count], node_map)
        _remap(n.body[: n.count], body_map)
        _remap(lk.a[: lk.count], node_map)
        _remap(lk.b[: lk.count], node_map)
        _remap(lk.body[: lk.count], body_map)
        for name in ("root", "mid", "tip"):
            _remap(lim.arrays[name][: lim.count], node_map)
        _remap(lim.frame[: lim.count].reshape(-1), node_map)
        _remap(lim.body[: lim.count], body_map)
        ch = self.characters
        char_map = ch.keep(ch.body[: ch.count] != body)
        _remap(ch.body[: ch.count], body_map)
        for name in ("nodes", "arm_node", "gaze_node"):
            _remap(ch.arrays[name][: ch.count].reshape(-1), node_map)
        _remap(ch.breath_links[: ch.count].reshape(-1), link_map)
        self.released = [[int(node_map[a]), int(node_map[b]), left] for a, b, left in self.released
                         if node_map[a] >= 0 and node_map[b] >= 0]  # fmt: skip
        self.rebuild_colliders()
        self.version += 1
        return {"nodes": node_map, "links": link_map, "bodies": body_map, "characters": char_map}

    # -- colliders ----------------------------------------------------------------

    def rebuild_colliders(self) -> None:
        """Derive the collider table from collidable links and sphere nodes.

        Within one body, two colliders never touch when they share a node or when a
        node of one is linked to a node of the other (neighbours through any link,
        stiffeners included): such pairs are joints, not contacts. Links in different
        self-collision groups of one body never meet either (arms pass legs), nor do
        LINK_NO_SELF links, nor anything in bodies whose ``self_collide`` is 0.
        """
        self.colliders_dirty = False
        n, lk, col = self.nodes, self.links, self.colliders
        col.clear()
        link_rows = np.flatnonzero(lk.flags[: lk.count] & LINK_COLLIDE)
        node_rows = np.flatnonzero(n.flags[: n.count] & NODE_SPHERE)
        total = len(link_rows) + len(node_rows)
        rows = col.allocate(total)
        col.a[rows] = np.concatenate([lk.a[link_rows], node_rows]).astype(np.int32)
        col.b[rows] = np.concatenate([lk.b[link_rows], node_rows]).astype(np.int32)
        col.radius[rows] = np.concatenate([lk.radius[link_rows], n.radius[node_rows]])
        col.link[rows] = np.concatenate([link_rows, np.full(len(node_rows), -1)]).astype(np.int32)
        col.body[rows] = np.concatenate([lk.body[link_rows], n.body[node_rows]]).astype(np.int32)

        loner = np.zeros(total, dtype=bool)  # never collides with its own body
        loner[: len(link_rows)] = (lk.flags[link_rows] & LINK_NO_SELF) != 0
        group = np.zeros(total, dtype=np.int32)  # within a body, groups only meet their own
        group[: len(link_rows)] = lk.group[link_rows]
        node_body = n.body[: n.count]
        col.local[rows], col.mask[rows] = _self_masks(
            col.a[rows], col.b[rows], col.body[rows], loner, group, self.bodies.self_collide, lk, node_body
        )
        # a held thing and the arm that holds it do not push each other apart; the rest
        # of the carrier's body does (a carried doll swings against the legs, not through
        # them: it is held high enough that no foot steps on it)
        grabs = np.flatnonzero(lk.flags[: lk.count] & LINK_GRAB)
        ch = self.characters
        # the whole arm that holds something, not just the hand: an arm round a body
        # (a hug) is squeezed between the hand's joint and the shoulder otherwise
        elbow_of = {}
        for c in range(ch.count):
            for hand, elbow in ((ROLES.index("l_hand"), ROLES.index("l_elbow")),
                                (ROLES.index("r_hand"), ROLES.index("r_elbow"))):  # fmt: skip
                elbow_of[int(ch.nodes[c, hand])] = int(ch.nodes[c, elbow])
        self.held = self._loose_held(grabs)
        # what a hand carries is no ground to stand on: a running child's knee lifts its foot
        # into the doll it carries, and a foot planted there stayed nailed in mid-air as the
        # doll swung on (collide marks what rests on a carried thing, the gait plants no foot there)
        n.flags[: n.count] &= ~np.uint32(NODE_CARRIED)
        for first, end, _, _ in self.held:
            n.flags[first:end] |= np.uint32(NODE_CARRIED)
        self.gentle = self._gentle_pairs(grabs)
        held_pairs = [(int(lk.a[g]), int(lk.b[g])) for g in grabs]
        carried = {(int(lk.a[g]), int(lk.b[g])) for g in grabs if int(lk.a[g]) in elbow_of}
        held_bodies = self._held_bodies()
        carried = {(hand, node) for hand, node in carried if int(n.body[node]) in held_bodies}
        held_pairs += [(a, b) for a, b, _ in self.released]
        for hand, node in carried:
            # a carried thing: only its capsules at the node the hand holds pass through the
            # holding arm; the rest of it meets that arm as it meets the rest of the body, so
            # it hangs off the arm rather than lying along (and through) the forearm
            thing, arm = int(n.body[node]), {hand, elbow_of[hand]}
            arm_capsules = [c for c in range(total) if int(col.a[c]) in arm or int(col.b[c]) in arm]
            for c in range(total):
                if int(col.body[c]) == thing and node in (int(col.a[c]), int(col.b[c])):
                    for other in arm_capsules:
                        _ignore(col.ignore, c, -2 - other)
        # what the hand a hand holds holds in turn (a wrist taken to drag someone who holds a
        # third body): that grip sits on the third body, so the first arm passes it too (the
        # dragger's forearm was held 14 cm inside the chest of the one its load held on to)
        beyond = {}
        for a, b in held_pairs:
            beyond.setdefault(a, []).append(int(n.body[b]))
        for a, b in held_pairs:
            ba, bb = int(n.body[a]), int(n.body[b])
            if (a, b) in carried:
                continue
            arm_a = {a, elbow_of.get(a, a)}
            for third in beyond.get(b, []) if b in elbow_of else []:
                if third != ba:
                    for c in range(total):
                        if int(col.a[c]) in arm_a or int(col.b[c]) in arm_a:
                            _ignore(col.ignore, c, third)
            # the held end is an arm too only when it is a hand (hand in hand); the
            # capsules at a held doll's middle still meet the carrier's body
            arm_b = {b, elbow_of[b]} if b in elbow_of else set()
            for c in range(total):
                if int(col.a[c]) in arm_a or int(col.b[c]) in arm_a:
                    _ignore(col.ignore, c, bb)
                elif int(col.a[c]) in arm_b or int(col.b[c]) in arm_b:
                    _ignore(col.ignore, c, ba)
        self.version += 1

    def _held_bodies(self) -> set[int]:
        """The bodies of the loose things hands hold now (rows of ``held``)."""
        return {int(self.nodes.body[first]) for first in self.held[:, 0]}

    def _loose_held(self, grabs: np.ndarray) -> np.ndarray:
        """The bodies held by the grab joints ``grabs`` that are loose things - not a
        character's body (a hug, hand in hand), no node locked (a ride's bar) - as rows of
        (first node, end node, first link, end link): a body's rows are contiguous."""
        n, lk = self.nodes, self.links
        characters = set(self.characters.body[: self.characters.count].tolist())
        out = []
        for body in sorted({int(n.body[lk.b[g]]) for g in grabs} - characters):
            nodes = np.flatnonzero(n.body[: n.count] == body)
            links = np.flatnonzero((lk.body[: lk.count] == body) & ((lk.flags[: lk.count] & LINK_GRAB) == 0))
            if not len(links) or (n.flags[nodes] & NODE_LOCKED).any():
                continue
            out.append((nodes[0], nodes[-1] + 1, links[0], links[-1] + 1))
        return np.array(out, dtype=np.int64).reshape(-1, 4)

    def _gentle_pairs(self, grabs: np.ndarray) -> np.ndarray:
        """(holder body, thing body) rows: each loose thing a hand holds or has let go of
        within the release grace, and the body of that hand - it cannot hurt its holder."""
        n = self.nodes
        pairs = [(int(self.links.a[g]), int(self.links.b[g])) for g in grabs]
        pairs += [(a, b) for a, b, _ in self.released]
        characters = set(self.characters.body[: self.characters.count].tolist())
        out = set()
        for a, b in pairs:
            holder, thing = int(n.body[a]), int(n.body[b])
            rows = n.body[: n.count] == thing
            if thing not in characters and not (n.flags[: n.count][rows] & NODE_LOCKED).any():
                out.add((holder, thing))
        return np.array(sorted(out), dtype=np.int64).reshape(-1, 2)

    def release_grace(self, a: int, b: int, steps: int) -> None:
        """Keep the arm at node ``a`` and the body of node ``b`` (or the other way round)
        from colliding for ``steps`` more steps after their grab joint is gone."""
        self.released.append([int(a), int(b), int(steps)])
        self.colliders_dirty = True

    def tick_released(self) -> None:
        """Count down the grace of released grabs; the collider table is rebuilt as one ends."""
        if not self.released:
            return
        for entry in self.released:
            entry[2] -= 1
        before = len(self.released)
        self.released = [e for e in self.released if e[2] > 0]
        if len(self.released) != before:
            self.colliders_dirty = True

    # -- read-outs ------------------------------------------------------------------

    def link_errors(self) -> np.ndarray:
        """Relative length error |len - rest| / rest of every non-grab link with rest > 0.

        Ropes count only when stretched beyond their length.
        """
        lk, pos = self.links, self.nodes.pos
        flags = lk.flags[: lk.count]
        sel = (lk.rest[: lk.count] > 0) & ((flags & (LINK_GRAB | LINK_OFF)) == 0)
        a, b = lk.a[: lk.count][sel], lk.b[: lk.count][sel]
        rest = lk.rest[: lk.count][sel]
        error = (np.linalg.norm(pos[a] - pos[b], axis=1) - rest) / rest
        rope = (flags[sel] & LINK_ROPE) != 0
        error[rope] = np.maximum(error[rope], 0.0)
        return np.abs(error)

    def momentum(self, nodes: np.ndarray | slice | None = None, dt: float = 1.0) -> np.ndarray:
        """Total linear momentum (kg m/s) of the given free nodes (default: all)."""
        n = self.nodes
        sel = slice(0, n.count) if nodes is None else nodes
        free = n.inv_mass[sel] > 0
        vel = (n.pos[sel] - n.prev[sel]) / dt
        return (n.mass[sel][free, None] * vel[free]).sum(axis=0)
