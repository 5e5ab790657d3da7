"""The crowd scene and scene parameters: a count of wandering characters, errors on bad values."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from twig_ecs import Scene, SceneError
from twig_ecs.cli import main
from twig_ecs.systems.behaviours.wander import Wander


def write(tmp_path, text: str):
    path = tmp_path / "scene.yaml"
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def test_crowd_loads_with_count_characters(scenes):
    scene = Scene.load("crowd", count=12)
    scenes.append(scene)
    assert scene.state.characters.count == 12
    assert [n for n in scene.entity_names if n.startswith("walker")] == [f"walker{k}" for k in range(12)]
    assert scene.parameters["count"] == 12


def test_crowd_area_grows_with_count(scenes):
    def extent(count: int) -> float:
        scene = Scene.load("crowd", count=count)
        scenes.append(scene)
        xz = np.array([scene.entity(f"walker{k}").position[[0, 2]] for k in range(count)])
        return float(np.ptp(xz[:, 0]) * np.ptp(xz[:, 1]))

    small, large = extent(4), extent(64)
    assert large == pytest.approx(small * (7 / 1) ** 2, rel=0.05), "same density: area ~ count"


def test_crowd_wanders_5_seconds_without_nan_or_deep_penetration(scenes):
    scene = Scene.load("crowd", count=30, seed=3)
    scenes.append(scene)
    start = np.array([scene.entity(f"walker{k}").position for k in range(30)])
    hurt: set[str] = set()
    scene.on("pain", lambda event: hurt.add(scene.name_of(event.body)))
    worst = 0.0
    for _ in range(300):
        scene.step()
        worst = max(worst, float(scene.state.stats[0]))
    end = np.array([scene.entity(f"walker{k}").position for k in range(30)])
    pos = scene.state.nodes.pos[: scene.state.nodes.count]
    assert np.isfinite(pos).all()
    assert worst < 0.05, f"capsules left {worst * 100:.1f} cm inside each other"
    assert (pos[:, 1] > -0.01).all(), "nothing sinks through the ground"
    moved = np.linalg.norm((end - start)[:, [0, 2]], axis=1)
    assert np.median(moved) > 2.0, "they walk about"
    assert (end[:, 1] > 0.6).all(), "and stay on their feet"
    # they wander; the only other thing a walker may be doing is the pain reflex after a
    # hard bump (withdraw staggers back, then turns away for 2 s in all)
    doing = {f"walker{k}": scene.entity(f"walker{k}").behaviour for k in range(30)}
    assert set(doing.values()) <= {"wander", "withdraw"}, doing
    assert {name for name, b in doing.items() if b == "withdraw"} <= hurt, (doing, hurt)
    assert list(doing.values()).count("wander") >= 25


def test_wanderers_pick_new_targets_when_they_arrive(scenes):
    scene = Scene.load("crowd", count=3, spacing=6.0)
    scenes.append(scene)
    scene.run(12.0)
    assert all(w.targets >= 2 for _, w in scene.world.get_component(Wander))


@pytest.mark.parametrize(
    ("params", "fragments"),
    [
        pytest.param({"count": 0}, ["count", "between 1 and 10000", "got 0"], id="below-min"),
        pytest.param({"count": "lots"}, ["count", "an integer", "lots"], id="not-a-number"),
        pytest.param({"count": 2.5}, ["count", "an integer"], id="not-whole"),
        pytest.param({"cont": 3}, ["no parameter 'cont'", "did you mean 'count'"], id="unknown"),
        pytest.param({"spacing": "wide"}, ["spacing", "a number"], id="float-parameter"),
    ],
)
def test_bad_parameter_values_are_clear_errors(params, fragments):
    with pytest.raises(SceneError) as info:
        Scene.load("crowd", **params)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_a_scene_without_parameters_refuses_one():
    with pytest.raises(SceneError, match="has no parameter 'count'.*takes: none"):
        Scene.load("playground", count=3)


def test_parameters_substitute_values_and_formulas(tmp_path, scenes):
    path = write(
        tmp_path,
        """
        twig: 1
        parameters:
          n: {default: 2, min: 1, max: 9}
          gap: 3.0
        entities:
          - name: ball
            body: ball
            repeat: {count: "$(n * n)", spacing: $gap}
            position: [0, "$(gap / 2)", 0]
    """,
    )
    scene = Scene.load(path, n=3)
    scenes.append(scene)
    assert len(scene.entity_names) == 9
    assert scene.entity("ball0").position[1] == pytest.approx(1.5, abs=0.2)  # gap / 2, plus its radius


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        pytest.param('"$(n +)"', "is not a formula", id="syntax"),
        pytest.param('"$m"', "unknown parameter 'm'", id="unknown-name"),
        pytest.param('"$(__import__(1))"', "is not allowed", id="no-calls"),
        pytest.param('"$(1 / (n - 2))"', "division by zero", id="arithmetic"),
    ],
)
def test_bad_formulas_say_file_line_and_path(tmp_path, value, fragment):
    path = write(
        tmp_path,
        f"""
        twig: 1
        parameters:
          n: 2
        entities:
          - name: a
            body: ball
            height: {value}
    """,
    )
    with pytest.raises(SceneError) as info:
        Scene.load(path)
    message = str(info.value)
    assert fragment in message
    assert "scene.yaml:7" in message and "entities[0].height" in message


def test_cli_takes_count_and_param(capsys):
    assert main(["run", "crowd", "--count", "4", "--seconds", "0.2"]) == 0
    assert "crowd:" in capsys.readouterr().out
    assert main(["run", "crowd", "--param", "count=many", "--seconds", "0.2"]) == 2
    assert "must be an integer" in capsys.readouterr().err
