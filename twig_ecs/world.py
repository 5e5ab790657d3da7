"""A scene's world: its entities and their components, held by the world itself.

Each :class:`World` is a small entity-component store of its own, with the calls systems
use (esper's names: ``create_entity``, ``add_component``, ``get_components``...), and no
global "current world": two scenes in one process, or one scene used from two threads
in turn, never switch anything. It replaces esper 3, whose worlds are module-level
contexts (a scene had to ``switch_world`` before every use, 23 places did) and whose
tables could be made deterministic and saved only through its private attributes.

Determinism: the entities having one component type are kept in an insertion-ordered
set (:class:`EntitySet`), so queries visit entities in an order that depends only on
which were added and removed - never on a hash table's history - and a world restored
from a snapshot visits them in the same order as the one saved. Queries are those of
esper 3.9 exactly (the same order, the same deferred deletion), so moving from esper
changed no trajectory.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, TypeVar

C = TypeVar("C")


class EntitySet(dict):
    """The entities having one component type: a set that iterates in insertion order.

    A dict with None values (dicts keep insertion order).
    """

    __slots__ = ()

    def add(self, entity: int) -> None:
        """Add ``entity`` (at the end, unless present)."""
        self[entity] = None

    def discard(self, entity: int) -> None:
        """Remove ``entity`` if present."""
        self.pop(entity, None)


class World:
    """Entities (ints) and their components (one object per component type per entity).

    Queries return lists cached until the world next changes; do not mutate them.
    """

    def __init__(self) -> None:
        self._next_entity = 1
        self._entities: dict[int, dict[type, Any]] = {}
        self._components: dict[type, EntitySet] = {}
        self._dead: set[int] = set()  # deleted, still visible until clear_dead_entities()
        self._one: dict[type, list] = {}  # query caches
        self._many: dict[tuple[type, ...], list] = {}
        self._resources: dict[type, Any] = {}

    def resource(self, kind: type[C]) -> C:
        """The world's one object of class ``kind`` (a spatial index, say), made on first use."""
        found = self._resources.get(kind)
        if found is None:
            found = self._resources[kind] = kind()
        return found

    def add_resource(self, resource: Any) -> None:
        """Make ``resource`` the world's one object of its class (one that needs arguments)."""
        self._resources[type(resource)] = resource

    def __getstate__(self) -> dict[str, Any]:
        """What a snapshot keeps: everything but the query caches."""
        state = dict(self.__dict__)
        state["_one"], state["_many"] = {}, {}
        return state

    def _changed(self) -> None:
        if self._one:
            self._one.clear()
        if self._many:
            self._many.clear()

    # -- entities ---------------------------------------------------------------------

    def create_entity(self, *components: Any) -> int:
        """A new entity with ``components``; returns its id."""
        entity = self._next_entity
        self._next_entity += 1
        self._entities[entity] = {}
        for component in components:
            self._components.setdefault(type(component), EntitySet()).add(entity)
            self._entities[entity][type(component)] = component
        self._changed()
        return entity

    def delete_entity(self, entity: int, immediate: bool = False) -> None:
        """Delete ``entity``: at once, or (by default) at the next :meth:`clear_dead_entities`."""
        if immediate:
            self._drop(entity)
            self._changed()
        else:
            self._dead.add(entity)

    def _drop(self, entity: int) -> None:
        for component_type in self._entities[entity]:
            members = self._components[component_type]
            members.discard(entity)
            if not members:
                del self._components[component_type]
        del self._entities[entity]

    def clear_dead_entities(self) -> None:
        """Delete the entities deleted with deferred delete since the last call."""
        if not self._dead:
            return
        for entity in self._dead:
            self._drop(entity)
        self._dead.clear()
        self._changed()

    def entity_exists(self, entity: int) -> bool:
        """Is ``entity`` alive (made and not deleted)?"""
        return entity in self._entities and entity not in self._dead

    def entities(self) -> list[int]:
        """Every entity, alive or awaiting deletion, in the order they were made."""
        return list(self._entities)

    # -- components -------------------------------------------------------------------

    def add_component(self, entity: int, component: Any, type_alias: type | None = None) -> None:
        """Give ``entity`` ``component`` (replacing one of the same type)."""
        component_type = type_alias or type(component)
        self._components.setdefault(component_type, EntitySet()).add(entity)
        self._entities[entity][component_type] = component
        self._changed()

    def remove_component(self, entity: int, component_type: type[C]) -> C:
        """Take ``entity``'s component of ``component_type`` away and return it."""
        members = self._components[component_type]
        members.discard(entity)
        if not members:
            del self._components[component_type]
        self._changed()
        return self._entities[entity].pop(component_type)

    def component_for_entity(self, entity: int, component_type: type[C]) -> C:
        """``entity``'s component of ``component_type`` (KeyError if it has none)."""
        return self._entities[entity][component_type]

    def try_component(self, entity: int, component_type: type[C]) -> C | None:
        """``entity``'s component of ``component_type``, or None."""
        components = self._entities.get(entity)
        if components and component_type in components:
            return components[component_type]
        return None

    def has_component(self, entity: int, component_type: type) -> bool:
        """Has ``entity`` a component of ``component_type``?"""
        return component_type in self._entities[entity]

    def components_of(self, entity: int) -> tuple[Any, ...]:
        """Every component of ``entity``, in the order they were added."""
        return tuple(self._entities[entity].values())

    # -- queries ----------------------------------------------------------------------

    def get_component(self, component_type: type[C]) -> list[tuple[int, C]]:
        """(entity, component) for every entity having ``component_type``, in insertion order."""
        cached = self._one.get(component_type)
        if cached is None:
            members = self._components.get(component_type, ())
            cached = [(entity, self._entities[entity][component_type]) for entity in members]
            self._one[component_type] = cached
        return cached

    def get_components(self, *component_types: type) -> list[tuple[int, tuple[Any, ...]]]:
        """(entity, (components...)) for every entity having all of ``component_types``.

        Walks the smallest of their entity sets (the first smallest) in insertion order.
        """
        cached = self._many.get(component_types)
        if cached is None:
            cached = list(self._query(component_types))
            self._many[component_types] = cached
        return cached

    def _query(self, component_types: tuple[type, ...]) -> Iterator[tuple[int, tuple[Any, ...]]]:
        sets = []
        for component_type in component_types:
            members = self._components.get(component_type)
            if members is None:
                return
            sets.append((component_type, members))
        if not sets:
            return
        smallest = min(range(len(sets)), key=lambda k: len(sets[k][1]))  # the first smallest
        others = [t for k, (t, _) in enumerate(sets) if k != smallest]
        for entity in sets[smallest][1]:
            components = self._entities[entity]
            if all(t in components for t in others):
                yield entity, tuple(components[t] for t in component_types)


def check_world(world: World) -> None:
    """Check a world read from a file holds together (ValueError saying what does not).

    Every entity id an int below the next one, each entity's components keyed by their
    type, every component set listing exactly the entities having that type, and the
    deferred deletions among the entities: the queries then cannot fail or loop.
    """
    if type(world._next_entity) is not int or not isinstance(world._entities, dict):
        raise ValueError("the world's entity table is malformed")
    if not isinstance(world._components, dict) or not isinstance(world._dead, set):
        raise ValueError("the world's component table is malformed")
    having: dict[type, set[int]] = {}
    for entity, components in world._entities.items():
        if type(entity) is not int or not 0 < entity < world._next_entity or not isinstance(components, dict):
            raise ValueError(f"entity {entity!r} is malformed")
        for component_type, component in components.items():
            if not isinstance(component_type, type) or not isinstance(component, component_type):
                raise ValueError(f"entity {entity}'s component {component_type!r} is malformed")
            having.setdefault(component_type, set()).add(entity)
    for component_type, members in world._components.items():
        if type(members) is not EntitySet or set(members) != having.get(component_type, set()):
            raise ValueError(f"the entities listed as having {component_type!r} are not those having it")
    if set(having) != set(world._components):
        raise ValueError("a component type is missing from the component table")
    if not world._dead <= set(world._entities):
        raise ValueError("an entity awaiting deletion does not exist")
    if not isinstance(world.__dict__.get("_resources"), dict) or any(
        type(value) is not kind for kind, value in world._resources.items()
    ):
        raise ValueError("the world's resources are malformed")
    world._changed()
