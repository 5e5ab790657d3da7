"""The one steering kernel (systems/control/steer.py): rows of walkers, each to its target round
what is in the way; approach (batch and per character) and wander call it."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.kernelmath import PELVIS
from twig_ecs.systems.behaviours import approach, wander
from twig_ecs.systems.control import steer


@pytest.fixture
def two_walkers():
    """A tiny world: two characters 3 m apart on open ground, and a post in front of the first."""
    with Scene.load("empty") as scene:
        scene.spawn("humanoid", name="a", position=(0.0, 0.0, 0.0), character=True)
        scene.spawn("humanoid", name="b", position=(3.0, 0.0, 0.0), character=True)
        scene.spawn("post", name="post", position=(0.0, 0.0, 1.5))
        scene.run(0.2)
        yield scene


def rows_for(scene: Scene, names: list[str]) -> steer.Walkers:
    ch = scene.state.characters
    rows = [scene.entity(n).character_row for n in names]
    w = steer.walkers(len(rows))
    w.crows[:] = rows
    w.pelvis[:] = ch.nodes[rows, PELVIS]
    w.me[:] = ch.body[rows]
    w.best_at[:] = scene.time
    return w


def test_a_row_walks_at_its_pace_and_one_at_its_target_arrives(two_walkers):
    scene = two_walkers
    w = rows_for(scene, ["a", "b"])
    w.point[0] = (0.0, 0.0, -10.0)  # away from the post: open ground
    w.speed[0] = 0.9
    here = scene.entity("b").position
    w.point[1] = here
    w.arrive[:] = 0.1
    walk = scene.state.characters.walk
    steer.steer_rows(
        steer.around(scene), w, steer.gains(), walk, scene.state.characters.mode, scene.time, scene.dt
    )
    assert w.status.tolist() == [steer.WALKING, steer.ARRIVED]
    a = walk[w.crows[0]]
    assert np.hypot(a[0], a[2]) == pytest.approx(0.9, abs=1e-6) and a[2] < -0.8, (
        "on at its own pace (the post behind it pushes it a little aside)"
    )
    assert not walk[w.crows[1]].any(), "there: it stands"
    assert w.improved[0] and w.best[0] == pytest.approx(w.distance[0])


def test_an_obstacle_bends_the_walk_and_a_stalled_row_is_stuck(two_walkers):
    scene = two_walkers
    ch = scene.state.characters
    walks = []
    for curl in (1, 0):
        w = rows_for(scene, ["a"])
        w.point[0] = (0.0, 0.0, 4.0)  # behind the post
        w.curl[0] = curl
        steer.steer_rows(steer.around(scene), w, steer.gains(), ch.walk, ch.mode, scene.time, scene.dt)
        walks.append(ch.walk[w.crows[0]].copy())
    curled, straight = walks
    assert abs(curled[0]) > abs(straight[0]) + 0.05, "the curl steers it sideways round the post"
    w = rows_for(scene, ["a"])
    w.point[0] = (0.0, 0.0, 4.0)
    w.best[0], w.best_at[0], w.stall[0] = 3.0, scene.time - 5.0, 4.0  # no headway for 5 s
    steer.steer_rows(steer.around(scene), w, steer.gains(), ch.walk, ch.mode, scene.time, scene.dt)
    assert w.status[0] == steer.STUCK and not ch.walk[w.crows[0]].any()


def test_approach_and_wander_steer_with_the_one_kernel():
    assert approach.steer_rows is steer.steer_rows and wander.steer_rows is steer.steer_rows
    assert not hasattr(approach, "steer_goals") and not hasattr(wander, "steer_crowd")


def test_play_and_ride_steer_with_the_one_kernel():
    """Steering is written once: play and ride walk with approach's one-row batch of the kernel,
    and the Python copy of the field they used is gone."""
    from twig_ecs import steering
    from twig_ecs.systems.behaviours import play, ride

    assert play.walk_towards is approach.walk_towards and ride.walk_towards is approach.walk_towards
    assert not hasattr(steering, "approach_velocity")
    assert not hasattr(play, "approach_velocity") and not hasattr(ride, "approach_velocity")


def test_walk_towards_goes_at_its_pace_round_the_post_and_never_arrives(two_walkers):
    """``walk_towards``: the field at the pace asked, bent by the post in the way unless the post
    is excluded (or beyond the cut-off), and no arrival of its own: at the point the field is nil."""
    scene = two_walkers
    a = scene.entity("a")
    behind_post = np.array([0.0, 0.0, 4.0])
    bent = approach.walk_towards(a, behind_post, 1.1)
    straight = approach.walk_towards(a, behind_post, 1.1, exclude=("post",))
    short = approach.walk_towards(a, behind_post, 1.1, cutoff=0.5)  # the post 1.5 m off: beyond it
    assert np.hypot(straight[0], straight[2]) == pytest.approx(1.1) and abs(straight[0]) < 0.05
    assert abs(bent[0]) > abs(straight[0]) + 0.05, "the curl steers it sideways round the post"
    assert np.array_equal(short, straight)
    here = a.position
    assert not approach.walk_towards(a, here, 1.1).any(), "at the point: no walk"


def test_the_fused_multiply_add_rounds_once_compiled_and_in_plain_python():
    """A wide body's rim is measured with one rounding (what numpy's norm gave play's steering);
    a kernel run in plain Python before it is compiled must measure the same."""
    from numba import njit

    a, c = 1.0 + 2.0**-30, -(1.0 + 2.0**-29)  # a * a = 1 + 2**-29 + 2**-60: the last bit is lost if rounded
    assert a * a + c == 0.0
    assert steer.fused_multiply_add(a, a, c) == 2.0**-60
    assert njit(lambda x, y, z: steer.fused_multiply_add(x, y, z))(a, a, c) == 2.0**-60
