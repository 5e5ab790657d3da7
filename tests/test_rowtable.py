"""A behaviour's state table (twig_ecs/rowtable.py): rows made once per goal, dropped when the
goal goes, made again when the store's rows move, packed into arrays only when the set changes;
the approach behaviour keeps its goals in one, for the batch and the per-character path alike."""

from __future__ import annotations

import pickle

import numpy as np

from twig_ecs import Scene, worlddata
from twig_ecs.rowtable import Column, RowTable


def table() -> RowTable:
    return RowTable(
        partner=Column(np.int64),
        aim=Column(np.float64, (3,)),
        links=Column(np.int64, ragged=True),
        clock=Column(np.float64, saved=True),
    )


def maker(made: list):
    """A ``make`` that records the keys it was asked for."""

    def make(i: int, key: int) -> dict | None:
        made.append(key)
        if key < 0:
            return None  # a key it cannot row (its target is gone)
        return {"partner": key * 10, "aim": (key, 0.0, -key), "links": list(range(key)), "clock": 0.0}

    return make


def test_rows_are_made_once_and_packed_in_key_order():
    rows, made = table(), []
    assert rows.sync([3, 1, 2], "v1", maker(made))
    assert made == [3, 1, 2]
    assert rows["partner"].tolist() == [30, 10, 20]
    assert rows["aim"].shape == (3, 3) and rows["aim"][1].tolist() == [1.0, 0.0, -1.0]
    assert rows["links"].tolist() == [0, 1, 2, 0, 0, 1]
    assert rows["links_start"].tolist() == [0, 3, 4] and rows["links_count"].tolist() == [3, 1, 2]
    assert not rows.sync([3, 1, 2], "v1", maker(made)), "the same keys: nothing packed again"
    assert rows.sync([2, 3], "v1", maker(made))
    assert made == [3, 1, 2], "the rows kept were not made again"
    assert rows["partner"].tolist() == [20, 30] and 1 not in rows


def test_a_kernel_s_writes_survive_a_repacking_and_a_layout_change_keeps_saved_columns():
    rows, made = table(), []
    rows.sync([1, 2], "v1", maker(made))
    rows["clock"][:] = (5.0, 6.0)  # what a kernel writes into the packed arrays
    rows["partner"][0] = 99
    rows.sync([2, 1, 4], "v1", maker(made))
    assert rows["clock"].tolist() == [6.0, 5.0, 0.0] and rows["partner"][1] == 99
    rows.sync([2, 1, 4], "v2", maker(made))  # the store's rows moved: every row made again
    assert made == [1, 2, 4, 2, 1, 4]
    assert rows["partner"][1] == 10, "a cached column is made again"
    assert rows["clock"].tolist() == [6.0, 5.0, 0.0], "a saved column is state: it stays"


def test_a_key_that_cannot_be_rowed_is_left_out_and_forget_drops_a_row():
    rows, made = table(), []
    rows.sync([1, -1, 2], "v1", maker(made))
    assert rows.keys == (1, 2) and rows.positions.tolist() == [0, 2] and rows.missing == (1,)
    rows.forget(2)
    assert 2 not in rows
    assert rows.sync([1, -1, 2], "v1", maker(made)), "a forgotten row packs again"
    assert made == [1, -1, 2, -1, 2], "(a refused key is asked again whenever it packs)"


def test_a_snapshot_keeps_only_the_saved_columns():
    """Through the snapshot codec (which sets attributes, calling no ``__init__``) and pickle."""
    rows, made = table(), []
    rows.sync([1, 2], "v1", maker(made))
    rows["clock"][:] = (5.0, 6.0)
    structure, blob, _ = worlddata.encode(rows, worlddata.Schema())
    for copy in (worlddata.decode(structure, blob, worlddata.Schema()), pickle.loads(pickle.dumps(rows))):
        assert copy.row(1) == {"clock": 5.0}, "only what is saved"
        assert copy.sync([1, 2], "v1", maker(made)), "restored: every row made again ..."
        assert copy["clock"].tolist() == [5.0, 6.0] and copy["partner"].tolist() == [10, 20], "... saved kept"


def test_approach_keeps_one_row_per_goal_in_its_table():
    """A tiny world: two walkers approaching a post; a goal that ends leaves the table."""
    with Scene.load("empty") as scene:
        a = scene.spawn("humanoid", name="a", position=(0.0, 0.0, 0.0), character=True)
        b = scene.spawn("humanoid", name="b", position=(2.0, 0.0, 0.0), character=True)
        scene.spawn("post", name="post", position=(1.0, 0.0, 4.0))
        scene.run(0.2)
        near, far = a.approach("post", stop_distance=3.9), b.approach("post", stop_distance=0.5)
        scene.step(2)
        rows = scene.behaviors["approach"].scratch["goals"]
        assert set(rows.keys) == {near.id, far.id}
        assert rows.row(far.id)["stop"] == 0.5 and rows.row(far.id)["target"][0] == 1  # a body's centre
        for _ in range(120):
            scene.step()
            if near.finished:
                break
        assert near.status == "done"
        scene.step()
        assert rows.keys == (far.id,), "the ended goal's row is gone"
        assert np.isfinite(rows["best"][0]) and far.memory["best"] == rows["best"][0]


def test_a_crowd_restored_mid_wander_walks_on_to_the_same_targets():
    """Wander keeps each wanderer's target and stall clock in its table (not in store columns
    of its own): a snapshot holds them, and the restored crowd steps on exactly as the original."""
    with Scene.load("crowd", count=6, seed=2) as scene:
        scene.step(90)
        targets = scene.behaviors["wander"].targets
        assert len(targets) >= 4 and (targets["speed"] > 0).all(), "wanderers with targets"
        assert not hasattr(scene.state.characters, "steer_goal")
        with Scene.restore(scene.snapshot()) as copy:
            restored = copy.behaviors["wander"].targets
            assert {key: restored.row(key)["goal"].tolist() for key in targets.keys} == {
                key: targets.row(key)["goal"].tolist() for key in targets.keys
            }
            scene.step(120)
            copy.step(120)
            assert copy.state_hash() == scene.state_hash()
