"""Soak checks: physics health figures over a run, and the first limit crossed, by frame and body."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.knocks import MOST
from twig_ecs.rises import DOWN, SHORTEST, UP
from twig_ecs.soak import Health, SoakLimits


@pytest.mark.soak  # reads the shared five-minute run
def test_five_minutes_of_schoolyard_stay_within_the_soak_limits(yard_five_minutes):
    # `twig run schoolyard --seconds 300 --soak --report json` (with a trace and a plot, which
    # the story tests read), simulated once per session: tests/yard_run.py
    report = yard_five_minutes.report
    assert yard_five_minutes.code == 0
    assert report["frames"] == 18000 and report["violation"] is None and report["nan"] is False
    limits = SoakLimits()
    assert 0.0 < report["max_speed_m_s"] <= limits.max_speed
    assert limits.min_y <= report["min_node_y"] < 0.05
    assert 0.0 < report["max_penetration_m"] <= limits.max_penetration
    assert 0.0 < report["max_link_error"] <= limits.max_link_error
    assert 0.0 < report["max_kinetic_energy_j"] <= limits.max_energy


@pytest.mark.soak  # reads the shared five-minute run
def test_everyone_who_goes_down_in_five_minutes_of_schoolyard_takes_its_time_getting_up(yard_five_minutes):
    # issue 34: every rise from a pelvis below 40% of standing height back above 90% takes at
    # least 0.8 s - through a kneel or at the posture's get-up rate, never a puppet's pop
    rises = yard_five_minutes.report["rises"]
    assert (rises["down_share"], rises["up_share"]) == (DOWN, UP)
    quick = {name: [r for r in figures["rises"] if r["seconds"] < SHORTEST]
             for name, figures in rises["characters"].items()}  # fmt: skip
    assert not any(quick.values()), f"rises quicker than {SHORTEST} s: {quick}"


@pytest.mark.soak  # reads the shared five-minute run
def test_no_child_moves_its_caregiver_half_a_metre_in_five_minutes_of_schoolyard(yard_five_minutes):
    # issue 34: a child's kick or bump moves the parent in proportion to their masses - a few
    # centimetres, never the 2 m a blow from its equal would
    carers = yard_five_minutes.report["knocks"]["caregivers"]
    assert carers["parent"]["touches"] > 0, "the children touched the parent (hugs, bumps)"
    assert carers["parent"]["furthest"]["moved_m"] < MOST, carers


def test_the_soak_stops_at_the_first_limit_crossed_and_names_frame_and_body(capsys):
    code = main(["run", "schoolyard", "--seconds", "20", "--max-link-error", "0.05"])  # implies --soak
    assert code == 1
    out, err = capsys.readouterr()
    assert "soak: max speed" in out
    line = err.strip()
    assert line.startswith("soak failed: frame ")
    assert "max_link_error" in line and "above the limit 0.05" in line
    frame = int(line.split("frame ")[1].split()[0])
    assert 0 < frame < 1200 and f"{frame} frames" in out  # the run stopped there
    # it names the body that crossed first: a character or the carried doll, whichever a
    # shove or a fast hand stretches first (the figure moves with every physics change)
    named = line.rsplit(" at ", 1)[1].strip("'")
    yard = Scene.load("schoolyard")
    try:
        assert named in {"parent", "small_child", "big_child", "ragdoll"} & set(yard.entity_names)
    finally:
        yard.close()


def test_a_node_too_fast_is_pinned_on_its_body(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    ball = scene.spawn("ball", name="cannonball", position=(0, 1, 0))
    ball.set_velocity((20.0, 0.0, 0.0))  # below settings.max_speed, the integrator's clamp
    scene.spawn("ragdoll", name="bystander", position=(3, 0.2, 0))
    health = Health(scene, SoakLimits(max_speed=15.0))
    scene.step()
    violation = health.update()
    assert violation is not None and violation.frame == 1 and violation.figure == "max_speed"
    assert violation.entity == "cannonball" and violation.value == pytest.approx(20.0, rel=0.05)
    scene.step()
    assert health.update() is None and health.violation is violation  # only the first is reported
    assert health.figures()["max_speed_m_s"] >= violation.value


def _overlap_named_after_dropping_two_ragdolls(scene) -> str:
    """Drop one ragdoll into another and return the body pair the soak names for the overlap."""
    scene.spawn("ragdoll", name="bottom", position=(0, 0.3, 0))
    scene.spawn("ragdoll", name="top", position=(0.05, 0.35, 0.0))
    health = Health(scene, SoakLimits(max_penetration=0.0001))  # what one step leaves (< 1 mm)
    scene.step()
    violation = health.update()
    assert violation is not None and violation.figure == "max_penetration"
    return violation.entity


def test_overlapping_bodies_are_named_as_a_pair(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    assert _overlap_named_after_dropping_two_ragdolls(scene) == "bottom / top"


def test_fence_panels_meeting_at_a_post_are_not_named_as_the_overlap(scenes):
    # two panels share a post (they overlap by design and the solver skips such fixed
    # pairs); the overlap to report is the one between the two ragdolls
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("fence", name="fence_a", position=(-5.0, 0.0, 3.0))
    scene.spawn("fence", name="fence_b", position=(0.0, 0.0, 3.0))
    assert _overlap_named_after_dropping_two_ragdolls(scene) == "bottom / top"


def test_nan_is_reported_with_the_body_it_appeared_in(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("ball", name="fine", position=(0, 1, 0))
    sick = scene.spawn("ragdoll", name="sick", position=(2, 0.3, 0))
    health = Health(scene)  # no limits: NaN is always reported
    scene.step()
    assert health.update() is None
    scene.state.nodes.pos[sick.body.node_start + 3] = np.nan
    violation = health.update()
    assert violation is not None and violation.figure == "nan" and violation.entity == "sick"
    assert "NaN in the positions of 'sick'" in violation.message() and health.nan
