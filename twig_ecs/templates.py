"""Body templates: validated, compiled descriptions of nodes, links and limits.

A template document (``content/bodies/*.yaml`` or a scene's ``templates:`` entry)
becomes a :class:`BodyTemplate`. Templates may ``extends:`` another one: mappings
merge key by key and lists replace (see docs/scenes.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.components import PainSensor
from twig_ecs.validate import (
    between,
    boolean,
    check_keys,
    color,
    fail,
    fraction,
    integer,
    join,
    mapping,
    names,
    nonnegative,
    number,
    positive,
    read,
    sequence,
    suggest,
    text,
    vec3,
)
from twig_ecs.yamldoc import YDict

TEMPLATE_KEYS = (
    "twig",
    "template",
    "extends",
    "description",
    "reference_height",
    "defaults",
    "nodes",
    "links",
    "joint_limits",
    "axle",
    "damping",
    "self_collision",
    "pain",
    "color",
)
NODE_KEYS = ("at", "mass", "radius", "locked", "lock_on_contact", "sphere", "damping", "muscle")
LINK_KEYS = ("nodes", "radius", "visible", "collide", "self_collide", "self_group", "length", "rope", "brace",
             "color")  # fmt: skip
LIMIT_KEYS = ("hinge", "frame", "side", "ref", "arc")
DAMPING_KEYS = ("air", "ground", "rolling")
PAIN_KEYS = ("threshold", "half_life", "gain")
DEFAULT_KEYS = ("height", "mass")
#: A body's height (m) and total mass (kg): the ranges a scene and the server's spawn accept.
HEIGHT = between(0.01, 100.0)
#: Rolling resistance (m/s^2, ``damping: {rolling}``): 0 (none) up to ten times gravity.
ROLLING = between(0.0, 100.0)
MASS = between(1e-3, 1e6)
#: A node's mass (kg at the reference height, or its share of a given total mass): a
#: denormal such as 5e-324 has an infinite inverse, and the body's nodes become NaN.
NODE_MASS = between(1e-6, 1e6)
#: Closer than this (m, at the reference height) two nodes are at one place.
SAME_PLACE = 1e-9


@dataclass(frozen=True, slots=True)
class Damping:
    """Per-step velocity damping d of SPEC 2, in the air and while touching a support."""

    air: float = 0.01
    ground: float = 0.3
    #: m/s^2: rolling resistance while touching a support - a constant deceleration of the
    #: speed along the ground, which stops it (a ball on grass or tarmac: 0.2-0.6), on top of
    #: ``ground`` (a fraction per step, which only ever halves the speed again and again)
    rolling: float = 0.0


@dataclass(frozen=True, slots=True)
class NodeSpec:
    """One point mass of a template, in reference-height coordinates."""

    name: str
    at: tuple[float, float, float]
    mass: float
    radius: float | None  # None: derived from the collidable links touching it
    locked: bool
    lock_on_contact: bool
    sphere: bool
    damping: Damping | None
    muscle_to: str | None
    muscle_damping: float


@dataclass(frozen=True, slots=True)
class LinkSpec:
    """A rigid link of a template; radius 0 makes an invisible stiffener."""

    a: str
    b: str
    radius: float
    visible: bool
    collide: bool
    self_collide: bool  # may it collide with other links of its own body?
    self_group: str  # if set, it meets only links of its body in the same group (or none)
    rope: bool  # only a maximum distance: slack when the nodes are closer
    brace: bool  # holds only while the body is passive; a character's control frees it
    length: float | None  # None: the distance between the nodes' ``at``
    color: tuple[float, float, float, float] | None


@dataclass(frozen=True, slots=True)
class LimitSpec:
    """A hinge limit: see :data:`twig_ecs.store.LIMIT_FIELDS`."""

    root: str
    mid: str
    tip: str
    frame: tuple[str, str, str, str]
    side: float
    ref: tuple[float, float]
    arc: tuple[float, float]  # radians


@dataclass(frozen=True, slots=True)
class BodyTemplate:
    """A compiled body template, ready to spawn at any height."""

    name: str
    file: str
    reference_height: float
    height: float  # default height when spawned
    mass: float | None  # default total mass (None: template masses scaled by height^3)
    color: tuple[float, float, float, float]
    nodes: tuple[NodeSpec, ...]
    links: tuple[LinkSpec, ...]
    limits: tuple[LimitSpec, ...]
    axle: tuple[str, str] | None
    damping: Damping
    self_collision: bool
    pain: PainSensor | None

    @property
    def node_names(self) -> tuple[str, ...]:
        """Node names in row order."""
        return tuple(n.name for n in self.nodes)

    def contact_radii(self) -> np.ndarray:
        """Each node's contact radius at the reference height: its own, or its fattest colliding link's."""
        index = {n.name: k for k, n in enumerate(self.nodes)}
        link_radius = np.zeros(len(self.nodes))
        for link in self.links:
            if link.collide:
                for end in (link.a, link.b):
                    link_radius[index[end]] = max(link_radius[index[end]], link.radius)
        own = [n.radius for n in self.nodes]
        return np.array([r if r is not None else lr for r, lr in zip(own, link_radius, strict=True)])

    def bounds(self, scale: float) -> tuple[np.ndarray, np.ndarray]:
        """The corners (low, high) of the body's box in its own frame (m) at ``scale`` (height /
        reference height), contact radii included."""
        if not self.nodes:
            return np.zeros(3), np.zeros(3)
        local = np.array([n.at for n in self.nodes], dtype=np.float64) * scale
        radius = self.contact_radii()[:, None] * scale
        return (local - radius).min(axis=0), (local + radius).max(axis=0)

    def span(self, height: float | None = None) -> float:
        """How far across (m) the body is at ``height`` (default: its own): the largest side
        of the box holding every node's contact sphere (:meth:`bounds`)."""
        low, high = self.bounds((height or self.height) / self.reference_height)
        return float((high - low).max())


def read_damping(doc: YDict, key: str, path: str, default: Damping | None) -> Damping | None:
    """A ``damping: {air, ground, rolling}`` mapping (air and ground: fractions removed per step;
    rolling: a deceleration in m/s^2)."""
    if key not in doc:
        return default
    d = read(doc, key, path, mapping)
    here = join(path, key)
    check_keys(d, here, DAMPING_KEYS)
    base = default or Damping()
    return Damping(read(d, "air", here, fraction, base.air), read(d, "ground", here, fraction, base.ground),
                   read(d, "rolling", here, ROLLING, base.rolling))  # fmt: skip


def read_pain(doc: YDict, key: str, path: str, default: PainSensor | None) -> PainSensor | None:
    """A ``pain: {threshold, half_life, gain}`` mapping, or ``pain: false``."""
    if key not in doc:
        return default
    if doc[key] is False:
        return None
    d = read(doc, key, path, mapping)
    here = join(path, key)
    check_keys(d, here, PAIN_KEYS)
    base = default or PainSensor()
    return PainSensor(
        threshold=read(d, "threshold", here, nonnegative, base.threshold),
        half_life=read(d, "half_life", here, positive, base.half_life),
        gain=read(d, "gain", here, nonnegative, base.gain),
    )


def compile_template(name: str, doc: YDict, path: str = "") -> BodyTemplate:
    """Validate a (merged) template document and build its BodyTemplate."""
    check_keys(doc, path, TEMPLATE_KEYS)
    ref_h = read(doc, "reference_height", path, HEIGHT, 1.0)
    defaults = read(doc, "defaults", path, mapping, None)
    height, mass = ref_h, None
    if defaults is not None:
        dpath = join(path, "defaults")
        check_keys(defaults, dpath, DEFAULT_KEYS)
        height = read(defaults, "height", dpath, HEIGHT, ref_h)
        mass = read(defaults, "mass", dpath, MASS, None)
    body_color = read(doc, "color", path, color, (0.8, 0.8, 0.8, 1.0))
    damping = read_damping(doc, "damping", path, Damping())
    assert damping is not None

    raw_nodes = read(doc, "nodes", path, mapping)
    npath = join(path, "nodes")
    if not raw_nodes:
        fail(doc, "nodes", npath, "a body needs at least one node")
    nodes = []
    for node_name, spec in raw_nodes.items():
        here = join(npath, node_name)
        spec = read(raw_nodes, node_name, npath, mapping)
        check_keys(spec, here, NODE_KEYS)
        muscle_to, muscle_d = None, 0.0
        if "muscle" in spec:
            m = read(spec, "muscle", here, mapping)
            mpath = join(here, "muscle")
            check_keys(m, mpath, ("to", "damping"))
            muscle_to = read(m, "to", mpath, text)
            if muscle_to not in raw_nodes:
                fail(
                    m, "to", join(mpath, "to"), f"unknown node '{muscle_to}'" + suggest(muscle_to, raw_nodes)
                )
            muscle_d = read(m, "damping", mpath, fraction, 0.1)
        nodes.append(
            NodeSpec(
                name=str(node_name),
                at=read(spec, "at", here, vec3),
                mass=read(spec, "mass", here, NODE_MASS, 1.0),
                radius=read(spec, "radius", here, nonnegative, None),
                locked=read(spec, "locked", here, boolean, False),
                lock_on_contact=read(spec, "lock_on_contact", here, boolean, False),
                sphere=read(spec, "sphere", here, boolean, False),
                damping=read_damping(spec, "damping", here, None),
                muscle_to=muscle_to,
                muscle_damping=muscle_d,
            )
        )
    known = {n.name: n for n in nodes}

    def node_ref(container, key, where: str) -> str:
        value = read(container, key, where, text)
        if value not in known:
            fail(container, key, join(where, key), f"unknown node '{value}'" + suggest(value, known))
        return value

    def node_list(container, key, where: str, count: int) -> tuple[str, ...]:
        values = read(container, key, where, names(count))
        lst = container[key]
        for i, v in enumerate(values):
            if v not in known:
                fail(lst, i, f"{join(where, key)}[{i}]", f"unknown node '{v}'" + suggest(v, known))
        return values

    links = []
    raw_links = read(doc, "links", path, sequence, [])
    lpath = join(path, "links")
    for i, spec in enumerate(raw_links):
        here = join(lpath, i)
        spec = read(raw_links, i, lpath, mapping)
        check_keys(spec, here, LINK_KEYS)
        a, b = node_list(spec, "nodes", here, 2)
        if a == b:
            fail(spec, "nodes", join(here, "nodes"), f"a link needs two different nodes, got '{a}' twice")
        radius = read(spec, "radius", here, nonnegative, 0.0)
        visible = read(spec, "visible", here, boolean, radius > 0)
        collide = read(spec, "collide", here, boolean, radius > 0)
        if collide and radius <= 0:
            fail(spec, "collide", join(here, "collide"), "a colliding link needs a radius greater than 0")
        length = read(spec, "length", here, positive, None)
        if length is None and math.dist(known[a].at, known[b].at) <= SAME_PLACE:
            fail(
                spec,
                "nodes",
                join(here, "nodes"),
                f"nodes '{a}' and '{b}' are at the same place: give the link a length",
            )
        self_collide = read(spec, "self_collide", here, boolean, True)
        self_group = read(spec, "self_group", here, text, "")
        rope = read(spec, "rope", here, boolean, False)
        brace = read(spec, "brace", here, boolean, False)
        link_color = read(spec, "color", here, color, None)
        links.append(
            LinkSpec(
                a, b, radius, visible, collide, self_collide, self_group, rope, brace, length, link_color
            )
        )

    limits = []
    raw_limits = read(doc, "joint_limits", path, sequence, [])
    jpath = join(path, "joint_limits")
    for i, spec in enumerate(raw_limits):
        here = join(jpath, i)
        spec = read(raw_limits, i, jpath, mapping)
        check_keys(spec, here, LIMIT_KEYS)
        root, mid, tip = node_list(spec, "hinge", here, 3)
        frame = node_list(spec, "frame", here, 4)
        side_name = read(spec, "side", here, text)
        if side_name not in ("left", "right"):
            fail(spec, "side", join(here, "side"), f"expected 'left' or 'right', got '{side_name}'")
        ref = read(spec, "ref", here, _pair, (1.0, 0.0))
        arc = read(spec, "arc", here, _pair)
        if arc[0] > arc[1] or arc[0] < -180 or arc[1] > 180 or arc[1] - arc[0] > 180:
            fail(spec, "arc", join(here, "arc"),
                 "expected [min, max] degrees, -180 <= min <= max <= 180, at most 180 apart")  # fmt: skip
        limits.append(
            LimitSpec(
                root,
                mid,
                tip,
                frame,
                1.0 if side_name == "left" else -1.0,
                ref,
                (math.radians(arc[0]), math.radians(arc[1])),
            )
        )

    axle = None
    if "axle" in doc:
        axle = node_list(doc, "axle", path, 2)
        for a in axle:
            if not known[a].locked:
                fail(doc, "axle", join(path, "axle"), f"axle node '{a}' must be locked: true")
        # the axle's direction is the line between its nodes: with no line it is NaN
        if axle[0] == axle[1]:
            fail(doc, "axle", join(path, "axle"), f"an axle needs two different nodes, got '{axle[0]}' twice")
        if math.dist(known[axle[0]].at, known[axle[1]].at) <= SAME_PLACE:
            fail(doc, "axle", join(path, "axle"), f"axle nodes '{axle[0]}' and '{axle[1]}' are at the "
                 "same place: the axle has no direction")  # fmt: skip

    return BodyTemplate(
        name=name,
        file=doc.file,
        reference_height=ref_h,
        height=height,
        mass=mass,
        color=body_color,
        nodes=tuple(nodes),
        links=tuple(links),
        limits=tuple(limits),
        axle=axle,
        damping=damping,
        self_collision=read(doc, "self_collision", path, boolean, True),
        pain=read_pain(doc, "pain", path, None),
    )


def _pair(value) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise ValueError("a list of two numbers")
    return number(value[0]), number(value[1])


__all__ = [
    "BodyTemplate",
    "Damping",
    "LimitSpec",
    "LinkSpec",
    "NodeSpec",
    "compile_template",
    "integer",
    "read_damping",
    "read_pain",
]
