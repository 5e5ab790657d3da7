"""The names of a world's entities: name -> entity and back, with suggestions for a typo."""

from __future__ import annotations

from collections.abc import Iterator

from twig_ecs.validate import suggest


class EntityNames:
    """Unique entity names, both ways, in the order they were given.

    The reverse look-up is kept because handles are made per step (``character_handle``)
    and must not search.
    """

    def __init__(self) -> None:
        self._entity: dict[str, int] = {}
        self._name: dict[int, str] = {}

    def add(self, name: str, entity: int) -> None:
        """Name ``entity`` (the caller has checked the name is free)."""
        assert name not in self._entity, name
        self._entity[name] = entity
        self._name[entity] = name

    def remove(self, name: str) -> int:
        """Forget ``name``; returns the entity it named."""
        entity = self._entity.pop(name)
        del self._name[entity]
        return entity

    def entity(self, name: str) -> int:
        """The entity called ``name`` (KeyError with suggestions if unknown)."""
        try:
            return self._entity[name]
        except KeyError:
            raise KeyError(f"no entity named '{name}'" + suggest(name, self._entity)) from None

    def name(self, entity: int) -> str | None:
        """The name of ``entity``, or None if it has none."""
        return self._name.get(entity)

    def __contains__(self, name: object) -> bool:
        return name in self._entity

    def __iter__(self) -> Iterator[str]:
        return iter(self._entity)

    def __len__(self) -> int:
        return len(self._entity)
