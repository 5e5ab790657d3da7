"""Scene files: validate a whole scene document into a plan before anything spawns.

Reading a scene never touches a world: :func:`read_scene` checks every key, name and
number and returns a :class:`ScenePlan`; only a complete, valid plan is built, so a
bad file leaves nothing half-loaded.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import MISSING, dataclass, field, fields, is_dataclass, replace
from pathlib import Path

import numpy as np

from twig_ecs.behavior import Behavior, check_class_reference, installed_behaviors, load_class
from twig_ecs.character import ARM_POSES, CHARACTER_KEYS, START_COMMANDS, CharacterSpec
from twig_ecs.components import PainSensor, Perception
from twig_ecs.errors import SceneError, TwigError
from twig_ecs.library import ContentLibrary, read_document
from twig_ecs.parameters import override, overrides_of, read_parameters, resolve, substitute
from twig_ecs.plugins import load_builtin_behaviors
from twig_ecs.spawn import MAX_EXTENT
from twig_ecs.store import ROLES
from twig_ecs.system import System
from twig_ecs.templates import (
    HEIGHT,
    MASS,
    BodyTemplate,
    Damping,
    read_damping,
    read_pain,
)
from twig_ecs.trust import check_plugin, is_checking_only
from twig_ecs.validate import (
    LIMIT,
    boolean,
    check_keys,
    color,
    fail,
    gather,
    integer,
    join,
    mapping,
    nonnegative,
    number,
    positive,
    raise_all,
    read,
    sequence,
    suggest,
    text,
    vec3,
)
from twig_ecs.yamldoc import YDict

SCENE_KEYS = ("twig", "name", "description", "parameters", "settings", "templates", "systems", "entities")
SYSTEM_KEYS = ("use", "name", "before", "after")
SETTINGS_KEYS = ("gravity", "iterations", "contact_energy", "max_speed")
ENTITY_KEYS = ("name", "body", "position", "facing", "height", "mass", "color", "pain", "damping",
               "character", "perception", "behaviors", "repeat")  # fmt: skip
REPEAT_KEYS = ("count", "spacing")


@dataclass
class Settings:
    """World-wide simulation settings (``settings:`` in a scene)."""

    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, -9.81, 0.0]))
    iterations: int = 8  # relaxation passes per step, for constraints and for contacts
    contact_energy: float = 0.05  # J: impacts at least this strong become Contact events
    max_speed: float = 25.0  # m/s: no node moves faster (a guard against constraint fights)


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
    character: CharacterSpec | None = None
    behaviors: list[BehaviorSpec] = field(default_factory=list)
    perception: Perception | None = None


@dataclass
class SystemSpec:
    """A user system named in the scene's ``systems:`` list."""

    cls: type
    name: str | None
    before: str | None
    after: str | None
    where: tuple[YDict, str]  # the YAML mapping and its path, for errors at build time


@dataclass
class BehaviorSpec:
    """A behaviour a character has (``behaviors:`` on an entity): its component."""

    name: str
    component: object


@dataclass
class ScenePlan:
    """A validated scene, ready to build."""

    name: str
    file: str
    settings: Settings
    entities: list[EntitySpec]
    library: ContentLibrary
    systems: list[SystemSpec] = field(default_factory=list)
    parameters: dict[str, int | float] = field(default_factory=dict)  # the values it was read with


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
    settings.max_speed = read(s, "max_speed", "settings", positive, settings.max_speed)
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
    height = read(raw, "height", path, HEIGHT, None)
    check_span(template, height, raw, "height" if height is not None else "body", path)
    return EntitySpec(
        name=name,
        template=template,
        position=read(raw, "position", path, vec3, (0.0, 0.0, 0.0)),
        facing=read(raw, "facing", path, number, 0.0),
        height=height,
        mass=read(raw, "mass", path, MASS, None),
        color=read(raw, "color", path, color, None),
        pain=pain,
        damping=read_damping(raw, "damping", path, None),
        character=read_character(raw, path, template),
    )


def check_span(template: BodyTemplate, height: float | None, container: YDict, key: str, path: str) -> None:
    """Fail (at ``container[key]``) when the body would be over MAX_EXTENT across at ``height``,
    as spawning it would: ``twig validate`` says so instead of the run."""
    span = template.span(height)
    if not span <= MAX_EXTENT:  # NaN too
        at = f"height {height:g} m" if height is not None else f"its default height {template.height:g} m"
        fail(container, key, join(path, key),
             f"at {at} body '{template.name}' would be {span:.0f} m across, over the {MAX_EXTENT:.0f} m "
             "limit (MAX_EXTENT); give a smaller height or radius")  # fmt: skip


def _target(value):
    """An entity name or a point [x, y, z]."""
    if isinstance(value, str) and value.strip():
        return value
    try:
        return vec3(value)
    except ValueError:
        raise ValueError("an entity name or a point [x, y, z]") from None


def _walk(value):
    """A ground velocity [x, z] or [x, y, z] in m/s."""
    if isinstance(value, list) and len(value) == 2:
        return (number(value[0]), 0.0, number(value[1]))
    try:
        return vec3(value)
    except ValueError:
        raise ValueError("a velocity [x, z] or [x, y, z] in m/s") from None


def _seat(value):
    """true (the ground) or the name of a seat entity."""
    if value is True or (isinstance(value, str) and value.strip()):
        return value
    raise ValueError("true (sit on the ground) or the name of a seat entity")


def _patrol(value):
    """{route: [[x, z], ...], speed: m/s}."""
    if not isinstance(value, dict) or "route" not in value or not set(value) <= {"route", "speed"}:
        raise ValueError("a mapping {route: [[x, z], ...], speed: m/s}")
    route = value["route"]
    if (
        not isinstance(route, list)
        or not route
        or not all(isinstance(p, list) and len(p) == 2 for p in route)
    ):
        raise ValueError("a route of [x, z] points")
    return {"route": [[number(x), number(z)] for x, z in route], "speed": positive(value.get("speed", 1.0))}


def _one_of(*names):
    def read_name(value):
        if value not in names:
            raise ValueError("one of " + ", ".join(names))
        return value

    return read_name


#: How each kind of start command's value is read (START_COMMANDS lists the keys).
_START_READERS = {
    "velocity": _walk,
    "target": _target,
    "entity": text,
    "gesture": _one_of("wave"),
    "pose": _one_of(*ARM_POSES),
    "seat": _seat,
    "patrol": _patrol,
}


def read_character(raw: YDict, path: str, template: BodyTemplate) -> CharacterSpec | None:
    """The ``character:`` key: true, or a mapping of settings and starting commands."""
    if "character" not in raw or raw["character"] is False:
        return None
    missing = [r for r in ROLES if r not in template.node_names]
    if missing:
        fail(raw, "character", join(path, "character"),
             f"a character needs a body with the humanoid's nodes; '{template.name}' lacks "
             + ", ".join(missing))  # fmt: skip
    if raw["character"] is True:
        return CharacterSpec()
    here = join(path, "character")
    doc = read(raw, "character", path, mapping)
    check_keys(doc, here, CHARACTER_KEYS)
    spec = CharacterSpec(max_speed=read(doc, "max_speed", here, positive, 6.0))
    for key, command in START_COMMANDS.items():
        if key in doc:
            spec.start[key] = read(doc, key, here, _START_READERS[command.takes])
    spec.where = {key: doc for key in spec.start}  # for name checks once all entities are known
    return spec


def read_scene(source: str | Path, library: ContentLibrary, parameters: dict | None = None) -> ScenePlan:
    """Read and fully validate a scene file (a path or a known scene name).

    ``parameters`` set the scene's declared ``parameters:`` (see
    :mod:`twig_ecs.parameters`); unknown names or bad values raise SceneError.
    """
    path = library.scene_path(source)
    doc = read_document(path)
    check_keys(doc, "", SCENE_KEYS)
    scene_name = str(doc.get("name", path.stem))
    declared, overrides = overrides_of(parameters or {})
    values = resolve(read_parameters(doc), declared, scene_name)
    substitute(doc, values)
    for name, value in overrides.items():  # then validated below as if written so
        override(doc, name, value, scene_name)
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
    systems = read_systems(doc, path)
    known = dict(load_builtin_behaviors())
    known.update({spec.cls.name: spec.cls for spec in systems if spec.cls and issubclass(spec.cls, Behavior)})
    entities = []
    seen: dict[str, int] = {}
    errors: list[SceneError] = []  # each entity is checked even when an earlier one is wrong
    raw_entities = read(doc, "entities", "", sequence, [])
    for i, raw in enumerate(raw_entities):
        with gather(errors):
            here = f"entities[{i}]"
            raw = read(raw_entities, i, "entities", mapping)
            first = read_entity(raw, here, library)
            for spec in repeat(raw, here, first):
                if spec.name in seen:
                    fail(
                        raw,
                        "name",
                        join(here, "name"),
                        f"duplicate entity name '{spec.name}' (first used by entities[{seen[spec.name]}])",
                    )
                seen[spec.name] = i
                spec.behaviors = read_behaviors(raw, here, known, systems, spec)
                spec.perception = read_perception(raw, here, spec)
                entities.append(spec)
    for spec in entities:  # names in character commands must exist
        if spec.character is None:
            continue
        i = seen[spec.name]  # its place in the file
        for key, value in spec.character.start.items():
            if isinstance(value, str) and START_COMMANDS[key].names_entity:
                if value not in seen or value == spec.name:
                    where = spec.character.where[key]
                    why = (
                        "itself" if value == spec.name else f"unknown entity '{value}'" + suggest(value, seen)
                    )
                    with gather(errors):
                        fail(where, key, f"entities[{i}].character.{key}", why)
    with gather(errors):
        settings = read_settings(doc)
    raise_all(errors)
    return ScenePlan(
        name=read(doc, "name", "", text, path.stem),
        file=str(path),
        settings=settings,
        entities=entities,
        library=library,
        systems=systems,
        parameters={**values, **overrides},
    )


#: Golden angle (degrees): facings and hues of repeated entities spread without a pattern.
GOLDEN = 137.50776


def repeat(raw: YDict, path: str, spec: EntitySpec) -> list[EntitySpec]:
    """The entity ``spec`` as written, or ``repeat: {count, spacing}`` copies of it.

    Copies are named ``name0``, ``name1``... and stand on a square grid ``spacing`` m
    apart centred on ``position`` (so the area grows with the count), with spread-out
    facings and, unless ``color`` is given, colours.
    """
    if "repeat" not in raw:
        return [spec]
    here = join(path, "repeat")
    doc = read(raw, "repeat", path, mapping)
    check_keys(doc, here, REPEAT_KEYS)
    count = read(doc, "count", here, integer(1, 100_000))
    spacing = read(doc, "spacing", here, positive, 2.0)
    side = math.ceil(math.sqrt(count))
    out = []
    for k in range(count):
        x = (k % side - (side - 1) / 2) * spacing
        z = (k // side - (side - 1) / 2) * spacing
        position = (spec.position[0] + x, spec.position[1], spec.position[2] + z)
        facing = (spec.facing + GOLDEN * k) % 360
        copy = replace(spec, name=f"{spec.name}{k}", position=position, facing=facing)
        if spec.color is None:
            r, g, b = colorsys.hsv_to_rgb((GOLDEN * k / 360.0) % 1.0, 0.55, 0.85)
            copy.color = (r, g, b, 1.0)
        out.append(copy)
    return out


def read_systems(doc: YDict, path: Path) -> list[SystemSpec]:
    """The ``systems:`` list: user systems to load and where they go in the schedule."""
    out = []
    raw = read(doc, "systems", "", sequence, [])
    for i, item in enumerate(raw):
        here = f"systems[{i}]"
        item = read(raw, i, "systems", mapping)
        check_keys(item, here, SYSTEM_KEYS)
        reference = read(item, "use", here, text)
        try:
            if is_checking_only():  # twig validate: read the reference, run nothing
                if not reference.partition(":")[0].endswith(".py"):
                    check_plugin(reference, path.parent)  # a file is reported as needing --trust instead
                check_class_reference(reference, str(path.parent))
                cls = None
            else:
                check_plugin(reference, path.parent)  # untrusted scenes: twig_ecs and installed plug-ins only
                cls = load_class(reference, str(path.parent))
        except TwigError as exc:
            fail(item, "use", join(here, "use"), str(exc))
        if cls is not None and not (isinstance(cls, type) and issubclass(cls, System)):
            fail(item, "use", join(here, "use"), f"'{reference}' is not a twig_ecs System subclass")
        before = read(item, "before", here, text, None)
        after = read(item, "after", here, text, None)
        out.append(SystemSpec(cls, read(item, "name", here, text, None), before, after, (item, here)))
    return out


def read_perception(raw: YDict, path: str, spec: EntitySpec) -> Perception | None:
    """A character's ``perception:`` (view cone, memory, valence and priority by name)."""
    if "perception" not in raw:
        return None
    here = join(path, "perception")
    if spec.character is None:
        fail(raw, "perception", here, "only characters perceive (add character: true)")
    doc = read(raw, "perception", path, mapping)
    check_keys(doc, here, ("view_angle", "view_distance", "memory_half_life", "valence", "priority"))
    values = {}
    for key in ("view_angle", "view_distance", "memory_half_life"):
        if key in doc:
            values[key] = read(doc, key, here, positive)
    for key in ("valence", "priority"):
        if key in doc:
            table = read(doc, key, here, mapping)
            values[key] = {str(k): read(table, k, join(here, key), number) for k in table}
    return Perception(**values)


def read_behaviors(raw: YDict, path: str, known: dict, systems: list[SystemSpec],
                   spec: EntitySpec) -> list[BehaviorSpec]:  # fmt: skip
    """An entity's ``behaviors:`` list: [{use: NAME, ...parameters}]."""
    if "behaviors" not in raw:
        return []
    if spec.character is None:
        fail(
            raw, "behaviors", join(path, "behaviors"), "only characters have behaviours (add character: true)"
        )
    out = []
    items = read(raw, "behaviors", path, sequence)
    for i, item in enumerate(items):
        here = f"{join(path, 'behaviors')}[{i}]"
        item = read(items, i, join(path, "behaviors"), mapping)
        name = read(item, "use", here, text)
        if (
            name not in known
            and is_checking_only()
            and (name in installed_behaviors() or any(s.cls is None for s in systems))
        ):
            out.append(BehaviorSpec(name, None))  # a plug-in's behaviour: not loaded, so not checked
            continue
        if name not in known:
            installed = installed_behaviors()
            if name in installed:
                try:
                    cls = installed[name].load()
                except Exception as exc:  # a broken installed plug-in
                    fail(item, "use", join(here, "use"), f"cannot load behaviour '{name}': {exc}")
                known[name] = cls
                systems.append(SystemSpec(cls, None, None, None, (item, here)))  # joins the behaviours stage
            else:
                hint = suggest(name, list(known) + list(installed))
                fail(item, "use", join(here, "use"), f"unknown behaviour '{name}'" + hint)
        cls = known[name]
        if getattr(cls, "component", None) is None:
            fail(
                item, "use", join(here, "use"), f"behaviour '{name}' takes commands (goals), not a place here"
            )
        params = {k: read_param(cls.component, item, k, here) for k in item if k != "use"}
        try:
            component = cls.component(**params)
        except TypeError as exc:
            fail(item, "use", here, f"bad parameters for '{name}': {exc}")
        out.append(BehaviorSpec(name, component))
    return out


def read_param(component: type, item: YDict, key: str, here: str):
    """One behaviour parameter, checked against its component field's default type.

    A number where a name goes (``caregiver: 5``) would otherwise load fine and fail inside
    the first step. Unknown keys pass through: the component's constructor names them.
    """
    spec = {f.name: f for f in fields(component)}.get(key) if is_dataclass(component) else None
    if spec is None:
        return item[key]
    default = spec.default if spec.default is not MISSING else spec.default_factory()  # type: ignore[misc]
    annotation = str(spec.type)
    if isinstance(default, bool):
        return read(item, key, here, boolean)
    if isinstance(default, int):
        return read(item, key, here, integer(-int(LIMIT), int(LIMIT)))
    if isinstance(default, float):
        return read(item, key, here, number)
    if isinstance(default, str):
        return read(item, key, here, text)
    if isinstance(default, list):
        value = read(item, key, here, sequence)
        if annotation.startswith("list[str"):
            return [read(value, i, join(here, key), text) for i in range(len(value))]
        return value
    if isinstance(default, dict):
        value = read(item, key, here, mapping)
        if annotation.startswith("dict[str, float"):
            return {str(k): read(value, k, join(here, key), number) for k in value}
        return value
    return item[key]
