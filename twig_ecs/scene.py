"""The Scene: one esper world plus the resources esper lacks, stepped at a fixed 60 Hz.

A Scene owns its world (and switches to it whenever it runs), the
:class:`~twig_ecs.store.PhysicsState` store, the clock, one seeded RNG, the settings,
the named system schedule and a typed event queue. Scenes never share entities.
"""

from __future__ import annotations

import hashlib
import itertools
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import esper
import numpy as np

from twig_ecs.behavior import Behavior, Goal, GoalDone, GoalFailed, Mind
from twig_ecs.character import CharacterHandle, make_character
from twig_ecs.components import Body, Character, GrabJoint, Memory, Name
from twig_ecs.errors import SceneError, TwigError
from twig_ecs.esperworld import make_deterministic
from twig_ecs.events import Event, Grabbed, Released
from twig_ecs.handles import BodyHandle
from twig_ecs.kernels import ensure_compiled
from twig_ecs.library import ContentLibrary
from twig_ecs.scenefile import EntitySpec, ScenePlan, Settings, read_scene
from twig_ecs.schedule import Schedule
from twig_ecs.spawn import spawn_body
from twig_ecs.store import LINK_GRAB, PhysicsState
from twig_ecs.system import System
from twig_ecs.validate import suggest

#: Steps (1/3 s) that an arm and what it let go of keep ignoring each other in collisions.
RELEASE_GRACE_STEPS = 20

_world_ids = itertools.count(1)


class Scene:
    """A simulated world: bodies, systems, a fixed-step clock and events.

    Build one with :meth:`load` (a YAML file or built-in name) or ``Scene()`` for an
    empty world, then :meth:`spawn`, :meth:`step` / :meth:`run`, and :meth:`close`.
    """

    #: The fixed simulation step (s).
    dt: float = 1.0 / 60.0

    def __init__(
        self,
        name: str = "scene",
        seed: int = 0,
        settings: Settings | None = None,
        library: ContentLibrary | None = None,
    ) -> None:
        self.name = name
        self.seed = seed
        self.settings = settings or Settings()
        self.library = library or ContentLibrary()
        self.state = PhysicsState()
        self.rng = np.random.default_rng(seed)
        self.frame = 0
        self.events: list[Event] = []
        self.event_counts: Counter[str] = Counter()
        self._handlers: dict[str, list[Callable[[Event], None]]] = {}
        self._names: dict[str, int] = {}
        self._name_by_entity: dict[int, str] = {}  # the reverse of _names: handles are made per step
        self._world = f"twig-scene-{next(_world_ids)}"
        self._closed = False
        self.schedule = Schedule()
        self._installed: list[System] | None = None
        # characters that were given goals (entity -> Mind), pruned when their goals run
        # out: goal-driven behaviours look only at these (see goal_holders)
        self._goal_holders: dict[int, Mind] = {}
        self.goals_made = 0  # goal ids count per scene, so a restored or replayed scene numbers alike
        self.activate()
        make_deterministic()
        from twig_ecs import systems as s
        from twig_ecs.behavior import load_builtin_behaviors

        self.behaviors: dict[str, Behavior] = {}
        for system in (s.IntegrateSystem(), s.ConstrainSystem(), s.CollideSystem(), s.SenseSystem(),
                       s.GaitSystem()):  # fmt: skip
            self.add_system(system)
        self.add_system(s.AttentionSystem(), after="sense", before="select_behavior")
        # behaviours propose activations before select_behavior picks and runs the winners
        for behavior in load_builtin_behaviors().values():
            self.add_system(behavior(), after="sense", before="select_behavior")
        self.add_system(s.SelectBehaviorSystem())
        self.add_system(s.PatrolSystem(), after="select_behavior", before="gait")
        # the low-level controllers sit with posture: gaze first (posture turns the
        # shoulders after the face), then posture, arms and breathing
        self.add_system(s.GazeSystem(), after="gait", before="posture")
        self.add_system(s.PostureSystem())
        self.add_system(s.ArmsSystem(), after="posture", before="render")
        self.add_system(s.RespirationSystem(), after="arms", before="render")

    # -- construction -------------------------------------------------------------

    @classmethod
    def load(
        cls,
        source: str | Path,
        seed: int = 0,
        content: tuple[str | Path, ...] | list[str | Path] = (),
        **parameters: int | float | str,
    ) -> Scene:
        """Load a scene from a YAML path or a built-in/user scene name (``"schoolyard"``).

        ``content`` lists extra folders of templates and scenes; keyword ``parameters``
        set the scene's declared ``parameters:`` (``Scene.load("crowd", count=300)``).
        The whole file is validated before anything is created; errors raise
        :class:`SceneError`.
        """
        library = ContentLibrary(content)
        plan = read_scene(source, library, parameters)
        return cls.from_plan(plan, seed)

    @classmethod
    def from_plan(cls, plan: ScenePlan, seed: int = 0) -> Scene:
        """Build a scene from a validated :class:`ScenePlan`."""
        scene = cls(plan.name, seed=seed, settings=plan.settings, library=plan.library)
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
                for behavior in spec.behaviors:
                    esper.add_component(scene._names[spec.name], behavior.component)
                if spec.perception is not None:
                    esper.add_component(scene._names[spec.name], spec.perception)
                    esper.add_component(scene._names[spec.name], Memory())
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
        self.activate()
        entity = spawn_body(self, spec.template, spec.name, spec.position, spec.facing, spec.height,
                            spec.mass, spec.color, spec.pain, spec.damping)  # fmt: skip
        self._names[spec.name] = entity
        self._name_by_entity[entity] = spec.name
        if spec.character is not None:
            make_character(self, entity, spec.facing, spec.character)
            return CharacterHandle(self, entity, spec.name)
        return BodyHandle(self, entity, spec.name)

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
        ``pain`` ({threshold, half_life, gain} or False), ``damping`` ({air, ground}).
        The name defaults to ``template`` plus a number; it must be unique.
        """
        from twig_ecs.scenefile import read_entity
        from twig_ecs.yamldoc import YDict

        if name is None:
            name = next(f"{template}{k}" for k in itertools.count(1) if f"{template}{k}" not in self._names)
        if name in self._names:
            raise SceneError(f"an entity named '{name}' already exists")
        raw = YDict({"name": name, "body": template, "position": list(position), "facing": facing, **params})
        raw.file = "<spawn>"
        spec = read_entity(raw, f"spawn({name!r})", self.library)
        return self._spawn_spec(spec)

    def remove(self, name: str) -> None:
        """Remove a body (its nodes, links, limits and any grab joints touching it).

        Goals of other characters that name it (as target, destination or seat) fail.
        """
        entity = self._entity_id(name)
        self.activate()
        for other, (_, mind) in list(esper.get_components(Character, Mind)):
            for goal in list(mind.goals):
                if other != entity and name in (goal.params.get("target"), goal.params.get("to"),
                                                goal.params.get("on")):  # fmt: skip
                    self.end_goal(self.character_handle(other), goal, False, f"'{name}' was removed")
        body = esper.component_for_entity(entity, Body)
        doomed = {entity}
        remap = self.state.remove_body(body.index)
        for e, grab in list(esper.get_component(GrabJoint)):
            if entity in (grab.holder, grab.held):
                doomed.add(e)
        for e in doomed:
            esper.delete_entity(e, immediate=True)
        self._apply_remap(remap)
        del self._names[name]
        del self._name_by_entity[entity]
        self._goal_holders.pop(entity, None)

    def _apply_remap(self, remap: dict[str, np.ndarray]) -> None:
        """Follow a store compaction: rewrite every row index held by components."""
        nodes, links, bodies = remap["nodes"], remap["links"], remap["bodies"]
        for _, grab in esper.get_component(GrabJoint):
            grab.index = int(links[grab.index])
        for _, body in esper.get_component(Body):
            body.index = int(bodies[body.index])
            body.node_start = int(nodes[body.node_start])
            body.link_start = int(links[body.link_start]) if body.link_count else 0
        live_grabs = {e for e, _ in esper.get_component(GrabJoint)}
        for _, character in esper.get_component(Character):
            character.index = int(remap["characters"][character.index])
            character.holding = {h: g for h, g in character.holding.items() if g in live_grabs}

    # -- grab joints --------------------------------------------------------------------

    def grab(self, holder: str, node: str, target: str, target_node: str, standoff: float = 0.0) -> int:
        """Join ``holder``'s ``node`` to ``target``'s ``target_node`` with a link that closes.

        The two nodes are drawn together by the constraint solver over a few steps and
        then held (a ball joint, SPEC 3) - at ``standoff`` metres apart when that is
        given: a hand on the surface of a torso rather than at the node inside it.
        Returns the grab joint's entity; :meth:`release` removes it.
        """
        self.activate()
        h, t = self.entity(holder), self.entity(target)
        if h.entity == t.entity:
            raise TwigError(f"'{holder}' cannot grab itself")
        a, b = h._row(node), t._row(target_node)
        links = self.state.links
        row = links.allocate(1).start
        links.a[row], links.b[row] = a, b
        # the joint starts at the nodes' distance and closes at GRAB_CLOSING m/s (see
        # ConstrainSystem): a hand pulls the thing in, it does not snap to it
        links.rest[row] = float(np.linalg.norm(self.state.nodes.pos[a] - self.state.nodes.pos[b]))
        links.min_rest[row] = max(0.0, float(standoff))
        links.flags[row] = LINK_GRAB
        links.body[row] = h.body.index
        entity = esper.create_entity(GrabJoint(row, h.entity, t.entity))
        links.entity[row] = entity
        self.state.version += 1
        self.state.colliders_dirty = True  # the hand and what it holds stop colliding
        self.emit(Grabbed(entity, h.entity, t.entity, node))
        return entity

    def release(self, grab: int) -> None:
        """Remove a grab joint made by :meth:`grab` (its entity id)."""
        self.activate()
        joint = esper.try_component(grab, GrabJoint)
        if joint is None:
            raise TwigError(f"no grab joint {grab}")
        links = self.state.links
        # the hand slides back out of what it held without being flung off it
        self.state.release_grace(links.a[joint.index], links.b[joint.index], RELEASE_GRACE_STEPS)
        keep = np.ones(links.count, dtype=bool)
        keep[joint.index] = False
        remap = links.keep(keep)
        self.emit(Released(grab, joint.holder, joint.held))
        esper.delete_entity(grab, immediate=True)
        for _, character in esper.get_component(Character):
            character.holding = {h: g for h, g in character.holding.items() if g != grab}
        for _, other in esper.get_component(GrabJoint):
            other.index = int(remap[other.index])
        for _, body in esper.get_component(Body):
            if body.link_count:
                body.link_start = int(remap[body.link_start])
        self.state.rebuild_colliders()

    def grabs(self) -> list[tuple[int, GrabJoint]]:
        """All grab joints as (entity, GrabJoint)."""
        self.activate()
        return list(esper.get_component(GrabJoint))

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
        self._installed = None  # re-map onto esper priorities before the next step
        return system

    def _install(self) -> None:
        systems = self.schedule.systems()
        for processor in list(esper._processors):  # noqa: SLF001 - esper has no clear API
            esper.remove_processor(type(processor))
        for rank, system in enumerate(systems):
            esper.add_processor(system, priority=len(systems) - rank)
        self._installed = systems

    # -- running ----------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Simulated time (s) since the scene started: frame * dt."""
        return self.frame * self.dt

    def activate(self) -> None:
        """Make this scene's esper world the current one."""
        if self._closed:
            raise TwigError(f"scene '{self.name}' is closed")
        if esper.current_world != self._world:
            esper.switch_world(self._world)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` fixed steps of 1/60 s."""
        self.activate()
        if self._installed is None:
            self._install()
        ensure_compiled()
        for _ in range(n):
            self.state.tick_released()
            if self.state.colliders_dirty:
                self.state.rebuild_colliders()
            self.events.clear()
            esper.process(self.dt)
            self.frame += 1

    def step_timed(self, times: dict[str, list[float]]) -> float:
        """One step like :meth:`step`, timing each system; returns the step's wall time (s).

        Appends each system's seconds to ``times[name]`` (for ``twig bench``).
        """
        clock = time.perf_counter
        start = clock()
        self.step(0)  # activate, install, compile: nothing when already done
        if self.state.colliders_dirty:
            self.state.rebuild_colliders()
        self.events.clear()
        esper.clear_dead_entities()  # as esper.process does before the processors
        for system in self._installed or ():
            t0 = clock()
            system.process(self.dt)
            times.setdefault(system.name, []).append(clock() - t0)
        self.frame += 1
        return clock() - start

    def run(self, seconds: float) -> None:
        """Advance by ``seconds`` of simulated time (rounded to whole steps)."""
        self.step(int(round(seconds / self.dt)))

    # -- events -----------------------------------------------------------------------

    def emit(self, event: Event) -> None:
        """Queue an event for this step and call its handlers."""
        self.events.append(event)
        self.event_counts[event.kind] += 1
        for handler in self._handlers.get(event.kind, ()):
            handler(event)

    def on(self, kind: str, handler: Callable[[Event], None]) -> None:
        """Call ``handler(event)`` for every event of ``kind`` (``"contact"``, ``"pain"``...)."""
        self._handlers.setdefault(kind, []).append(handler)

    # -- reading ------------------------------------------------------------------------

    def _entity_id(self, name: str) -> int:
        try:
            return self._names[name]
        except KeyError:
            raise KeyError(f"no entity named '{name}'" + suggest(name, self._names)) from None

    def character_handle(self, entity: int) -> CharacterHandle:
        """The handle of a character by entity id."""
        name = self._name_by_entity.get(entity)
        if name is None:
            name = self.name_of(entity) or str(entity)
        return CharacterHandle(self, entity, name)

    def note_goal(self, entity: int, mind: Mind) -> None:
        """Record that a character was given a goal (see :meth:`goal_holders`)."""
        self._goal_holders[entity] = mind

    def goal_holders(self) -> list[tuple[int, Mind]]:
        """(entity, mind) of the characters holding goals: goal-driven behaviours look only here.

        Costs as many characters as hold goals, not all of them: characters join when
        given a goal (:meth:`note_goal`) and leave here once their goals have run out.
        """
        holders = self._goal_holders
        done = [e for e, mind in holders.items() if not mind.goals]
        for e in done:
            del holders[e]
        return list(holders.items())

    def end_goal(self, character: CharacterHandle, goal: Goal, ok: bool = True, reason: str = "") -> None:
        """Finish a character's goal: mark it, drop it from the queue, report it."""
        if goal.finished:
            return
        goal.status, goal.reason = ("done" if ok else "failed"), reason
        mind = esper.component_for_entity(character.entity, Mind)
        if goal in mind.goals:
            mind.goals.remove(goal)
        if ok:
            self.emit(GoalDone(character.entity, goal.id, goal.behavior))
        else:
            self.emit(GoalFailed(character.entity, goal.id, goal.behavior, reason))
        if goal.on_end is not None:
            goal.on_end(goal)

    def entity(self, name: str) -> BodyHandle:
        """The handle of the entity called ``name`` (KeyError with suggestions if unknown).

        Characters get a :class:`~twig_ecs.character.CharacterHandle` with the control API.
        """
        entity = self._entity_id(name)
        self.activate()
        if esper.has_component(entity, Character):
            return CharacterHandle(self, entity, name)
        return BodyHandle(self, entity, name)

    @property
    def entity_names(self) -> list[str]:
        """Names of all named entities, in spawn order."""
        return list(self._names)

    def name_of(self, entity: int) -> str | None:
        """The name of an entity (a body; None for a grab joint or an unknown entity)."""
        name = self._name_by_entity.get(entity)
        if name is not None:  # a named body: the common case, without esper look-ups
            return name
        self.activate()
        name = esper.try_component(entity, Name)
        return name.value if name else None

    def new_goal_id(self) -> int:
        """A fresh goal id, unique within this scene (1, 2, 3...)."""
        self.goals_made += 1
        return self.goals_made

    def state_hash(self) -> str:
        """A hash of every node position: equal hashes mean equal trajectories so far."""
        n = self.state.nodes
        return hashlib.sha256(np.ascontiguousarray(n.pos[: n.count]).tobytes()).hexdigest()[:16]

    # -- snapshots ---------------------------------------------------------------------

    def snapshot(self) -> bytes:
        """The whole world as bytes: store, components, systems, RNG, goals, grabs.

        :meth:`restore` rebuilds it; the file layout is in :mod:`twig_ecs.snapshot`.
        """
        from twig_ecs.snapshot import snapshot

        return snapshot(self)

    @classmethod
    def restore(cls, data: bytes) -> Scene:
        """A scene from :meth:`snapshot` bytes; it runs on exactly as the original would.

        Snapshot files are trusted input (they may name plug-in code to import); a corrupt,
        truncated or other-version file raises :class:`~twig_ecs.snapshot.SnapshotError`.
        """
        from twig_ecs.snapshot import restore

        return restore(data)

    # -- lifetime ------------------------------------------------------------------------

    def close(self) -> None:
        """Delete this scene's world; the scene cannot be used afterwards."""
        if self._closed:
            return
        if esper.current_world == self._world:
            esper.switch_world("default")
        if self._world in esper.list_worlds():
            esper.delete_world(self._world)
        self._closed = True

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Scene '{self.name}' t={self.time:.2f}s bodies={self.state.bodies.count}>"
