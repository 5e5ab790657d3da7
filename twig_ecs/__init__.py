"""twig-ecs: lightweight procedural character animation with believable physical
interactions, as an entity-component-system (a re-creation of Horswill's Twig).

Start with :class:`Scene`::

    from twig_ecs import Scene
    scene = Scene.load("schoolyard")
    scene.run(2.0)
    print(scene.entity("parent").position)
"""

from pathlib import Path as _Path

from twig_ecs.version import __version__  # the one place the release number is written


def _checkout_subpackages() -> None:
    """Find ``twig_ecs.components``/``.systems``/``.content`` in a checkout.

    The design keeps ``components/``, ``systems/`` and ``content/`` at the top of the
    repository, beside ``twig_ecs/``; an install maps them into the package. Run from a
    checkout (its ``twig_ecs/`` first on ``sys.path``, as with ``python -m twig_ecs`` or
    ``python benchmarks/...`` there), the package looks for them beside itself too.
    """
    here = _Path(__file__).resolve().parent
    root = here.parent
    if not (here / "systems").is_dir() and (root / "systems" / "__init__.py").is_file():
        if (root / "pyproject.toml").is_file() and str(root) not in __path__:
            __path__.append(str(root))


_checkout_subpackages()

from twig_ecs.kernels import configure_cache  # noqa: E402

configure_cache()  # before any kernel module is imported

from twig_ecs.errors import SceneError, ScheduleError, TwigError  # noqa: E402
from twig_ecs.plugins import (  # noqa: E402
    BehavioursPlugin,
    ControlPlugin,
    PhysicsPlugin,
    Plugin,
    SchoolyardMotivesPlugin,
)
from twig_ecs.scene import Scene  # noqa: E402
from twig_ecs.scenefile import Settings  # noqa: E402
from twig_ecs.system import System  # noqa: E402

__all__ = ["BehavioursPlugin", "ControlPlugin", "PhysicsPlugin", "Plugin", "Scene", "SceneError",
           "SchoolyardMotivesPlugin", "ScheduleError",
           "Settings", "System", "TwigError", "__version__"]  # fmt: skip
