"""Selection over arrays (issue 36): ``select_behavior`` picks the winners of the proposals
made as lists (``Behavior.propose_all``: a goal behaviour's fixed activation, the embrace's)
in one numpy pass, and gives the same winners, switches, ``last`` proposals, batches and
trajectories as the per-character loop over each mind's dict."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.behavior import Behavior
from twig_ecs.bench import cases
from twig_ecs.components import Character
from twig_ecs.mind import GOAL_ACTIVATION, Mind
from twig_ecs.systems.behaviours.embrace import EMBRACE
from twig_ecs.systems.control.select_behavior import IDLE, MIN_DWELL, STICKINESS, URGENT, SelectBehaviorSystem
from twig_ecs.systems.control.selection import choose_winners


def loop_winner(proposals: dict[str, float], was: str, since: float, now: float) -> str:
    """The per-character rule, as select_behavior's loop has it."""
    proposals = dict(proposals)
    proposals.setdefault("idle", IDLE)
    best = max(proposals, key=proposals.__getitem__)
    if best != was and was in proposals:
        held = now - since < MIN_DWELL
        margin = proposals[best] - (proposals[was] + STICKINESS)
        if margin <= 0.0 or (held and margin < URGENT):
            best = was
    return best


def test_the_compiled_pass_picks_the_winner_the_per_character_rule_picks():
    """Random proposals with ties, bonuses just over and under STICKINESS and URGENT, winners
    held and not: every character's winner is the loop's; it goes through the loop where it
    switched or its winner acts alone; its listed proposals as bits of their codes."""
    rng = np.random.default_rng(7)
    names = ["a", "b", "c", "idle"]
    n = 4000
    levels = np.array([IDLE, 0.5, 0.5 + STICKINESS, 0.5 + 1.01 * STICKINESS, 0.5 + STICKINESS + URGENT, 0.9])
    values = np.where(rng.random((n, 4)) < 0.5, rng.choice(levels, (n, 4)), -np.inf)
    values[:, -1] = IDLE
    was = rng.integers(0, 4, n)
    since = rng.choice([0.0, 0.9, 1.0 - MIN_DWELL, 0.95], n)
    now = 1.0
    codes = np.array([2, 0, 1, 3])  # columns "c", "a", "b", idle by code
    batch = np.array([False, True, True, True])  # by code: "a" acts alone
    got, alone, keys = np.empty(n, np.int64), np.empty(n, np.bool_), np.empty(n, np.int64)
    choose_winners(values, codes, codes[was], since, now, batch, got, alone, keys)
    column_names = ["c", "a", "b", "idle"]
    for k in range(n):
        proposals = {column_names[c]: float(values[k, c]) for c in range(3) if values[k, c] != -np.inf}
        winner = loop_winner(proposals, column_names[was[k]], float(since[k]), now)
        assert names[got[k]] == winner, k
        assert alone[k] == (winner != column_names[was[k]] or winner == "a"), k
        assert keys[k] == sum(1 << int(codes[c]) for c in range(3) if values[k, c] != -np.inf), k


class Tied(Behavior):
    """Proposes, per character, ``value`` for the characters named in ``names`` (a tie with
    another behaviour, which the order they proposed in settles), and acts by standing still."""

    name = "tied"
    names: tuple[str, ...] = ()
    value = EMBRACE

    def activation(self, character, mind, goal) -> float:
        return self.value if character.name in self.names else 0.0

    def act(self, character, mind, goal, dt: float) -> None:
        character.stop()


class TiedEarly(Tied):
    """:class:`Tied` proposing over arrays (``propose_crowd``), scheduled before the embrace (it
    proposes first): ``value`` for ``names``, and for every other character a low activation
    that differs from one to the next (under the embrace's and the hug's: they carry on)."""

    name = "tied_early"

    def propose_crowd(self, crowd) -> np.ndarray:
        names = [self.scene.name_of(entity) for entity in crowd.entities]
        return np.array([self.value if name in self.names else 0.3 + 0.01 * (len(name) + k % 5)
                         for k, name in enumerate(names)])  # fmt: skip


class TiedLate(Tied):
    """:class:`Tied` under another name."""

    name = "tied_late"


class TiedFirst(Tied):
    """:class:`Tied` under another name (scheduled before the embrace)."""

    name = "tied_first"


def hugging_scene(over_arrays: bool, monkeypatch) -> tuple[Scene, list]:
    """Twelve characters in pairs: hugs short and long, a scripted partner (it does not embrace),
    plug-in behaviours proposing per character, tied with the embrace and a hug, proposing
    before and after them, and a goal given later. Returns the scene and its event log."""
    monkeypatch.setattr(Behavior, "propose_over_arrays", over_arrays)
    scene, pairs = cases._grid_of_pairs(12, seed=5)
    # (after select_behavior: it proposes for the next step, before all the others)
    scene.add_system(Tied(), after="hug").names = ("b1", "a3")
    scene.add_system(TiedFirst(), before="embrace").names = ("b1",)  # tied with the embrace, which it beats
    early = scene.add_system(TiedEarly(), before="embrace")
    early.names = ("b0", "b3", "a1")  # before it: it wins b0's and b3's ties (a1: tied with its hug)
    late = scene.add_system(TiedLate(), after="hug")
    late.names, late.value = ("a2",), GOAL_ACTIVATION  # a tie with a2's hug, which wins
    for k, (a, b) in enumerate(pairs):
        if k < 4:
            a.hug(b.name, duration=0.5 + 0.5 * k)
    pairs[2][1].autonomous = False
    walker = pairs[5][0]  # two walks one after the other: the second starts while approach wins
    x, _, z = walker.position
    walker.approach((float(x) + 0.6, 0.0, float(z)))
    walker.approach((float(x) + 0.6, 0.0, float(z) + 0.6))
    events: list = []
    for kind in ("behavior.changed", "goal.done", "goal.failed"):
        scene.on(kind, lambda e, events=events: events.append((scene.frame, e)))
    return scene, events


def minds_of(scene: Scene) -> list:
    """Each character's winner, since, switches, last proposals (in their order) and its
    goal's status and start."""
    return [(e, mind.winner, mind.since, mind.switches, list(mind.last.items()), len(mind.activations),
             mind.goal and (mind.goal.status, mind.goal.started))
            for e, (_, mind) in scene.world.get_components(Character, Mind)]  # fmt: skip


def test_a_hugging_scene_selects_the_same_over_arrays_as_per_character(scenes, monkeypatch):
    """Every step: the same winners, switch times, switch counts, `last` proposals in the same
    order and the same events; and the same trajectory (state hash)."""
    runs = []
    for over_arrays in (False, True):
        scene, events = hugging_scene(over_arrays, monkeypatch)
        scenes.append(scene)
        seen = []
        for step in range(240):
            if step == 30:  # a goal given mid-run: pending, then active
                scene.character_handle(scene.entity_id("a4")).hug("b4", duration=0.5)
            scene.step()
            seen.append(minds_of(scene))
        runs.append((seen, events, scene.state_hash()))
    (loop, loop_events, loop_hash), (arrays, array_events, array_hash) = runs
    assert any(len(dict(last)) > 2 for step in loop for *_, last, _, _ in step), "some mixed proposals"
    for step, (a, b) in enumerate(zip(loop, arrays, strict=True)):
        assert a == b, step
    assert [(f, repr(e)) for f, e in loop_events] == [(f, repr(e)) for f, e in array_events]
    won = {"hug", "embrace", "tied_first", "tied_early", "step_back"}
    assert {e.new for _, e in loop_events if hasattr(e, "new")} >= won
    assert sum(e.kind == "goal.done" and e.behavior == "approach" for _, e in loop_events) == 2
    assert any(e.kind == "goal.done" and e.behavior == "hug" for _, e in loop_events), "hugs that end"
    assert loop_hash == array_hash


#: The bench's crowds by case name.
BUILD = {"hug": cases.hugging_pairs, "brawl": cases.brawl, "crowd": cases.crowd,
         "approach": cases.approach_crowd}  # fmt: skip


@pytest.mark.parametrize("case", list(BUILD))
def test_bench_crowds_run_the_same_over_arrays(scenes, monkeypatch, case):
    """The bench's hugging pairs, brawl, wandering crowd and approach crowd at 40: the same
    trajectory and minds both ways."""
    hashes = []
    for over_arrays in (False, True):
        monkeypatch.setattr(Behavior, "propose_over_arrays", over_arrays)
        scene = BUILD[case](40)
        scenes.append(scene)
        scene.step(150)
        hashes.append((scene.state_hash(), minds_of(scene)))
    assert hashes[0] == hashes[1]


def test_the_goal_index_is_kept_across_steps_until_a_goal_is_given_or_ends(scenes):
    """The holders of a goal behaviour are looked up once while no goal is given or ends (not
    once a step), and again as soon as one is."""
    scene, pairs = cases._grid_of_pairs(6, seed=5)
    scenes.append(scene)
    (a0, b0), (a1, b1), (a2, _) = pairs
    a0.hug(b0.name, duration=0.2)
    a1.hug(b1.name, duration=30.0)
    scene.step()
    first = scene.goal_holders_of("hug")
    scene.step(5)
    assert scene.goal_holders_of("hug") is first, "the same list: not looked up again"
    a2.approach((0.0, 0.0, 0.0))
    given = scene.goal_holders_of("hug")
    assert given is not first and given == first
    assert [e for e, _ in scene.goal_holders_of("approach")] == [a2.entity]
    while a0.mind.goal is not None:  # the short hug ends
        scene.step()
    assert [e for e, _ in scene.goal_holders_of("hug")] == [a1.entity]


def test_two_systems_of_one_behaviour_both_count_over_arrays(scenes, monkeypatch):
    """Two systems of one behaviour (the second in the schedule under another name) proposing
    over arrays under the behaviour's one name: both proposals count, as both dict writes did
    (one name twice in a step: selected the per-character way)."""
    runs = []
    for over_arrays in (False, True):
        monkeypatch.setattr(Behavior, "propose_over_arrays", over_arrays)
        scene, pairs = cases._grid_of_pairs(4, seed=5)
        scenes.append(scene)
        scene.add_system(TiedEarly(), before="embrace").names = ("a0", "b0")
        scene.add_system(TiedEarly(), name="tied_early_too", before="embrace").names = ("a1", "b1")
        scene.step(20)
        runs.append(minds_of(scene))
    assert runs[0] == runs[1]
    assert {winner for _, winner, *_ in runs[1]} == {"tied_early"}, "every character wins it"


def test_steps_without_listed_proposals_between_goals_select_the_same(scenes, monkeypatch):
    """A walker's goals with idle steps between (no proposal made as a list: the loop alone
    selects, and its winner goes back to idle): the next goal starts with a switch, both ways."""
    runs = []
    for over_arrays in (False, True):
        monkeypatch.setattr(Behavior, "propose_over_arrays", over_arrays)
        scene, pairs = cases._grid_of_pairs(2, seed=5)
        scenes.append(scene)
        walker = pairs[0][0]
        changes: list = []
        scene.on("behavior.changed", lambda e, s=scene, c=changes: c.append((s.frame, e.old, e.new)))
        seen = []
        x, _, z = walker.position
        for k in range(3):
            walker.approach((float(x) + 0.5 * (k % 2), 0.0, float(z) + 0.5))
            while walker.mind.goal is not None:
                scene.step()
                seen.append(minds_of(scene))
            scene.step(20)  # idle
            seen.append(minds_of(scene))
        runs.append((seen, changes))
    assert runs[0] == runs[1]
    assert [new for _, _, new in runs[1][1]].count("approach") == 3, "each walk starts with a switch"


class Toggled(Behavior):
    """Proposes over arrays while ``on`` (for everyone), nothing otherwise; acts in a batch,
    doing nothing."""

    name = "toggled"
    batch = True
    on = True

    def propose_crowd(self, crowd) -> np.ndarray:
        return np.full(len(crowd.entities), 0.5 if self.on else 0.0)

    def act_batch(self, rows, entities, dt, goals=None) -> None:
        pass


def test_a_behaviour_that_stops_proposing_and_starts_again_switches_both_ways(scenes, monkeypatch):
    """Steps with no proposal made as a list (the loop alone selects) between steps with them:
    the winner goes to idle and back, with a switch each time, both ways."""
    runs = []
    for over_arrays in (False, True):
        monkeypatch.setattr(Behavior, "propose_over_arrays", over_arrays)
        scene = Scene(plugins=[])
        scenes.append(scene)
        toggled = scene.add_system(Toggled())
        scene.add_system(SelectBehaviorSystem())
        scene.spawn("humanoid", name="kid", character=True)
        changes: list = []
        scene.on("behavior.changed", lambda e, s=scene, c=changes: c.append((s.frame, e.old, e.new)))
        for on in (True, False, True, False, True):
            toggled.on = on
            scene.step(30)
        runs.append(changes)
    assert runs[0] == runs[1]
    assert [(old, new) for _, old, new in runs[1]] == [("idle", "toggled"), ("toggled", "idle")] * 2 + [
        ("idle", "toggled")
    ]
