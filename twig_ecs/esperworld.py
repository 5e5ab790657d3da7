"""A scene's esper world: deterministic component sets, and capturing/restoring the world's data.

esper keeps the entities that have each component type in a plain ``set``. A set of
ints iterates in an order that depends on its whole history (table size, collisions,
deleted slots), and a set rebuilt from a snapshot can iterate differently - so a
restored scene would visit characters in another order than the original and drift
apart. Every scene therefore gives its world an *insertion-ordered* set
(:class:`EntitySet`): iteration order then follows only which entities were added and
removed, survives pickling exactly, and a restored scene runs on identically.
"""

from __future__ import annotations

import itertools
import re
from typing import Any

import esper

_world_ids = itertools.count(1)


def new_world_name() -> str:
    """A fresh esper world name for a scene (a new or a restored one): no two scenes share a world."""
    return f"twig-scene-{next(_world_ids)}"


class EntitySet(dict):
    """The entities having one component type: a set that iterates in insertion order.

    A dict with None values (dicts keep insertion order); esper uses only ``add``,
    ``discard``, ``len``, truth, ``in`` and iteration.
    """

    __slots__ = ()

    def add(self, entity: int) -> None:
        """Add ``entity`` (at the end, unless present)."""
        self[entity] = None

    def discard(self, entity: int) -> None:
        """Remove ``entity`` if present."""
        self.pop(entity, None)


class ComponentTable(dict):
    """esper's component-type -> entities table whose new entries are :class:`EntitySet` s.

    esper creates a plain ``set()`` the first time it meets a component type; this turns
    it into an EntitySet as it is stored.
    """

    __slots__ = ()

    def __setitem__(self, key: Any, value: Any) -> None:
        if type(value) is set:
            value = EntitySet.fromkeys(value)
        super().__setitem__(key, value)


def make_deterministic() -> None:
    """Give the current (new, empty) esper world an ordered component table."""
    assert not esper._components, "only an empty world"  # noqa: SLF001 - esper keeps worlds in globals
    esper._components = ComponentTable()  # noqa: SLF001


def capture() -> dict[str, Any]:
    """The current world's data: next entity id, component table, entities, pending deletions.

    The processors are not included: the scene re-installs its systems.
    """
    return {
        "next_entity": _peek(esper._entity_count),  # noqa: SLF001
        "components": esper._components,  # noqa: SLF001
        "entities": esper._entities,  # noqa: SLF001
        "dead": sorted(esper._dead_entities),  # noqa: SLF001
    }


def restore(data: dict[str, Any]) -> None:
    """Fill the current (new, empty) esper world with data from :func:`capture`."""
    assert not esper._entities, "only an empty world"  # noqa: SLF001
    components = ComponentTable()
    for key, members in data["components"].items():
        components[key] = members if isinstance(members, EntitySet) else EntitySet.fromkeys(members)
    esper._components = components  # noqa: SLF001
    esper._entities = data["entities"]  # noqa: SLF001
    esper._dead_entities = set(data["dead"])  # noqa: SLF001
    esper._entity_count = itertools.count(int(data["next_entity"]))  # noqa: SLF001
    esper.clear_cache()


def _peek(counter: itertools.count) -> int:
    """The next value of an ``itertools.count`` without consuming it."""
    match = re.fullmatch(r"count\((-?\d+)\)", repr(counter))
    assert match, f"unexpected counter {counter!r}"
    return int(match.group(1))
