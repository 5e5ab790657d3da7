"""Fuzzing the scene loader: any YAML, any structure, any mutation of the real scenes.

Whatever the file holds, loading it either gives a scene or raises the loader's own
:class:`SceneError` (file:line, where, what) - never another exception - and a scene
that loads runs a few steps without one. The budget is
fixed and the examples derandomized so CI is repeatable; run longer with
``TWIG_FUZZ_EXAMPLES=5000 python -m pytest tests/test_fuzz_scenes.py`` (docs/reliability.md).
"""

from __future__ import annotations

import copy
import os
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from twig_ecs import Scene
from twig_ecs.errors import SceneError
from twig_ecs.library import builtin_dir
from twig_ecs.scenefile import CHARACTER_KEYS, ENTITY_KEYS, SCENE_KEYS, SETTINGS_KEYS

EXAMPLES = int(os.environ.get("TWIG_FUZZ_EXAMPLES", "0")) or None
FUZZ = settings(
    max_examples=EXAMPLES or 80,
    deadline=None,
    derandomize=EXAMPLES is None,  # CI: the same examples every run
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
KID = "twig: 1\nentities:\n  - {name: k, body: humanoid, character: true, "
#: Steps a scene that loaded must then run without an exception.
STEPS = 3
BUILTIN_SCENES = {p.stem: yaml.safe_load(p.read_text()) for p in (builtin_dir() / "scenes").glob("*.yaml")}
KEYS = SCENE_KEYS + ENTITY_KEYS + CHARACTER_KEYS + SETTINGS_KEYS + ("use", "route", "speed", "template")
NAMES = ("humanoid", "ragdoll", "ball", "bench", "merry_go_round", "parent", "small_child", "big_child",
         "attachment", "play", "hug", "schoolyard", "left", "x.py:Nope", "twig_ecs.systems:Nope")  # fmt: skip

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(-3, 3),
    st.floats(),
    st.floats(-10, 10),
    st.text(max_size=12),
    st.sampled_from(NAMES),
)
keys = st.one_of(st.sampled_from(KEYS), st.text(max_size=8), st.integers(-2, 5))
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=5), st.dictionaries(keys, inner, max_size=6)),
    max_leaves=25,
)
entity = st.dictionaries(st.sampled_from(ENTITY_KEYS), values, max_size=8)
documents = st.fixed_dictionaries(
    {"twig": st.one_of(st.just(1), scalars)},
    optional={
        "name": scalars,
        "settings": st.one_of(st.dictionaries(st.sampled_from(SETTINGS_KEYS), values), values),
        "templates": values,
        "systems": values,
        "entities": st.one_of(st.lists(entity, max_size=4), values),
    },
)


def load_text(text: str | bytes) -> None:
    """Load ``text`` as a scene file: a scene or SceneError, nothing else; a scene that loads runs."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fuzz.yaml"
        path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
        try:
            scene = Scene.load(path)
        except SceneError as exc:
            assert str(exc), "a SceneError says what is wrong"
            return
        with scene:
            scene.step(STEPS)  # what loads must run: bad values are load errors, not step errors


def dump(doc) -> str:
    return yaml.safe_dump(doc, allow_unicode=True, sort_keys=False)


@pytest.mark.slow  # 80 scenes loaded and stepped
@FUZZ
@given(documents)
def test_random_scene_documents_load_or_raise_scene_error(doc):
    load_text(dump(doc))


@FUZZ
@given(values)
def test_any_yaml_value_loads_or_raises_scene_error(doc):
    load_text(dump(doc))


@FUZZ
@given(st.one_of(st.text(max_size=300), st.binary(max_size=300)))
@example("twig: 1\nentities: [" * 3000)  # deep nesting
@example("a: &a [1, 2]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a]\nc: &c [*b, *b, *b, *b, *b, *b, *b, *b]\n" * 1)
@example("twig: 1\nentities:\n  - !!python/object/apply:os.system ['true']\n")
@example("twig: 1\nname: x\nname: y\n")  # duplicate key
@example(b"\xff\xfe\x00t\x00w")  # not UTF-8
@example("twig: 1\nentities:\n  - {name: a, body: ball, position: [1e999, 0, 0]}\n")
@example("twig: 1\nentities:\n  - {name: a, body: humanoid, height: 1e-300, character: true}\n")
@example("twig: 1\nsettings: {iterations: 100000000000000000000}\n")
@example(KID + "behaviors: [{use: attachment, caregiver: 5}]}\n")  # loaded, then failed in a step
@example(KID + "behaviors: [{use: play, joy: x}]}\n")
def test_raw_text_and_bytes_load_or_raise_scene_error(text):
    load_text(text)


def _paths(node, here=()):
    """Every path into a YAML tree (dict keys and list indices)."""
    yield here
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*here, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*here, i))


@pytest.mark.slow  # 80 built-in scenes mutated, loaded and stepped
@FUZZ
@given(st.sampled_from(sorted(BUILTIN_SCENES)), st.data())
def test_mutations_of_the_builtin_scenes_load_or_raise_scene_error(name, data):
    doc = copy.deepcopy(BUILTIN_SCENES[name])
    for _ in range(data.draw(st.integers(1, 4), label="mutations")):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = data.draw(st.sampled_from(paths), label="path")
        parent = doc
        for part in path[:-1]:
            parent = parent[part]
        last = path[-1]
        how = data.draw(st.sampled_from(["replace", "delete", "duplicate", "rename", "scale"]), label="how")
        if how == "replace":
            parent[last] = data.draw(values, label="value")
        elif how == "delete":
            del parent[last]
        elif how == "duplicate" and isinstance(parent, list):
            parent.insert(last, copy.deepcopy(parent[last]))
        elif how == "rename" and isinstance(parent, dict):
            parent[data.draw(keys, label="key")] = parent.pop(last)
        elif how == "scale" and isinstance(parent[last], int | float) and not isinstance(parent[last], bool):
            factor = data.draw(st.sampled_from([-1, 0, 1e-9, 1e9, 1e300]), label="factor")
            parent[last] = parent[last] * factor
    load_text(dump(doc))
