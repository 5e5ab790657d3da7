"""The Scene: a world of entities plus its resources, stepped at a fixed 60 Hz.

A Scene owns its :class:`~twig_ecs.world.World` (entities and components), the
:class:`~twig_ecs.store.PhysicsState` store, one seeded RNG, the settings, the named
system schedule (filled by its plugins, :mod:`twig_ecs.plugins`) and an
:class:`~twig_ecs.events.EventBus`. Scenes never share entities. Store surgery for grab
joints and removals is in :mod:`twig_ecs.grabs`; the fixed step in :mod:`twig_ecs.clock`.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import threading
import time
import weakref
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from twig_ecs import grabs as grab_joints
from twig_ecs import snapshot
from twig_ecs.behavior import Behavior, Goal, Mind
from twig_ecs.character import CharacterHandle, make_character
from twig_ecs.clock import STEP, FixedStepClock
from twig_ecs.components import Character, GrabJoint, Memory, Name
from twig_ecs.errors import SceneError, TwigError
from twig_ecs.events import Event, EventBus
from twig_ecs.goalbook import GoalBook
from twig_ecs.grabs import RELEASE_GRACE_STEPS  # noqa: F401 - its old home; tests and plug-ins read it here
from twig_ecs.handles import BodyHandle
from twig_ecs.kernels import ensure_compiled
from twig_ecs.library import ContentLibrary
from twig_ecs.names import EntityNames
from twig_ecs.plugins import Plugin, default_plugins
from twig_ecs.scenefile import (
    EntitySpec,
    ScenePlan,
    Settings,
    read_behaviors,
    read_entity,
    read_perception,
    read_scene,
)
from twig_ecs.schedule import Schedule
from twig_ecs.spawn import spawn_body
from twig_ecs.step import StepContext
from twig_ecs.store import PhysicsState
from twig_ecs.system import System
from twig_ecs.threads import ThreadChoice
from twig_ecs.trust import trusting
from twig_ecs.validate import seed as seed_value
from twig_ecs.world import World
from twig_ecs.yamldoc import YDict

#: Held for each step of any scene (and its set-up): scenes stepped from several threads take
#: turns a step at a time, so kernels' thread pool serves one step at once.
STEP_LOCK = threading.RLock()
#: Scenes made in this process and not closed (weakly: a dropped scene leaves it).
_OPEN: weakref.WeakSet[Scene] = weakref.WeakSet()


def open_scenes() -> list[Scene]:
    """The scenes of this process that are alive and not closed (tests check none is left)."""
    return list(_OPEN)


class Scene:
    """A simulated world: bodies, systems, a fixed-step clock and events.

    Build one with :meth:`load` (a YAML file or built-in name) or ``Scene()`` for an
    empty world, then :meth:`spawn`, :meth:`step` / :meth:`run`, and :meth:`close`.
    """

    #: The fixed simulation step (s).
    dt: float = STEP

    def __init__(
        self,
        name: str = "scene",
        seed: int = 0,
        settings: Settings | None = None,
        library: ContentLibrary | None = None,
        plugins: Sequence[Plugin] | None = None,
    ) -> None:
        """An empty world whose schedule holds the systems of ``plugins``.

        ``plugins`` default to everything built in (:func:`~twig_ecs.plugins.default_plugins`);
        ``Scene(plugins=[PhysicsPlugin()])`` is a world of bodies that nobody moves.
        """
        plugins = list(default_plugins() if plugins is None else plugins)
        for plugin in plugins:
            if not isinstance(plugin, Plugin):
                raise TwigError(f"Scene(plugins=...) takes Plugin objects, got {plugin!r}"
                                " (write PhysicsPlugin(), not PhysicsPlugin)")  # fmt: skip
        self.name = name
        try:
            self.seed = seed_value(seed)
        except ValueError as exc:
            raise SceneError(f"Scene(seed={seed!r}): {exc}") from None
        self.settings = settings or Settings()
        self.library = library or ContentLibrary()
        self.state = PhysicsState()
        self.rng = np.random.default_rng(seed)
        self.frame = 0
        self.bus = EventBus()
        self.names = EntityNames()
        self.world = World()
        self.goals = GoalBook(self.world, self.bus.emit)
        self.world.add_resource(self.goals)
        self._closed = False
        _OPEN.add(self)
        self.schedule = Schedule()
        self._installed: list[System] | None = None
        self._threads = ThreadChoice()  # how many threads its steps use (measured; twig_ecs.threads)
        self.behaviors: dict[str, Behavior] = {}
        self.plugins: list[Plugin] = plugins
        try:
            for plugin in plugins:
                plugin.build(self)
        except BaseException:
            self.close()  # a plugin that fails leaves no world behind
            raise

    # -- construction -------------------------------------------------------------

    @classmethod
    def load(
        cls,
        source: str | Path,
        seed: int = 0,
        content: tuple[str | Path, ...] | list[str | Path] = (),
        plugins: Sequence[Plugin] | None = None,
        trust: bool = False,
        **parameters: int | float | str,
    ) -> Scene:
        """Load a scene from a YAML path or a built-in/user scene name (``"schoolyard"``).

        ``content`` lists extra folders of templates and scenes; keyword ``parameters``
        set the scene's declared ``parameters:`` (``Scene.load("crowd", count=300)``);
        ``plugins`` as for ``Scene()`` (default: all built in). ``trust=True`` lets the
        scene import the plug-in files and modules it names (``--trust``); without it, only
        twig_ecs and installed plug-in packages (docs/reliability.md, "Trust"). The whole
        file is validated before anything is created; errors raise :class:`SceneError`.
        """
        library = ContentLibrary(content)
        with trusting(True) if trust else contextlib.nullcontext():
            plan = read_scene(source, library, parameters)
        return cls.from_plan(plan, seed, plugins)

    @classmethod
    def from_plan(cls, plan: ScenePlan, seed: int = 0, plugins: Sequence[Plugin] | None = None) -> Scene:
        """Build a scene from a validated :class:`ScenePlan` (with ``plugins``, default all)."""
        unloaded = [spec for spec in plan.systems if spec.cls is None]
        if unloaded:  # read by `twig validate`, which loads no plug-in code
            raise TwigError("this scene plan was only checked (no plug-in loaded): load it to build it")
        scene = cls(plan.name, seed=seed, settings=plan.settings, library=plan.library, plugins=plugins)
        scene.source = plan.file
        scene.parameters = dict(plan.parameters)
        try:
            for system_spec in plan.systems:
                item, here = system_spec.where
                try:
                    scene.add_system(system_spec.cls(), name=system_spec.name, before=system_spec.before,
                                     after=system_spec.after)  # fmt: skip
                except TwigError as exc:
                    file, line = item.where("use")
                    raise SceneError(str(exc), file, line, here) from None
                except Exception as exc:  # a plug-in whose constructor breaks
                    file, line = item.where("use")
                    raise SceneError(
                        f"cannot create {system_spec.cls.__name__}: {exc}", file, line, here
                    ) from None
            for spec in plan.entities:
                scene._spawn_spec(spec)
            for i, spec in enumerate(plan.entities):  # starting commands may name later entities
                if spec.character is not None and spec.character.start:
                    try:
                        scene.entity(spec.name).apply(spec.character.start)
                    except TwigError as exc:
                        doc = next(iter(spec.character.where.values()))
                        file, line = doc.where()
                        raise SceneError(str(exc), file, line, f"entities[{i}].character") from None
        except BaseException:
            scene.close()  # nothing half-loaded
            raise
        return scene

    source: str | None = None
    #: The values of the scene file's parameters it was loaded with.
    parameters: dict[str, int | float] = {}

    def _spawn_spec(self, spec: EntitySpec) -> BodyHandle:
        self.check_open()
        entity = spawn_body(self, spec.template, spec.name, spec.position, spec.facing, spec.height,
                            spec.mass, spec.color, spec.pain, spec.damping)  # fmt: skip
        self.names.add(spec.name, entity)
        if spec.character is None:
            return BodyHandle(self, entity, spec.name)
        make_character(self, entity, spec.facing, spec.character)
        for behavior in spec.behaviors:
            self.world.add_component(entity, behavior.component)
        if spec.perception is not None:
            self.world.add_component(entity, spec.perception)
            self.world.add_component(entity, Memory())
        return CharacterHandle(self, entity, spec.name)

    def spawn(
        self,
        template: str,
        name: str | None = None,
        position: tuple[float, float, float] = (0.0, 0.0, 0.0),
        facing: float = 0.0,
        **params,
    ) -> BodyHandle:
        """Spawn a body from a template by name; returns its handle.

        ``params``: ``height`` (m), ``mass`` (kg, total), ``color`` ([r, g, b]),
        ``pain`` ({threshold, half_life, gain} or False), ``damping`` ({air, ground}),
        ``character`` (True, or a mapping of ``max_speed`` and the scene file's starting
        commands - ``walk``, ``look_at``... - which it then starts doing); for a character,
        ``perception`` and ``behaviors`` as in a scene file (a behaviour must be one of this
        scene's systems). The name defaults to ``template`` plus a number; it must be unique.
        """
        if name is None:
            name = next(f"{template}{k}" for k in itertools.count(1) if f"{template}{k}" not in self.names)
        if name in self.names:
            raise SceneError(f"an entity named '{name}' already exists")
        raw = YDict({"name": name, "body": template, "position": list(position), "facing": facing, **params})
        raw.file = "<spawn>"
        here = f"spawn({name!r})"
        spec = read_entity(raw, here, self.library)
        spec.perception = read_perception(raw, here, spec)
        spec.behaviors = read_behaviors(raw, here, {n: type(b) for n, b in self.behaviors.items()}, [], spec)
        for behavior in spec.behaviors:
            if behavior.name not in self.behaviors:  # an installed plug-in's, not running here
                raise SceneError(f"{here}: behaviour '{behavior.name}' is not one of this scene's systems "
                                 "(add it with add_system, or in the scene file's systems:)")  # fmt: skip
        handle = self._spawn_spec(spec)
        if spec.character is not None and spec.character.start:
            try:
                handle.apply(spec.character.start)
            except TwigError:  # e.g. look_at an entity that does not exist: no half-made character
                self.remove(spec.name)
                raise
        return handle

    def remove(self, name: str) -> None:
        """Remove a body (its nodes, links, limits and any grab joints touching it).

        Goals of other characters that name it (as target, destination or seat) fail.
        """
        entity = self.entity_id(name)
        self.check_open()
        for other, (_, mind) in list(self.world.get_components(Character, Mind)):
            for goal in list(mind.goals):
                if other != entity and name in (goal.params.get("target"), goal.params.get("to"),
                                                goal.params.get("on")):  # fmt: skip
                    self.end_goal(self.character_handle(other), goal, False, f"'{name}' was removed")
        grab_joints.remove_body(self, entity)
        self.names.remove(name)
        self.goals.forget(entity)

    # -- grab joints --------------------------------------------------------------------

    def grab(self, holder: str, node: str, target: str, target_node: str, standoff: float = 0.0) -> int:
        """Join ``holder``'s ``node`` to ``target``'s ``target_node`` with a link that closes.

        The two nodes are drawn together by the constraint solver over a few steps and
        then held (a ball joint, SPEC 3) - at ``standoff`` metres apart when that is
        given: a hand on the surface of a torso rather than at the node inside it.
        Returns the grab joint's entity; :meth:`release` removes it.
        """
        self.check_open()
        return grab_joints.join(self, self.entity(holder), node, self.entity(target), target_node, standoff)

    def release(self, grab: int) -> None:
        """Remove a grab joint made by :meth:`grab` (its entity id)."""
        self.check_open()
        grab_joints.release(self, grab)

    def grabs(self) -> list[tuple[int, GrabJoint]]:
        """All grab joints as (entity, GrabJoint)."""
        self.check_open()
        return list(self.world.get_component(GrabJoint))

    # -- systems --------------------------------------------------------------------

    def add_system(
        self, system: System, name: str | None = None, before: str | None = None, after: str | None = None
    ) -> System:
        """Insert a system into the schedule by stage name (see :class:`Schedule`)."""
        system.scene = self
        self.schedule.add(system, name=name, before=before, after=after)
        system.setup()
        if isinstance(system, Behavior):
            self.behaviors[name or system.name] = system
        self._installed = None  # the schedule's order is read again before the next step
        return system

    def _install(self) -> None:
        self._installed = self.schedule.systems()

    # -- running ----------------------------------------------------------------------

    @property
    def thread_choice(self) -> ThreadChoice:
        """How many threads this scene's steps use and what its trials measured (``summary()``);
        assign another (``ThreadChoice``) to choose differently from the next step on."""
        return self._threads

    @thread_choice.setter
    def thread_choice(self, choice: ThreadChoice) -> None:
        self._threads = choice

    @property
    def time(self) -> float:
        """Simulated time (s) since the scene started: frame * dt."""
        return self.frame * self.dt

    def check_open(self) -> None:
        """Raise :class:`~twig_ecs.errors.TwigError` if the scene has been closed."""
        if self._closed:
            raise TwigError(f"scene '{self.name}' is closed")

    def step(self, n: int = 1, times: dict[str, list[float]] | None = None) -> None:
        """Advance ``n`` fixed steps of 1/60 s: the one step loop.

        Each step: release grace counts down, colliders are rebuilt if bodies or grabs
        changed, the last step's events are dropped, grips pulled too far let go
        (:func:`twig_ecs.grabs.slip`), then every system runs once in schedule order.
        ``times``: also append each system's wall seconds to ``times[name]`` (``twig
        bench``); timing a step never changes what it computes.

        Scenes stepped from several threads take turns, a step at a time (:data:`STEP_LOCK`).
        """
        with STEP_LOCK:
            self.check_open()
            if self._installed is None:
                self._install()
        ensure_compiled()
        state, dt = self.state, self.dt
        threads, clock = self._threads, time.perf_counter
        for _ in range(n):
            with STEP_LOCK:
                threads.begin(state.bodies.count)
                started = clock()
                self._step_once(state, dt, times)
                threads.end(clock() - started)

    def _step_once(self, state: PhysicsState, dt: float, times: dict[str, list[float]] | None) -> None:
        """One step of :meth:`step` (under :data:`STEP_LOCK`)."""
        self.check_open()
        state.tick_released()
        if state.colliders_dirty:
            state.rebuild_colliders()
        self.bus.next_step()
        self.world.clear_dead_entities()  # entities deleted with deferred delete go now
        grab_joints.slip(self)  # grips the last step pulled too far give way
        ctx = self.step_context()
        if times is None:
            for system in self._installed:
                system.run(ctx)
        else:
            clock = time.perf_counter
            for system in self._installed:
                t0 = clock()
                system.run(ctx)
                times.setdefault(system.name, []).append(clock() - t0)
        self.frame += 1

    def step_context(self) -> StepContext:
        """The context the next step hands every system (:class:`~twig_ecs.step.StepContext`)."""
        return StepContext(dt=self.dt, frame=self.frame, time=self.time, world=self.world,
                           state=self.state, rng=self.rng, settings=self.settings, events=self.bus,
                           scene=self)  # fmt: skip

    def step_timed(self, times: dict[str, list[float]]) -> float:
        """One :meth:`step`, timing each system into ``times``; returns the step's wall time (s)."""
        self.step(0)  # activate, install, compile: nothing when already done
        start = time.perf_counter()
        self.step(1, times)
        return time.perf_counter() - start

    def run(self, seconds: float) -> None:
        """Advance by ``seconds`` of simulated time (rounded to whole steps)."""
        self.step(FixedStepClock(self.dt).steps_for(seconds))

    # -- events -----------------------------------------------------------------------

    @property
    def events(self) -> list[Event]:
        """The events of the latest step (cleared when the next step begins)."""
        return self.bus.events

    @property
    def event_counts(self) -> Counter[str]:
        """Running totals of events by kind since the scene started."""
        return self.bus.counts

    @property
    def _handlers(self) -> dict[str, list[Callable[[Event], None]]]:
        return self.bus.handlers

    @_handlers.setter
    def _handlers(self, handlers: dict[str, list[Callable[[Event], None]]]) -> None:
        self.bus.handlers = handlers

    def emit(self, event: Event) -> None:
        """Queue an event for this step and call its handlers."""
        self.bus.emit(event)

    def on(self, kind: str, handler: Callable[[Event], None]) -> None:
        """Call ``handler(event)`` for every event of ``kind`` (``"contact"``, ``"pain"``...)."""
        self.bus.on(kind, handler)

    # -- reading ------------------------------------------------------------------------

    def entity_id(self, name: str) -> int:
        """The entity id of the entity called ``name`` (KeyError with suggestions if unknown)."""
        return self.names.entity(name)

    def character_handle(self, entity: int) -> CharacterHandle:
        """The handle of a character by entity id."""
        name = self.names.name(entity)
        if name is None:
            name = self.name_of(entity) or str(entity)
        return CharacterHandle(self, entity, name)

    # -- goals (the world's GoalBook, under the names the behaviours know) ----------------

    def note_goal(self, entity: int, mind: Mind) -> None:
        """Record that a character was given a goal (see :meth:`goal_holders`)."""
        self.goals.note(entity, mind)

    def goal_holders(self) -> list[tuple[int, Mind]]:
        """(entity, mind) of the characters holding goals: goal-driven behaviours look only here."""
        return self.goals.holders()

    def goal_holders_of(self, behavior: str) -> list[tuple[int, Mind]]:
        """The :meth:`goal_holders` whose current goal is for ``behavior``, in the same order."""
        return self.goals.holders_of(behavior, self.frame)

    def end_goal(self, character: CharacterHandle, goal: Goal, ok: bool = True, reason: str = "") -> None:
        """Finish a character's goal: mark it, drop it from the queue, report it."""
        self.goals.end(character.entity, goal, ok, reason)

    def new_goal_id(self) -> int:
        """A fresh goal id, unique within this scene (1, 2, 3...)."""
        return self.goals.new_id()

    # -- reading (continued) ----------------------------------------------------------

    def entity(self, name: str) -> BodyHandle:
        """The handle of the entity called ``name`` (KeyError with suggestions if unknown).

        Characters get a :class:`~twig_ecs.character.CharacterHandle` with the control API.
        """
        entity = self.entity_id(name)
        self.check_open()
        if self.world.has_component(entity, Character):
            return CharacterHandle(self, entity, name)
        return BodyHandle(self, entity, name)

    @property
    def entity_names(self) -> list[str]:
        """Names of all named entities, in spawn order (a new list: see :meth:`has_entity`)."""
        return list(self.names)

    def has_entity(self, name: str) -> bool:
        """Is there an entity named ``name``? (A lookup, not a copy of every name.)"""
        return name in self.names

    def name_of(self, entity: int) -> str | None:
        """The name of an entity (a body; None for a grab joint or an unknown entity)."""
        name = self.names.name(entity)
        if name is not None:  # a named body: the common case, without component look-ups
            return name
        self.check_open()
        name = self.world.try_component(entity, Name)
        return name.value if name else None

    def state_hash(self) -> str:
        """A hash of every node position: equal hashes mean equal trajectories so far."""
        n = self.state.nodes
        return hashlib.sha256(np.ascontiguousarray(n.pos[: n.count]).tobytes()).hexdigest()[:16]

    # -- snapshots ---------------------------------------------------------------------

    def snapshot(self) -> bytes:
        """The whole world as bytes: store, components, systems, RNG, goals, grabs.

        :meth:`restore` rebuilds it; the file layout is in :mod:`twig_ecs.snapshot`.
        """
        return snapshot.snapshot(self)

    @classmethod
    def restore(cls, data: bytes) -> Scene:
        """A scene from :meth:`snapshot` bytes; it runs on exactly as the original would.

        A snapshot is data: it builds only the world's own classes and plain values, and the
        plug-in modules it lists only when installed, loaded here already, or trusted. A
        corrupt, truncated, hostile or other-version file raises
        :class:`~twig_ecs.snapshot.SnapshotError`.
        """
        return snapshot.restore(data)

    # -- lifetime ------------------------------------------------------------------------

    def _reopen(self) -> None:
        """Open a scene just read from a snapshot (whose process-bound parts were left out)."""
        self._closed = False
        self._installed = None  # the schedule's order is read again at the first step
        self._threads = ThreadChoice()  # measured afresh in this process
        _OPEN.add(self)

    def close(self) -> None:
        """Delete this scene's world; the scene cannot be used afterwards."""
        if self._closed:
            return
        _OPEN.discard(self)
        self._closed = True

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Scene '{self.name}' t={self.time:.2f}s bodies={self.state.bodies.count}>"


snapshot.register_scene_class(Scene)
