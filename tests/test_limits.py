"""Caps with clear errors (issue 16, items 5 and 7): formula cost, body size and body count."""

from __future__ import annotations

import pytest

from twig_ecs import Scene, spawn
from twig_ecs.cli import main
from twig_ecs.errors import SceneError


@pytest.mark.parametrize(
    ("formula", "says"),
    [
        ("$(((((10**64)**64)**64)**64)**64)", "number too large"),
        ("$(2**64**64)", "exponent too large"),
        ("$(" + "(" * 2000 + "1" + ")" * 2000 + ")", "at most 1000 characters"),
        ("$(" + "(" * 400 + "1" + ")" * 400 + ")", "not a formula|nested too deeply"),
    ],
    ids=["tower", "exponent", "long", "deep"],
)
def test_a_costly_formula_is_refused_quickly_with_a_clear_error(tmp_path, capsys, formula, says):
    scene = tmp_path / "f.yaml"
    scene.write_text(f"twig: 1\nname: f\nentities:\n  - {{name: b, body: ball, facing: '{formula}'}}\n")
    assert main(["validate", str(scene)]) == 1
    err = capsys.readouterr().err
    assert "entities[0].facing" in err
    assert any(s in err for s in says.split("|")), err


def test_a_body_too_big_or_one_too_many_is_refused_and_the_scene_is_unchanged(monkeypatch):
    with Scene.load("empty") as scene:
        with pytest.raises(SceneError, match="over the 30 m limit"):
            scene.spawn("merry_go_round", name="tower", height=100.0)
        assert "tower" not in scene.entity_names and scene.state.bodies.count == 0
        monkeypatch.setattr(spawn, "MAX_BODIES", 3)
        for k in range(3):
            scene.spawn("ball", name=f"b{k}", position=(k, 1, 0))
        with pytest.raises(SceneError, match="already has 3 bodies"):
            scene.spawn("ball", name="b3")
        scene.step(5)
        assert scene.entity_names == ["b0", "b1", "b2"] or sorted(scene.entity_names) == ["b0", "b1", "b2"]


@pytest.mark.parametrize(
    ("text", "says"),
    [("entities: &a [*a]\n", "refers to itself"), ("entities: " + "[" * 5000 + "]" * 5000 + "\n", "nested")],
    ids=["recursive-alias", "deep"],
)
def test_recursive_or_deep_yaml_gets_a_clear_error_not_a_traceback(tmp_path, capsys, text, says):
    scene = tmp_path / "y.yaml"
    scene.write_text("twig: 1\nname: y\n" + text)
    assert main(["validate", str(scene)]) == 1
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err
