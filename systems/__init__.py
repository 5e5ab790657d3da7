"""Systems: esper processors run in the scene's named schedule, one per file.

The physics systems (integrate, constrain, collide, sense) each make one call per step
into a numba kernel that loops over the whole :class:`~twig_ecs.store.PhysicsState`;
the character controllers (gait, gaze, posture, arms, respiration) likewise make one
call each over the table of characters. Which systems a scene runs is up to its plugins
(:mod:`twig_ecs.plugins`); the order of their stages is :data:`twig_ecs.schedule.PIPELINE`.
"""

from twig_ecs.kernelcache import configure_cache

configure_cache()  # before any system module defines its kernels (numba binds the cache then)

from twig_ecs.systems.arms import ArmsSystem  # noqa: E402
from twig_ecs.systems.attention import AttentionSystem  # noqa: E402
from twig_ecs.systems.collide import CollideSystem  # noqa: E402
from twig_ecs.systems.constrain import ConstrainSystem  # noqa: E402
from twig_ecs.systems.gait import GaitSystem  # noqa: E402
from twig_ecs.systems.gaze import GazeSystem  # noqa: E402
from twig_ecs.systems.integrate import IntegrateSystem  # noqa: E402
from twig_ecs.systems.patrol import PatrolSystem  # noqa: E402
from twig_ecs.systems.posture import PostureSystem  # noqa: E402
from twig_ecs.systems.respiration import RespirationSystem  # noqa: E402
from twig_ecs.systems.select_behavior import SelectBehaviorSystem  # noqa: E402
from twig_ecs.systems.sense import SenseSystem  # noqa: E402

__all__ = [
    "ArmsSystem",
    "AttentionSystem",
    "CollideSystem",
    "ConstrainSystem",
    "GaitSystem",
    "GazeSystem",
    "IntegrateSystem",
    "PatrolSystem",
    "PostureSystem",
    "RespirationSystem",
    "SelectBehaviorSystem",
    "SenseSystem",
]
