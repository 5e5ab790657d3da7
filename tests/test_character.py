"""Character control through the public API: stand, walk, turn, reach, grab, sit, look, breathe."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import knee_hyperextension

from twig_ecs import Scene, SceneError, TwigError


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees between two vectors."""
    cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


@pytest.fixture
def person(empty_scene):
    """A 1.75 m character standing at the origin, facing +z, settled for half a second."""
    character = empty_scene.spawn("humanoid", name="person", character=True)
    empty_scene.run(0.5)
    return character


def test_standing_a_minute_holds_height_upright_and_in_place(person):
    scene = person.scene
    start = person.position
    lowest = highest = start[1]
    for _ in range(60):
        scene.run(1.0)
        lowest = min(lowest, person.position[1])
        highest = max(highest, person.position[1])
        assert person.node("neck")[1] > person.position[1] + 0.3, "shoulders stay above the pelvis"
    assert lowest >= 0.95 * person.stand_height and highest <= 1.05 * person.stand_height
    drift = np.linalg.norm((person.position - start)[[0, 2]])
    assert drift < 0.05
    assert person.posture == "stand"


def test_walking_keeps_pace_alternates_steps_plants_feet_and_keeps_knees_forward(person):
    scene = person.scene
    person.walk((0.0, 0.0, 1.2))
    scene.run(1.0)  # get going
    start = person.position
    feet = {"l_foot": None, "r_foot": None}
    order, last_steps, slide, hyper, twist = [], person.steps, 0.0, -1.0, 0.0
    for _ in range(600):
        scene.step()
        if person.steps != last_steps:
            order.append(person.last_foot)
            last_steps = person.steps
        for foot in feet:
            if person.is_locked(foot):
                feet[foot] = person.node(foot) if feet[foot] is None else feet[foot]
                # along the ground: a trailing foot comes up on its toes before it steps
                slide = max(slide, float(np.linalg.norm((person.node(foot) - feet[foot])[[0, 2]])))
            else:
                feet[foot] = None
        hyper = max(hyper, knee_hyperextension(person))
        twist = max(twist, angle_between(person.facing, person.shoulder_facing))
    speed = np.linalg.norm((person.position - start)[[0, 2]]) / 10.0
    assert speed == pytest.approx(1.2, abs=0.2)
    assert len(order) >= 15
    assert all(a != b for a, b in zip(order, order[1:], strict=False)), f"steps do not alternate: {order}"
    assert slide < 0.02, "a planted foot slid"
    assert hyper < 0.02, "a knee bent backwards"
    assert twist <= 90.0


def test_turning_ninety_degrees_faces_the_new_way_within_two_seconds(person):
    scene = person.scene
    person.walk((0.0, 0.0, 1.2))
    scene.run(2.0)
    person.walk((1.2, 0.0, 0.0))
    worst_twist = 0.0
    for _ in range(120):
        scene.step()
        worst_twist = max(worst_twist, angle_between(person.facing, person.shoulder_facing))
    assert angle_between(person.facing, np.array([1.0, 0.0, 0.0])) < 15.0
    assert worst_twist <= 90.0


def test_reach_brings_the_hand_to_a_reachable_point_within_a_second(person):
    target = person.node("r_shoulder") + np.array([-0.15, -0.2, 0.45])
    person.reach(tuple(target), hand="right")
    person.scene.run(1.0)
    assert np.linalg.norm(person.node("r_hand") - target) < 0.05


def test_a_grabbed_ball_stays_in_hand_on_a_five_metre_walk_and_falls_when_released(person):
    scene = person.scene
    ball = scene.spawn("ball", name="ball", position=tuple(person.node("r_hand") + [0.0, 0.0, 0.12]))
    ball.lock("centre")  # held up for the grab
    scene.step()
    person.grab("ball", hand="right")
    ball.unlock("centre")
    assert person.holding == {"right": "ball"}
    scene.run(0.5)  # the grip closes
    start = person.position
    person.walk((0.0, 0.0, 1.0))
    worst = 0.0
    while np.linalg.norm((person.position - start)[[0, 2]]) < 5.0:
        scene.step()
        worst = max(worst, float(np.linalg.norm(person.node("r_hand") - ball.node("centre"))))
        assert scene.time < 30, "it should have walked 5 m"
    assert worst < 0.05
    person.stop()
    person.release("right")
    height = ball.node("centre")[1]
    scene.run(1.0)
    assert person.holding == {}
    assert ball.node("centre")[1] < height - 0.5, "released, the ball falls"


def test_grab_out_of_reach_is_refused_with_a_reason(person):
    person.scene.spawn("ball", name="far", position=(3.0, 0.0, 3.0))
    with pytest.raises(TwigError, match=r"'far' is .* m from the right hand .* reach for it first"):
        person.grab("far")


def test_sit_on_a_bench_then_stand_up(person):
    scene = person.scene
    scene.spawn("bench", name="bench", position=(0.0, 0.0, -0.3))
    person.sit(on="bench")
    scene.run(3.0)
    assert person.posture == "sit"
    seat_top = 0.45 + 0.05
    assert seat_top < person.position[1] < seat_top + 0.2, "the pelvis rests on the seat"
    person.stand()
    scene.run(2.0)
    assert person.posture == "stand"
    assert person.position[1] == pytest.approx(person.stand_height, rel=0.05)


def test_sit_on_the_ground_then_stand_up(person):
    person.sit()
    person.scene.run(2.0)
    assert person.position[1] < 0.25
    person.stand()
    person.scene.run(2.0)
    assert person.position[1] == pytest.approx(person.stand_height, rel=0.05)


@pytest.mark.parametrize("where", [(3.0, 1.6, -2.0), (-2.0, 0.3, 2.0), (0.5, 3.0, 1.0)])
def test_the_face_turns_to_a_look_at_target(person, where):
    person.look_at(where)
    person.scene.run(1.5)
    to_target = np.asarray(where) - person.node("head")
    assert angle_between(person.head_direction, to_target) < 20.0
    assert angle_between(person.facing, person.shoulder_facing) <= 90.0


def test_the_face_follows_a_moving_entity(person):
    ball = person.scene.spawn("ball", name="ball", position=(2.0, 0.11, 2.0))
    person.look_at("ball")
    ball.set_velocity((-2.0, 0.0, 0.0))
    person.scene.run(1.0)
    assert angle_between(person.head_direction, ball.node("centre") - person.node("head")) < 20.0


def breathing_rate(person, seconds: float) -> float:
    """Breaths per second, from upward zero crossings of the shoulders' height over the neck."""
    scene = person.scene
    lift = []
    for _ in range(int(seconds * 60)):
        scene.step()
        shoulders = (person.node("l_shoulder")[1] + person.node("r_shoulder")[1]) / 2
        lift.append(shoulders - person.node("neck")[1])
    lift = np.asarray(lift) - np.mean(lift)
    crossings = np.count_nonzero((lift[:-1] < 0) & (lift[1:] >= 0))
    return crossings / seconds


def test_breathing_is_faster_at_a_run_than_at_rest(person):
    at_rest = breathing_rate(person, 12.0)
    person.walk((0.0, 0.0, 2.5))
    person.scene.run(1.0)
    running = breathing_rate(person, 12.0)
    assert 0.1 < at_rest < 0.5
    assert running > at_rest * 2


def test_gestures_wave_above_the_head_and_point_at_a_target(person):
    person.gesture("wave")
    person.scene.run(1.0)
    assert person.node("r_hand")[1] > person.node("head")[1]
    ball = person.scene.spawn("ball", name="ball", position=(-2.0, 0.11, 3.0))
    person.gesture("point", target="ball")
    person.scene.run(1.0)
    arm = person.node("r_hand") - person.node("r_shoulder")
    assert angle_between(arm, ball.node("centre") - person.node("r_shoulder")) < 15.0
    with pytest.raises(TwigError, match="unknown gesture 'wiggle'"):
        person.gesture("wiggle")


def test_bad_commands_raise_clear_errors(person):
    with pytest.raises(TwigError, match="walk speed 50.00 m/s"):
        person.walk((50.0, 0.0))
    with pytest.raises(TwigError, match="must be 3 finite numbers"):
        person.look_at((1.0, float("nan"), 0.0))
    with pytest.raises(TwigError, match="hand must be 'left', 'right' or 'both'"):
        person.reach((0, 1, 1), hand="middle")
    with pytest.raises(TwigError, match="no entity named 'nobody'"):
        person.look_at("nobody")


def test_a_character_scene_starts_its_characters_doing_what_it_says(tmp_path, scenes):
    path = tmp_path / "start.yaml"
    path.write_text(
        "twig: 1\nentities:\n"
        "  - {name: walker, body: humanoid, character: {walk: [0, 1.0], look_at: ball}}\n"
        "  - {name: ball, body: ball, position: [3, 0, 3]}\n"
    )
    scene = Scene.load(path)
    scenes.append(scene)
    scene.run(3.0)
    walker = scene.entity("walker")
    assert walker.position[2] > 2.0
    assert walker.gaze_target is not None


def test_character_starting_commands_are_checked_when_loading(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("twig: 1\nentities:\n  - name: a\n    body: humanoid\n    character: {look_at: bal}\n")
    with pytest.raises(
        SceneError, match=r"bad.yaml:5: entities\[0\].character.look_at: unknown entity 'bal'"
    ):
        Scene.load(path)
    path.write_text("twig: 1\nentities:\n  - {name: b, body: ball, character: true}\n")
    with pytest.raises(SceneError, match="a character needs a body with the humanoid's nodes"):
        Scene.load(path)
