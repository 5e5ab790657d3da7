"""The batch plug-in API (issue 36): a behaviour over arrays (Crowd) moves characters as the
same behaviour written per character does, and says clearly what it cannot do."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import TwigError
from twig_ecs.behavior import Behavior, Mind
from twig_ecs.bench.cases import plugin_strollers
from twig_ecs.crowd import Crowd


def test_a_behaviour_over_arrays_walks_its_characters_as_the_per_character_one_does(scenes):
    one_by_one, over_arrays = plugin_strollers(9), plugin_strollers(9, batch=True)
    scenes += [one_by_one, over_arrays]
    start = one_by_one.state.nodes.pos[: one_by_one.state.nodes.count].copy()
    one_by_one.run(2.0)
    over_arrays.run(2.0)
    a = one_by_one.state.nodes.pos[: one_by_one.state.nodes.count]
    b = over_arrays.state.nodes.pos[: over_arrays.state.nodes.count]
    assert np.abs(a - start).max() > 0.5, "they walked"
    # the same sums in the same order but for numpy's norm of one vector or of many rows: the
    # last bit of a length, nowhere near a millimetre
    assert np.abs(a - b).max() < 1e-9
    assert {mind.winner for _, mind in over_arrays.world.get_component(Mind)} == {"stroll"}


class TooFast(Behavior):
    """Asks one character to run at 50 m/s."""

    name = "too_fast"

    def propose_crowd(self, crowd):
        return np.ones(len(crowd))

    def act_crowd(self, crowd):
        v = np.zeros((len(crowd), 2))
        v[-1] = (50.0, 0.0)
        crowd.walk(v)


def test_a_crowd_refuses_a_speed_past_a_characters_top_and_a_wrong_shape_naming_what(empty_scene):
    scene = empty_scene
    for k in range(3):
        scene.spawn("humanoid", name=f"c{k}", position=(2.0 * k, 0, 0), character=True)
    scene.add_system(TooFast())
    with pytest.raises(TwigError, match=r"walk speed 50.00 m/s is more than 'c2' can do"):
        scene.step()
    assert np.all(scene.state.characters.walk[:3] == 0.0), "nothing was written"
    crowd = Crowd(scene, [0, 1, 2], [scene.entity_id(f"c{k}") for k in range(3)], scene.dt)
    with pytest.raises(TwigError, match=r"give 3 rows of \(x, z\) or \(x, y, z\)"):
        crowd.walk([1.0, 0.0])
    with pytest.raises(TwigError, match="this behaviour has no component"):
        crowd.settings("radius")
    crowd.look_at(crowd.positions + crowd.facing)
    assert crowd.positions.shape == (3, 3) and np.allclose(np.linalg.norm(crowd.facing, axis=1), 1.0)
