"""Node locks, lock-on-contact, muscle damping, grab joints, spheres and the broad phase."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import TwigError
from twig_ecs.yamldoc import parse_yaml


def test_a_locked_node_stays_put_and_holds_its_body_up(empty_scene):
    scene = empty_scene
    body = scene.spawn("humanoid", name="h", position=(0, 1.0, 0))
    body.lock("head")
    where = body.node("head")
    scene.run(2.0)
    np.testing.assert_allclose(body.node("head"), where)
    assert body.node("l_foot")[1] > 0.5, "it hangs from its head"
    body.unlock("head")
    scene.run(2.0)
    assert body.node("head")[1] < where[1] - 0.5, "unlocked, it falls"


def test_lock_on_contact_freezes_a_node_where_it_lands(empty_scene):
    scene = empty_scene
    ball = scene.spawn("ball", name="b", position=(0, 2.0, 0))
    ball.lock_on_contact("centre")
    ball.set_velocity((2.0, 0.0, 0.0))
    scene.run(1.5)
    assert ball.is_locked("centre")
    landed = ball.node("centre")
    scene.run(1.0)
    np.testing.assert_allclose(ball.node("centre"), landed)
    assert landed[1] == pytest.approx(0.11, abs=1e-3)


def test_ground_damping_stops_a_sliding_body_and_air_damping_barely_slows_it(zero_g_scene, empty_scene):
    flying = zero_g_scene.spawn("ball", name="b", position=(0, 3, 0))
    flying.set_velocity((5.0, 0.0, 0.0))
    zero_g_scene.run(1.0)
    rolling = empty_scene.spawn("ball", name="b", position=(0, 0.11, 0),
                                damping={"air": 0.002, "ground": 0.3})  # fmt: skip
    rolling.set_velocity((5.0, 0.0, 0.0))
    empty_scene.run(1.0)
    assert flying.velocity[0] > 4.0
    assert abs(rolling.velocity[0]) < 0.05


def test_muscle_damping_removes_velocity_relative_to_its_node(zero_g_scene):
    relative_speed = {}
    for name, muscle in (("free", ""), ("damped", ", muscle: {to: a, damping: 0.2}")):
        doc = parse_yaml(
            "nodes:\n  a: {at: [0, 0, 0], mass: 1}\n"
            f"  b: {{at: [0, 0.5, 0], mass: 1{muscle}}}\n"
            "links:\n  - {nodes: [a, b]}\n"
            "damping: {air: 0, ground: 0}\n"
        )
        zero_g_scene.library.add_template(name, doc)
        pair = zero_g_scene.spawn(name, name=name, position=(3.0 * len(relative_speed), 3, 0))
        pair.set_node_velocity("b", (2.0, 0.0, 0.0))  # b swings around a
    zero_g_scene.run(1.0)
    for name in ("free", "damped"):
        pair = zero_g_scene.entity(name)
        relative_speed[name] = np.linalg.norm(pair.node_velocity("b") - pair.node_velocity("a"))
    assert relative_speed["free"] > 0.9
    assert relative_speed["damped"] < 0.01


def test_grab_joint_pulls_hand_and_target_together_and_release_frees_them(empty_scene):
    scene = empty_scene
    scene.spawn("humanoid", name="h")
    ball = scene.spawn("ball", name="ball", position=(0.6, 1.0, 0.3))
    grab = scene.grab("h", "r_hand", "ball", "centre")
    scene.run(2.0)  # the joint draws them together at GRAB_CLOSING m/s
    hand = scene.entity("h").node("r_hand")
    assert np.linalg.norm(hand - ball.node("centre")) < 0.02
    scene.release(grab)
    ball.set_velocity((0.0, 0.0, 3.0))
    scene.run(0.5)
    assert np.linalg.norm(scene.entity("h").node("r_hand") - ball.node("centre")) > 0.3
    assert scene.grabs() == []
    with pytest.raises(TwigError, match="cannot grab itself"):
        scene.grab("h", "r_hand", "h", "l_hand")


def test_balls_meet_head_on_without_overlapping_and_stop_each_other(zero_g_scene):
    scene = zero_g_scene
    a = scene.spawn("ball", name="a", position=(-1, 3, 0), damping={"air": 0, "ground": 0})
    b = scene.spawn("ball", name="b", position=(1, 3, 0), damping={"air": 0, "ground": 0})
    a.set_velocity((2.0, 0.0, 0.0))
    b.set_velocity((-2.0, 0.0, 0.0))
    closest = np.inf
    for _ in range(90):
        scene.step()
        closest = min(closest, np.linalg.norm(a.node("centre") - b.node("centre")))
    assert closest > 0.22 - 0.01
    # projection makes contacts perfectly inelastic: equal masses head-on stop dead
    assert abs(a.velocity[0]) < 0.05 and abs(b.velocity[0]) < 0.05


def test_far_apart_bodies_produce_no_candidate_pairs(empty_scene):
    scene = empty_scene
    scene.spawn("humanoid", name="a", position=(0, 0, 0))
    scene.spawn("humanoid", name="b", position=(50, 0, 0))
    scene.spawn("ball", name="c", position=(-50, 0, 50))
    scene.step()
    st = scene.state
    pairs = st.pairs[: st.n_pairs]
    bodies = st.colliders.body[pairs]
    assert len(pairs) > 0, "limbs of one body near each other are candidates"
    assert np.all(bodies[:, 0] == bodies[:, 1]), "no pair may join bodies 50 m apart"
    # brought together, the pairs appear
    scene.entity("b").translate((-49.5, 0, 0))
    scene.step()
    pairs = st.pairs[: st.n_pairs]
    bodies = st.colliders.body[pairs]
    assert np.any(bodies[:, 0] != bodies[:, 1])
