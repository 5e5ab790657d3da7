"""Dragging a body through the public API: both hands on it, walking backwards, the body
sliding along the ground behind the hands (BELIEVABILITY "Purposeful actions")."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene


def drag_a_limp_child(distance: float = 4.0) -> dict:
    """A 1.75 m adult drags a limp 1.4 m child (33 kg) ``distance`` m; what each frame of the
    pull showed (from the moment both hands hold until the goal ends)."""
    with Scene.load("empty") as scene:
        adult = scene.spawn("humanoid", name="adult", character=True)
        child = scene.spawn("humanoid", name="child", character=True, height=1.4, position=(0.3, 0.0, 1.5))
        child.go_limp()
        scene.run(2.0)  # lying on the ground
        rows = child.body.rows
        nodes = scene.state.nodes
        start = child.position
        goal = adult.drag("child", distance=distance)
        began = scene.time
        frames = []
        while not goal.finished and scene.time - began < 30.0:
            scene.step()
            holding = adult.holding
            if not frames and not (holding.get("left") == "child" and holding.get("right") == "child"):
                continue  # still getting hold of it
            joints = [j for _, j in scene.grabs() if j.holder == adult.entity and j.held == child.entity]
            hands = [adult.node("l_hand"), adult.node("r_hand")]
            legs = [child.node_row(n) for n in ("l_knee", "r_knee", "l_foot", "r_foot")]
            frames.append({
                "lowest": float((nodes.pos[rows, 1] - nodes.radius[rows]).min()),  # gap to the ground
                "joints": len(joints),
                "wrists_held": all(min(np.linalg.norm(child.node(w) - h) for h in hands) < 0.1
                                   for w in ("l_hand", "r_hand")),
                "legs_down": float((nodes.pos[legs, 1] - nodes.radius[legs]).max()),
                "torso": adult.torso_pitch,
                "pelvis": adult.position[1] / adult.stand_height,
                "backwards": float(adult.velocity @ adult.facing),
            })  # fmt: skip
        return {
            "status": goal.status,
            "reason": goal.reason,
            "frames": frames,
            "moved": float(np.hypot(*(child.position - start)[[0, 2]])),
            "seconds": scene.time - began,
            "mass": child.mass,
        }


def test_a_limp_body_is_dragged_by_both_wrists_with_its_lower_half_on_the_ground():
    seen = drag_a_limp_child()
    assert seen["status"] == "done", seen["reason"]
    assert 30.0 < seen["mass"] < 36.0
    frames = seen["frames"]
    assert len(frames) > 60
    lowest = np.array([f["lowest"] for f in frames])
    assert np.mean(lowest <= 0.1) >= 0.8, "the body slides along the ground"
    assert lowest.max() <= 0.3, "it is never lifted off it"
    assert all(f["joints"] == 2 for f in frames), "both hands hold, all the way"
    assert all(f["wrists_held"] for f in frames[60:]), "by its wrists (a grip closes at 0.6 m/s)"
    assert np.mean([f["legs_down"] <= 0.1 for f in frames]) >= 0.8, "its legs slide along the ground"
    assert seen["moved"] > 3.0  # the dragger walked 4 m; the body straightens out behind it first


def test_the_dragger_walks_backwards_upright_and_slowed_by_the_load():
    seen = drag_a_limp_child()
    frames = seen["frames"][60:]  # from a second after taking hold: up from the stoop
    assert max(f["torso"] for f in frames) <= 25.0
    assert min(f["pelvis"] for f in frames) >= 0.75
    backwards = np.array([f["backwards"] for f in frames])
    assert np.mean(backwards < 0.0) > 0.8, "it faces the body and steps away from it"
    pace = -float(np.mean(backwards))
    assert 0.15 < pace < 0.8, f"{pace:.2f} m/s: slower than a walk, not standing still"


@pytest.mark.parametrize("fell_facing", [0, 90, 180, -90])
def test_however_the_body_fell_both_hands_take_it_and_it_slides(fell_facing):
    """A limp child fallen any way round (wrists or ankles nearer, or under it in a heap):
    the dragger gets both hands on it - its wrists or ankles, else the nearest parts - and
    pulls it 3 m along the ground."""
    with Scene.load("empty") as scene:
        adult = scene.spawn("humanoid", name="adult", character=True)
        child = scene.spawn("humanoid", name="child", character=True, height=1.4, position=(0.3, 0.0, 1.8),
                            facing=fell_facing)  # fmt: skip
        child.go_limp()
        scene.run(2.0)
        rows = child.body.rows
        nodes = scene.state.nodes
        goal = adult.drag("child", distance=3.0)
        lowest = []
        while not goal.finished and scene.time < 25.0:
            scene.step()
            if "start" in goal.memory:
                lowest.append(float((nodes.pos[rows, 1] - nodes.radius[rows]).min()))
                assert len(adult.holding) == 2
        assert goal.status == "done", goal.reason
        assert np.mean(np.array(lowest) <= 0.1) >= 0.8
