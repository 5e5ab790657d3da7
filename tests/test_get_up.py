"""Getting up (issue 34): a body that has fallen rises over most of a second, never pops up."""

from __future__ import annotations

import pytest

from twig_ecs import Scene

LOW, UP = 0.4, 0.9  # of standing height: a pelvis below LOW is down; at UP it is up again


def rise_time(height: float) -> float:
    """A character of ``height`` falls limp, lies a second, is told to stand: seconds from its
    pelvis last below LOW of its standing height to first at UP."""
    with Scene.load("empty") as scene:
        person = scene.spawn("humanoid", name="p", height=height, character=True)
        scene.run(0.5)
        person.go_limp()
        scene.run(1.5)
        stand = person.stand_height
        assert person.position[1] < LOW * stand, "it lies on the ground"
        person.stand()
        low_at = scene.time
        while scene.time < low_at + 5.0:
            scene.step()
            y = person.position[1]
            if y < LOW * stand:
                low_at = scene.time
            elif y >= UP * stand:
                return scene.time - low_at
        raise AssertionError("it did not get up within 5 s")


@pytest.mark.parametrize("height", [1.05, 1.75])
def test_a_fallen_body_gets_up_over_most_of_a_second_not_in_a_pop(height):
    # before: the pelvis went from the ground to 90% of standing height in about 0.2 s
    took = rise_time(height)
    assert 0.8 <= took <= 2.0, f"{took:.2f} s from lying to standing"
