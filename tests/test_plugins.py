"""Scenes built from plugins, single systems on small worlds, and the one fixed-step clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twig_ecs import Scene, System, TwigError
from twig_ecs.behavior import Behavior
from twig_ecs.clock import FixedStepClock
from twig_ecs.plugins import (
    BehavioursPlugin,
    ControlPlugin,
    PhysicsPlugin,
    Plugin,
    SchoolyardMotivesPlugin,
    builtin_behaviors,
    default_plugins,
)
from twig_ecs.schedule import BEHAVIOURS, PIPELINE
from twig_ecs.trust import trusting

GRAVITY = 9.81
NO_DAMPING = {"air": 0.0, "ground": 0.0}


def system_names(scene: Scene) -> list[str]:
    return [system.name for system in scene.schedule.systems()]


# -- plugins ------------------------------------------------------------------------------


def test_a_physics_only_scene_drops_a_ball_as_gravity_says_and_stops_it_on_the_ground(scenes):
    scene = Scene(plugins=[PhysicsPlugin()])
    scenes.append(scene)
    assert system_names(scene) == ["integrate", "constrain", "collide", "sense"]
    ball = scene.spawn("ball", name="ball", position=(0.0, 3.0, 0.0), damping=NO_DAMPING)
    start = ball.position[1]
    scene.run(0.5)
    fallen, n = start - ball.position[1], 30
    assert fallen == pytest.approx(GRAVITY * scene.dt**2 * n * (n + 1) / 2, rel=1e-6)  # Verlet, no drag
    assert fallen == pytest.approx(0.5 * GRAVITY * 0.5**2, rel=0.04)  # y0 - y = g t^2 / 2
    scene.run(3.0)
    nodes = scene.state.nodes
    assert nodes.pos[: nodes.count, 1].min() > -0.01, "the ground holds it"
    assert np.linalg.norm(nodes.pos[: nodes.count] - nodes.prev[: nodes.count], axis=1).max() < 0.05
    assert scene.event_counts["contact"] == 0, "contact events are between bodies, the ground is none"


def test_a_scene_without_behaviour_plugins_has_no_behaviour_stages_and_its_character_stands(scenes):
    scene = Scene(plugins=[PhysicsPlugin(), ControlPlugin()])
    scenes.append(scene)
    assert scene.behaviors == {}
    assert not any(isinstance(system, Behavior) for system in scene.schedule.systems())
    kid = scene.spawn("humanoid", name="kid", character=True)
    head = kid.node("head")[1]
    scene.run(3.0)
    assert kid.node("head")[1] > 0.9 * head, "the controllers alone keep it standing"
    assert kid.behaviour == "idle"


def test_the_default_plugins_are_everything_built_in_in_pipeline_order(scenes):
    scene = Scene()
    scenes.append(scene)
    assert [type(p) for p in scene.plugins] == [type(p) for p in default_plugins()]
    behaviours = [b.name for b in builtin_behaviors()]
    expected = [n for n in PIPELINE[: PIPELINE.index(BEHAVIOURS)] if n != BEHAVIOURS]
    expected += behaviours + [n for n in PIPELINE[PIPELINE.index(BEHAVIOURS) + 1 :] if n != "render"]
    assert system_names(scene) == expected
    assert set(scene.behaviors) == set(behaviours)


def test_behaviours_propose_in_one_order_whichever_plugins_bring_them_in_any_order(scenes):
    forward = Scene(plugins=[PhysicsPlugin(), ControlPlugin(), SchoolyardMotivesPlugin(), BehavioursPlugin()])
    backward = Scene(plugins=[BehavioursPlugin(), SchoolyardMotivesPlugin(), ControlPlugin(),
                              PhysicsPlugin()])  # fmt: skip
    scenes.extend([forward, backward])
    assert system_names(forward) == system_names(backward)
    only_motives = Scene(plugins=[SchoolyardMotivesPlugin()])
    scenes.append(only_motives)
    assert system_names(only_motives) == ["attachment", "fight", "play", "ride", "wander", "watch"]


class Tally(System):
    """Counts its runs and notes which systems ran before it in the same step."""

    name = "tally"

    def setup(self) -> None:
        self.runs = 0

    def process(self, dt: float) -> None:
        self.runs += 1


class TallyPlugin(Plugin):
    """A user plugin: one system, placed by stage name."""

    name = "tally"

    def build(self, scene: Scene) -> None:
        scene.add_system(Tally(), after="collide", before="sense")


def test_a_user_plugin_puts_its_system_where_its_stage_names_say(scenes):
    scene = Scene(plugins=[*default_plugins(), TallyPlugin()])
    scenes.append(scene)
    names = system_names(scene)
    assert names.index("collide") < names.index("tally") < names.index("sense")
    scene.step(5)
    (tally,) = [s for s in scene.schedule.systems() if isinstance(s, Tally)]
    assert tally.runs == 5
    with trusting():  # the plug-in is this test file: a snapshot imports it only when trusted
        restored = Scene.restore(scene.snapshot())  # plugins are part of the world it keeps
    scenes.append(restored)
    assert [type(p) for p in restored.plugins] == [type(p) for p in scene.plugins]
    assert system_names(restored) == names


class Shy(Behavior):
    """A user behaviour: it proposes nothing, it only has to find its place."""

    name = "shy"


def test_a_user_behaviour_proposes_after_the_built_in_ones_and_before_selection(scenes):
    scene = Scene()
    scenes.append(scene)
    scene.add_system(Shy())
    names = system_names(scene)
    assert names.index("withdraw") < names.index("shy") == names.index("select_behavior") - 1
    assert scene.behaviors["shy"].name == "shy"


def test_a_plugin_class_instead_of_an_instance_is_refused_with_the_fix(scenes):
    with pytest.raises(TwigError, match=r"write PhysicsPlugin\(\), not PhysicsPlugin"):
        Scene(plugins=[PhysicsPlugin])


def test_a_scene_file_loads_with_the_plugins_given(scenes):
    scene = Scene.load("schoolyard", plugins=[PhysicsPlugin()])
    scenes.append(scene)
    assert system_names(scene) == ["integrate", "constrain", "collide", "sense"]
    assert "parent" in scene.entity_names
    scene.run(1.0)  # characters with no controllers fall over, which physics alone allows
    assert scene.state.link_errors().max() < 0.05


# -- one step loop -------------------------------------------------------------------------


def test_timing_a_step_never_changes_what_it_computes(scenes):
    plain = Scene.load("schoolyard", seed=3)
    timed = Scene.load("schoolyard", seed=3)
    scenes.extend([plain, timed])
    for scene in (plain, timed):  # a grab let go: the release grace counts down each step
        grab = scene.grab("parent", "r_hand", "small_child", "l_hand")
        scene.step(10)
        scene.release(grab)
    times: dict[str, list[float]] = {}
    plain.step(60)
    for _ in range(60):
        assert timed.step_timed(times) > 0.0
    assert timed.state_hash() == plain.state_hash()
    assert timed.frame == plain.frame
    assert set(times) == set(system_names(timed)) and all(len(t) == 60 for t in times.values())


# -- the clock -----------------------------------------------------------------------------


def test_the_clock_pays_out_whole_steps_and_keeps_the_rest():
    clock = FixedStepClock(dt=0.1, max_steps=8)
    assert clock.advance(0.25) == 2
    assert clock.accumulator == pytest.approx(0.05)
    assert clock.fraction == pytest.approx(0.5)
    assert clock.advance(0.05) == 1
    assert clock.accumulator == pytest.approx(0.0, abs=1e-12)
    assert clock.until_next_step() == pytest.approx(0.1)


def test_the_clock_drops_time_it_cannot_catch_up_with():
    clock = FixedStepClock(dt=0.1, max_steps=3, max_elapsed=None)
    assert clock.advance(2.0) == 3
    assert clock.accumulator == 0.0 and clock.dropped == pytest.approx(1.7)
    capped = FixedStepClock(dt=0.1, max_steps=100, max_elapsed=0.25)
    assert capped.advance(10.0) == 2, "a long gap counts as max_elapsed"


def test_a_paused_clock_pays_nothing_but_the_single_steps_asked_for():
    clock = FixedStepClock(dt=0.1)
    clock.single_step()
    clock.single_step()
    assert clock.paused
    assert clock.advance(5.0) == 2
    assert clock.advance(5.0) == 0
    assert clock.fraction == 1.0 and math.isinf(clock.until_next_step())
    clock.paused = False
    assert clock.advance(0.1) == 1


def test_the_time_scale_slows_the_simulation_against_the_wall_clock():
    half = FixedStepClock(dt=0.1, scale=0.5)
    assert sum(half.advance(0.1) for _ in range(10)) == 5
    assert half.until_next_step() == pytest.approx(0.2)
    with pytest.raises(ValueError, match="time scale"):
        half.scale = -1.0
    with pytest.raises(ValueError, match="dt must be positive"):
        FixedStepClock(dt=0.0)


def test_headless_runs_and_the_scene_count_steps_alike(scenes):
    scene = Scene(plugins=[])
    scenes.append(scene)
    assert FixedStepClock(scene.dt).steps_for(1.0) == 60
    scene.run(1.0)
    assert scene.frame == 60 and system_names(scene) == []
