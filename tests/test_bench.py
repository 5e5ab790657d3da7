"""``twig bench``: the report's shape (not its timings), and MuJoCo's ragdolls when installed."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs.bench import cases
from twig_ecs.bench.run import SIZED, run_bench
from twig_ecs.bench.table import format_report
from twig_ecs.cli import main


def test_bench_reports_each_case_split_by_system():
    report = run_bench(("schoolyard", "crowd"), (3,), steps=3, warmup=1, mujoco=False)
    assert [r["case"] for r in report["cases"]] == ["schoolyard", "crowd 3"]
    crowd = report["cases"][1]
    assert crowd["characters"] == 3 and not crowd["nan"]
    expected = {"integrate", "constrain", "collide", "wander", "select_behavior", "gait"}
    assert expected <= set(crowd["systems_ms"])
    assert set(crowd["groups_ms"]) == {"physics", "behaviour", "control"}
    text = format_report(report)
    assert "crowd 3" in text and "split by system" in text


def test_bench_times_each_cases_set_up_apart_from_its_steps():
    """Building the scene and its first step (installing its systems) are reported, not
    mixed into the step times."""
    report = run_bench(("crowd",), (3,), steps=3, warmup=2, mujoco=False)
    crowd = report["cases"][0]
    assert crowd["build_s"] > 0.0 and crowd["first_step_s"] > 0.0
    assert "set-up (s)" in format_report(report) and "first step" in format_report(report)


def test_bench_command_prints_json(capsys):
    assert main(["bench", "--cases", "ragdolls", "--sizes", "2", "--steps", "2", "--warmup", "1",
                 "--no-mujoco", "--json"]) == 0  # fmt: skip
    assert '"ragdolls 2"' in capsys.readouterr().out


def test_bench_rejects_unknown_cases(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "--cases", "crowds"])
    assert "choose from" in capsys.readouterr().err


def test_mujoco_ragdolls_are_as_many_capsule_humanoids():
    pytest.importorskip("mujoco")
    from twig_ecs.bench.mujoco_ragdolls import Ragdolls

    sim = Ragdolls(4)
    for _ in range(30):
        sim.step()
    info = sim.info()
    assert info["bodies"] == 4 * 12 and info["geoms"] == 4 * 13
    assert info["unstable"] == 0


def test_mujocos_compiled_model_is_kept_and_steps_the_same(tmp_path, monkeypatch):
    """MuJoCo compiles a model in time quadratic in its bodies (a minute for 1000 ragdolls):
    the bench keeps the compiled model and loads it the next time, the same model."""
    pytest.importorskip("mujoco")
    from twig_ecs.bench.mujoco_ragdolls import Ragdolls

    monkeypatch.setenv("TWIG_CACHE_DIR", str(tmp_path))
    first, second = Ragdolls(3), Ragdolls(3)
    assert not first.info()["cached"] and second.info()["cached"]
    assert len(list((tmp_path / "mujoco-models").glob("*.mjb"))) == 1
    for _ in range(20):
        first.step()
        second.step()
    assert np.array_equal(first.data.qpos, second.data.qpos)
    assert Ragdolls(4).info()["cached"] is False  # another model: compiled


def test_bench_skips_mujoco_where_its_model_would_take_hours_to_compile(tmp_path, monkeypatch):
    """Above ``COMPILE_LIMIT`` ragdolls the bench says why there is no comparison rather than
    wait on MuJoCo's compiler; a model compiled before (cached) is used at any size."""
    pytest.importorskip("mujoco")
    from twig_ecs.bench import mujoco_ragdolls

    monkeypatch.setenv("TWIG_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(mujoco_ragdolls, "COMPILE_LIMIT", 2)
    said: list[str] = []
    report = run_bench(("ragdolls",), (3,), steps=2, warmup=1, say=said.append)
    assert "mujoco" not in report["cases"][0] and any("no MuJoCo comparison" in line for line in said)
    mujoco_ragdolls.Ragdolls(3)  # compiled once (by hand here): in the cache now
    report = run_bench(("ragdolls",), (3,), steps=2, warmup=1)
    assert report["cases"][0]["mujoco"]["cached"]


@pytest.mark.parametrize("kind", ["schoolyard", *SIZED])
def test_every_bench_case_steps_the_same_timed_and_untimed(kind):
    """What ``twig bench`` times is what users run: ``step_timed`` (as the bench steps) and
    plain steps give the same state hash, case by case."""
    make = cases.schoolyard if kind == "schoolyard" else (lambda: getattr(cases, SIZED[kind])(6))
    with make() as timed, make() as plain:
        times: dict[str, list[float]] = {}
        for _ in range(90):
            timed.step_timed(times)
        plain.step(90)
        assert timed.state_hash() == plain.state_hash()
        assert timed.frame == plain.frame == 90


def test_the_goal_driven_cases_do_what_they_say():
    """Hugging pairs get their arms round each other, brawlers grapple, strollers walk their
    circles through the plug-in: the bench times those behaviours, not idle characters."""
    with cases.hugging_pairs(4) as scene:
        scene.run(4.0)
        hugger = scene.entity("a0")
        assert hugger.behaviour == "hug" and hugger.goals[0].memory["phase"] in ("wrap", "hold")
        assert scene.entity("b0").behaviour == "embrace"
    with cases.brawl(4) as scene:
        scene.run(3.0)
        assert scene.entity("a0").behaviour == "grapple"
        # the grappled defend themselves, or flinch from a blow (the pain reflex)
        assert {scene.entity(f"b{k}").behaviour for k in (0, 1)} <= {"defend", "withdraw"}
    with cases.plugin_strollers(3) as scene:
        start = scene.entity("s0").position
        scene.run(3.0)
        person = scene.entity("s0")
        assert person.behaviour == "stroll"
        assert np.hypot(*(person.position - start)[[0, 2]]) > 1.0, "it walked"
        assert abs(np.hypot(person.position[0], person.position[2]) - 1.5) < 0.6, "round its circle"
