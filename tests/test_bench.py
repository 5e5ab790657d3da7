"""``twig bench``: the report's shape (not its timings), and MuJoCo's ragdolls when installed."""

from __future__ import annotations

import pytest

from twig_ecs.bench.run import run_bench
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
