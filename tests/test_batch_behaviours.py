"""Behaviours over arrays (issue 19): a batch behaviour must do what its per-character form does.

``approach`` steers every character it wins in one kernel call (``steer_goals``); its
per-character form (``Approach.act`` -> ``steer_to``) stays for plug-ins and rare targets.
Both must write the same walk vectors from the same state - round walls, wide bodies,
what a character holds, moving targets - and end goals the same way.
"""

from __future__ import annotations

import copy

import esper
import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.behavior import Mind


def approachers(scene: Scene) -> tuple[list[int], list[int], list]:
    """Rows, entities and goals of the characters whose current goal is an approach."""
    holders = scene.goal_holders_of("approach")
    rows = [scene.character_handle(e).character.index for e, _ in holders]
    return rows, [e for e, _ in holders], [mind.goal for _, mind in holders]


def walks_both_ways(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The walk vectors the batch and the per-character form write from this state (the
    state, goal memories included, put back after each)."""
    approach = scene.behaviors["approach"]
    rows, entities, goals = approachers(scene)
    ch = scene.state.characters
    walk, memories = ch.walk.copy(), [copy.deepcopy(g.memory) for g in goals]
    approach.act_batch(rows, entities, scene.dt, goals=goals)
    batch = ch.walk[rows].copy()
    ch.walk[:] = walk
    for goal, memory in zip(goals, memories, strict=True):
        goal.memory.clear()
        goal.memory.update(memory)
    for entity, goal in zip(entities, goals, strict=True):
        approach.act(scene.character_handle(entity), esper.component_for_entity(entity, Mind), goal, scene.dt)
    single = ch.walk[rows].copy()
    ch.walk[:] = walk
    for goal, memory in zip(goals, memories, strict=True):
        goal.memory.clear()
        goal.memory.update(memory)
    return batch, single


def busy_yard(targets=("ball", "parent", "merry_go_round", [7.5, 0.0, 11.5])) -> Scene:
    """The schoolyard (fence: walls; merry-go-round: a wide body; the small child holds the
    doll) with its characters scripted and eight more spawned, every one approaching something
    (the extras go to ``targets`` in turn)."""
    scene = Scene.load("schoolyard", seed=3)
    for name in ("parent", "big_child", "small_child"):
        scene.entity(name).autonomous = False
    scene.entity("parent").approach([8.2, 0.0, -6.0], stop_distance=0.3, direction=[1.0, 0.0, 0.0])
    scene.entity("big_child").approach("merry_go_round", stop_distance=0.2, arms="reach")
    scene.entity("small_child").approach("parent", arms="hug")
    rng = np.random.default_rng(5)
    for k in range(8):
        x, z = rng.uniform(-6.0, 6.0, 2)
        extra = scene.spawn("humanoid", name=f"x{k}", position=(float(x), 0.0, float(z)), character=True)
        extra.approach(targets[k % len(targets)], stop_distance=0.4)
    return scene


def test_batch_approach_walks_as_the_per_character_form_does():
    """Round walls, a wide body, held things, moving targets: the same walk vector to 1e-9 m/s."""
    with busy_yard() as scene:
        compared = 0
        for _ in range(12):
            scene.step(20)
            batch, single = walks_both_ways(scene)
            assert batch.shape == single.shape and len(batch) >= 5
            np.testing.assert_allclose(batch, single, atol=1e-9)
            compared += int((np.abs(single) > 0.05).any(axis=1).sum())
        assert compared > 50, "most of them were walking when compared"


def test_batch_approach_arrives_and_reports_as_before():
    """Goals end done at the stop distance (events and callbacks), the gaze and arms as asked."""
    # no extra chases the parent here: two followers that stop 0.4 m from it hem it in, and
    # it steers round them for good (the walk vectors with moving targets: the test above)
    with busy_yard(targets=("ball", "merry_go_round", [7.5, 0.0, 11.5])) as scene:
        ended = []
        parent = scene.entity("parent")
        goal = parent.goals[0]
        goal.on_end = ended.append
        big = scene.entity("big_child")
        for _ in range(20 * 60):
            scene.step()
            if scene.frame == 30:
                assert big.arm_modes == {"left": "reach", "right": "reach"}
                assert scene.entity("small_child").arm_modes == {"left": "hug", "right": "hug"}
                assert scene.entity("small_child").gaze_target is not None
            if goal.finished:
                break
        assert goal.status == "done" and ended == [goal]
        assert np.hypot(parent.position[0] - 8.2, parent.position[2] + 6.0) <= 0.3 + 0.1 + 0.02
        assert scene.event_counts["goal.done"] >= 1


@pytest.mark.parametrize("curl", [True, False])
def test_a_stalled_batch_approach_fails_stuck(curl):
    """Straight at a wall with no way round fails 'stuck' after the stall time; with the curl it
    gets round instead (the same outcomes as the per-character form)."""
    with Scene.load("empty") as scene:
        walker = scene.spawn("humanoid", name="walker", character=True)
        for k in range(-2, 3):
            scene.spawn("post", name=f"post{k}", position=(0.6 * k, 0.0, 2.5))
        scene.spawn("ball", name="goal", position=(0.0, 0.0, 5.0))
        scene.run(0.3)
        goal = walker.approach("goal", stop_distance=0.6, curl=curl)
        for _ in range(20 * 60):
            scene.step()
            if goal.finished:
                break
        if curl:
            assert goal.status == "done", goal.reason
        else:
            assert goal.status == "failed" and goal.reason.startswith("stuck")


def test_a_snapshot_mid_approach_resumes_the_same_world():
    """The batch's packed arrays are not state: a scene restored mid-approach (stall clocks and
    all, from the goals' memory) steps on exactly as the original does."""
    with busy_yard() as scene:
        scene.step(45)
        data = scene.snapshot()
        with Scene.restore(data) as copy_:
            scene.step(90)
            copy_.step(90)
            assert copy_.state_hash() == scene.state_hash()
            assert [g.memory.get("best") for g in approachers(copy_)[2]] == [
                g.memory.get("best") for g in approachers(scene)[2]
            ]
