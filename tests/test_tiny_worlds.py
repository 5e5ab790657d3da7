"""Single systems on tiny worlds (issue 32): each test builds a scene with only the systems it
tests - ``Scene(plugins=[])`` and ``add_system`` - a few bodies, and steps it.

Behaviour selection's hysteresis, the fixed-step clock driving a scene, the collision
system's near pairs and contacts on four bodies, and the approach steering field.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from twig_ecs import Scene, Settings
from twig_ecs.behavior import Behavior
from twig_ecs.clock import FixedStepClock
from twig_ecs.kernelmath import approach_field
from twig_ecs.steering import SteeringParams
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.control.select_behavior import MIN_DWELL, STICKINESS, URGENT, SelectBehaviorSystem
from twig_ecs.systems.physics.collide import CollideSystem, near_pairs

# -- selection: the winner keeps the floor (STICKINESS, MIN_DWELL, URGENT) --------------------------


class Proposes(Behavior):
    """A behaviour that proposes, for every character, the activation the test sets."""

    name = "proposes"
    wanted = 0.0

    def activation(self, character, mind, goal) -> float:
        return self.wanted


class Steady(Proposes):
    name = "steady"


class Eager(Proposes):
    name = "eager"


def chooser(scenes) -> tuple[Scene, Steady, Eager, list[tuple[float, str, str]]]:
    """A character with two proposing behaviours and the selection system, nothing else
    (no physics: it stands where it was made). Returns the scene, the two behaviours and
    the list of its winner changes as (time, old, new)."""
    scene = Scene(plugins=[])
    scenes.append(scene)
    steady, eager = scene.add_system(Steady()), scene.add_system(Eager())
    scene.add_system(SelectBehaviorSystem())
    scene.spawn("humanoid", name="kid", character=True)
    changes: list[tuple[float, str, str]] = []
    scene.on("behavior.changed", lambda e: changes.append((scene.time, e.old, e.new)))
    return scene, steady, eager, changes


def winner(scene: Scene) -> str:
    return scene.character_handle(scene.entity_id("kid")).mind.winner


def test_a_winner_keeps_winning_against_a_rival_less_than_its_stickiness_higher(scenes):
    scene, steady, eager, changes = chooser(scenes)
    steady.wanted = 0.5
    scene.run(1.0)
    assert winner(scene) == "steady" and changes == [(0.0, "idle", "steady")]
    eager.wanted = steady.wanted + 0.8 * STICKINESS  # higher, but not by the winner's bonus
    scene.run(2.0)  # long past MIN_DWELL
    assert winner(scene) == "steady" and len(changes) == 1
    eager.wanted = steady.wanted + 1.2 * STICKINESS  # now it beats the bonus: it takes over at once
    at = scene.time
    scene.step()
    assert winner(scene) == "eager" and changes[1:] == [(at, "steady", "eager")]


def test_a_stronger_rival_waits_for_the_winners_dwell_time_but_an_urgent_one_does_not(scenes):
    scene, steady, eager, changes = chooser(scenes)
    steady.wanted = 0.5
    scene.step()
    eager.wanted = steady.wanted + STICKINESS + 0.1  # clearly stronger, not urgent
    while len(changes) < 2 and scene.time < 1.0:
        scene.step()
    took_over = changes[1][0]
    assert changes[1][1:] == ("steady", "eager")
    assert MIN_DWELL <= took_over < MIN_DWELL + 1.5 * scene.dt, "right when the winner's dwell ran out"
    steady.wanted = eager.wanted + STICKINESS + 0.1  # the other way round: it waits again
    scene.run(0.5 * MIN_DWELL)
    assert len(changes) == 2
    steady.wanted = eager.wanted + STICKINESS + URGENT + 0.05  # a reflex: no waiting
    at = scene.time
    scene.step()
    assert changes[2] == (at, "eager", "steady") and at - took_over < MIN_DWELL


def test_near_equal_proposals_that_trade_places_every_frame_switch_once(scenes):
    scene, steady, eager, changes = chooser(scenes)
    for k in range(120):  # two seconds of a jittering tie, each ahead every other frame
        ahead, behind = (steady, eager) if k % 2 == 0 else (eager, steady)
        ahead.wanted, behind.wanted = 0.5 + 0.5 * STICKINESS, 0.5
        scene.step()
    assert changes == [(0.0, "idle", "steady")]


# -- the clock: wall time in, whole steps out ------------------------------------------------------


def test_a_scene_driven_by_the_clock_keeps_its_books_at_half_speed_through_a_stall(scenes):
    """Irregular frames at half speed, and a 3 s stall: the scene advances exactly the steps the
    clock pays; simulated time follows the wall at the scale, less the time the stall dropped."""
    scene = Scene(plugins=[])
    scenes.append(scene)
    clock = FixedStepClock(scene.dt, max_steps=4, max_elapsed=0.25, scale=0.5)
    frames = np.random.default_rng(5).uniform(0.0, 0.05, 400)  # 0-50 ms per drawn frame
    frames[200] = 3.0  # a stall: counts as max_elapsed (0.25 s), of which 4 steps are paid
    for elapsed in frames:
        scene.step(clock.advance(float(elapsed)))
        books = clock.paid * clock.dt + clock.accumulator + clock.dropped
        assert books == pytest.approx(clock.simulated_wall, abs=1e-9)
        assert 0.0 <= clock.accumulator < clock.dt
    assert scene.frame == clock.paid
    wall = float(frames.sum()) - 3.0 + 0.25
    assert clock.wall == pytest.approx(wall)
    assert clock.dropped == pytest.approx(0.125 - 4 * scene.dt, abs=scene.dt), "the stall's catch-up"
    assert scene.time == pytest.approx(0.5 * wall - clock.dropped, abs=scene.dt)


def test_a_paused_scene_moves_only_by_the_single_steps_asked_for(scenes):
    scene = Scene(plugins=[])
    scenes.append(scene)
    clock = FixedStepClock(scene.dt)
    scene.step(clock.advance(0.5))
    assert scene.frame == 8, "a half-second frame counts as 0.25 s (15 steps), paid at most 8"
    clock.single_step()
    clock.single_step()
    for _ in range(30):
        scene.step(clock.advance(0.1))
    assert scene.frame == 10
    clock.paused = False
    clock.reset()  # time spent paused is not owed
    clock.due_now()  # a server resuming: one step at once
    scene.step(clock.advance(0.0))
    assert scene.frame == 11


# -- collide alone, on four bodies -------------------------------------------------------------------


def posts(scenes) -> tuple[Scene, CollideSystem]:
    """Four fixed posts (capsules 0.3 m in radius) and the collision system alone: ``a`` and ``b``
    overlap by 5 cm; ``b`` and ``c`` are 6 cm apart; ``c`` 26 cm and ``d`` 11 cm from ``a``
    diagonally, where the boxes of the broad phase overlap though the capsules are apart. After
    the step that builds the colliders their nodes are let loose (nothing steps them again):
    the broad phase pairs no two bodies whose contact points are all pinned."""
    scene = Scene(plugins=[])
    scenes.append(scene)
    collide = scene.add_system(CollideSystem())
    for name, (x, z) in {"a": (0.0, 0.0), "b": (0.55, 0.0), "c": (0.55, 0.66), "d": (-0.5, -0.5)}.items():
        scene.spawn("post", name=name, position=(x, 0.0, z))
    scene.step()  # builds the colliders; fixed posts do not move
    nodes = scene.state.nodes
    nodes.flags[: nodes.count] ^= nodes.flags[: nodes.count] & NODE_LOCKED  # (the locked bit cleared)
    return scene, collide


def named_pairs(scene: Scene, pairs: np.ndarray) -> list[str]:
    """Collider pairs as the names of the bodies they belong to ("ab")."""
    names = {scene.entity(n).body.index: n for n in scene.entity_names}
    body = scene.state.colliders.body
    return ["".join(sorted(names[int(body[i])] + names[int(body[j])])) for i, j in pairs.tolist()]


def test_the_broad_phase_pairs_overlapping_boxes_and_near_pairs_keep_those_within_the_margin(scenes):
    scene, collide = posts(scenes)
    st = scene.state
    n = collide.broad_phase()
    assert sorted(named_pairs(scene, st.pairs[:n])) == ["ab", "ac", "ad", "bc"], "d is far from b and c"
    col = st.colliders
    for margin, kept in ((0.1, ["ab", "bc"]), (0.01, ["ab"]), (0.2, ["ab", "ad", "bc"]), (0.3, None)):
        near, count = near_pairs(st.nodes.pos, col.a, col.b, col.radius, st.pairs, n, margin)
        expected = kept if kept is not None else named_pairs(scene, st.pairs[:n])
        order = named_pairs(scene, st.pairs[:n])
        assert named_pairs(scene, near[:count]) == [p for p in order if p in expected], margin


def test_collide_alone_pushes_touching_bodies_apart_by_their_masses_and_leaves_the_rest(scenes):
    """No gravity and no integration: only the contact pass moves anything. ``a`` (0.4 kg) and
    ``b`` (1.2 kg) overlap by 4 cm; ``c`` and ``d`` are 5 cm apart."""
    scene = Scene(plugins=[], settings=Settings(gravity=np.zeros(3)))
    scenes.append(scene)
    scene.add_system(CollideSystem())
    masses = {"a": 0.4, "b": 1.2, "c": 0.4, "d": 0.4}
    balls = {name: scene.spawn("ball", name=name, position=(x, 1.0, 0.0), mass=masses[name])
             for name, x in {"a": 0.0, "b": 0.18, "c": 1.0, "d": 1.27}.items()}  # fmt: skip
    before = {name: ball.position.copy() for name, ball in balls.items()}
    scene.step()
    moved = {name: ball.position - before[name] for name, ball in balls.items()}
    assert moved["a"][0] == pytest.approx(-0.03, abs=1e-6) and moved["b"][0] == pytest.approx(0.01, abs=1e-6)
    assert masses["a"] * moved["a"] + masses["b"] * moved["b"] == pytest.approx(np.zeros(3), abs=1e-9)
    assert np.all(moved["c"] == 0.0) and np.all(moved["d"] == 0.0), "a gap is no contact"
    gap = np.linalg.norm(balls["b"].position - balls["a"].position) - 0.22
    assert gap == pytest.approx(0.0, abs=1e-6), "just touching now"
    scene.step(10)
    assert all(np.array_equal(ball.position, before[name] + moved[name]) for name, ball in balls.items())


# -- steering: the approach field -------------------------------------------------------------------

HERE = np.zeros(3)
NO_OBSTACLES = np.zeros((0, 3))


def ground(x: float, z: float) -> np.ndarray:
    return np.array([x, 0.0, z])


def approach_velocity(here: np.ndarray, goal: np.ndarray, obstacles: np.ndarray,
                      params: SteeringParams) -> np.ndarray:  # fmt: skip
    """The field's walk vector (x, 0, z) from ``here`` to ``goal`` round ``obstacles``: the
    compiled field the steering kernel calls for each walker, on its own."""
    p = params
    wx, wz = approach_field(here[0], here[2], goal[0], goal[2], obstacles, len(obstacles), p.speed,
                            p.repulsion, p.cutoff, p.min_sq, p.curl, p.fade)  # fmt: skip
    return np.array([wx, 0.0, wz])


def test_the_approach_field_heads_for_the_goal_at_walking_pace_and_slows_over_the_last_metre():
    params = SteeringParams()
    far = approach_velocity(HERE, ground(3.0, 4.0), NO_OBSTACLES, params)
    assert far == pytest.approx(ground(0.6, 0.8) * params.speed)
    close = approach_velocity(HERE, ground(0.0, 0.4), NO_OBSTACLES, params)
    assert close == pytest.approx(ground(0.0, 0.4 * params.speed))
    assert np.all(approach_velocity(HERE, HERE, NO_OBSTACLES, params) == 0.0), "there: it stands"


def test_an_obstacle_ahead_turns_the_walk_aside_and_one_past_the_cutoff_does_nothing():
    params = SteeringParams()
    goal = ground(0.0, 5.0)
    post = ground(0.0, 0.8).reshape(1, 3)  # straight ahead, in the way
    curled = approach_velocity(HERE, goal, post, params)
    straight = approach_velocity(HERE, goal, post, SteeringParams(curl=False))
    assert straight[0] == pytest.approx(0.0) and straight[2] < 0.5 * params.speed, (
        "without curl it only slows in front of it"
    )
    # with curl it walks round, always to the same side: (p - o) x e_y, here +x
    assert curled[0] > 0.5 * params.speed
    assert math.hypot(curled[0], curled[2]) <= params.speed + 1e-12
    beyond = ground(0.0, -params.cutoff - 0.01).reshape(1, 3)
    assert approach_velocity(HERE, goal, beyond, params) == pytest.approx(ground(0.0, params.speed))


def test_obstacles_fade_out_near_the_goal_so_nobody_is_held_off_it():
    params = SteeringParams()
    behind = ground(0.0, 0.5).reshape(1, 3)  # standing just past a goal 0.5 m ahead
    pushed = approach_velocity(HERE, ground(0.0, 0.5), behind, SteeringParams(fade=1e-9))
    faded = approach_velocity(HERE, ground(0.0, 0.5), behind, params)
    assert pushed[2] < 0.0, "at full strength it would push the walker back off its goal"
    assert faded[2] > 0.0, "faded (to a quarter at half a metre), the goal wins"
