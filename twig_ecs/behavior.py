"""Behaviour-based control (SPEC 4): behaviours, goals and the registry of behaviour kinds.

Each behaviour kind is a :class:`Behavior` system. Every step it looks at the characters
that have its component and proposes an *activation* (a utility) for each; the
``select_behavior`` system then picks each character's winner and calls the winner's
:meth:`Behavior.act`, which writes the character's *motor vector* - walk vector, arm
modes and targets, gaze, posture - into the controllers' targets. Only winners act.

Commands from Python or RPC become :class:`~twig_ecs.mind.Goal` s: ``character.approach("ball")``
queues a goal, the matching behaviour gives it a high activation while it runs, and its
end is reported as a ``goal.done`` or ``goal.failed`` event (and to a callback).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from twig_ecs.components import Character
from twig_ecs.crowd import Crowd
from twig_ecs.errors import TwigError
from twig_ecs.goals import GoalSchema
from twig_ecs.mind import (  # noqa: F401 - a mind's parts, here too for behaviours and plug-ins
    GOAL_ACTIVATION,
    GOAL_SCHEMAS,
    BehaviorChanged,
    Goal,
    GoalDone,
    GoalFailed,
    Mind,
    _goal_schema_listeners,
    on_goal_schema,
)
from twig_ecs.schedule import BEHAVIOURS
from twig_ecs.system import System
from twig_ecs.validate import suggest

if TYPE_CHECKING:
    from collections.abc import Sequence

    from twig_ecs.character import CharacterHandle
    from twig_ecs.step import StepContext


class Behavior(System):
    """Base class of behaviour systems: propose activations, act when winning.

    Subclasses set ``name`` (the behaviour kind, also its schedule stage) and implement
    :meth:`activation` and :meth:`act`. A behaviour driven by goals declares its
    ``schema`` instead of a name (which makes it ``goal_driven``): it is active while the
    character's current goal names it.
    """

    #: Every behaviour proposes in the schedule's behaviours stage, before select_behavior.
    stage: ClassVar[str | None] = BEHAVIOURS
    goal_driven: ClassVar[bool] = False
    #: A goal behaviour's schema (:class:`~twig_ecs.goals.GoalSchema`): the goal's name,
    #: parameters with kinds, defaults and docs. Declaring one makes the behaviour
    #: goal-driven and names it; the handle method, the checks, the RPC method and the docs
    #: tables are all derived from it.
    schema: ClassVar[GoalSchema | None] = None
    #: For a behaviour that characters *have* (rather than are commanded to do): the
    #: component type holding its per-character parameters (a dataclass). Only
    #: characters with that component are considered; scenes attach it with
    #: ``behaviors: [{use: NAME, ...params}]`` on a character.
    component: ClassVar[type | None] = None
    #: A reflex (pain withdrawal) runs even for a scripted, non-autonomous character.
    reflex: ClassVar[bool] = False

    #: Proposals made with :meth:`propose_all` go to select_behavior as lists, which it
    #: selects over arrays (False: into each mind's dict, the per-character form).
    propose_over_arrays: ClassVar[bool] = True

    #: A batch behaviour acts for all the characters it wins in one call,
    #: :meth:`act_batch`, over arrays (crowds); others act per character.
    batch: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "act_crowd" in cls.__dict__:  # it acts over arrays: for all it won, in one call
            cls.batch = True
        old = [key for key in ("params", "required", "kinds") if key in cls.__dict__]
        if old:  # the attributes a goal's parameters were declared with before schemas
            raise TwigError(f"behaviour class {cls.__name__}: {', '.join(old)}: a goal's parameters are "
                            "declared in its schema now (docs/authoring-behaviours.md)")  # fmt: skip
        schema = cls.__dict__.get("schema")
        if schema is None:
            return
        if cls.__dict__.get("name", schema.name) != schema.name:
            raise TwigError(f"behaviour class {cls.__name__}: name '{cls.__dict__['name']}' differs from "
                            f"its schema's '{schema.name}' (give the name once, in the schema)")  # fmt: skip
        cls.name = schema.name
        cls.goal_driven = True
        GOAL_SCHEMAS[schema.name] = schema
        for listener in _goal_schema_listeners:
            listener(schema)

    def candidates(self) -> list[tuple[int, Mind]]:
        """The (entity, mind) pairs this behaviour may propose for (a superset is fine).

        Goal-driven: characters whose current goal is this behaviour's; with a component:
        characters having it; otherwise every character. Narrowing this keeps a crowd from costing each
        behaviour a Python call per character per step.
        """
        if self.goal_driven:
            return self.scene.goal_holders_of(self.name)
        if self.component is not None:
            return [
                (e, mind) for e, (_, mind, _) in self.world.get_components(Character, Mind, self.component)
            ]
        return [(e, mind) for e, (_, mind) in self.world.get_components(Character, Mind)]

    def run(self, ctx: StepContext) -> None:
        """Propose this behaviour's activation for every character."""
        scene = self.scene
        name = self.name
        if self.goal_driven and type(self).activation is Behavior.activation:
            # the default: a fixed activation while its goal is current, no handle needed
            if type(self).candidates is Behavior.candidates:  # the goal holders: kept while the goals are
                entities, minds = self.scratch.keyed("holders", scene.goals.changes, self._goal_holders)
            else:
                entities, minds = self._goal_holders()
            if entities:
                self.propose_all(ctx.frame, entities, minds, GOAL_ACTIVATION)
            return
        if type(self).propose_crowd is not Behavior.propose_crowd:
            self._propose_over_arrays(ctx)
            return
        for entity, mind, goal in self._proposers():
            value = self.activation(scene.character_handle(entity), mind, goal)
            if value > 0.0:
                mind.activations[name] = value

    def propose_all(self, frame: int, entities: Sequence[int], minds: Sequence[Mind],
                    value: float | np.ndarray) -> None:  # fmt: skip
        """Propose ``value`` (one for all, or one each) for every one of ``entities`` (``minds``:
        their minds) this step (``frame``), as ``mind.activations[self.name] = value`` does for
        one: a list that select_behavior takes in one piece and selects over arrays."""
        value = float(value) if np.ndim(value) == 0 else np.asarray(value, dtype=np.float64)
        if not Behavior.propose_over_arrays:
            for mind, one in zip(minds, np.broadcast_to(value, len(minds)).tolist(), strict=True):
                mind.activations[self.name] = one
            return
        made = self.scratch.get("proposed")
        if made is None or made[0] != frame:
            made = self.scratch["proposed"] = (frame, [])
        made[1].append((next(_PROPOSAL_ORDER), self.name, entities, minds, value))

    def _goal_holders(self) -> tuple[list[int], list[Mind]]:
        """The entities and minds of the :meth:`candidates` whose current goal is this behaviour's."""
        name = self.name
        holders = [(e, m) for e, m in self.candidates() if m.goals and m.goals[0].behavior == name]
        return [e for e, _ in holders], [m for _, m in holders]

    def _proposers(self):
        """(entity, mind, goal) of each character this behaviour may propose for now: a
        goal-driven one's with its goal current (and that goal), others' (goal None) but a
        scripted character's, which does only what it is told (reflexes apart)."""
        name = self.name
        for entity, mind in self.candidates():
            if not (self.goal_driven or self.reflex or mind.autonomous):
                continue
            goal = mind.goal if self.goal_driven else None
            if self.goal_driven and (goal is None or goal.behavior != name):
                continue
            yield entity, mind, goal

    def _propose_over_arrays(self, ctx: StepContext) -> None:
        """:meth:`run` for a behaviour that defines :meth:`propose_crowd`: one call for all."""
        name = self.name
        picked = list(self._proposers())
        if not picked:
            return
        world = self.world
        rows = [world.component_for_entity(e, Character).index for e, _, _ in picked]
        crowd = Crowd(self.scene, rows, [e for e, _, _ in picked], ctx.dt, [g for _, _, g in picked],
                      self.component)  # fmt: skip
        values = np.asarray(self.propose_crowd(crowd), dtype=np.float64).reshape(-1)
        if len(values) != len(picked):
            raise TwigError(f"behaviour '{name}': propose_crowd gave {len(values)} values for {len(picked)} "
                            "characters")  # fmt: skip
        wanted = np.flatnonzero(values > 0.0).tolist()
        if wanted:
            self.propose_all(ctx.frame, [picked[k][0] for k in wanted], [picked[k][1] for k in wanted],
                             values[wanted])  # fmt: skip

    def activation(self, character: CharacterHandle, mind: Mind, goal: Goal | None) -> float:
        """How much this behaviour wants to run for this character now (0: not at all)."""
        return GOAL_ACTIVATION if goal is not None else 0.0

    def start(self, character: CharacterHandle, goal: Goal | None) -> None:
        """Called when this behaviour starts winning for a character."""

    def act(self, character: CharacterHandle, mind: Mind, goal: Goal | None, dt: float) -> None:
        """Write the motor vector: walk, arms, gaze, posture targets."""

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """Act for every character this behaviour won this step (a batch behaviour).

        ``rows`` are their rows in the store's character table, ``entities`` their
        entities; a goal-driven behaviour also gets ``goals``, each one's current goal (None
        where it has none of this behaviour's). The default calls :meth:`act_crowd` with
        them as a :class:`~twig_ecs.crowd.Crowd` where a subclass defines it, else :meth:`act`
        for each.
        """
        if type(self).act_crowd is not Behavior.act_crowd:
            self.act_crowd(Crowd(self.scene, rows, entities, dt, goals, self.component))
            return
        for entity in entities:
            mind = self.world.component_for_entity(entity, Mind)
            goal = mind.goal if mind.goal is not None and mind.goal.behavior == self.name else None
            self.act(self.scene.character_handle(entity), mind, goal, dt)

    def act_crowd(self, crowd: Crowd) -> None:
        """The batch form of :meth:`act`: write the motor vectors of every character this
        behaviour won this step at once, over arrays (``crowd.walk(velocities)``...). A
        subclass that defines it acts only this way (docs/authoring-behaviours.md)."""

    def propose_crowd(self, crowd: Crowd) -> np.ndarray:
        """The batch form of :meth:`activation`: how much this behaviour wants to run for each
        of the characters it may propose for (an array, 0: not at all). A subclass that
        defines it is asked this way, once a step, instead of once per character."""
        raise NotImplementedError

    def stop(self, character: CharacterHandle, goal: Goal | None) -> None:
        """Called when this behaviour stops winning (tidy up: release grabs, unlock)."""

    # -- goal helpers for subclasses ------------------------------------------------------

    def settings(self, character: CharacterHandle) -> Any:
        """This behaviour's component on a character (its per-character parameters)."""
        return self.world.component_for_entity(character.entity, self.component)

    def finish(self, character: CharacterHandle, goal: Goal, ok: bool = True, reason: str = "") -> None:
        """End ``goal`` (done or failed) and report it."""
        character.scene.end_goal(character, goal, ok, reason)


#: The order proposals are made in, across behaviours: a character's proposals are compared
#: in it (the first of equal ones wins, as in a mind's dict).
_PROPOSAL_ORDER = itertools.count()

#: Behaviour kinds by name: the systems that implement them (filled by register()).
REGISTRY: dict[str, type[Behavior]] = {}


def goal_targets(scene, behavior: str) -> dict[int, tuple[int, Goal]]:
    """The live targets of one goal behaviour: {target entity: (goal holder entity, goal)}.

    Reads the scene's goal holders; a goal whose target no longer exists is left out.
    """
    out: dict[int, tuple[int, Goal]] = {}
    for entity, mind in scene.goal_holders_of(behavior):
        goal = mind.goal
        target = goal.params.get("target")
        if scene.has_entity(target):
            out[scene.entity(target).entity] = (entity, goal)
    return out


def register(cls: type[Behavior]) -> type[Behavior]:
    """Make a behaviour kind known by its ``name`` (a class decorator)."""
    if not cls.name:
        raise TwigError(f"behaviour class {cls.__name__} needs a name")
    REGISTRY[cls.name] = cls
    return cls


#: Entry point group through which installed packages offer behaviours.
ENTRY_POINT_GROUP = "twig_ecs.behaviors"


def installed_behaviors() -> dict[str, Any]:
    """Behaviours offered by installed packages (entry points), by name, not yet loaded."""
    from importlib.metadata import entry_points

    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def load_class(reference: str, base_dir: str | None = None) -> type:
    """The class named by ``"package.module:Class"`` or ``"path/to/file.py:Class"``.

    A file path is taken relative to ``base_dir`` (the scene file's folder). Raises
    TwigError with the reason when the module or class cannot be had.
    """
    import importlib
    import importlib.util
    from pathlib import Path

    module_name, sep, class_name = reference.partition(":")
    if not sep or not module_name or not class_name:
        raise TwigError(f"expected 'module:Class' or 'file.py:Class', got '{reference}'")
    try:
        if module_name.endswith(".py"):
            path = Path(module_name)
            if not path.is_absolute() and base_dir is not None:
                path = Path(base_dir) / path
            if not path.is_file():
                raise TwigError(f"no such file '{path}'")
            import sys

            name = f"twig_plugin_{path.stem}"
            spec = importlib.util.spec_from_file_location(name, path)
            assert spec is not None and spec.loader is not None
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module  # dataclasses and pickling look modules up here
            try:
                spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[name]
                raise
        else:
            module = importlib.import_module(module_name)
    except TwigError:
        raise
    except Exception as exc:  # a broken plug-in: say what broke, not a traceback
        raise TwigError(f"cannot import '{module_name}': {type(exc).__name__}: {exc}") from None
    try:
        return getattr(module, class_name)
    except AttributeError:
        names = [n for n in dir(module) if not n.startswith("_")]
        raise TwigError(f"'{module_name}' has no '{class_name}'" + suggest(class_name, names)) from None


#: The largest plug-in file :func:`check_class_reference` reads (it is parsed, never run).
MAX_PLUGIN_FILE = 4 << 20


def check_class_reference(reference: str, base_dir: str | None = None) -> None:
    """Check a ``"file.py:Class"`` or ``"package.module:Class"`` reference without running any code.

    ``twig validate`` runs no plug-in code, trusted or not: a file is read as text and
    parsed (:mod:`ast`) to see that it defines the class at its top level; a module of
    twig_ecs is imported (it is this program), any other only looked for. Raises
    TwigError with the reason.
    """
    import ast
    import importlib.util
    from pathlib import Path

    module_name, sep, class_name = reference.partition(":")
    if not sep or not module_name or not class_name:
        raise TwigError(f"expected 'module:Class' or 'file.py:Class', got '{reference}'")
    if not module_name.endswith(".py"):
        if module_name.split(".")[0] == "twig_ecs":
            load_class(reference)
        elif importlib.util.find_spec(module_name.split(".")[0]) is None:
            raise TwigError(f"cannot import '{module_name}': no module named '{module_name.split('.')[0]}'")
        return
    path = Path(module_name)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if not path.is_file():
        raise TwigError(f"no such file '{path}'")
    if path.stat().st_size > MAX_PLUGIN_FILE:
        raise TwigError(f"'{path}' is larger than {MAX_PLUGIN_FILE >> 20} MiB: not a plug-in file")
    try:
        tree = ast.parse(path.read_bytes(), filename=str(path))
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        raise TwigError(f"cannot read '{path}': {type(exc).__name__}: {exc}") from None
    names = [node.name for node in tree.body if isinstance(node, ast.ClassDef)]
    names += [t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
              if isinstance(t, ast.Name)]  # fmt: skip  # Class = other.Class
    if class_name not in names:
        raise TwigError(f"'{module_name}' has no '{class_name}'" + suggest(class_name, names))
