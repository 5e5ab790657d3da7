"""The autonomous schoolyard (SPEC 5): the safe-home-base cycle and play, from a fixed seed."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from twig_ecs.report import run_with_report


@pytest.fixture(scope="module")
def story(tmp_path_factory):
    """Ninety seconds of the schoolyard, with its report and per-step trace."""
    folder = tmp_path_factory.mktemp("yard")
    trace = folder / "trace.csv"
    plot = folder / "plot.png"
    report = run_with_report("schoolyard", 90.0, seed=0, trace=trace, plot=plot)
    with open(trace) as f:
        everyone = list(csv.DictReader(f))
    rows = [r for r in everyone if r["character"] == "small_child"]
    return report, rows, plot, everyone


def test_the_small_child_leaves_looks_back_returns_and_hugs(story):
    report, _, _, _ = story
    small = report["characters"]["small_child"]
    assert small["max_distance_from_caregiver"] > 5.0, "it wanders off beyond several metres"
    assert small["look_backs"] >= 2
    assert small["hugs"] >= 1
    assert small["time_per_behaviour"]["play"] > 20.0
    assert report["nan"] is False


def test_anxiety_rises_with_distance_and_falls_after_a_hug(story):
    _, rows, _, _ = story
    anxiety = np.array([float(r["anxiety"]) for r in rows])
    distance = np.array([float(r["caregiver_distance"]) for r in rows])
    behaviour = [r["behaviour"] for r in rows]
    far = distance > 4.0
    assert far.any()
    # while far away anxiety climbs (until it tops out at 1); near the parent it fades
    climbing = far[:-1] & (anxiety[:-1] < 0.999)
    assert np.mean(np.diff(anxiety)[climbing] > 0) > 0.95
    near = distance[:-1] < 1.5
    assert np.mean(np.diff(anxiety)[near & (anxiety[:-1] > 0)] < 0) > 0.95
    # the step a hug ends, anxiety is (close to) gone
    ends = [k for k in range(1, len(rows)) if behaviour[k - 1] == "hug" and behaviour[k] != "hug"]
    assert ends
    before_hug = anxiety[
        [k for k in range(1, len(rows)) if behaviour[k] == "hug" and behaviour[k - 1] != "hug"]
    ]
    assert before_hug.max() > 0.7
    # a hug that reached the parent leaves the child soothed
    reached = [k for k in ends if distance[k] < 1.5]
    assert reached and all(anxiety[k] < 0.2 for k in reached)


def test_children_play_ball_spin_the_merry_go_round_and_the_doll_is_carried(story, tmp_path):
    report, _, plot, _ = story
    kids = report["characters"]
    assert kids["small_child"]["ball_touches"] + kids["big_child"]["ball_touches"] >= 10
    assert report["merry_go_round_peak_rad_s"] > 0.5, "a child spun it"
    assert kids["small_child"]["held_fraction"]["ragdoll"] > 0.9
    assert kids["parent"]["time_per_behaviour"]["watch"] > 80.0
    assert plot.stat().st_size > 10_000


def test_a_feisty_child_picks_a_fight_and_the_small_one_flinches_away(tmp_path, scenes):
    from twig_ecs import Scene

    yard = tmp_path / "fight.yaml"
    yard.write_text(
        "twig: 1\nentities:\n"
        "  - name: big_child\n    body: humanoid\n    height: 1.35\n    character: true\n"
        "    behaviors: [{use: fight, rival: small_child, temper: 5.0, reach: 3.0}]\n"
        "  - name: small_child\n    body: humanoid\n    height: 1.05\n    position: [0, 0, 2]\n"
        "    facing: 180\n    pain: {threshold: 1.5}\n    character: true\n"
    )
    scene = Scene.load(yard, seed=0)
    scenes.append(scene)
    changes = []
    scene.on("behavior.changed", lambda e: changes.append((scene.time, scene.name_of(e.character), e.new)))
    scene.run(8.0)
    fights = [t for t, who, new in changes if who == "big_child" and new == "grapple"]
    flinches = [t for t, who, new in changes if who == "small_child" and new == "withdraw"]
    assert fights, "the fight behaviour starts a grapple when the rival is near"
    assert flinches and flinches[0] > fights[0], "the blows hurt and the small child flinches away"
