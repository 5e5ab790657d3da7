"""The Character component: a body that controls itself (SPEC 3)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Character:
    """Marks a body as a character and holds what its controllers do not keep in arrays.

    ``index`` is its row in ``PhysicsState.characters`` (control state, node roles);
    ``holding`` maps a hand ("left"/"right") to the entity of its grab joint.
    """

    index: int
    max_speed: float = 6.0  # m/s
    holding: dict[str, int] = field(default_factory=dict)
    route: list[tuple[float, float]] = field(default_factory=list)  # patrol waypoints (x, z)
    route_speed: float = 1.0  # m/s along the route
    waypoint: int = 0  # index of the waypoint it walks to
