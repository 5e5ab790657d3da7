"""A humanoid torso never stays a mirror image of itself (systems/physics/torso.py): links
cannot tell the two apart, so a body flipped by a push is put back by hand."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene


def _chirality(person) -> float:
    """The signed volume of the pelvis, both hips and the mid-spine: its sign is the torso's side."""
    p = person.node("pelvis")
    return float(np.cross(person.node("l_hip") - p, person.node("r_hip") - p) @ (person.node("spine") - p))


@pytest.mark.parametrize("flipped", [("pelvis", "spine", "neck", "head"), ("pelvis",)])
def test_a_torso_turned_inside_out_is_back_the_right_way_within_a_step(tmp_path, flipped):
    path = tmp_path / "one.yaml"
    path.write_text("twig: 1\nentities:\n  - {name: a, body: humanoid, height: 1.35, character: true}\n")
    with Scene.load(path) as scene:
        person = scene.character_handle(scene.entity("a").entity)
        scene.run(1.0)
        rest = _chirality(person)
        nodes, hips = scene.state.nodes, 0.5 * (person.node("l_hip") + person.node("r_hip"))
        plane = person.node("spine") if flipped == ("pelvis",) else person.node("neck")
        normal = np.cross(person.node("l_hip") - person.node("r_hip"), plane - hips)
        normal /= np.linalg.norm(normal)
        for name in flipped:  # the mirror image: the lower back bowed forwards, or the pelvis through
            i = person.node_row(name)
            nodes.pos[i] -= 2.0 * ((nodes.pos[i] - hips) @ normal) * normal
            nodes.prev[i] = nodes.pos[i]
        assert _chirality(person) * rest < 0.0
        scene.step()
        assert _chirality(person) / rest > 0.9, "the right way out again"
        scene.run(2.0)
        assert _chirality(person) / rest > 0.9 and person.node("pelvis")[1] > 0.5 * person.stand_height
