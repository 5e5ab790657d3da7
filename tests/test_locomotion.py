"""Believable locomotion (issue 14), measured through the public API with the walk lab's helpers."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene, walklab
from twig_ecs.events import Pain
from twig_ecs.systems.control.gait import HEEL_RISE
from twig_ecs.torso import TorsoRecorder

#: Frames (1/60 s) a child's torso may spend beyond 35 degrees in five minutes of the schoolyard,
#: and the most it may tip. Seed 0 now, on session 12's machine: none (28 and 32 degrees at most;
#: seeds 0-7 none, 32 at most). Other machines compile the kernels for their own CPU, and the
#: chaotic story amplifies the last bit, so a few frames' slack: before the righting reflex seeds
#: 0-7 had 79 frames (66 degrees at most), session 7's main 10 and 61 frames on seed 0 alone
FOLD_FRAMES = 5
#: The parent's largest torso pitch in five minutes of the yard (degrees): a stoop to hug the small
#: child (15-19 on seeds 0-3 since the hug aims at the partner's height), never a fold.
PARENT_STOOP = 25.0
MOST_PITCH = 40.0


def test_walk_lab_measures_a_straight_walk_through_the_public_api():
    w = walklab.measure_walk(1.75, 1.2, settle=1.5, seconds=3.0)
    assert 1.0 <= w["speed"] <= 1.4, "the walker keeps about the pace it was asked for"
    assert w["cadence"] > 1.0 and w["step"] > 0.2, "touchdowns alternate and move it on"
    assert 0.0 <= w["double"] <= 1.0 and w["lift"] > 0.0
    assert w["froude"] == pytest.approx(1.2**2 / (9.81 * w["legs"]))


def test_standing_characters_keep_their_feet_planted_while_using_arms_and_eyes():
    moves = walklab.measure_idle(seconds=10.0)
    assert set(moves) == set(walklab.IDLE)
    for name, n in moves.items():
        assert n <= 2, f"{name} re-stepped {n} times in 10 s (before: 26-43)"


def test_lab_helpers_measure_a_known_track():
    # a foot planted for 10 steps then lifted for 10, twice: 2 lifts, cadence from touchdowns
    locked = np.array(([True] * 10 + [False] * 10) * 2 + [True] * 5)
    both = np.stack([locked, np.roll(locked, 10)], axis=1)
    pos = {name: np.zeros((len(locked), 3)) for name in walklab.TRACKED}
    track = walklab.Track(0.1, pos, both, stand_height=1.0, radius=0.05)
    assert walklab.foot_moves(track) == 4
    downs = walklab.touchdowns(track)
    assert [k for k, f in downs if f == 0] == [20, 40]
    assert walklab.walk_figures(track)["twice"] == 0.0, "the feet take turns"
    track.locked[32:35, 1] = False  # the right foot (down at 30) up and down again before the left lands
    assert walklab.walk_figures(track)["twice"] == 1.0
    straight = walklab.knee_flexion(np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.5, 0.0]), np.zeros(3))
    bent = walklab.knee_flexion(
        np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.5, 0.5]), np.array([0.0, 0.0, 0.0])
    )
    assert straight == pytest.approx(0.0, abs=1e-3) and bent == pytest.approx(90.0)


def test_walklab_report_and_contact_sheet(tmp_path, monkeypatch):
    rows = [dict(height=1.75, asked=1.2, speed=1.2, froude=0.17, cadence=2.0, step=0.6, legs=0.87, knee=20.0,
                 pelvis=1.0, bob=0.04, double=0.2, lift=0.1, ahead=0.2)]  # fmt: skip
    text = walklab.format_report(rows, {1.75: 12.0}, {"pointer": 0})
    assert "1.75" in text and "pointer (points): 0" in text and "1.8-2.0" in text
    sheet = walklab.contact_sheet(tmp_path / "sheet.png", frames=2, size=(64, 64), columns=2)
    from PIL import Image

    image = np.asarray(Image.open(sheet))
    assert image.shape == (64, 128, 3)
    assert image.std() > 5.0, "the frames show something"


@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_planted_feet_do_not_slide_in_a_turn(scenes, speed):
    # along the ground: a trailing foot comes up on its toes before it steps (the heel rise),
    # which moves its node up, not across
    scene = Scene.load("empty")
    scenes.append(scene)
    person = scene.spawn("humanoid", name="p", height=1.35, character=True)
    scene.run(0.5)
    person.walk((0.0, 0.0, speed))
    scene.run(2.0)
    person.walk((1.0, 0.0, -0.2))
    held: dict[str, np.ndarray | None] = {"l_foot": None, "r_foot": None}
    slide = 0.0
    for _ in range(180):
        scene.step()
        for foot in held:
            if person.is_locked(foot):
                held[foot] = person.node(foot) if held[foot] is None else held[foot]
                slide = max(slide, float(np.linalg.norm((person.node(foot) - held[foot])[[0, 2]])))
            else:
                held[foot] = None
    assert slide == 0.0


# -- the walk's figures (issue 14, "Done when"), measured as `twig walklab` does ------------


#: The readers of ``adult_walks`` go to one worker (xdist's loadgroup), which measures the
#: three walks once (a second), not each worker that gets one of them.
ADULT_WALKS = pytest.mark.xdist_group("adult-walks")


@pytest.fixture(scope="module")
def adult_walks():
    return {v: walklab.measure_walk(1.75, v) for v in (0.8, 1.2, 1.6)}


@ADULT_WALKS
def test_an_adult_walks_1_2_m_s_with_a_persons_cadence_step_and_straight_knees(adult_walks):
    w = adult_walks[1.2]
    assert 1.8 <= w["cadence"] <= 2.1, f"{w['cadence']:.2f} steps/s (before issue 14: 3.0)"
    assert 0.60 <= w["step"] <= 0.75, f"{w['step']:.2f} m steps (before issue 14: 0.39)"
    assert w["knee"] <= 20.0, f"median stance knee flexion {w['knee']:.0f} deg (before: 34; issue 14: 64)"
    assert w["pelvis"] >= 0.9, "the pelvis rides at walking height"
    assert 0.1 <= w["double"] <= 0.35, "both feet are down for part of each step"
    assert w["ahead"] > 0.0, "the foot lands ahead of its hip"
    assert 1.0 <= w["speed"] <= 1.4, "it walks at about the pace it was asked for"


@ADULT_WALKS
def test_an_adult_walks_at_a_steady_pace_with_even_steps(adult_walks):
    # before (issue 35): the pelvis surged from 0.82 to 1.43 of its mean pace inside every
    # step, and left and right steps differed by 12% (0.62 / 0.55 m)
    w = adult_walks[1.2]
    assert w["pace_low"] >= 0.8 and w["pace_high"] <= 1.2, (w["pace_low"], w["pace_high"])
    assert w["step_lr"] <= 0.05, f"left and right steps differ by {100 * w['step_lr']:.0f}%"


@pytest.mark.parametrize("height", [1.75, 1.2, 1.05])
def test_a_standing_character_holds_its_pelvis_up_on_straight_legs(height):
    stand = walklab.measure_stand(height)
    assert stand["knee"] <= 10.0, f"knees bent {stand['knee']:.0f} deg standing still (before: 38-40)"
    assert stand["pelvis"] >= 0.98 and stand["moves"] == 0, stand


@ADULT_WALKS
def test_slower_and_faster_adult_walks_scale_in_proportion(adult_walks):
    slow, normal, fast = (adult_walks[v] for v in (0.8, 1.2, 1.6))
    assert slow["step"] < normal["step"], "longer steps when walking faster"
    assert fast["step"] >= 0.5, "a brisk walk keeps long steps (a person: ~0.8 m at 1.6 m/s; here ~0.55)"
    assert slow["cadence"] < normal["cadence"] < fast["cadence"], "and quicker ones"
    for w in (slow, fast):
        assert 1.3 <= w["cadence"] <= 2.6 and w["knee"] <= 25.0 and w["pelvis"] >= 0.9


def test_children_step_faster_than_adults_but_not_at_a_scurry():
    small = walklab.measure_walk(1.05, 1.0)
    big = walklab.measure_walk(1.35, 1.0)
    adult = walklab.measure_walk(1.75, 1.0)
    assert small["cadence"] <= 3.2, f"1.05 m child at 1.0 m/s: {small['cadence']:.2f} steps/s (before: 5.0)"
    assert small["knee"] <= 22.0, f"1.05 m child's stance knee {small['knee']:.0f} deg (before: 39)"
    assert small["pelvis"] >= 0.9
    assert adult["cadence"] < big["cadence"] < small["cadence"], "cadence goes with sqrt(g / leg length)"
    assert small["step"] < big["step"] < adult["step"]


@pytest.mark.parametrize("height", walklab.SIZES)
def test_a_u_turn_at_1_2_m_s_stays_upright(height):
    assert walklab.measure_uturn(height) <= 30.0


def test_a_torso_thrown_over_in_a_running_turn_is_caught(scenes):
    # a 1.35 m child running 2 m/s told to turn back 135 degrees: its legs swing out from
    # under it in the flight and the torso is thrown forwards (46 degrees without the
    # righting reflex, an arm flung out; 36 with it, upright again 0.2 s later)
    scene = Scene.load("empty")
    scenes.append(scene)
    child = scene.spawn("humanoid", name="c", height=1.35, character=True)
    child.walk((0.0, 0.0, 2.0))
    scene.run(2.0)
    turn = np.radians(-135.0)
    child.walk((2.0 * np.sin(turn), 0.0, 2.0 * np.cos(turn)))
    pitch = []
    for _ in range(120):
        scene.step()
        pitch.append(float(child.torso_pitch))
    worst = int(np.argmax(pitch))
    assert max(pitch) <= 38.0, f"the torso tipped {max(pitch):.0f} degrees"
    assert max(pitch[worst + 12 :]) <= 25.0, "and is upright again within 0.2 s"


def adult_running(scenes, after: float, seconds: float) -> walklab.Track:
    """A 1.75 m adult asked to run at 2.5 m/s, recorded for ``seconds`` from ``after`` s into the run."""
    scene = Scene.load("empty")
    scenes.append(scene)
    adult = scene.spawn("humanoid", name="a", height=1.75, character=True)
    scene.run(0.5)
    adult.walk((0.0, 0.0, 2.5))
    scene.run(after)
    return walklab.record(adult, seconds)


@ADULT_WALKS
def test_an_adult_runs_2_5_m_s_at_a_persons_cadence_with_a_short_flight(scenes, adult_walks):
    # before (issue 35): 1.89 steps/s of 0.9-1.0 m, airborne half the time, and in the first
    # seconds the same foot landed twice in a row
    track = adult_running(scenes, after=1.0, seconds=5.0)
    run = walklab.walk_figures(track)
    assert 2.5 <= run["cadence"] <= 3.1, f"{run['cadence']:.2f} steps/s (before: 1.89)"
    assert 0.15 <= run["flight"] <= 0.40, f"airborne {run['flight']:.2f} of the time (before: 0.50)"
    assert abs(run["pelvis"] - adult_walks[1.2]["pelvis"]) <= 0.05, "the pelvis runs at about walking height"
    assert run["step_lr"] <= 0.1 and 0.8 <= run["step"] <= 1.1, (run["step"], run["step_lr"])
    assert 2.25 <= run["speed"] <= 2.75, "within 10% of the asked pace"
    feet = [f for _, f in walklab.touchdowns(track)]
    assert all(a != b for a, b in zip(feet, feet[1:], strict=False)), f"a foot landed twice in a row: {feet}"


@ADULT_WALKS  # (reads the shared walks: one worker computes them)
def test_a_runner_bends_its_elbows_and_swings_its_arms_against_its_legs(scenes, adult_walks):
    # before (issue 35): a runner's arms hung from the shoulders as a walker's do, kicked on at
    # each step - median elbow flexion 10 and 31 degrees at 2.5 m/s (a person's: ~90)
    track = adult_running(scenes, after=2.0, seconds=3.0)
    elbows = np.median(walklab.elbow_flexion(track), axis=0)
    assert np.all((elbows >= 60.0) & (elbows <= 120.0)), f"elbows bent {elbows.round()} deg (before: 10, 31)"
    assert walklab.arm_phase(track) <= -0.7, "each hand goes forward as its own foot goes back"
    walking = adult_walks[1.2]
    assert walking["elbow"] <= 25.0, f"walking, the arms hang nearly straight ({walking['elbow']:.0f} deg)"
    assert walking["arm_phase"] <= -0.7, "and swing against the legs too"


def test_a_child_running_with_its_doll_keeps_it_held_and_swings_the_other_arm(tmp_path, scenes):
    # the hand that holds the doll keeps its carry pose (elbow ~55 deg); only the free arm
    # takes up the run's bent swing (before: it hung, elbow ~13 deg)
    path = tmp_path / "scene.yaml"
    path.write_text(
        "twig: 1\nentities:\n"
        "  - {name: child, body: humanoid, height: 1.05, position: [0, 0, 0], facing: 0,\n"
        "     character: {hold: doll}}\n"
        "  - {name: doll, body: ragdoll, position: [0.144, 0.227, 0.0], facing: 0}\n"
    )
    scene = Scene.load(path)
    scenes.append(scene)
    child = scene.character_handle(scene.entity("child").entity)
    child.walk((0.0, 0.0, 2.2))
    scene.run(1.0)
    track = walklab.record(child, 2.0)
    held, free = np.median(walklab.elbow_flexion(track), axis=0)
    assert child.holding == {"left": "doll"}, "it still holds the doll"
    assert child.arm_modes == {"left": "carry", "right": "hang"}
    assert 35.0 <= held <= 75.0, f"the doll held up before the belly (elbow {held:.0f} deg)"
    assert 60.0 <= free <= 120.0, f"the free arm bent as a runner's (elbow {free:.0f} deg; before: 13)"
    doll = scene.entity("doll").node("spine")
    assert np.linalg.norm(doll - child.node("l_hand")) < 0.05, "the doll is in the hand"


@pytest.mark.parametrize("speed", [2.2, 2.3, 2.4])
def test_an_adult_runs_just_past_the_walk_with_even_steps_not_bounds(speed):
    # before (issue 35): asked 2.2-2.4 m/s the adult bounded - 1.74-1.94 steps/s, airborne about
    # half the time, left and right steps 15-31% apart: a foot that hung a few cm up at the end of
    # its step flew again to the next landing spot, and the other foot stepped again when it landed
    run = walklab.measure_walk(1.75, speed)
    assert 2.4 <= run["cadence"] <= 3.1, f"{run['cadence']:.2f} steps/s (before: 1.74-1.94)"
    assert run["step_lr"] <= 0.10, (
        f"left and right steps differ by {100 * run['step_lr']:.0f}% (before: 15-31)"
    )
    assert run["twice"] == 0, "the feet take turns"
    assert run["double"] == 0.0 and run["flight"] > 0.1, "a run: never both feet down, a flight every step"


@pytest.mark.parametrize(
    ("height", "speeds"),
    [(1.75, (0.8, 1.2, 1.6, 2.0, 2.2, 2.5, 2.8, 3.0)), (1.05, (0.8, 1.2, 1.6, 1.8, 2.0, 2.2))],
)
def test_every_size_reaches_the_pace_it_is_asked_for_walking_and_running(height, speeds):
    # before (issue 35): the adult asked 2.8 and 3.0 m/s reached 2.50 and 2.58 (its step held near
    # 1.0 m by the leg's reach while the cadence stayed at 2.6), the 1.05 m child asked 2.2 1.97;
    # now past the longest step the leg reaches the cadence goes up instead
    for speed in speeds:
        got = walklab.measure_walk(height, speed)["speed"]
        assert abs(got / speed - 1.0) <= 0.10, f"{height} m asked {speed} m/s reached {got:.2f}"


def test_past_a_walks_limit_a_child_runs_with_both_feet_off_the_ground_capped_by_its_size(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    child = scene.spawn("humanoid", name="c", height=1.05, character=True)
    scene.run(0.5)
    legs = walklab.leg_length(child)
    child.walk((0.0, 0.0, 2.2))  # Froude ~0.95: a run
    scene.run(2.5)
    run = walklab.walk_figures(walklab.record(child, 3.0))
    assert run["speed"] >= 1.9, "faster than a walk's limit (Froude 0.5: 1.6 m/s at this size)"
    assert 0.1 <= run["flight"] <= 0.6 and run["double"] == 0.0, "a flight phase, never both feet down"
    assert run["cadence"] <= 4.0 and run["step"] >= 1.0 * legs, "long strides, not a scurry"
    assert run["pelvis"] >= 0.9 and run["ahead"] > 0.0, "upright, each foot landing ahead of its hip"
    child.walk((0.0, 0.0, 6.0))  # more than any child can run
    scene.run(2.5)
    track = walklab.record(child, 3.0)
    speed = walklab.walk_figures(track)["speed"]
    assert speed <= 1.1 * (1.5 * 9.81 * legs) ** 0.5, "no faster than the run's limit, Froude 1.5"
    assert np.all(walklab.torso_pitch(track) < 35.0), "and upright"


def test_a_swinging_foot_stays_within_its_legs_reach_in_sharp_turns(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    person = scene.spawn("humanoid", name="p", height=1.35, character=True)
    scene.run(0.5)
    legs = walklab.leg_length(person)
    worst = 0.0
    for k, heading in enumerate([(0.0, 1.2), (1.2, 0.0), (0.0, -1.2), (-1.0, 0.6)] * 2):
        person.walk((heading[0], 0.0, heading[1]))
        for _ in range(40 + 7 * k):
            scene.step()
            for side in "lr":
                reach = np.linalg.norm(person.node(f"{side}_foot") - person.node(f"{side}_hip"))
                worst = max(worst, float(reach) / legs)
    assert worst <= 1.02, f"a foot got {worst:.3f} leg lengths from its hip"


def test_elbows_and_knees_stay_in_a_human_range_in_a_grapple(pair):
    scene = pair
    a, b = scene.entity("a"), scene.entity("b")
    a.grapple("b", duration=4.0)
    elbows, knees = [], []
    for _ in range(7 * 60):
        scene.step()
        for h in (a, b):
            for s in "lr":
                arm = (h.node(f"{s}_shoulder"), h.node(f"{s}_elbow"), h.node(f"{s}_hand"))
                leg = (h.node(f"{s}_hip"), h.node(f"{s}_knee"), h.node(f"{s}_foot"))
                elbows.append(walklab.knee_flexion(*arm))
                knees.append(walklab.knee_flexion(*leg))
    assert max(elbows) <= 150.0, f"an elbow folded {max(elbows):.0f} deg (a person's ~145; before: 164-177)"
    assert max(knees) <= 140.0, f"a knee folded {max(knees):.0f} deg"


# -- the schoolyard's torso line (issue 14): no fold beyond 35 degrees but right after a blow --------


def test_the_torso_figures_count_a_fall_but_not_a_fold_right_after_a_blow(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("humanoid", name="upright", character=True)
    fallen = scene.spawn("humanoid", name="fallen", character=True, position=(3.0, 0.0, 0.0))
    knocked = scene.spawn("humanoid", name="knocked", character=True, position=(-3.0, 0.0, 0.0))
    torso = TorsoRecorder(scene)
    fallen.go_limp()
    knocked.go_limp()
    scene.emit(Pain(knocked.entity, "pelvis-spine", knocked.entity, 50.0, 1.0))
    for _ in range(int(1.8 / scene.dt)):  # inside the window after the blow
        scene.step()
        torso.step()
    report = torso.report()
    assert report["limit_deg"] == 35.0 and report["after_blow_s"] > 0.0
    figures = report["characters"]
    assert figures["upright"]["frames_over"] == 0 and figures["upright"]["max_deg"] < 10.0
    assert figures["fallen"]["frames_over"] > 0 and figures["fallen"]["max_deg"] > 35.0, "a collapse counts"
    assert figures["knocked"]["frames_over"] == 0, "not right after a blow"
    assert figures["knocked"]["frames_over_after_blows"] > 0, "but it is counted apart"


@pytest.mark.soak  # reads the shared five-minute run
def test_five_minutes_in_the_schoolyard_keep_everyone_upright(yard_five_minutes):
    torso = yard_five_minutes.report["torso"]["characters"]
    assert set(torso) == {"parent", "big_child", "small_child"}
    # the parent stoops to hug the 1.05 m child since session 15 (its arms aim at the child's
    # height: 15-19 deg at the hold); it never folds (nothing beyond 35 deg)
    assert torso["parent"]["max_deg"] <= PARENT_STOOP and torso["parent"]["frames_over"] == 0, torso["parent"]
    # before (main bf67a60): 79 deg and 83 frames beyond 35 - it fell twice after a ride,
    # stepping on the deck's rim; and it folded over in a squat run round that rim
    # session 7's main (45de1e8): small child 44 deg and 10 frames beyond 35; big child 77 deg and
    # 61 frames - its feet met the deck's rim bar as it ran round holding a handle that drew it in
    # over the rim, a foot locked in mid-air on its own other leg. Session 8: 37 (4 frames) and 74 (24).
    # Session 10, on its machine (other digits for the same code): 31 (0) and 50 (35) before the
    # hug's lean eased off, 47 (11) and 50 (26) after, 38 (10) and 30 (0) once the rider pushes the
    # merry-go-round off instead of sprinting, 37 (9) and 30 (0) with its run-out after a ride
    # Session 12: 36 (5) and 38 (11) before the righting reflex (systems/control/posture.py), 28 (0) and
    # 32 (0) with it
    for child in ("small_child", "big_child"):
        figures = torso[child]
        assert figures["frames_over"] <= FOLD_FRAMES and figures["max_deg"] <= MOST_PITCH, (child, figures)


@pytest.mark.soak  # five minutes of the schoolyard each
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_five_minutes_in_the_schoolyard_keep_everyone_upright_on_other_seeds(scenes, seed):
    # seed 0 is the shared run above. Session 12, before the righting reflex: small / big child
    # 39 (7) / 20 (0), 36 (2) / 37 (4), 30 (0) / 32 (0); with it 29 (0) / 27 (0), 27 (0) / 30 (0),
    # 29 (0) / 29 (0) - largest pitch in degrees (frames beyond 35)
    scene = Scene.load("schoolyard", seed=seed)
    scenes.append(scene)
    torso = TorsoRecorder(scene)
    for _ in range(int(round(300.0 / scene.dt))):
        scene.step()
        torso.step()
    figures = torso.report()["characters"]
    parent = figures["parent"]
    assert parent["max_deg"] <= PARENT_STOOP and parent["frames_over"] == 0, parent
    for child in ("small_child", "big_child"):
        assert figures[child]["frames_over"] <= FOLD_FRAMES and figures[child]["max_deg"] <= MOST_PITCH, (
            child,
            figures[child],
        )


def _touchdown_heights(child, was: dict[str, bool]) -> list[float]:
    """Heights (m) at which the character's feet were planted this frame (``was``: planted
    last frame, updated)."""
    out = []
    for foot in ("l_foot", "r_foot"):
        now = child.is_locked(foot)
        if now and not was[foot]:
            out.append(float(child.node(foot)[1]))
        was[foot] = now
    return out


@pytest.mark.parametrize("height", [1.05, 1.35])
def test_feet_plant_only_on_the_ground_in_sharp_turns_and_reversals(scenes, height):
    # the shins cross as a child turns back on itself: a shin resting on the other leg
    # once marked its foot as supported, and the foot locked in mid-air. (Once planted, a
    # trailing foot may come up on its toes before it steps: the heel rise, at most
    # HEEL_RISE leg lengths.)
    scene = Scene.load("empty")
    scenes.append(scene)
    child = scene.spawn("humanoid", name="c", height=height, character=True)
    scene.run(0.5)
    legs = walklab.leg_length(child)
    was = {"l_foot": True, "r_foot": True}
    highest, raised, pitch = 0.0, 0.0, 0.0
    for k, heading in enumerate([(0.0, 1.2), (0.0, -1.2), (1.2, 0.0), (-1.0, 0.6), (0.2, -1.2)] * 3):
        child.walk((heading[0], 0.0, heading[1]))
        for _ in range(35 + 5 * (k % 4)):
            scene.step()
            highest = max([highest, *_touchdown_heights(child, was)])
            raised = max([raised, *(float(child.node(f)[1]) for f in was if child.is_locked(f))])
            pitch = max(pitch, float(child.torso_pitch))
    assert highest <= 0.06, f"a foot planted {highest:.2f} m up"
    assert raised <= 0.06 + HEEL_RISE * legs, f"a planted foot came {raised:.2f} m up"
    assert pitch <= 35.0, f"the torso tipped {pitch:.0f} degrees"
