"""Components that say what is true: entities for bodies, state of behaviours on the character."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.components import Body, PainSensor
from twig_ecs.systems.behaviours.withdraw import Withdrawing


def test_a_crowd_has_one_entity_per_body_and_its_nodes_and_links_are_rows_of_that_body(scenes):
    scene = Scene.load("crowd", count=30)
    scenes.append(scene)
    st = scene.state
    assert len(scene.world.entities()) == st.bodies.count == 30  # no entity per node or link
    owned = np.full(st.nodes.count, -1)
    for _, body in scene.world.get_component(Body):
        rows = body.rows
        owned[rows] = body.index
        links = slice(body.link_start, body.link_start + body.link_count)
        assert (st.links.body[links] == body.index).all()
    assert (owned == st.nodes.body[: st.nodes.count]).all(), "every node row belongs to its body's range"


def test_pain_sensor_parameters_live_in_the_store_and_read_back(empty_scene):
    scene = empty_scene
    kid = scene.spawn("humanoid", name="kid", pain={"threshold": 3.0, "half_life": 0.7})
    ball = scene.spawn("ball", name="ball", position=(3.0, 0.2, 0.0))
    sensor = kid.pain_sensor
    assert isinstance(sensor, PainSensor)
    assert (sensor.threshold, sensor.half_life) == (3.0, 0.7)
    assert ball.pain_sensor is None, "the ball's template says pain: false"
    assert scene.world.get_component(PainSensor) == [], "parameters, not a component nobody reads"
    scene.state.bodies.pain_threshold[kid.body.index] = 5.0  # the store is the truth
    assert kid.pain_sensor.threshold == 5.0


@pytest.fixture
def hurt(scenes):
    """A character struck on the head by a fast ball; stepped until the blow lands."""
    scene = Scene.load("empty")
    scenes.append(scene)
    kid = scene.spawn("humanoid", name="kid", character=True, pain={"threshold": 1.0})
    scene.run(0.3)
    ball = scene.spawn("ball", name="ball", position=(0.0, 1.55, 2.5))
    ball.set_velocity((0.0, 0.0, -14.0))
    pains = []
    scene.on("pain", pains.append)
    for _ in range(60):
        scene.step()
        if any(p.body == kid.entity for p in pains):
            break
    assert pains, "the ball should hurt"
    return scene


def test_a_pain_withdrawal_is_a_component_on_the_character_until_it_is_over(hurt):
    scene = hurt
    kid, ball = scene.entity("kid"), scene.entity("ball")
    scene.step()
    retreat = scene.world.try_component(kid.entity, Withdrawing)
    assert retreat is not None and retreat.source == ball.entity
    assert retreat.stagger_until < retreat.until and retreat.until > scene.time
    assert abs(float(np.linalg.norm(retreat.away)) - 1.0) < 1e-9
    assert kid.behaviour == "withdraw"
    last = retreat
    for _ in range(10 * 60):  # (a ball bouncing back for a second blow starts the retreat again)
        scene.step()
        retreat = scene.world.try_component(kid.entity, Withdrawing)
        if retreat is None:
            break
        last = retreat
    assert retreat is None, "an ended retreat is forgotten"
    assert scene.time >= last.until and kid.behaviour != "withdraw"


def test_a_snapshot_mid_withdrawal_restores_the_retreat_and_runs_on_identically(hurt):
    scene = hurt
    scene.step(10)
    copy = Scene.restore(scene.snapshot())
    try:
        kid = scene.entity("kid").entity
        restored = copy.world.component_for_entity(kid, Withdrawing)
        original = scene.world.component_for_entity(kid, Withdrawing)
        assert (restored.until, restored.source) == (original.until, original.source)
        scene.run(1.0)
        copy.run(1.0)
        assert copy.state_hash() == scene.state_hash()
    finally:
        copy.close()


def test_removing_a_character_mid_withdrawal_takes_its_retreat_with_it(hurt):
    scene = hurt
    scene.step()
    scene.remove("kid")
    scene.step(5)
    assert scene.world.get_component(Withdrawing) == []


def test_hands_gliding_round_in_a_hug_are_state_that_ends_with_the_hug(pair):
    scene = pair
    a, b = scene.entity("a"), scene.entity("b")
    goal = a.hug("b", duration=1.0)
    seen = set()
    for _ in range(15 * 60):
        scene.step()
        aims = scene.state.characters.hand_aim[a.character.index]  # (after each step: the table may grow)
        seen |= {hand for h, hand in enumerate(("left", "right")) if np.isfinite(aims[h]).all()}
        if goal.finished:
            break
    assert goal.status == "done", goal.reason
    assert seen == {"left", "right"}, "both hands glided round while it hugged"
    scene.step(30)
    aims = scene.state.characters.hand_aim
    assert np.isnan(aims[a.character.index]).all(), "the hug is over: its hands are lowered"
    assert np.isnan(aims[b.character.index]).all(), "and so is the embrace that answered it"
