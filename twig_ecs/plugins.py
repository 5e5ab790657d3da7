"""Plugins: each feature registers its own systems into the schedule's named stages.

A plugin is a small object with a ``name`` and a :meth:`Plugin.build` that adds its
systems to a scene (Bevy's ``Plugin``). The stages they go into, and so the order of a
step, are written once, in :data:`twig_ecs.schedule.PIPELINE`; a plugin only says *which*
systems it brings. ``Scene(plugins=[...])`` builds a scene from the plugins it is given;
without the argument a scene gets :func:`default_plugins`, which is everything built in::

    from twig_ecs import Scene
    from twig_ecs.plugins import PhysicsPlugin

    scene = Scene(plugins=[PhysicsPlugin()])   # bodies fall, collide and feel; nobody acts

A user plugin subclasses :class:`Plugin` (a module-level class, so snapshots can name it)
and calls ``scene.add_system`` in ``build``, with ``before=``/``after=`` stage names where
it needs a place of its own (a :class:`~twig_ecs.behavior.Behavior` goes to the
behaviours stage by itself).
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache
from typing import TYPE_CHECKING, ClassVar

from twig_ecs.behavior import REGISTRY, Behavior
from twig_ecs.schedule import BEHAVIOURS
from twig_ecs.system import System
from twig_ecs.systems import behaviours as behaviour_package
from twig_ecs.systems.control.arms import ArmsSystem
from twig_ecs.systems.control.attention import AttentionSystem
from twig_ecs.systems.control.gait import GaitSystem
from twig_ecs.systems.control.gaze import GazeSystem
from twig_ecs.systems.control.glance import GlanceSystem
from twig_ecs.systems.control.patrol import PatrolSystem
from twig_ecs.systems.control.posture import PostureSystem
from twig_ecs.systems.control.respiration import RespirationSystem
from twig_ecs.systems.control.select_behavior import SelectBehaviorSystem
from twig_ecs.systems.physics.collide import CollideSystem
from twig_ecs.systems.physics.constrain import ConstrainSystem
from twig_ecs.systems.physics.integrate import IntegrateSystem
from twig_ecs.systems.physics.sense import SenseSystem

if TYPE_CHECKING:
    from twig_ecs.goals import GoalSchema
    from twig_ecs.step import SceneView


class Plugin:
    """A feature that adds its systems to a scene: subclass it and implement :meth:`build`."""

    #: A short name for the feature (shown in errors and ``Scene.plugins``).
    name: ClassVar[str] = ""
    #: The system classes this plugin adds, in the order it adds them.
    systems: ClassVar[tuple[type[System], ...]] = ()

    def build(self, scene: SceneView) -> None:
        """Add this plugin's systems to ``scene`` (each into the stage of its own name or set)."""
        for cls in self.systems:
            scene.add_system(cls())

    def __repr__(self) -> str:
        return f"<{type(self).__name__}>"


class PhysicsPlugin(Plugin):
    """Point-mass physics: Verlet integration, constraints, collisions and the sense of impact."""

    name = "physics"
    systems = (IntegrateSystem, ConstrainSystem, CollideSystem, SenseSystem)


class ControlPlugin(Plugin):
    """A character's body control: attention, behaviour selection, patrol, gait, glances, gaze,
    posture, arms and breathing. Without behaviours every character stands idle, balanced."""

    name = "control"
    systems = (GaitSystem, AttentionSystem, SelectBehaviorSystem, PatrolSystem, GlanceSystem, GazeSystem,
               PostureSystem, ArmsSystem, RespirationSystem)  # fmt: skip


@cache
def builtin_behaviors() -> tuple[type[Behavior], ...]:
    """Every built-in behaviour, in the order they propose each step (whichever plugins bring them).

    Found, not listed: each :class:`~twig_ecs.behavior.Behavior` class defined in a module
    of the ``twig_ecs.systems.behaviours`` package, modules by name and classes in the
    order their module defines them. A new built-in behaviour is one module there.
    """
    found: list[type[Behavior]] = []
    for info in sorted(pkgutil.iter_modules(behaviour_package.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{behaviour_package.__name__}.{info.name}")
        found += [value for value in vars(module).values()
                  if isinstance(value, type) and issubclass(value, Behavior)
                  and value.__module__ == module.__name__ and value.name]  # fmt: skip
    return tuple(found)


def motives() -> tuple[type[Behavior], ...]:
    """The schoolyard's motives: behaviours a character *has* (a component says how strongly),
    reflexes apart."""
    return tuple(b for b in builtin_behaviors() if b.component is not None and not b.reflex)


def goal_behaviors() -> tuple[type[Behavior], ...]:
    """The goal behaviours (what a character is told to do), their answers and the reflexes
    (the pain withdrawal; a hug's step back, whose component is only where it steps from)."""
    return tuple(b for b in builtin_behaviors() if b.component is None or b.reflex)


class _BuiltinBehaviours(Plugin):
    """Adds built-in behaviours so that they propose in :func:`builtin_behaviors` order,
    whichever of the behaviour plugins a scene has and in whatever order it lists them."""

    @staticmethod
    def behaviours() -> tuple[type[Behavior], ...]:
        """The behaviours this plugin brings."""
        raise NotImplementedError

    def build(self, scene: SceneView) -> None:
        stages = scene.schedule.stages
        names = [b.name for b in builtin_behaviors()]
        for cls in self.behaviours():
            at = names.index(cls.name)
            # between its nearest built-in neighbours already in the schedule (a linked-list insert)
            after = next((n for n in reversed(names[:at]) if n in stages), None)
            before = next((n for n in names[at + 1 :] if n in stages), None)
            if after is None and before is None:
                scene.add_system(cls())  # the first: it joins the behaviours stage
            else:
                scene.add_system(cls(), after=after or BEHAVIOURS, before=before or "select_behavior")


class SchoolyardMotivesPlugin(_BuiltinBehaviours):
    """The schoolyard's motives: attachment to a caregiver, play, fights, rides, watching, wandering.

    Each proposes only for the characters that carry its component, so a scene pays only
    for the motives its characters have.
    """

    name = "motives"

    @staticmethod
    def behaviours() -> tuple[type[Behavior], ...]:
        """Every built-in behaviour with a component: the motives."""
        return motives()


class BehavioursPlugin(_BuiltinBehaviours):
    """The goal behaviours (approach, carry, hug, sit...), their answers and the pain reflex."""

    name = "behaviours"

    @staticmethod
    def behaviours() -> tuple[type[Behavior], ...]:
        """Every built-in behaviour without a component."""
        return goal_behaviors()


def default_plugins() -> list[Plugin]:
    """Everything built in: what ``Scene()`` and every scene file get."""
    return [PhysicsPlugin(), ControlPlugin(), SchoolyardMotivesPlugin(), BehavioursPlugin()]


def load_builtin_behaviors() -> dict[str, type[Behavior]]:
    """The registry of behaviour kinds, by name, with the built-in ones certainly in it."""
    for cls in builtin_behaviors():
        REGISTRY.setdefault(cls.name, cls)
    return {k: v for k, v in REGISTRY.items() if v.__module__.startswith("twig_ecs.")}


def builtin_goal_schemas() -> list[GoalSchema]:
    """The schemas of the built-in goal behaviours, modules by name and classes in the order
    their module defines them (as :func:`builtin_behaviors`: never the order some test or
    plug-in happened to import them in, which reordered the docs' tables)."""
    return [cls.schema for cls in builtin_behaviors() if cls.schema is not None]
