"""twig-ecs: lightweight procedural character animation with believable physical
interactions, as an entity-component-system (a re-creation of Horswill's Twig).

Start with :class:`Scene`::

    from twig_ecs import Scene
    scene = Scene.load("schoolyard")
    scene.run(2.0)
    print(scene.entity("parent").position)
"""

from twig_ecs.errors import SceneError, ScheduleError, TwigError
from twig_ecs.scene import Scene
from twig_ecs.scenefile import Settings
from twig_ecs.system import System

__version__ = "0.1.0"
__all__ = ["Scene", "SceneError", "ScheduleError", "Settings", "System", "TwigError", "__version__"]
