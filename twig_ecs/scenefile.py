"""Scene files: validate a whole scene document into a plan before anything spawns.

Reading a scene never touches a world: :func:`read_scene` checks every key, name and
number and returns a :class:`ScenePlan`; only a complete, valid plan is built, so a
bad file leaves nothing half-loaded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from twig_ecs.components import PainSensor
from twig_ecs.library import ContentLibrary, read_document
from twig_ecs.templates import (
    BodyTemplate,
    Damping,
    read_damping,
    read_pain,
)
from twig_ecs.validate import (
    check_keys,
    color,
    fail,
    integer,
    join,
    mapping,
    nonnegative,
    number,
    positive,
    read,
    sequence,
    suggest,
    text,
    vec3,
)
from twig_ecs.yamldoc import YDict

SCENE_KEYS = ("twig", "name", "description", "settings", "templates", "entities")
SETTINGS_KEYS = ("gravity", "iterations", "contact_energy")
ENTITY_KEYS = ("name", "body", "position", "facing", "height", "mass", "color", "pain", "damping")


@dataclass
class Settings:
    """World-wide simulation settings (``settings:`` in a scene)."""

    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, -9.81, 0.0]))
    iterations: int = 8  # relaxation passes per step, for constraints and for contacts
    contact_energy: float = 0.05  # J: impacts at least this strong become Contact events


@dataclass
class EntitySpec:
    """One entity to spawn: a template with placement and overrides."""

    name: str
    template: BodyTemplate
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    facing: float = 0.0  # degrees about +y; 0 faces +z
    height: float | None = None
    mass: float | None = None
    color: tuple[float, float, float, float] | None = None
    pain: PainSensor | None | bool = True  # True: the template's own
    damping: Damping | None = None


@dataclass
class ScenePlan:
    """A validated scene, ready to build."""

    name: str
    file: str
    settings: Settings
    entities: list[EntitySpec]
    library: ContentLibrary


def read_settings(doc: YDict) -> Settings:
    """The ``settings:`` block, with defaults for what it leaves out."""
    settings = Settings()
    if "settings" not in doc:
        return settings
    s = read(doc, "settings", "", mapping)
    check_keys(s, "settings", SETTINGS_KEYS)
    settings.gravity = np.array(read(s, "gravity", "settings", vec3, tuple(settings.gravity)))
    settings.iterations = read(s, "iterations", "settings", integer(1, 64), settings.iterations)
    settings.contact_energy = read(s, "contact_energy", "settings", nonnegative, settings.contact_energy)
    return settings


def read_entity(raw: YDict, path: str, library: ContentLibrary) -> EntitySpec:
    """One ``entities:`` item."""
    check_keys(raw, path, ENTITY_KEYS)
    name = read(raw, "name", path, text)
    body = read(raw, "body", path, text)
    if not library.has_template(body):
        fail(
            raw,
            "body",
            join(path, "body"),
            f"unknown template '{body}'" + suggest(body, library.template_names),
        )
    template = library.template(body)
    pain: PainSensor | None | bool = True
    if "pain" in raw:
        pain = read_pain(raw, "pain", path, template.pain)
    return EntitySpec(
        name=name,
        template=template,
        position=read(raw, "position", path, vec3, (0.0, 0.0, 0.0)),
        facing=read(raw, "facing", path, number, 0.0),
        height=read(raw, "height", path, positive, None),
        mass=read(raw, "mass", path, positive, None),
        color=read(raw, "color", path, color, None),
        pain=pain,
        damping=read_damping(raw, "damping", path, None),
    )


def read_scene(source: str | Path, library: ContentLibrary) -> ScenePlan:
    """Read and fully validate a scene file (a path or a known scene name)."""
    path = library.scene_path(source)
    doc = read_document(path)
    check_keys(doc, "", SCENE_KEYS)
    if "template" in doc:
        fail(doc, "template", "template", "this is a body template, not a scene")
    library = library.copy()
    if "templates" in doc:
        templates = read(doc, "templates", "", mapping)
        for tname in templates:
            read(templates, tname, "templates", mapping)
            library.add_template(str(tname), templates[tname], join("templates", str(tname)))
        for tname in templates:  # compile now so errors surface at load
            library.template(str(tname))
    entities = []
    seen: dict[str, int] = {}
    raw_entities = read(doc, "entities", "", sequence, [])
    for i, raw in enumerate(raw_entities):
        here = f"entities[{i}]"
        raw = read(raw_entities, i, "entities", mapping)
        spec = read_entity(raw, here, library)
        if spec.name in seen:
            fail(
                raw,
                "name",
                join(here, "name"),
                f"duplicate entity name '{spec.name}' (first used by entities[{seen[spec.name]}])",
            )
        seen[spec.name] = i
        entities.append(spec)
    return ScenePlan(
        name=read(doc, "name", "", text, path.stem),
        file=str(path),
        settings=read_settings(doc),
        entities=entities,
        library=library,
    )
