"""The hug's walk-up over arrays (issue 36): every walking hugger of a step in one pass, the
steered ones in one ``steer_rows`` call, writing exactly what the per-character walk-up
(``Hug._act_each``: ``steer_to`` a character at a time) writes from the same state."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from twig_ecs import Scene

#: What a walk-up writes in the character table.
WRITTEN = ("walk", "gaze_node", "gaze_mode", "arm_mode", "mode", "seat", "mode_time")


def walking_up() -> tuple[Scene, list]:
    """Huggers in every case the walk-up has: far (steered round the others), near (the
    last steps straight in), a child and a grown-up both ways, a run, two told to hug each
    other, one whose partner walks off (pursued) and one that starts sitting."""
    scene = Scene.load("empty")
    #: (name, height, x, z, facing) of everyone; then who hugs whom and how
    people = (("h0", 1.75, 0.0, 0.0, 0), ("p0", 1.75, 0.0, 3.0, 180), ("h1", 1.05, 4.0, 0.0, 0),
              ("p1", 1.75, 4.0, 1.5, 180), ("h2", 1.75, 8.0, 0.0, 0), ("p2", 1.05, 8.0, 2.5, 180),
              ("h3", 1.6, 12.0, 0.0, 0), ("p3", 1.6, 12.0, 4.0, 180), ("m0", 1.75, 16.0, 0.0, 0),
              ("m1", 1.6, 16.0, 3.5, 180), ("h4", 1.75, 20.0, 0.0, 0), ("p4", 1.75, 20.0, 2.0, 180),
              ("h5", 1.35, 24.0, 0.0, 0), ("p5", 1.75, 24.0, 2.2, 180))  # fmt: skip
    for name, height, x, z, facing in people:
        scene.spawn("humanoid", name=name, position=(x, 0.0, z), facing=facing, height=height, character=True)
    scene.run(0.3)
    scene.entity("h5").sit()
    scene.run(0.5)
    goals = [scene.entity(f"h{k}").hug(f"p{k}", duration=30.0) for k in range(4)]
    goals.append(scene.entity("h4").hug("p4", duration=30.0, run=True))
    goals.append(scene.entity("h5").hug("p5", duration=30.0))
    goals += [scene.entity("m0").hug("m1", duration=30.0), scene.entity("m1").hug("m0", duration=30.0)]
    scene.entity("p3").approach([12.0, 0.0, 12.0], stop_distance=0.3)  # walks off: pursued
    return scene, goals


def both_ways(scene: Scene) -> tuple[dict, dict]:
    """What the batch and the per-character form write from this state (the character table
    and every hug goal's memory; the state put back after each)."""
    hug = scene.behaviors["hug"]
    holders = scene.goal_holders_of("hug")
    entities = [e for e, _ in holders]
    rows = [scene.character_handle(e).character.index for e in entities]
    goals = [mind.goal for _, mind in holders]
    ch = scene.state.characters
    before = {name: getattr(ch, name).copy() for name in WRITTEN}
    memories = [copy.deepcopy(g.memory) for g in goals]

    def outcome() -> dict:
        out = {name: getattr(ch, name).copy() for name in WRITTEN}
        out["memories"] = [copy.deepcopy(g.memory) for g in goals]
        for name in WRITTEN:
            getattr(ch, name)[:] = before[name]
        for goal, memory in zip(goals, memories, strict=True):
            goal.memory.clear()
            goal.memory.update(memory)
        return out

    hug.act_batch(rows, entities, scene.dt, goals=goals)
    batch = outcome()
    hug._act_each(rows, entities, goals, scene.dt)
    return batch, outcome()


def test_the_walk_up_over_arrays_writes_what_the_per_character_walk_up_does():
    with walking_up()[0] as scene:
        phases_seen = set()
        for step in range(150):
            if step % 5 == 0:
                batch, single = both_ways(scene)
                for name in WRITTEN:
                    assert np.array_equal(batch[name], single[name], equal_nan=True), (step, name)
                assert batch["memories"] == single["memories"], step
                phases_seen |= {m.get("phase", "approach") for m in batch["memories"]}
            scene.step()
        assert phases_seen >= {"approach", "wrap"}, "walk-ups and wraps were compared"


def test_every_walking_hugger_is_steered_in_one_call_not_one_steer_to_each(monkeypatch):
    from twig_ecs.systems.behaviours import approach, hug

    def per_character(*args, **kwargs):
        raise AssertionError("steer_to called for one hugger")

    from twig_ecs.systems.control.steer import steer_rows

    calls = []

    def counted(at, rows, *args):
        calls.append(len(rows.crows))
        return steer_rows(at, rows, *args)

    scene, goals = walking_up()
    with scene:
        monkeypatch.setattr(hug, "steer_to", per_character)
        monkeypatch.setattr(approach, "steer_rows", counted)  # (the batch's call: approach.steer_batch)
        start = {k: scene.entity(f"h{k}").position.copy() for k in range(4)}
        scene.run(1.0)
        assert [g.status for g in goals] == ["active"] * len(goals), [g.reason for g in goals]
        assert max(calls) >= 3, "the far huggers were steered together"
        for k in range(4):
            moved = scene.entity(f"h{k}").position - start[k]
            assert np.hypot(moved[0], moved[2]) > 0.2, f"h{k} walked up"


@pytest.mark.parametrize("what", ["gone", "not a character"])
def test_a_hug_whose_partner_cannot_be_hugged_fails_and_the_other_walk_ups_go_on(what):
    scene, goals = walking_up()
    with scene:
        if what == "gone":
            scene.remove("p0")
            reason = "removed"
        else:
            scene.spawn("humanoid", name="h6", position=(30.0, 0.0, 0.0), character=True)
            scene.spawn("humanoid", name="doll", position=(30.0, 0.0, 2.0))
            goals.insert(0, scene.entity("h6").hug("doll"))
            reason = "not a character"
        scene.run(0.5)
        assert goals[0].status == "failed" and reason in goals[0].reason
        assert [g.status for g in goals[1:]] == ["active"] * (len(goals) - 1), [g.reason for g in goals]
