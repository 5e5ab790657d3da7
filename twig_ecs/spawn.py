"""Spawning: turn a body template into store rows and world entities."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twig_ecs.components import Body, Name, PainSensor
from twig_ecs.store import (
    LINK_BRACE,
    LINK_COLLIDE,
    LINK_NO_SELF,
    LINK_ROPE,
    LINK_VISIBLE,
    NODE_LOCK_ON_CONTACT,
    NODE_LOCKED,
    NODE_SPHERE,
)
from twig_ecs.templates import BodyTemplate, Damping

if TYPE_CHECKING:
    from twig_ecs.step import SceneView

#: Most bodies one scene may hold (twice the crowd's largest count): every step costs at least
#: their number, and a server must keep answering.
MAX_BODIES = 10000
#: Largest a body may be across (m), contact radii included: the broad phase files every
#: collider in the grid cells its box covers, so one huge body (a merry-go-round of height
#: 100, a ball of height 100, a node of radius 250) makes each step take seconds or more
#: memory than there is.
MAX_EXTENT = 30.0


def yaw_matrix(degrees: float) -> np.ndarray:
    """Rotation about +y taking the template's forward (+z) to (sin a, 0, cos a)."""
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def check_capacity(scene: SceneView, name: str, template: BodyTemplate, scale: float) -> None:
    """Refuse (SceneError, with the limit and the way out) a body past MAX_BODIES or MAX_EXTENT.

    Called before anything of the body is made (store rows, entities, colliders).
    """
    from twig_ecs.errors import SceneError

    bodies = scene.state.bodies.count
    if bodies >= MAX_BODIES:
        raise SceneError(f"cannot add '{name}': the scene already has {bodies} bodies, the most it may "
                         f"hold (MAX_BODIES); remove some first")  # fmt: skip
    low, high = template.bounds(scale)
    extent = float((high - low).max())
    if not extent <= MAX_EXTENT:  # NaN too
        across = f"{extent:.0f}" if extent < 1e6 else f"{extent:.3g}"  # a radius of 1e300 too
        raise SceneError(f"cannot add '{name}': at this height it would be {across} m across (contact "
                         f"radii included), over the {MAX_EXTENT:.0f} m limit (MAX_EXTENT); give a smaller "
                         f"height or radius")  # fmt: skip


def crowding(scene: SceneView, template: BodyTemplate, scale: float, position, facing: float) -> list[int]:
    """The bodies (store rows) with a node reaching into the box a new body would fill there.

    The server refuses a spawn into a pile (see ``twig_ecs.server.methods.MAX_CROWD``): a
    few hundred bodies at one spot make each step take seconds.
    """
    low, high = template.bounds(scale)
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1])
                        for z in (low[2], high[2])])  # fmt: skip
    world = corners @ yaw_matrix(facing).T + np.asarray(position, dtype=np.float64)
    lo, hi = world.min(axis=0), world.max(axis=0)
    nodes = scene.state.nodes
    pos, radius = nodes.pos[: nodes.count], nodes.radius[: nodes.count, None]
    inside = np.all((pos + radius >= lo) & (pos - radius <= hi), axis=1)
    return sorted({int(b) for b in np.unique(nodes.body[: nodes.count][inside])})


def spawn_body(
    scene: SceneView,
    template: BodyTemplate,
    name: str,
    position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    facing: float = 0.0,
    height: float | None = None,
    mass: float | None = None,
    color: tuple[float, float, float, float] | None = None,
    pain: PainSensor | None | bool = True,
    damping: Damping | None = None,
) -> int:
    """Create one body: rows in the store and one entity (Name, Body). Returns the body entity.

    ``height`` scales lengths and radii by height/reference_height; masses scale by the
    cube of that unless ``mass`` (total, kg) is given. The caller has validated names.
    """
    state = scene.state
    height = height or template.height
    scale = height / template.reference_height
    check_capacity(scene, name, template, scale)
    total = sum(n.mass for n in template.nodes)
    target_mass = mass or template.mass
    mass_scale = target_mass / total if target_mass else scale**3
    rot = yaw_matrix(facing)
    origin = np.asarray(position, dtype=np.float64)
    body_color = np.asarray(color or template.color, dtype=np.float32)
    index = {n.name: k for k, n in enumerate(template.nodes)}

    body = state.add_body()
    body_entity = scene.world.create_entity()
    state.bodies.entity[body] = body_entity
    state.bodies.self_collide[body] = template.self_collision
    sensor = template.pain if pain is True else pain
    if sensor is not None:
        state.bodies.pain_threshold[body] = sensor.threshold
        state.bodies.pain_half_life[body] = sensor.half_life
        state.bodies.pain_gain[body] = sensor.gain

    # -- nodes
    nodes = state.nodes
    rows = nodes.allocate(len(template.nodes))
    first = rows.start
    local = np.array([n.at for n in template.nodes], dtype=np.float64) * scale
    world = local @ rot.T + origin
    nodes.pos[rows] = world
    nodes.prev[rows] = world
    nodes.lock_pos[rows] = world
    nodes.body[rows] = body
    nodes.color[rows] = body_color
    radii = template.contact_radii()  # the node's own, or the fattest collidable link touching it
    for k, spec in enumerate(template.nodes):
        i = first + k
        m = spec.mass * mass_scale
        nodes.mass[i] = m
        nodes.inv_mass[i] = 1.0 / m
        nodes.radius[i] = radii[k] * scale
        d = damping or spec.damping or template.damping
        nodes.damp_air[i], nodes.damp_ground[i], nodes.roll_decel[i] = d.air, d.ground, d.rolling
        flags = 0
        if spec.locked:
            flags |= NODE_LOCKED
        if spec.lock_on_contact:
            flags |= NODE_LOCK_ON_CONTACT
        if spec.sphere:
            flags |= NODE_SPHERE
        nodes.flags[i] = flags
        if spec.muscle_to is not None:
            nodes.damp_ref[i] = first + index[spec.muscle_to]
            nodes.damp_rel[i] = spec.muscle_damping
    if template.axle is not None:
        a, b = first + index[template.axle[0]], first + index[template.axle[1]]
        axis = nodes.pos[b] - nodes.pos[a]
        axis /= np.linalg.norm(axis)
        for k in range(len(template.nodes)):
            i = first + k
            if i in (a, b) or template.nodes[k].locked:
                continue
            offset = nodes.pos[i] - nodes.pos[a]
            along = float(offset @ axis)
            nodes.axle_a[i], nodes.axle_b[i] = a, b
            nodes.axle_height[i] = along
            nodes.axle_radius[i] = float(np.linalg.norm(offset - along * axis))

    # -- links
    links = state.links
    lrows = links.allocate(len(template.links))
    groups = {g: k + 1 for k, g in enumerate(sorted({ln.self_group for ln in template.links} - {""}))}
    for k, spec in enumerate(template.links):
        j = lrows.start + k
        ia, ib = first + index[spec.a], first + index[spec.b]
        links.a[j], links.b[j] = ia, ib
        if spec.length is not None:
            links.rest[j] = spec.length * scale
        else:
            links.rest[j] = float(np.linalg.norm(nodes.pos[ia] - nodes.pos[ib]))
        links.radius[j] = spec.radius * scale
        links.flags[j] = (
            (LINK_VISIBLE if spec.visible else 0)
            | (LINK_COLLIDE if spec.collide else 0)
            | (0 if spec.self_collide else LINK_NO_SELF)
            | (LINK_ROPE if spec.rope else 0)
            | (LINK_BRACE if spec.brace else 0)
        )
        links.group[j] = groups.get(spec.self_group, 0)
        links.body[j] = body
        links.color[j] = spec.color if spec.color is not None else body_color

    # -- joint limits
    limits = state.limits
    mrows = limits.allocate(len(template.limits))
    for k, spec in enumerate(template.limits):
        j = mrows.start + k
        limits.root[j] = first + index[spec.root]
        limits.mid[j] = first + index[spec.mid]
        limits.tip[j] = first + index[spec.tip]
        limits.frame[j] = [first + index[f] for f in spec.frame]
        limits.side[j] = spec.side
        limits.ref[j] = spec.ref
        limits.set_arc(j, *spec.arc)
        limits.body[j] = body

    # the pain sensor's parameters live in the store's body columns (above), not in a component
    components = [
        Name(name),
        Body(
            template=template.name,
            index=body,
            node_start=first,
            node_names=template.node_names,
            link_start=lrows.start,
            link_count=len(template.links),
            height=height,
        ),
    ]
    for component in components:
        scene.world.add_component(body_entity, component)
    state.colliders_dirty = True  # rebuilt once before the next step, not per spawn
    return body_entity
