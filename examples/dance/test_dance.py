"""The example plug-in loads from YAML, wins when nothing else does, and yields to goals."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from twig_ecs import Scene, SceneError

HERE = Path(__file__).parent


@pytest.fixture
def floor():
    scene = Scene.load(HERE / "scene.yaml", trust=True)  # its plug-in is a file: Python we vouch for
    yield scene
    scene.close()


def test_the_dancer_dances_and_the_wallflower_does_not(floor):
    dancer, wallflower = floor.entity("dancer"), floor.entity("wallflower")
    start = dancer.position
    xs = []
    for _ in range(240):
        floor.step()
        xs.append(dancer.position[0])
    assert dancer.behaviour == "dance" and wallflower.behaviour == "idle"
    assert np.ptp(xs) > 0.1, "it sways from side to side"
    assert np.linalg.norm((dancer.position - start)[[0, 2]]) < 0.5, "round the same spot"
    assert dancer.mind.switches <= 2, "no flicker between dance and idle"


def test_a_command_outranks_the_dance(floor):
    dancer = floor.entity("dancer")
    floor.run(1.0)
    goal = dancer.approach((0.0, 0.0, 3.0), stop_distance=0.3)
    floor.run(6.0)
    assert goal.status == "done"
    floor.run(0.5)
    assert dancer.behaviour == "dance", "it goes back to dancing"


def test_a_misspelled_plug_in_is_reported_with_file_and_line(tmp_path):
    scene = tmp_path / "bad.yaml"
    shutil.copy(HERE / "dance.py", tmp_path)  # a plug-in file, relative to the scene's folder
    scene.write_text("twig: 1\nsystems:\n  - use: dance.py:Dnace\nentities: []\n")
    with pytest.raises(
        SceneError, match=r"bad.yaml:3: systems\[0\].use: .* has no 'Dnace' \(did you mean 'Dance'\?\)"
    ):
        Scene.load(scene, trust=True)
    scene.write_text(
        "twig: 1\nsystems:\n  - use: dance.py:Dance\nentities:\n"
        "  - {name: d, body: humanoid, character: true, behaviors: [{use: danse}]}\n"
    )
    with pytest.raises(
        SceneError, match=r"bad.yaml:5: entities\[0\].behaviors\[0\].use: unknown behaviour 'danse'"
    ):
        Scene.load(scene, trust=True)


def test_the_dance_over_arrays_moves_a_floor_as_the_dance_per_character_does(tmp_path):
    # the same floor twice: twelve dancers under CrowdDance (crowd.yaml), and the same file
    # with the per-character Dance put in its place
    crowd = (HERE / "crowd.yaml").read_text()
    one_by_one = tmp_path / "one_by_one.yaml"
    per_character = crowd.replace("dance.py:CrowdDance", "dance.py:Dance").replace("crowd_dance", "dance")
    one_by_one.write_text(per_character)
    shutil.copy(HERE / "dance.py", tmp_path)
    with Scene.load(HERE / "crowd.yaml", trust=True) as arrays, Scene.load(one_by_one, trust=True) as each:
        start = arrays.state.nodes.pos[: arrays.state.nodes.count].copy()
        arrays.run(3.0)
        each.run(3.0)
        a = arrays.state.nodes.pos[: arrays.state.nodes.count]
        b = each.state.nodes.pos[: each.state.nodes.count]
        assert {arrays.entity(f"dancer{k}").behaviour for k in range(12)} == {"crowd_dance"}
        assert np.abs(a - start).max() > 0.1, "they dance"
        # numpy's sin and norms against math's differ in the last bits, and three seconds of
        # stepping grow that (to 4e-6 m on the straight-legged gait): the same dance to 0.1 mm
        assert np.abs(a - b).max() < 1e-4
