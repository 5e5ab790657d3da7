"""Systems: esper processors run in the scene's named schedule, one per file.

The physics systems (integrate, constrain, collide, sense) each make one call per step
into a numba kernel that loops over the whole :class:`~twig_ecs.store.PhysicsState`.
"""

from twig_ecs.systems.collide import CollideSystem
from twig_ecs.systems.constrain import ConstrainSystem
from twig_ecs.systems.integrate import IntegrateSystem
from twig_ecs.systems.sense import SenseSystem

__all__ = ["CollideSystem", "ConstrainSystem", "IntegrateSystem", "SenseSystem"]
