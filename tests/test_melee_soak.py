"""Carry and drag: a hand told to fetch one thing lets go of what it held first.

More tests of the goal melee (issue 31) follow with its fixes."""

from __future__ import annotations

from twig_ecs import Scene


def test_a_hand_told_to_carry_something_else_lets_go_of_what_it_held(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    ann = scene.character_handle(scene.spawn("humanoid", name="ann", character=True).entity)
    scene.spawn("ball", name="toy", position=tuple(ann.node("r_hand")))
    scene.spawn("ragdoll", name="doll", position=(0.0, 0.3, 1.2))
    ann.grab("toy", hand="right")
    scene.run(0.5)
    goal = ann.carry("doll", hand="right")
    scene.run(8.0)
    # before: the goal was done at once, the hand still holding the ball ("carrying" the doll)
    assert goal.status == "done" and ann.holding == {"right": "doll"}
