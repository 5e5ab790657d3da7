"""Behaviours through the public API: approach, hug, grapple, drag, freeze, sit/stand, selection."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import max_overlap_between_bodies

from twig_ecs import Scene, TwigError
from twig_ecs.store import LINK_COLLIDE


def run_until(scene: Scene, goal, seconds: float) -> None:
    """Step until the goal ends or the time is up."""
    for _ in range(int(seconds * 60)):
        scene.step()
        if goal.finished:
            return


def wall_scene(scenes) -> Scene:
    """A character, a wall of five posts 2.5 m ahead, a ball behind the wall."""
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("humanoid", name="walker", character=True)
    for k in range(-2, 3):
        scene.spawn("post", name=f"post{k}", position=(0.6 * k, 0.0, 2.5))
    scene.spawn("ball", name="goal", position=(0.0, 0.0, 5.0))
    scene.run(0.3)
    return scene


def overlap_with_posts(scene: Scene) -> float:
    st = scene.state
    posts = {scene.entity(f"post{k}").body.index for k in range(-2, 3)}
    walker = scene.entity("walker").body.index
    keep = [b for b in range(st.bodies.count) if b in posts or b == walker]
    assert len(keep) == 6
    return max_overlap_between_bodies(scene)


def test_approach_curls_round_an_obstacle_and_arrives_without_overlapping_it(scenes):
    scene = wall_scene(scenes)
    walker = scene.entity("walker")
    goal = walker.approach("goal", stop_distance=0.6)
    worst = 0.0
    for _ in range(20 * 60):
        scene.step()
        worst = max(worst, max_overlap_between_bodies(scene) if scene.frame % 6 == 0 else 0.0)
        if goal.finished:
            break
    assert goal.status == "done", goal.reason
    gap = np.hypot(*(walker.position - scene.entity("goal").position)[[0, 2]])
    assert gap <= 0.6 + 0.15
    assert worst <= 0.02, "it never walks into the posts"


def test_without_the_curl_term_the_same_approach_stalls_at_the_wall(scenes):
    scene = wall_scene(scenes)
    walker = scene.entity("walker")
    goal = walker.approach("goal", stop_distance=0.6, curl=False)
    run_until(scene, goal, 20.0)
    assert goal.status == "failed" and "stuck" in goal.reason
    assert walker.position[2] < 2.5, "it never got past the wall"


def torso_gap(scene: Scene, hugger: str, other: str) -> float:
    """Closest distance between the hugger's torso capsules and any capsule of the other."""
    from helpers import _closest

    st, lk, pos = scene.state, scene.state.links, scene.state.nodes.pos
    a, b = scene.entity(hugger), scene.entity(other)
    torso_nodes = {a.body.node_index(n) for n in ("pelvis", "spine", "neck", "l_shoulder", "r_shoulder")}
    mine = [j for j in range(a.body.link_start, a.body.link_start + a.body.link_count)
            if lk.flags[j] & LINK_COLLIDE and {int(lk.a[j]), int(lk.b[j])} <= torso_nodes]  # fmt: skip
    theirs = [
        j
        for j in range(b.body.link_start, b.body.link_start + b.body.link_count)
        if lk.flags[j] & LINK_COLLIDE
    ]
    assert st is not None
    return min(_closest(pos[lk.a[i]], pos[lk.b[i]], pos[lk.a[j]], pos[lk.b[j]]) - lk.radius[i] - lk.radius[j]
               for i in mine for j in theirs)  # fmt: skip


def test_hug_puts_both_hands_behind_the_target_torso_and_lets_go(pair):
    a, b = pair.entity("a"), pair.entity("b")
    goal = a.hug("b", duration=2.0)
    closest, behind = np.inf, []
    for _ in range(15 * 60):
        pair.step()
        if goal.memory.get("phase") == "hold":
            # the arms go round by reaching, not by joints: the bodies keep colliding
            assert a.holding == {} and pair.grabs() == []
            # the torso's frontal plane runs through its shoulders and hips
            centre = sum(b.node(n) for n in ("l_shoulder", "r_shoulder", "l_hip", "r_hip")) / 4
            axis = (b.node("spine") - a.node("spine")) * [1, 0, 1]
            axis /= np.linalg.norm(axis)
            behind.append(min((a.node(h) - centre) @ axis for h in ("l_hand", "r_hand")))
            closest = min(closest, torso_gap(pair, "a", "b"))
        if goal.finished:
            break
    assert goal.status == "done", goal.reason
    assert behind and np.median(behind[-len(behind) // 4 :]) > 0.0, "the hands are behind the target's torso"
    assert closest <= 0.02, "the target touches the hugger's torso"
    pair.step(2)
    assert a.holding == {} and pair.grabs() == [], "the hug is released"
    assert b.pain == 0.0, "a gentle hug does not hurt"


def test_grapple_hurts_the_target_and_its_pain_withdrawal_wins_and_backs_it_off(pair):
    a, b = pair.entity("a"), pair.entity("b")
    changes = []
    pair.on("behavior.changed", lambda e: changes.append((pair.name_of(e.character), e.new)))
    goal = a.grapple("b", duration=5.0)
    start, backed, peak = None, 0.0, 0.0
    for _ in range(12 * 60):
        pair.step()
        peak = max(peak, b.pain)
        if b.behaviour == "withdraw":
            start = b.position if start is None else start
            backed = max(backed, float(np.hypot(*(b.position - start)[[0, 2]])))
        if goal.finished:
            break
    threshold = pair.state.bodies.pain_threshold[b.body.index]
    assert peak > threshold
    assert ("b", "withdraw") in changes
    assert backed > 0.3


def test_a_dragged_ragdoll_follows_within_arms_reach(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    dragger = scene.spawn("humanoid", name="dragger", character=True)
    doll = scene.spawn("ragdoll", name="doll", position=(0.3, 0.1, 1.5))
    scene.run(1.0)
    start = doll.position
    seen = {}

    def ended(goal):
        seen["gap"] = float(np.linalg.norm(dragger.node("r_hand") - doll.position))
        seen["moved"] = float(np.hypot(*(doll.position - start)[[0, 2]]))

    goal = dragger.drag("doll", distance=5.0, on_end=ended)
    run_until(scene, goal, 25.0)
    assert goal.status == "done", goal.reason
    assert seen["moved"] > 4.5
    assert seen["gap"] < 0.6, "the ragdoll stays within arm's reach"


def test_freeze_holds_every_node_within_a_centimetre(pair):
    a = pair.entity("a")
    a.walk((0.0, 0.0, 1.0))
    pair.run(1.0)
    goal = a.freeze(duration=2.0)
    pair.step(2)
    before = a.node_positions
    pair.run(1.5)
    assert np.abs(a.node_positions - before).max() < 0.01
    run_until(pair, goal, 2.0)
    assert goal.status == "done"
    pair.step(2)
    assert not any(a.is_locked(n) for n in ("head", "pelvis", "l_hand"))


def test_sit_and_stand_as_goals(pair):
    a = pair.entity("a")
    pair.spawn("bench", name="bench", position=(2.0, 0.0, 0.0))
    done = []
    sit = a.do("sit", on="bench", on_end=done.append)
    run_until(pair, sit, 20.0)
    assert sit.status == "done" and a.posture == "sit"
    stand = a.do("stand", on_end=done.append)
    run_until(pair, stand, 5.0)
    assert stand.status == "done" and a.posture == "stand"
    assert [g.behavior for g in done] == ["sit", "stand"]
    kinds = [e.kind for e in pair.events]
    assert "goal.done" in kinds or pair.event_counts["goal.done"] >= 2


def test_the_higher_activation_wins_and_switching_does_not_flicker(pair):
    a = pair.entity("a")
    a.approach((0.0, 0.0, -3.0), stop_distance=0.2)
    a.do("gesture", name="wave", duration=1.0)  # queued behind the approach
    pair.run(0.5)
    assert a.behaviour == "approach"
    assert a.mind.last["approach"] > a.mind.last["idle"]
    pair.run(10.0)
    # approach, then gesture, then idle: a handful of switches, not one per frame
    assert a.mind.switches <= 4
    assert a.behaviour == "idle" and a.goals == []


def test_goal_commands_check_their_arguments(pair):
    a = pair.entity("a")
    with pytest.raises(TwigError, match="no goal behaviour 'dance'"):
        a.do("dance")
    with pytest.raises(TwigError, match="unknown parameter"):
        a.do("hug", target="b", tightly=True)
    with pytest.raises(KeyError, match="no entity named 'c'"):
        a.hug("c")
    with pytest.raises(TwigError, match="cannot hug itself"):
        a.hug("a")
    with pytest.raises(TwigError, match="approach: 'arms' must be one of reach, hug, grapple"):
        a.approach("b", arms="tickle")


def test_carry_fetches_a_ball_and_brings_it_to_a_place(pair):
    a = pair.entity("a")
    ball = pair.spawn("ball", name="ball", position=(-1.0, 0.0, 1.0))
    goal = a.carry("ball", to=(2.0, 0.0, -2.0))
    run_until(pair, goal, 30.0)
    assert goal.status == "done", goal.reason
    assert a.holding == {"right": "ball"}
    assert np.hypot(*(ball.position - np.array([2.0, 0.0, -2.0]))[[0, 2]]) < 1.0
    assert ball.position[1] > 0.3, "it is carried, not rolled"


def test_an_installed_package_offers_a_behaviour_by_entry_point(tmp_path, monkeypatch, scenes):
    # a real (if tiny) installed distribution: a module and its dist-info on sys.path
    (tmp_path / "shimmy_pkg.py").write_text(
        "from dataclasses import dataclass\n"
        "from twig_ecs.behavior import Behavior\n\n"
        "@dataclass\nclass Mood:\n    joy: float = 0.5\n\n"
        "class Shimmy(Behavior):\n    name = 'shimmy'\n    component = Mood\n\n"
        "    def activation(self, character, mind, goal):\n        return self.settings(character).joy\n\n"
        "    def act(self, character, mind, goal, dt):\n        character.gesture('wave', hand='both')\n"
    )
    info = tmp_path / "shimmy_pkg-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: shimmy-pkg\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[twig_ecs.behaviors]\nshimmy = shimmy_pkg:Shimmy\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    scene_file = tmp_path / "party.yaml"
    scene_file.write_text(
        "twig: 1\nentities:\n"
        "  - {name: s, body: humanoid, character: true, behaviors: [{use: shimmy, joy: 0.7}]}\n"
    )
    scene = Scene.load(scene_file)
    scenes.append(scene)
    scene.run(1.0)
    shimmer = scene.entity("s")
    assert shimmer.behaviour == "shimmy"
    assert shimmer.arm_modes == {"left": "wave", "right": "wave"}
