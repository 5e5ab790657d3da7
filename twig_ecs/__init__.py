"""twig-ecs: lightweight procedural character animation with believable physical
interactions, as an entity-component-system (a re-creation of Horswill's Twig).

Start with :class:`Scene`::

    from twig_ecs import Scene
    scene = Scene.load("schoolyard")
    scene.run(2.0)
    print(scene.entity("parent").position)
"""

from twig_ecs.kernels import configure_cache

configure_cache()  # before any kernel module is imported

from twig_ecs.errors import SceneError, ScheduleError, TwigError  # noqa: E402
from twig_ecs.scene import Scene  # noqa: E402
from twig_ecs.scenefile import Settings  # noqa: E402
from twig_ecs.system import System  # noqa: E402

__version__ = "0.1.0"
__all__ = ["Scene", "SceneError", "ScheduleError", "Settings", "System", "TwigError", "__version__"]
