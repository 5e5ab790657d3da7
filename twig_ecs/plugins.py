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

from typing import TYPE_CHECKING, ClassVar

from twig_ecs.behavior import REGISTRY, Behavior
from twig_ecs.schedule import BEHAVIOURS
from twig_ecs.system import System
from twig_ecs.systems.approach import Approach
from twig_ecs.systems.arms import ArmsSystem
from twig_ecs.systems.attachment import AttachmentBehavior
from twig_ecs.systems.attention import AttentionSystem
from twig_ecs.systems.carry import Carry, Cradle, Drag
from twig_ecs.systems.collide import CollideSystem
from twig_ecs.systems.constrain import ConstrainSystem
from twig_ecs.systems.embrace import Embrace
from twig_ecs.systems.fight import Defend, Fight
from twig_ecs.systems.gait import GaitSystem
from twig_ecs.systems.gaze import GazeSystem
from twig_ecs.systems.grapple import Grapple
from twig_ecs.systems.hug import Hug
from twig_ecs.systems.integrate import IntegrateSystem
from twig_ecs.systems.patrol import PatrolSystem
from twig_ecs.systems.play import Play
from twig_ecs.systems.posture import PostureSystem
from twig_ecs.systems.posture_goals import Freeze, Gesture, SitDown, StandUp
from twig_ecs.systems.respiration import RespirationSystem
from twig_ecs.systems.ride import Ride
from twig_ecs.systems.select_behavior import SelectBehaviorSystem
from twig_ecs.systems.sense import SenseSystem
from twig_ecs.systems.wander import WanderBehavior
from twig_ecs.systems.watch import Watch
from twig_ecs.systems.withdraw import Withdraw

if TYPE_CHECKING:
    from twig_ecs.goals import GoalSchema
    from twig_ecs.scene import Scene


class Plugin:
    """A feature that adds its systems to a scene: subclass it and implement :meth:`build`."""

    #: A short name for the feature (shown in errors and ``Scene.plugins``).
    name: ClassVar[str] = ""
    #: The system classes this plugin adds, in the order it adds them.
    systems: ClassVar[tuple[type[System], ...]] = ()

    def build(self, scene: Scene) -> None:
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
    """A character's body control: attention, behaviour selection, patrol, gait, gaze, posture,
    arms and breathing. Without behaviours every character stands idle, balanced."""

    name = "control"
    systems = (GaitSystem, AttentionSystem, SelectBehaviorSystem, PatrolSystem, GazeSystem, PostureSystem,
               ArmsSystem, RespirationSystem)  # fmt: skip


#: Every built-in behaviour, in the order they propose each step (whichever plugins bring
#: them): goal behaviours, the answers they draw from others (cradle to carry, embrace to
#: hug, defend to a fight), the schoolyard's motives and the pain reflex.
BUILTIN_BEHAVIORS: tuple[type[Behavior], ...] = (
    Approach, AttachmentBehavior, Carry, Drag, Cradle, Fight, Defend, Grapple, Embrace, Hug, Play,
    SitDown, StandUp, Freeze, Gesture, Ride, WanderBehavior, Watch, Withdraw,
)  # fmt: skip

#: The schoolyard's motives: behaviours a character *has* (a component says how strongly).
MOTIVES: tuple[type[Behavior], ...] = (AttachmentBehavior, Fight, Play, Ride, WanderBehavior, Watch)

#: The goal behaviours (what a character is told to do), their answers and the pain reflex.
GOAL_BEHAVIORS: tuple[type[Behavior], ...] = tuple(b for b in BUILTIN_BEHAVIORS if b not in MOTIVES)


class _BuiltinBehaviours(Plugin):
    """Adds built-in behaviours so that they propose in :data:`BUILTIN_BEHAVIORS` order,
    whichever of the behaviour plugins a scene has and in whatever order it lists them."""

    def build(self, scene: Scene) -> None:
        stages = scene.schedule.stages
        names = [b.name for b in BUILTIN_BEHAVIORS]
        for cls in self.systems:
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
    systems = MOTIVES


class BehavioursPlugin(_BuiltinBehaviours):
    """The goal behaviours (approach, carry, hug, sit...), their answers and the pain reflex."""

    name = "behaviours"
    systems = GOAL_BEHAVIORS


def default_plugins() -> list[Plugin]:
    """Everything built in: what ``Scene()`` and every scene file get."""
    return [PhysicsPlugin(), ControlPlugin(), SchoolyardMotivesPlugin(), BehavioursPlugin()]


def load_builtin_behaviors() -> dict[str, type[Behavior]]:
    """The registry of behaviour kinds, by name, with the built-in ones certainly in it."""
    for cls in BUILTIN_BEHAVIORS:
        REGISTRY.setdefault(cls.name, cls)
    return {k: v for k, v in REGISTRY.items() if v.__module__.startswith("twig_ecs.")}


def builtin_goal_schemas() -> list[GoalSchema]:
    """The schemas of the built-in goal behaviours, in the order they are registered."""
    return [cls.schema for cls in load_builtin_behaviors().values() if cls.schema is not None]
