"""Bad scene and template input: each mistake gets a clear message with file:line."""

from __future__ import annotations

import textwrap

import pytest

from twig_ecs import Scene, SceneError
from twig_ecs.cli import main
from twig_ecs.scene import open_scenes


def write(tmp_path, text: str, name: str = "scene.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def load_error(path, *content) -> SceneError:
    before = len(open_scenes())
    with pytest.raises(SceneError) as info:
        Scene.load(path, content=content)
    assert len(open_scenes()) == before, "a failed load must leave no world behind"
    return info.value


GOOD_BODY = """
    - name: a
      body: humanoid
"""


@pytest.mark.parametrize(
    ("text", "line", "fragments"),
    [
        pytest.param("twig: 1\nentities: [\n  - name: a\n", 3, ["invalid YAML"], id="yaml-syntax"),
        pytest.param(
            "twig: 1\nentities:\n  - name: a\n    body: humanod\n",
            4,
            ["entities[0].body", "unknown template 'humanod'", "did you mean 'humanoid'"],
            id="unknown-template",
        ),
        pytest.param(
            "twig: 1\nentities:\n  - body: humanoid\n",
            3,
            ["entities[0].name", "missing required key"],
            id="missing-key",
        ),
        pytest.param(
            "twig: 1\nentities:\n  - name: a\n    body: humanoid\n    height: tall\n",
            5,
            ["entities[0].height", "expected a number from 0.01 to 100", "got 'tall' (text)"],
            id="wrong-type",
        ),
        pytest.param(
            "twig: 1\nentities:\n  - name: a\n    body: humanoid\n    height: -1.2\n",
            5,
            ["entities[0].height", "a number from 0.01 to 100"],
            id="negative-height",
        ),
        pytest.param(
            "twig: 1\nentities:\n  - name: a\n    body: ball\n  - name: a\n    body: ball\n",
            5,
            ["entities[1].name", "duplicate entity name 'a'", "entities[0]"],
            id="duplicate-names",
        ),
        pytest.param(
            "twig: 1\nentites: []\n",
            2,
            ["entites", "unknown key 'entites'", "did you mean 'entities'"],
            id="unknown-top-level-key",
        ),
        pytest.param("twig: 2\nentities: []\n", 1, ["twig", "unsupported version 2"], id="version"),
        pytest.param("entities: []\n", 1, ["twig", "missing required key", "twig: 1"], id="no-version"),
        pytest.param(
            "twig: 1\nsettings:\n  iterations: 0\n",
            3,
            ["settings.iterations", "whole number from 1 to 64"],
            id="iterations-range",
        ),
    ],
)
def test_bad_scene_gets_clear_error_with_file_and_line(tmp_path, text, line, fragments):
    path = write(tmp_path, text)
    err = load_error(path)
    message = str(err)
    assert message.startswith(f"{path}:{line}: "), message
    for fragment in fragments:
        assert fragment in message, message


def scene_with_template(links: str, nodes: str | None = None, extra: str = "") -> str:
    nodes = nodes or "      a: {at: [0, 0.5, 0], mass: 1}\n      b: {at: [0, 1.0, 0], mass: 1}\n"
    return (
        "twig: 1\ntemplates:\n  stick:\n    nodes:\n" + nodes + "    links:\n" + links + extra
        + "entities:\n  - name: s\n    body: stick\n"
    )  # fmt: skip


@pytest.mark.parametrize(
    ("links", "nodes", "line", "fragments"),
    [
        pytest.param(
            "      - {nodes: [a, c], radius: 0.05}\n",
            None,
            8,
            ["templates.stick.links[0].nodes[1]", "unknown node 'c'"],
            id="link-to-unknown-node",
        ),
        pytest.param(
            "      - {nodes: [a, b], radius: -0.05}\n",
            None,
            8,
            ["templates.stick.links[0].radius", "at least 0"],
            id="negative-radius",
        ),
        pytest.param(
            "      - {nodes: [a, b], length: 0}\n",
            None,
            8,
            ["templates.stick.links[0].length", "greater than 0"],
            id="zero-length",
        ),
        pytest.param(
            "      - {nodes: [a, b]}\n",
            "      a: {at: [0, 0.5, 0], mass: 0}\n      b: {at: [0, 1.0, 0]}\n",
            5,
            ["templates.stick.nodes.a.mass", "a number from 1e-06 to 1e+06"],
            id="zero-mass",
        ),
        pytest.param(
            "      - {nodes: [a, b], colour: red}\n",
            None,
            8,
            ["templates.stick.links[0].colour", "unknown key 'colour'", "did you mean 'color'"],
            id="unknown-link-key",
        ),
    ],
)
def test_bad_template_gets_clear_error_with_file_and_line(tmp_path, links, nodes, line, fragments):
    path = write(tmp_path, scene_with_template(links, nodes))
    message = str(load_error(path))
    assert message.startswith(f"{path}:{line}: "), message
    for fragment in fragments:
        assert fragment in message, message


def test_error_in_user_template_file_points_into_that_file(tmp_path):
    bodies = tmp_path / "mine"
    bodies.mkdir()
    template = write(bodies, "twig: 1\ntemplate: pole\nnodes:\n  a: {at: [0, 1, 0], mass: -3}\n", "pole.yaml")
    scene = write(tmp_path, "twig: 1\nentities:\n  - {name: p, body: pole}\n")
    message = str(load_error(scene, bodies))
    assert message.startswith(f"{template}:4: nodes.a.mass"), message


def test_user_content_folder_adds_templates_that_extend_built_ins(tmp_path, scenes):
    folder = tmp_path / "content"
    folder.mkdir()
    write(folder, "twig: 1\ntemplate: giant\nextends: humanoid\ndefaults: {height: 3.0}\n", "giant.yaml")
    path = write(tmp_path, "twig: 1\nentities:\n  - {name: g, body: giant}\n")
    scene = Scene.load(path, content=[folder])
    scenes.append(scene)
    head = scene.entity("g").node("head")
    assert head[1] == pytest.approx(1.60 * 3.0 / 1.75, rel=1e-6)


def test_validate_cli_reports_every_bad_file_and_exits_non_zero(tmp_path, capsys):
    good = write(tmp_path, "twig: 1\nentities:\n  - {name: b, body: ball}\n", "good.yaml")
    bad = write(tmp_path, "twig: 1\nentities:\n  - {name: b, body: bal}\n", "bad.yaml")
    code = main(["validate", str(good), str(bad)])
    out, err = capsys.readouterr()
    assert code == 1
    assert f"ok: {good}" in out
    assert f"error: {bad}:3: entities[0].body: unknown template 'bal'" in err
    assert "Traceback" not in err


def test_run_cli_on_missing_scene_says_so_without_traceback(capsys):
    code = main(["run", "schoolyrd", "--seconds", "1"])
    _, err = capsys.readouterr()
    assert code == 2
    assert "unknown scene 'schoolyrd'" in err and "did you mean 'schoolyard'" in err
    assert "Traceback" not in err


def test_spawn_with_bad_parameters_raises_and_leaves_the_world_intact(empty_scene):
    scene = empty_scene
    scene.spawn("ball", name="b")
    before = (scene.state.nodes.count, scene.state.links.count, scene.entity_names)
    with pytest.raises(SceneError, match="unknown template 'humanod'"):
        scene.spawn("humanod", name="x")
    with pytest.raises(SceneError, match="height.*a number from 0.01 to 100"):
        scene.spawn("humanoid", name="y", height=-1)
    with pytest.raises(SceneError, match="already exists"):
        scene.spawn("ball", name="b")
    assert (scene.state.nodes.count, scene.state.links.count, scene.entity_names) == before


def test_hostile_sizes_are_refused_with_a_message(tmp_path):
    huge = write(tmp_path, "twig: 1\nentities:\n  - {name: a, body: humanoid, height: 1e300}\n", "huge.yaml")
    assert "at most 1e+06" in str(load_error(huge))
    far = write(
        tmp_path, "twig: 1\nentities:\n  - {name: a, body: ball, position: [1e9, 0, 0]}\n", "far.yaml"
    )
    assert "entities[0].position" in str(load_error(far))
    bomb = "twig: 1\na: &a [x, x, x, x, x, x, x, x, x, x]\n"
    for k in range(1, 9):
        bomb += (
            f"{'abcdefghij'[k]}: &{'abcdefghij'[k]} [" + ", ".join([f"*{'abcdefghij'[k - 1]}"] * 10) + "]\n"
        )
    message = str(load_error(write(tmp_path, bomb, "bomb.yaml")))
    assert "document too large" in message


def test_validate_reports_every_unknown_key_of_an_entity_in_the_users_words(tmp_path, capsys):
    """`hieght` and `colour` both (only the first was said), and a list is a 'list', not a 'YList'."""
    from twig_ecs.cli import main

    path = tmp_path / "typos.yaml"
    path.write_text("twig: 1\nentities:\n  - {name: a, body: humanoid, hieght: 1.5, colour: [1, 0, 0]}\n"
                    "  - {name: b, body: ball, position: [1, 2]}\n")  # fmt: skip
    assert main(["validate", str(path)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"error: {path}:3: entities[0].hieght: unknown key 'hieght' (did you mean 'height'?)",
        f"error: {path}:3: entities[0].colour: unknown key 'colour' (did you mean 'color'?)",
        f"error: {path}:4: entities[1].position: expected a list of three numbers [x, y, z], "
        "got [1, 2] (list)",
    ]
