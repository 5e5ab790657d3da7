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

#: Public names and the modules that define them: imported on first use (PEP 562), so
#: ``twig --version`` and ``twig --help`` start without loading numba and the kernels.
_LAZY = {
    "Scene": "twig_ecs.scene",
    "Settings": "twig_ecs.scenefile",
    "System": "twig_ecs.system",
    "Plugin": "twig_ecs.plugins",
    "PhysicsPlugin": "twig_ecs.plugins",
    "ControlPlugin": "twig_ecs.plugins",
    "BehavioursPlugin": "twig_ecs.plugins",
    "SchoolyardMotivesPlugin": "twig_ecs.plugins",
}

from twig_ecs.errors import SceneError, ScheduleError, TwigError  # noqa: E402


def __getattr__(name: str):
    """Import a public name's module the first time the name is used."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'twig_ecs' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = ["BehavioursPlugin", "ControlPlugin", "PhysicsPlugin", "Plugin", "Scene", "SceneError",
           "SchoolyardMotivesPlugin", "ScheduleError",
           "Settings", "System", "TwigError", "__version__"]  # fmt: skip
