"""follow: a character walks after another and keeps near it (a built-in behaviour added as
one module, systems/behaviours/follow.py, plus this test)."""

from __future__ import annotations

import numpy as np

from twig_ecs.steering import ground_distance


def _pair(scene):
    leader = scene.spawn("humanoid", name="ann", position=(0.0, 0.0, 0.0), facing=90.0, character=True)
    follower = scene.spawn("humanoid", name="bob", position=(-2.0, 0.0, 0.0), facing=90.0, character=True)
    return leader, follower


def test_a_follower_walks_after_its_leader_and_stops_near_it(empty_scene):
    scene = empty_scene
    leader, follower = _pair(scene)
    start = follower.position.copy()
    leader.approach([6.0, 0.0, 0.0], stop_distance=0.1)
    goal = follower.follow("ann", distance=1.5)
    scene.run(12.0)
    assert ground_distance(leader.position, np.array([6.0, 0.0, 0.0])) < 0.5, "the leader got there"
    assert ground_distance(follower.position, start) > 4.0, "the follower went with it"
    gap = ground_distance(follower.position, leader.position)
    assert 1.0 < gap < 2.1, f"it keeps near, not on top: {gap:.2f} m"
    assert follower.behaviour == "follow" and goal.status == "active"  # following until told otherwise


def test_following_ends_after_its_duration_and_fails_when_the_leader_is_gone(empty_scene):
    scene = empty_scene
    _, follower = _pair(scene)
    done = follower.follow("ann", duration=1.0)
    scene.run(1.5)
    assert done.status == "done"
    gone = follower.follow("ann")
    scene.step(2)
    scene.remove("ann")
    scene.step(2)
    assert gone.status == "failed" and "ann" in gone.reason  # "'ann' was removed"


def test_follow_is_a_goal_of_the_handle_and_of_the_server():
    from twig_ecs.character import CharacterHandle
    from twig_ecs.server.methods import find_method

    assert callable(CharacterHandle.follow)
    assert find_method("follow") is not None
