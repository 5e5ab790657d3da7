"""The spatial index: one per world, built once a step, asked "who is near" (issue 32).

Tiny worlds of a few balls with only the systems the test needs: the index must find
exactly what a scan of every node finds.
"""

from __future__ import annotations

import numpy as np

from twig_ecs import Scene
from twig_ecs.systems.control.spatial import SpatialIndex

SPOTS = {"a": (0.0, 0.1, 0.0), "b": (1.0, 0.1, 0.0), "c": (3.0, 0.1, 0.5), "d": (10.0, 0.1, 10.0)}


def four_balls() -> Scene:
    scene = Scene(plugins=[])  # no system at all: the balls stay where they are put
    for name, where in SPOTS.items():
        scene.spawn("ball", name=name, position=where)
    return scene


def brute_force(scene: Scene, point, radius: float) -> set[int]:
    nodes = scene.state.nodes
    pos, body = nodes.pos[: nodes.count], nodes.body[: nodes.count]
    near = (pos[:, 0] - point[0]) ** 2 + (pos[:, 2] - point[2]) ** 2 < radius**2
    return set(body[near].tolist())


def test_bodies_near_a_point_are_those_a_scan_of_every_node_finds():
    with four_balls() as scene:
        index = SpatialIndex.of(scene)
        row = {name: scene.entity(name).body.index for name in SPOTS}
        assert set(index.bodies_near(scene, (0.0, 0.0, 0.0), 1.5).tolist()) == {row["a"], row["b"]}
        assert set(index.bodies_near(scene, (2.0, 0.0, 0.0), 1.3).tolist()) == {row["b"], row["c"]}
        assert index.bodies_near(scene, (6.0, 0.0, 6.0), 1.0).size == 0
        rng = np.random.default_rng(7)
        for _ in range(200):
            point = (rng.uniform(-2, 12), 0.0, rng.uniform(-2, 12))
            radius = float(rng.uniform(0.1, 9.0))  # up to radii that scan every node
            found = index.bodies_near(scene, point, radius).tolist()
            assert len(found) == len(set(found)), "each body once"
            assert set(found) == brute_force(scene, point, radius)


def test_the_index_is_one_per_world_built_once_a_step_and_not_saved():
    with four_balls() as scene, four_balls() as other:
        index = SpatialIndex.of(scene)
        assert SpatialIndex.of(scene) is index and SpatialIndex.of(other) is not index
        grid = index.grid(scene)
        assert index.grid(scene) is grid  # every query of a step shares it
        scene.step()
        assert index.grid(scene) is not grid  # the next step builds it again
        restored = Scene.restore(scene.snapshot())
        try:
            fresh = SpatialIndex.of(restored)
            assert "_grid" not in vars(fresh)  # nothing of it came from the file
            assert set(fresh.bodies_near(restored, (0.0, 0.0, 0.0), 1.5).tolist()) == set(
                index.bodies_near(scene, (0.0, 0.0, 0.0), 1.5).tolist()
            )
        finally:
            restored.close()
