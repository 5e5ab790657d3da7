"""The scene's behaviour parameters, found live, for the inspector's sliders.

A character's behaviours keep their parameters in components (``Attachment.per_metre``,
``Playful.speed``...: the keys of its ``behaviors:`` items in the scene file). A
:class:`Tunable` is one such number on one character; changing its ``value`` changes the
component the behaviour reads at its next step. State kept in the same components
(anxiety, counters) is not offered.

A slider's range is the field's declared bounds when it has them
(``field(default=0.5, metadata={"range": (0.0, 1.0)})``), else one scaled to the value:
from 0 to a round number at least three times the larger of the scene's value and the
field's default (``per_second`` 0.006: 0 to 0.02, so a pixel is a small step of it, not
0.007 as on a 0-1 range).
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, fields, is_dataclass
from pathlib import Path

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
    kinds = {}
    for name, system in scene.behaviors.items():
        component = getattr(system, "component", None)
        if component is not None and is_dataclass(component):
            kinds.setdefault(component, name)
    out = []
    for entity_name in scene.entity_names:
        entity = scene.entity(entity_name).entity
        for component_type, behaviour in kinds.items():
            component = scene.world.try_component(entity, component_type)
            if component is None:
                continue
            for f in fields(component_type):
                value = getattr(component, f.name)
                if f.name in STATE_FIELDS or isinstance(value, bool) or not isinstance(value, float):
                    continue
                low, high = slider_range(f, value)
                out.append(Tunable(entity_name, behaviour, f.name, component, low, high, value))
    return out


def slider_range(spec, value: float) -> tuple[float, float]:
    """The slider's (low, high) for a component field ``spec`` now holding ``value``.

    The field's declared ``metadata["range"]`` if it has one (widened to take in the value);
    else from 0 to :func:`round_up` of three times the value's size (the larger of the
    scene's value and the field's default, so a value set to 0 keeps a useful range), on
    the value's side of 0.
    """
    declared = spec.metadata.get("range") if spec.metadata else None
    if declared is not None:
        low, high = (float(v) for v in declared)
        return min(low, value), max(high, value)
    default = spec.default if isinstance(spec.default, float) and spec.default is not MISSING else 0.0
    size = max(abs(value), abs(default))
    reach = round_up(3.0 * size) if size > 0 else 1.0
    return (-reach, 0.0) if value < 0 else (0.0, reach)


def round_up(x: float) -> float:
    """The smallest of 1, 2, 2.5 and 5 times a power of ten that is at least ``x`` (> 0)."""
    power = 10.0 ** math.floor(math.log10(x))
    for step in (1.0, 2.0, 2.5, 5.0, 10.0):
        if step * power >= x * (1 - 1e-12):
            return step * power
    return 10.0 * power


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
