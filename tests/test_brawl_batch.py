"""Grapple, defend and withdraw over arrays (issue 36): every grappler, every defender and every
one flinching from a blow of a step in one pass (the walking-up grapplers in one ``steer_rows``
call), writing exactly what the per-character forms (``Grapple.act``, ``Defend.activation`` and
``Defend.act``, ``Withdraw.activation`` and ``Withdraw.act``, through the handle API) write from
the same state."""

from __future__ import annotations

import copy

import numpy as np

from twig_ecs import Scene
from twig_ecs.mind import Mind
from twig_ecs.systems.behaviours import fight, grapple, withdraw

#: What grapple and defend write in the character table (``prev``, the blows, apart).
WRITTEN = ("walk", "gaze_node", "gaze_mode", "arm_mode", "arm_node", "arm_point", "mode", "seat", "mode_time")


def brawling() -> tuple[Scene, list]:
    """Grapplers in every case the fight has: walking up from near and far (steered round the
    others), a child and a grown-up both ways, one that starts sitting, a target that walks
    off (pursued, then stepped after, then let go), and a short fight that ends."""
    scene = Scene.load("empty")
    #: (name, height, x, z, facing) of everyone
    people = (("g0", 1.75, 0.0, 0.0, 0), ("t0", 1.75, 0.0, 1.6, 180), ("g1", 1.75, 4.0, 0.0, 0),
              ("t1", 1.05, 4.0, 2.5, 180), ("g2", 1.05, 8.0, 0.0, 0), ("t2", 1.75, 8.0, 1.4, 180),
              ("g3", 1.6, 12.0, 0.0, 0), ("t3", 1.6, 12.0, 1.2, 180), ("g4", 1.75, 16.0, 0.0, 0),
              ("t4", 1.75, 16.0, 3.5, 180), ("g5", 1.35, 20.0, 0.0, 0),
              ("t5", 1.6, 20.0, 1.5, 180))  # fmt: skip
    for name, height, x, z, facing in people:
        scene.spawn("humanoid", name=name, position=(x, 0.0, z), facing=facing, height=height, character=True)
    scene.run(0.3)
    scene.entity("g5").sit()
    scene.run(0.5)
    goals = [scene.entity(f"g{k}").grapple(f"t{k}", duration=30.0) for k in (0, 1, 2, 4, 5)]
    goals.append(scene.entity("g3").grapple("t3", duration=1.2))  # over within the run
    scene.entity("t1").approach([4.0, 0.0, 12.0], stop_distance=0.3)  # walks off: pursued, then let go
    return scene, goals


def _restorer(scene: Scene, entities: list[int]):
    """A function that puts back what grapple and defend write: the character table's columns,
    the nodes' previous positions, the goals' memories, statuses and queues."""
    ch = scene.state.characters
    before = {name: getattr(ch, name).copy() for name in WRITTEN}
    prev = scene.state.nodes.prev.copy()
    minds = [scene.world.component_for_entity(e, Mind) for e in entities]
    queues = [list(mind.goals) for mind in minds]
    goals = [goal for queue in queues for goal in queue]
    kept = [(copy.deepcopy(g.memory), g.status, g.reason) for g in goals]

    def outcome() -> dict:
        out = {name: getattr(ch, name).copy() for name in WRITTEN}
        out["prev"] = scene.state.nodes.prev.copy()
        out["goals"] = [(copy.deepcopy(g.memory), g.status, g.reason) for g in goals]
        for name in WRITTEN:
            getattr(ch, name)[:] = before[name]
        scene.state.nodes.prev[:] = prev
        for mind, queue in zip(minds, queues, strict=True):
            mind.goals[:] = queue
        for goal, (memory, status, reason) in zip(goals, kept, strict=True):
            goal.memory.clear()
            goal.memory.update(memory)
            goal.status, goal.reason = status, reason
        return out

    return outcome


def grapples_both_ways(scene: Scene, left_alone: tuple[str, ...] = ()) -> tuple[dict, dict] | None:
    """What the batch (those it leaves to the per-character form, named ``left_alone``, acting
    after it) and the per-character grapple write from this state (None: no one grapples)."""
    behaviour = scene.behaviors["grapple"]
    holders = scene.goal_holders_of("grapple")
    if not holders:
        return None
    entities = [e for e, _ in holders]
    rows = [scene.character_handle(e).character.index for e in entities]
    goals = [mind.goal for _, mind in holders]
    outcome = _restorer(scene, entities)
    untouched = outcome()
    left = grapple.act_grapples(behaviour, rows, entities, goals, scene.dt)
    if len(left) == len(goals):  # a rare event (a walk-up stalled): per character, nothing written
        _assert_same(outcome(), untouched, -1)
        return None
    assert [scene.name_of(entities[k]) for k in left] == list(left_alone)
    for k in left:
        behaviour.act(scene.character_handle(entities[k]), holders[k][1], goals[k], scene.dt)
    batch = outcome()
    for entity, (_, mind) in zip(entities, holders, strict=True):
        behaviour.act(scene.character_handle(entity), mind, mind.goal, scene.dt)
    return batch, outcome()


def defences_both_ways(scene: Scene) -> tuple[dict, dict] | None:
    """What the batch and the per-character defence propose and write from this state (None:
    no one is attacked)."""
    defend = scene.behaviors["defend"]
    picked = defend.candidates()
    if not picked:
        return None
    entities = [e for e, _ in picked]
    rows = [scene.character_handle(e).character.index for e in entities]
    outcome = _restorer(scene, entities)
    proposed = fight.defend_activations(defend, defend.fighter_rows, entities, np.array(rows))
    assert fight.act_defences(defend, defend.attacked_by, defend.fighter_rows, rows, entities), (
        "the batch took the step"
    )
    batch = outcome() | {"proposed": proposed.tolist()}
    single = [defend.activation(scene.character_handle(e), mind, None) for e, mind in picked]
    for entity, mind in picked:
        defend.act(scene.character_handle(entity), mind, None, scene.dt)
    return batch, outcome() | {"proposed": single}


def withdrawals_both_ways(scene: Scene) -> tuple[dict, dict] | None:
    """What the batch and the per-character pain withdrawal propose and write from this state
    (None: no one withdraws)."""
    behaviour = scene.behaviors["withdraw"]
    picked = behaviour.candidates()
    if not picked:
        return None
    entities = [e for e, _ in picked]
    rows = [scene.character_handle(e).character.index for e in entities]
    outcome = _restorer(scene, entities)

    class Picked:  # what propose_crowd reads of its crowd
        pass

    crowd = Picked()
    crowd.entities = entities
    proposed = behaviour.propose_crowd(crowd)
    assert withdraw.act_withdrawals(behaviour, rows, entities), "the batch took the step"
    batch = outcome() | {"proposed": proposed.tolist()}
    single = [behaviour.activation(scene.character_handle(e), mind, None) for e, mind in picked]
    for entity, mind in picked:
        behaviour.act(scene.character_handle(entity), mind, None, scene.dt)
    return batch, outcome() | {"proposed": single}


def _assert_same(batch: dict, single: dict, step: int) -> None:
    for name in (*WRITTEN, "prev"):
        same = np.array_equal(batch[name], single[name], equal_nan=True)
        assert same, (step, name, np.argwhere(batch[name] != single[name])[:4])
    for name in ("goals", "proposed"):
        assert batch.get(name) == single.get(name), (step, name)


def test_grapple_over_arrays_writes_what_the_per_character_grapple_does():
    with brawling()[0] as scene:
        seen = set()
        for step in range(330):
            if step % 3 == 0:
                both = grapples_both_ways(scene)
                if both is not None:
                    _assert_same(*both, step)
                    for memory, _, _ in both[0]["goals"]:
                        seen.add("fighting" if "fighting" in memory else "walking up")
                        seen |= {("blow", memory["blow"] % 3)} if "blow" in memory else set()
            scene.step()
        assert seen >= {"walking up", "fighting", ("blow", 0), ("blow", 1), ("blow", 2)}, seen


def test_a_grapple_at_a_ragdoll_goes_per_character_and_the_others_over_arrays():
    scene, goals = brawling()
    with scene:
        scene.spawn("humanoid", name="g6", position=(24.0, 0.0, 0.0), character=True)
        scene.spawn("humanoid", name="doll", position=(24.0, 0.0, 1.5))  # a ragdoll: no character
        at_doll = scene.entity("g6").grapple("doll", duration=30.0)
        for step in range(120):
            if step % 4 == 0:
                both = grapples_both_ways(scene, left_alone=("g6",))
                if both is not None:
                    _assert_same(*both, step)
            scene.step()
        assert at_doll.status == "active" and "blow" in at_doll.memory, "it closed in and hits the doll"


def test_defend_over_arrays_proposes_and_writes_what_the_per_character_defend_does():
    with brawling()[0] as scene:
        compared = 0
        for step in range(240):
            if step % 3 == 0:
                both = defences_both_ways(scene)
                if both is not None:
                    _assert_same(*both, step)
                    compared += 1
            scene.step()
        assert compared > 20


def test_withdraw_over_arrays_proposes_and_writes_what_the_per_character_withdrawal_does():
    with brawling()[0] as scene:
        staggering = walking_away = 0
        for step in range(300):
            if step % 3 == 0:
                both = withdrawals_both_ways(scene)
                if both is not None:
                    _assert_same(*both, step)
                    for _, retreat in scene.world.get_component(withdraw.Withdrawing):
                        if retreat.until > scene.time:  # backing off, or walking away after
                            staggering += retreat.stagger_until > scene.time
                            walking_away += retreat.stagger_until <= scene.time
            scene.step()
        assert staggering > 3 and walking_away > 10, (staggering, walking_away)


def test_a_brawl_runs_over_arrays_to_the_same_ends_as_the_per_character_fights(monkeypatch):
    # the whole run, through select_behavior: the same trajectory and the same goal ends
    # (done, let go, stalled) as with the per-character forms alone
    from twig_ecs.behavior import Behavior

    def run() -> tuple[str, list]:
        scene, goals = brawling()
        with scene:
            scene.run(5.5)
            return scene.state_hash(), [(g.status, g.reason) for g in goals]

    batch = run()
    with monkeypatch.context() as per_character:
        per_character.setattr(
            grapple.Grapple, "batch", False
        )  # select_behavior calls act a character at a time
        per_character.setattr(fight.Defend, "batch", False)
        per_character.setattr(fight.Defend, "propose_crowd", Behavior.propose_crowd)
        per_character.setattr(withdraw.Withdraw, "batch", False)
        per_character.setattr(withdraw.Withdraw, "propose_crowd", Behavior.propose_crowd)
        per_character.setattr(withdraw, "act_withdrawals", None)
        per_character.setattr(grapple, "act_grapples", None)
        per_character.setattr(fight, "act_defences", None)
        single = run()
    assert batch == single
    assert ("done", "") in batch[1], "a fight ended (its time fought, or the target got away)"


def test_the_walking_up_grapplers_are_steered_in_one_call_not_one_steer_to_each(monkeypatch):
    from twig_ecs.systems.behaviours import approach
    from twig_ecs.systems.control.steer import steer_rows

    def per_character(*args, **kwargs):
        raise AssertionError("steer_to called for one grappler")

    calls = []

    def counted(at, rows, *args):
        calls.append(len(rows.crows))
        return steer_rows(at, rows, *args)

    scene, goals = brawling()
    with scene:
        monkeypatch.setattr(grapple, "steer_to", per_character)
        monkeypatch.setattr(approach, "steer_to", per_character)
        monkeypatch.setattr(approach, "steer_rows", counted)  # (the batch's call: approach.steer_batch)
        scene.run(0.5)
        assert [g.status for g in goals] == ["active"] * len(goals), [g.reason for g in goals]
        assert max(calls) >= 4, "the grapplers walking up were steered together"


def test_a_grapple_at_someone_removed_fails_and_the_other_fights_go_on():
    scene, goals = brawling()
    with scene:
        scene.run(0.2)
        scene.remove("t0")  # the store's rows move: the table of targets is made again
        scene.run(1.5)
        assert goals[0].status == "failed" and "removed" in goals[0].reason
        assert "failed" not in [g.status for g in goals[1:]], [g.reason for g in goals]
        assert "fighting" in goals[2].memory and "blow" in goals[2].memory, "g2 closed in and fights"


def _calls_counted(monkeypatch, module, name: str, sizes_at: int) -> list[int]:
    """Put a counter on ``module.name`` (an array pass); returns the list that gets each call's
    count of characters (the length of its argument ``sizes_at``)."""
    sizes = []
    over_arrays = getattr(module, name)

    def counted(*args):
        sizes.append(len(args[sizes_at]))
        return over_arrays(*args)

    monkeypatch.setattr(module, name, counted)
    return sizes


def _lined_up(count: int) -> Scene:
    """An empty scene with characters p0, p1, ... 3 m apart along x."""
    scene = Scene.load("empty")
    for k in range(count):
        scene.spawn("humanoid", name=f"p{k}", position=(3.0 * k, 0.0, 0.0), character=True)
    return scene


def test_a_fight_or_two_goes_a_character_at_a_time_and_more_over_arrays(monkeypatch):
    # the pass over arrays costs about the same for one grappler as for a hundred (0.4 ms a
    # step): the schoolyard's one or two fights go through the per-character form, which
    # writes the same (the tests above); from ARRAYS_FROM on, the arrays
    sizes = _calls_counted(monkeypatch, grapple, "act_grapples", 3)  # (its goals)
    with _lined_up(2 * grapple.ARRAYS_FROM) as scene:
        first = [scene.entity(f"p{k}").grapple(f"p{k + 1}", duration=30.0) for k in (0, 2)]

        def gap() -> float:
            return abs(scene.entity("p0").position[0] - scene.entity("p1").position[0])

        before = gap()
        scene.run(1.0)
        assert sizes == [] and all(goal.status == "active" for goal in first)
        assert gap() < before - 0.5, "it walked up to its target"
        for k in range(4, 2 * grapple.ARRAYS_FROM, 2):
            scene.entity(f"p{k}").grapple(f"p{k + 1}", duration=30.0)
        scene.run(0.2)
        assert sizes and set(sizes) == {grapple.ARRAYS_FROM}


def test_a_lone_defender_squares_up_a_character_at_a_time_and_two_over_arrays(monkeypatch):
    # as the grapple: for one defender the arrays cost twice the per-character form
    sizes = _calls_counted(monkeypatch, fight, "act_defences", 4)  # (its entities)
    with _lined_up(4) as scene:
        scene.entity("p0").grapple("p1", duration=30.0)
        scene.run(1.5)
        assert sizes == [] and scene.entity("p1").behaviour == "defend", "the one attacked squares up"
        scene.entity("p2").grapple("p3", duration=30.0)
        scene.run(1.5)
        assert sizes and max(sizes) == fight.ARRAYS_FROM
