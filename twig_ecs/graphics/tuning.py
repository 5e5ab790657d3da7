"""The scene's behaviour parameters, found live, for the inspector's sliders.

A character's behaviours keep their parameters in components (``Attachment.per_metre``,
``Playful.speed``...: the keys of its ``behaviors:`` items in the scene file). A
:class:`Tunable` is one such number on one character; changing its ``value`` changes the
component the behaviour reads at its next step. State kept in the same components
(anxiety, counters) is not offered.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path

import esper

#: Float fields of behaviour components that are the behaviour's state, not a parameter.
STATE_FIELDS = frozenset({"anxiety"})


@dataclass
class Tunable:
    """One behaviour parameter of one character, with the slider's range."""

    entity: str
    behaviour: str
    field: str
    component: object
    low: float
    high: float
    initial: float

    @property
    def value(self) -> float:
        """The value the behaviour uses now."""
        return float(getattr(self.component, self.field))

    @value.setter
    def value(self, new: float) -> None:
        setattr(self.component, self.field, float(min(self.high, max(self.low, new))))

    @property
    def key(self) -> tuple[str, str, str]:
        """(entity, behaviour, parameter): where it goes in the scene file."""
        return (self.entity, self.behaviour, self.field)


def find_tunables(scene) -> list[Tunable]:
    """Every behaviour parameter (a float of a behaviour's component) of every character."""
    scene.activate()  # the scene's esper world
    kinds = {}
    for name, system in scene.behaviors.items():
        component = getattr(system, "component", None)
        if component is not None and is_dataclass(component):
            kinds.setdefault(component, name)
    out = []
    for entity_name in scene.entity_names:
        entity = scene.entity(entity_name).entity
        for component_type, behaviour in kinds.items():
            component = esper.try_component(entity, component_type)
            if component is None:
                continue
            for f in fields(component_type):
                value = getattr(component, f.name)
                if f.name in STATE_FIELDS or isinstance(value, bool) or not isinstance(value, float):
                    continue
                # a range round the scene's value: from 0 to three times it (rates and chances are small)
                high = max(1.0, 3.0 * abs(value)) if value >= 0 else 0.0
                low = 0.0 if value >= 0 else 3.0 * value
                out.append(Tunable(entity_name, behaviour, f.name, component, low, high, value))
    return out


def changed(tunables: list[Tunable]) -> dict[tuple[str, str, str], float]:
    """The parameters moved away from the values the scene started with."""
    return {t.key: t.value for t in tunables if t.value != t.initial}


def builtin_scene(path: str | Path) -> bool:
    """Is ``path`` one of the package's own scene files (not to be edited by a window)?"""
    import twig_ecs.content

    content = Path(twig_ecs.content.__file__).resolve().parent
    try:
        Path(path).resolve().relative_to(content)
    except ValueError:
        return False
    return True
