"""A fight reads as exchanges (issue 34): arms drawn back and thrown out, shoves that land
and move the one shoved, a defender that shoves back - not a static clinch of tangled arms.

The figures are what a viewer notices, from node positions: how often each fighter's
elbows open together (a two-handed shove), how far each torso travels, and the
longest time the two stand locked, neither torso moving.
"""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene

FIGHT = 5.0  # s of fighting within reach


def elbow_angle(handle, side: str) -> float:
    """Shoulder-elbow-hand angle (degrees): 180 straight, smaller bent."""
    s, e, h = (handle.node(side + n) for n in ("shoulder", "elbow", "hand"))
    u, v = s - e, h - e
    return float(np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1.0, 1.0))))


def two_handed_throws(angles: np.ndarray, dt: float, opening: float = 60.0, out: float = 110.0,
                      bent: float = 110.0) -> int:  # fmt: skip
    """How many times both elbows open by ``opening`` degrees or more within 0.3 s to ``out``
    degrees or more (both arms thrown out together: a shove, not a one-handed blow with the
    other hand at guard), counting again only once both are bent below ``bent`` (frames x 2
    array of the left and right elbow angles)."""
    window = max(1, round(0.3 / dt))
    count, armed = 0, True
    for k in range(len(angles)):
        opened = angles[k] - angles[max(0, k - window) : k + 1].min(axis=0)
        if armed and opened.min() >= opening and angles[k].min() >= out:
            count, armed = count + 1, False
        elif angles[k].max() < bent:
            armed = True
    return count


def longest_lock(torso_a: np.ndarray, torso_b: np.ndarray, dt: float, moved: float = 0.1) -> float:
    """The longest span (s) in which neither torso moved ``moved`` m from where it was at the
    span's start: the two stand locked, whatever their arms do."""
    best, start = 0, 0
    for k in range(len(torso_a)):
        if (
            max(np.linalg.norm(torso_a[k] - torso_a[start]), np.linalg.norm(torso_b[k] - torso_b[start]))
            > moved
        ):
            start = k
        best = max(best, k - start)
    return best * dt


def ground_path(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points[:, [0, 2]], axis=0), axis=1).sum())


def fight_figures() -> dict:
    """A 1.75 m fighter and a 1.6 m defender that feels no pain: the figures of 5 s of fighting."""
    scene = Scene.load("empty")
    try:
        scene.spawn("humanoid", name="a", character=True)
        scene.spawn(
            "humanoid", name="b", character=True, position=(0.2, 0.0, 2.5), facing=180, height=1.6, pain=False
        )
        scene.run(0.3)
        a, b = scene.entity("a"), scene.entity("b")
        goal = a.grapple("b", duration=FIGHT)
        rows = []
        for _ in range(int((FIGHT + 8.0) * 60)):
            scene.step()
            if "fighting" in goal.memory:
                elbows_a = [elbow_angle(a, "l_"), elbow_angle(a, "r_")]
                elbows_b = [elbow_angle(b, "l_"), elbow_angle(b, "r_")]
                rows.append((elbows_a, elbows_b, a.node("spine"), b.node("spine")))
            if goal.finished:
                break
        assert goal.status == "done", goal.reason
        ea, eb, ta, tb = (np.array([r[k] for r in rows]) for k in range(4))
        return {
            "seconds": len(rows) * scene.dt,
            "fighter_shoves": two_handed_throws(ea, scene.dt),
            "defender_shoves": two_handed_throws(eb, scene.dt),
            "fighter_elbow_range": float(ea.max() - ea.min()),
            "fighter_torso_path": ground_path(ta),
            "defender_torso_path": ground_path(tb),
            "defender_torso_reach": float(np.linalg.norm((tb - tb[0])[:, [0, 2]], axis=1).max()),
            "longest_lock": longest_lock(ta, tb, scene.dt),
        }
    finally:
        scene.close()


@pytest.fixture(scope="module")
def fight() -> dict:
    """The figures of one fight, shared by the tests below."""
    return fight_figures()


def test_the_fighter_shoves_again_and_again_arms_drawn_back_then_thrown_out(fight):
    # before: one two-handed shove in 5 s; the arms then stayed tangled at the other's chest
    assert fight["fighter_shoves"] >= 2
    assert fight["fighter_elbow_range"] >= 130.0, "elbows bend to load and straighten to strike"


def test_a_defender_that_feels_no_pain_shoves_back(fight):
    assert fight["defender_shoves"] >= 2, "it answers the shoves with its own (before: none)"


def test_both_fighters_torsos_move(fight):
    # before: the fighter's torso travelled 0.45 m in 5 s and the defender's 0.33 m, never
    # more than 6 cm from where it stood
    assert fight["fighter_torso_path"] >= 0.8
    assert fight["defender_torso_path"] >= 0.5
    assert fight["defender_torso_reach"] >= 0.2, "the one shoved staggers back a step"


def test_the_two_never_stand_locked(fight):
    # before: 3.9 s in which neither torso moved 10 cm - the static clinch
    assert fight["longest_lock"] <= 1.0


def test_a_snapshot_mid_fight_restores_the_exchange_and_runs_on_identically(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("humanoid", name="a", character=True)
    scene.spawn(
        "humanoid", name="b", character=True, position=(0.2, 0.0, 2.5), facing=180, height=1.6, pain=False
    )
    scene.run(0.3)
    scene.entity("a").grapple("b", duration=FIGHT)
    scene.run(3.9)  # a shove on its way, the defender's guard up
    copy = Scene.restore(scene.snapshot())
    try:
        scene.run(1.5)
        copy.run(1.5)
        assert copy.state_hash() == scene.state_hash()
    finally:
        copy.close()
