"""The Python API: content counts, spawning, removal, the schedule, the CLI report."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from twig_ecs import Scene, ScheduleError, System
from twig_ecs.store import LINK_COLLIDE, LINK_VISIBLE


def body_counts(scene: Scene, name: str) -> tuple[int, int, int, int]:
    """(nodes, links, visible links, colliding links) of one body."""
    body = scene.entity(name).body
    flags = scene.state.links.flags[body.link_start : body.link_start + body.link_count]
    return (
        len(body.node_names),
        body.link_count,
        int(np.count_nonzero(flags & LINK_VISIBLE)),
        int(np.count_nonzero(flags & LINK_COLLIDE)),
    )


def test_built_in_bodies_have_the_documented_structure(empty_scene):
    scene = empty_scene
    scene.spawn("humanoid", name="h")
    scene.spawn("merry_go_round", name="m", position=(5, 0, 0))
    scene.spawn("ball", name="b", position=(-3, 0, 0))
    scene.spawn("ragdoll", name="r", position=(0, 0, 3))
    nodes, links, visible, colliding = body_counts(scene, "h")
    assert (nodes, visible, colliding) == (16, 13, 13) and links > visible
    assert body_counts(scene, "m") == (18, 41, 25, 25)
    assert body_counts(scene, "b")[0] == 1
    assert body_counts(scene, "r")[:3] == (16, links, 13)


def test_height_scales_a_humanoid(empty_scene):
    scene = empty_scene
    tall = scene.spawn("humanoid", name="tall", height=1.75)
    small = scene.spawn("humanoid", name="small", height=0.875, position=(3, 0, 0))
    assert small.node("head")[1] == pytest.approx(tall.node("head")[1] / 2)
    assert small.mass == pytest.approx(tall.mass / 8)


def test_facing_turns_the_body_about_the_vertical(empty_scene):
    scene = empty_scene
    body = scene.spawn("humanoid", name="h", facing=90)
    # facing 90 degrees looks along +x, so its left side is towards -z
    assert body.node("l_hip")[2] < body.node("r_hip")[2]
    assert body.node("l_knee")[0] > body.node("l_hip")[0]


def test_removing_a_body_keeps_the_others_intact(empty_scene):
    scene = empty_scene
    for k in range(3):
        scene.spawn("humanoid", name=f"h{k}", position=(2.0 * k, 0, 0))
    scene.run(0.5)
    keep = {n: scene.entity(n).node_positions for n in ("h0", "h2")}
    rest_before = scene.state.links.rest[: scene.state.links.count].copy()
    scene.remove("h1")
    assert scene.entity_names == ["h0", "h2"]
    assert scene.has_entity("h0") and not scene.has_entity("h1") and not scene.has_entity("nobody")
    for name, pos in keep.items():
        np.testing.assert_array_equal(scene.entity(name).node_positions, pos)
    # every remaining link still joins nodes at its rest length
    assert scene.state.links.count == len(rest_before) * 2 // 3
    assert scene.state.link_errors().max() < 0.05
    scene.run(0.5)
    with pytest.raises(KeyError, match="no entity named 'h1'"):
        scene.entity("h1")


def test_scenes_do_not_share_entities(scenes):
    a = Scene.load("schoolyard")
    b = Scene.load("empty")
    scenes += [a, b]
    b.spawn("ball", name="only")
    a.step()
    b.step()
    assert b.entity_names == ["only"]
    assert "only" not in a.entity_names
    assert a.state.nodes.count > b.state.nodes.count == 1


class Recorder(System):
    """Notes the frame at which it runs, to check schedule order."""

    def __init__(self, name: str, log: list) -> None:
        self.name = name
        self.log = log

    def process(self, dt: float) -> None:
        self.log.append(self.name)


def test_user_systems_run_in_the_order_given_by_before_and_after(empty_scene):
    log: list[str] = []
    scene = empty_scene
    scene.add_system(Recorder("late", log), after="posture")
    scene.add_system(Recorder("early", log), before="integrate")
    scene.add_system(Recorder("between", log), after="collide", before="sense")
    scene.step()
    assert log == ["early", "between", "late"]
    names = scene.schedule.names()
    assert names.index("early") < names.index("integrate")
    assert names.index("collide") < names.index("between") < names.index("sense")


def test_a_cycle_or_unknown_stage_in_the_schedule_is_an_error(empty_scene):
    scene = empty_scene
    with pytest.raises(ScheduleError, match="cycle"):
        scene.add_system(Recorder("loop", []), after="sense", before="integrate")
    with pytest.raises(ScheduleError, match="unknown stage 'colide'.*collide"):
        scene.add_system(Recorder("x", []), after="colide")
    scene.step()  # the failed insertions left the schedule as it was
    assert "loop" not in scene.schedule.names()


def test_time_advances_in_fixed_steps(empty_scene):
    empty_scene.run(1.0)
    assert empty_scene.frame == 60
    assert empty_scene.time == pytest.approx(1.0)


def test_twig_run_prints_a_json_report_matching_the_python_api():
    out = subprocess.run(
        [sys.executable, "-m", "twig_ecs", "run", "schoolyard", "--seconds", "2", "--report", "json"],
        capture_output=True,
        text=True,
        check=True,
    )
    report = json.loads(out.stdout)
    for key in ("scene", "seconds", "frames", "step_ms", "max_link_error", "max_penetration_m",
                "min_node_y", "nan", "state_hash", "events"):  # fmt: skip
        assert key in report
    assert report["nan"] is False
    assert report["frames"] == 120
    assert report["step_ms"]["median"] > 0 and report["step_ms"]["p95"] >= report["step_ms"]["median"]
    with Scene.load("schoolyard") as scene:
        scene.run(2.0)
        assert report["state_hash"] == scene.state_hash()


def test_spawn_starts_a_character_doing_its_starting_commands(empty_scene):
    """`character: {walk: ...}` in Scene.spawn does what it does in a scene file (it was ignored)."""
    from twig_ecs.errors import TwigError

    ann = empty_scene.spawn("humanoid", name="ann", character={"walk": [0.0, 0.0, 1.0]})
    empty_scene.run(2.0)
    assert ann.position[2] > 1.0, "it walked off along +z"
    with pytest.raises(TwigError, match="no entity named 'nobody'"):
        empty_scene.spawn("humanoid", name="bob", position=(3, 0, 0), character={"look_at": "nobody"})
    assert "bob" not in empty_scene.entity_names, "no half-made character is left behind"


def test_a_bad_seed_or_an_unwritable_name_from_python_is_refused_with_a_clear_error(empty_scene):
    from twig_ecs.errors import SceneError

    for seed in (-1, 2**64, 1.5, "0", True):
        with pytest.raises(SceneError, match="a seed is a whole number from 0 to"):
            Scene(seed=seed)
    with Scene(seed=np.int64(7)) as scene:
        assert scene.seed == 7
    with pytest.raises(SceneError, match="lone surrogate"):
        empty_scene.spawn("ball", name="\ud800")  # a trace or a snapshot could not write it out


def test_a_balls_position_and_velocity_are_the_mass_weighted_means_bit_for_bit(empty_scene):
    # a one-node body takes a shortcut in plain floats: it must give numpy's figures exactly
    ball = empty_scene.spawn("ball", name="b", position=(0.3, 1.2, -0.4))
    ball.set_velocity((1.7, 0.4, -2.9))
    empty_scene.step(7)
    nodes, rows = empty_scene.state.nodes, ball.body.rows
    m = nodes.mass[rows]
    position = (nodes.pos[rows] * m[:, None]).sum(axis=0) / m.sum()
    velocity = ((nodes.pos[rows] - nodes.prev[rows]) / empty_scene.dt * m[:, None]).sum(axis=0) / m.sum()
    assert ball.position.tolist() == position.tolist()
    assert ball.velocity.tolist() == velocity.tolist()
    assert abs(ball.velocity[2] + 2.9) < 0.05  # (it flies: a figure that could be wrong)
