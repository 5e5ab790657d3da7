"""Getting up (issue 34): a character that went down rises as a person does, never with a pop.

:class:`twig_ecs.rises.RiseRecorder` times each rise from a pelvis below 40% of standing
height back above 90%; ``twig run --report json`` carries it as ``rises``.
"""

from __future__ import annotations

from twig_ecs import Scene
from twig_ecs.rises import DOWN, UP, RiseRecorder


def test_the_rise_figures_time_a_fall_and_the_getting_up_after_it(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("humanoid", name="upright", character=True)
    fallen = scene.spawn("humanoid", name="fallen", character=True, position=(3.0, 0.0, 0.0))
    rises = RiseRecorder(scene)
    fallen.go_limp()
    for _ in range(int(2.0 / scene.dt)):  # a ragdoll: down on the ground
        scene.step()
        rises.step()
    assert fallen.position[1] < DOWN * fallen.stand_height
    assert rises.report()["characters"] == {}, "no rise while it lies there"
    fallen.stand()
    for _ in range(int(4.0 / scene.dt)):
        scene.step()
        rises.step()
    assert fallen.position[1] > UP * fallen.stand_height
    figures = rises.report()["characters"]
    assert set(figures) == {"fallen"}, "the one that stood all along never rose"
    (rise,) = figures["fallen"]["rises"]
    assert 1.9 <= rise["at_s"] <= 2.0 + 4.0 and rise["lowest"] < 0.25 and rise["seconds"] > 0.0
    assert figures["fallen"]["quickest_s"] == rise["seconds"]
