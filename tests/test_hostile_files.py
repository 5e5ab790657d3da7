"""Hostile files (issue 31): every file the CLI reads is bounded before the work it would cost.

Scenes, templates and replays that would take minutes to read, read until memory runs
out, or end in a traceback are refused with one ``error:`` line, in well under the 5 s
the issue allows; files at each size limit are read or refused within it. Each case is
the issue's own input or the worst of its kind we could build.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
from pathlib import Path

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.errors import SceneError
from twig_ecs.files import FileReadError, read_bounded
from twig_ecs.progress import Progress
from twig_ecs.replay import MAX_FRAMES, ReplayError, read_replay, replay
from twig_ecs.server.replay import MAX_EMBEDDED_BYTES, MAX_REPLAY_BYTES
from twig_ecs.yamldoc import MAX_BYTES, MAX_NODES

#: The issue's bound: a file at its size limit is read or refused within this (s).
LIMIT_S = 5.0
SCENE = "twig: 1\nname: hostile\n"


def cli(capsys, *args: str) -> tuple[int, list[str], str, float]:
    """Run ``twig ARGS`` in this process: (exit code, stderr lines, stdout, seconds)."""
    started = time.perf_counter()
    try:
        code = main(list(args))
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    seconds = time.perf_counter() - started
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, err.splitlines(), out, seconds


def one_error(lines: list[str]) -> str:
    """The single ``error:`` line of a refused file."""
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1, lines
    return errors[0]


def entity(facing: str) -> str:
    return SCENE + f"entities:\n  - {{name: b, body: ball, facing: {facing}}}\n"


# -- the issue's inputs: minutes of work or a traceback, each now one error line at once ---------

HOSTILE = {
    # 75 bytes: round() worked out 10**100000000 first (340 s)
    "round-digits": (entity("'$(round(1, -100000000))'"), "round's digits must be from -64 to 64"),
    # YAML 1.1 base-60, 1.2 MB: quadratic in PyYAML (135 s); now over the size limit
    "base-60-integer": (SCENE + "x: " + ":".join(["59"] * 400_000) + "\n", "too large"),
    # an overflowing base-60 float was an OverflowError; YAML 1.2 has no base 60: it is text
    "base-60-float": (entity(":".join(["59"] * 200) + ".5"), "expected a finite number"),
    # 300 000 flow keys (113 s); over the size limit
    "flow-keys": (SCENE + "x: {" + ", ".join(f"k{i}: 1" for i in range(300_000)) + "}\n", "too large"),
    # 20 000 flow keys, under the size limit: the node cap stops the parser
    "flow-keys-under-size": (
        SCENE + "x: {" + ", ".join(f"k{i}: 1" for i in range(20_000)) + "}\n",
        f"more than {MAX_NODES} nodes",
    ),  # fmt: skip
    # Python refuses to convert an integer of over 4300 digits: a ValueError traceback
    "5000-digit-integer": (entity("9" * 5000), "number too long"),
    "huge-hex-integer": (entity("0x" + "f" * 400), "number too long"),
    "huge-integer-from-formula": (entity("'$(ceil(1e308) * 100)'"), "between -1e+06 and 1e+06"),
    # PyYAML's constructors raise AttributeError, KeyError, IndexError on these explicit tags
    "bad-timestamp": (entity("!!timestamp 2001-13-45"), "not a valid timestamp value: '2001-13-45'"),
    "bad-bool": (entity("!!bool maybe"), "not a valid bool value: 'maybe'"),
    "bad-int": (entity("!!int _"), "not a valid int value: '_'"),
}


@pytest.mark.parametrize("case", list(HOSTILE))
def test_the_issues_hostile_yaml_is_refused_at_once_with_one_error_line(tmp_path, capsys, case):
    text, says = HOSTILE[case]
    path = tmp_path / "hostile.yaml"
    path.write_text(text)
    code, err, _, seconds = cli(capsys, "validate", str(path))
    assert code == 1
    assert says in one_error(err)
    assert seconds < LIMIT_S, f"{case}: {seconds:.1f} s"


# -- every YAML file at the size limit: read or refused within the bound ------------------------


def at_limit(unit: str, head: str = SCENE, tail: str = "\n") -> str:
    """``head + unit * n + tail`` as long as MAX_BYTES allows."""
    return head + unit * ((MAX_BYTES - len(head) - len(tail)) // len(unit)) + tail


AT_LIMIT = {
    "newlines": at_limit("\n"),
    "comments": at_limit("# a comment of some length, as a long file might hold\n"),
    "spaces": at_limit(" ", SCENE + "name2: 1"),
    "plain-scalar": at_limit("a", SCENE + "x: "),
    "quoted-escapes": at_limit("\\x41", SCENE + 'x: "', '"\n'),
    "digits": at_limit("9", SCENE + "x: "),
    "base-60": at_limit(":59", SCENE + "x: 1"),
    "flow-sequence": at_limit("1,", SCENE + "x: [", "1]\n"),
    "empty-lists": at_limit("[],", SCENE + "x: [", "[]]\n"),
    "flow-keys": at_limit("k: 1, ", SCENE + "x: {", "}\n"),
    "block-sequence": at_limit("- 1\n", SCENE + "x:\n"),
    "anchors": at_limit("&a 1, ", SCENE + "x: [", "1]\n"),
    "documents": at_limit("---\n", ""),
    "long-keys": at_limit("? " + "a" * 900 + "\n: 1\n"),
    "entities": at_limit("  - {name: b, body: ball, position: [0, 1, 0]}\n", SCENE + "entities:\n"),
    "alias-expansion": SCENE
    + "a: &a ["
    + ",".join(["1"] * 300)
    + "]\nb: &b ["
    + ",".join(["*a"] * 300)
    + "]\nc: ["
    + ",".join(["*b"] * 300)
    + "]\n",
    "template-nodes": at_limit("  n{}: {{at: [0, 1, 0]}}\n", "twig: 1\ntemplate: big\nnodes:\n"),
}


@pytest.mark.parametrize("case", list(AT_LIMIT))
def test_a_yaml_file_at_the_size_limit_is_read_or_refused_within_5_s(tmp_path, capsys, case):
    text = AT_LIMIT[case]
    if "{}" in text:  # node names must differ
        lines = text.splitlines(keepends=True)
        text = "".join(line.format(k) if "{}" in line else line for k, line in enumerate(lines))
        text = text[:MAX_BYTES]
        text = text[: text.rindex("\n") + 1]
    assert len(text.encode()) <= MAX_BYTES
    path = tmp_path / "limit.yaml"
    path.write_text(text)
    code, err, _, seconds = cli(capsys, "validate", str(path))
    assert code in (0, 1)
    if code:
        one_error(err)
    assert seconds < LIMIT_S, f"{case}: {seconds:.1f} s"


def test_a_yaml_file_one_byte_over_the_limit_is_refused_unread(tmp_path, capsys):
    path = tmp_path / "over.yaml"
    path.write_text(at_limit("#\n") + "#" * 10)
    code, err, _, _ = cli(capsys, "validate", str(path))
    assert code == 1 and "is too large" in one_error(err) and "at most 256 KiB" in err[0]


# -- files that never end, or block -------------------------------------------------------------

needs_dev_zero = pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")


@needs_dev_zero
def test_a_link_to_dev_zero_is_refused_as_a_scene_a_content_file_or_a_replay(tmp_path, capsys):
    scene = tmp_path / "zero.yaml"
    scene.symlink_to("/dev/zero")
    content = tmp_path / "content"
    content.mkdir()
    (content / "bodies.yaml").symlink_to("/dev/zero")
    replay_file = tmp_path / "zero.twigreplay"
    replay_file.symlink_to("/dev/zero")
    for args in (["validate", str(scene)], ["validate", "--content", str(content), "empty"],
                 ["run", "--replay", str(replay_file)]):  # fmt: skip
        code, err, _, seconds = cli(capsys, *args)
        assert code in (1, 2) and "not a regular file" in one_error(err), args
        assert seconds < LIMIT_S


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path, capsys):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    fifo = tmp_path / "pipe.twigreplay"
    os.mkfifo(fifo)
    code, err, _, _ = cli(capsys, "run", "--replay", str(fifo))
    assert code == 2 and "not a regular file" in one_error(err)


@needs_dev_zero
def test_read_bounded_refuses_devices_folders_and_files_over_the_cap(tmp_path):
    small = tmp_path / "small.bin"
    small.write_bytes(b"x" * 100)
    assert read_bounded(small, 100) == b"x" * 100
    with pytest.raises(FileReadError, match="too large: 100 bytes, at most 99 bytes"):
        read_bounded(small, 99)
    with pytest.raises(FileReadError, match="not a regular file"):
        read_bounded("/dev/zero", 1 << 20, "snapshot")
    with pytest.raises(FileReadError, match="not a regular file"):
        read_bounded(tmp_path, 1 << 20)
    with pytest.raises(SceneError, match="cannot read snapshot .*No such file"):
        read_bounded(tmp_path / "missing", 10, "snapshot", SceneError)


# -- replays --------------------------------------------------------------------------------------


def write_replay(path: Path, *records: dict, header: dict | None = None) -> Path:
    head = {"twig_replay": 1, "scene": "empty", "seed": 0, "content": [], "autonomous": True}
    path.write_text("\n".join(json.dumps(r) for r in [head | (header or {}), *records]) + "\n")
    return path


def test_a_two_line_replay_naming_a_day_of_frames_is_refused_before_it_runs(tmp_path, capsys):
    path = write_replay(tmp_path / "day.twigreplay", {"end": 5_184_000, "state_hash": "x"})
    code, err, _, seconds = cli(capsys, "run", "--replay", str(path))
    assert code == 2 and seconds < LIMIT_S
    assert f"0..{MAX_FRAMES} (1 h at 60 Hz, the longest replay)" in one_error(err)
    late = write_replay(tmp_path / "late.twigreplay", {"frame": MAX_FRAMES + 1, "method": "ping"})
    with pytest.raises(ReplayError, match="not a command record"):
        read_replay(late)


@pytest.mark.parametrize(
    ("records", "header", "says"),
    [
        ([], {"seed": -1}, "'seed' has the wrong type or range (-1)"),
        ([], {"seed": 2**64}, "'seed' has the wrong type or range"),
        (["[" * 100_000 + "]" * 100_000], {}, "line 2 is nested too deeply"),
        ([{"frame": 10, "method": "ping"}, {"frame": 5, "method": "ping"}], {}, "commands out of order"),
        ([{"frame": 10, "method": "ping"}, {"end": 5, "state_hash": "x"}], {}, "before the last command"),
        ([], {"files": {"scene": {"path": "s.yaml", "text": "#" * (MAX_EMBEDDED_BYTES + 1)}}}, "embeds"),
        (["9" * 5000], {}, "line 2 is not JSON"),
    ],
    ids=[
        "negative-seed",
        "huge-seed",
        "deep-json",
        "out-of-order",
        "end-before-commands",
        "embeds-too-much",
        "5000-digit-line",
    ],  # fmt: skip
)
def test_a_malformed_replay_gets_one_clear_error_line(tmp_path, capsys, records, header, says):
    path = tmp_path / "bad.twigreplay"
    head = {"twig_replay": 1, "scene": "empty", "seed": 0, "content": [], "autonomous": True} | header
    lines = [json.dumps(head)] + [r if isinstance(r, str) else json.dumps(r) for r in records]
    path.write_text("\n".join(lines) + "\n")
    code, err, _, seconds = cli(capsys, "run", "--replay", str(path))
    assert code == 2 and says in one_error(err) and seconds < LIMIT_S


@needs_dev_zero
def test_a_replay_naming_dev_zero_as_its_recorded_scene_does_not_read_it(tmp_path):
    text = SCENE + "entities:\n  - {name: b, body: ball}\n"
    zero = tmp_path / "zero.yaml"
    zero.symlink_to("/dev/zero")
    path = write_replay(tmp_path / "z.twigreplay", {"end": 3, "state_hash": "x"},
                        header={"files": {"scene": {"path": str(zero), "text": text}}})  # fmt: skip
    result = replay(path)  # the embedded copy, not /dev/zero
    assert result["scene"] == "hostile" and result["frames"] == 3


def test_a_replay_at_its_size_limit_is_read_and_run_within_5_s(tmp_path, capsys):
    line = json.dumps({"frame": 0, "method": "ping"}) + "\n"
    head = json.dumps({"twig_replay": 1, "scene": "empty", "seed": 0, "content": [], "autonomous": True})
    path = tmp_path / "big.twigreplay"
    commands = (MAX_REPLAY_BYTES - len(head) - 1) // len(line)
    path.write_text(head + "\n" + line * commands)
    assert path.stat().st_size <= MAX_REPLAY_BYTES
    code, err, out, seconds = cli(capsys, "run", "--replay", str(path), "--report", "json")
    assert code == 1 and json.loads(out)["commands"] == commands  # no end line: no recorded hash to match
    assert seconds < LIMIT_S
    path.write_text(path.read_text() + line)
    code, err, _, _ = cli(capsys, "run", "--replay", str(path))
    assert code == 2 and "is too large" in one_error(err)


def test_a_long_replay_reports_progress_on_stderr_and_keeps_the_json_clean(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(Progress, "QUIET", 0.0)
    monkeypatch.setattr(Progress, "EVERY", 0.0)
    path = write_replay(tmp_path / "long.twigreplay", {"frame": 700, "method": "ping"},
                        {"end": 1800, "state_hash": "x"})  # fmt: skip
    code, err, out, _ = cli(capsys, "run", "--replay", str(path), "--report", "json")
    assert code == 1 and json.loads(out)["frames"] == 1800  # stdout: the report alone
    assert "replay: frame 600 of 1800 (33%, 10 s simulated)" in err
    assert "replay: frame 1800 of 1800 (100%, 30 s simulated)" in err


def test_a_short_replay_says_nothing_about_progress(tmp_path, capsys):
    path = write_replay(tmp_path / "short.twigreplay", {"end": 1200, "state_hash": "x"})
    code, err, _, _ = cli(capsys, "run", "--replay", str(path))
    assert code == 1 and not any("replay: frame" in line for line in err)


# -- the command line ------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", ["-1", str(2**64), "zero"])
def test_a_seed_that_is_not_a_whole_number_from_0_is_a_usage_error(capsys, seed):
    code, err, _, _ = cli(capsys, "run", "empty", "--seed", seed, "--seconds", "0.1")
    assert code == 2 and any(
        "--seed" in line and ("from 0 to" in line or "whole number" in line) for line in err
    )


def test_a_seed_of_zero_or_more_still_runs(capsys):
    code, _, out, _ = cli(capsys, "run", "empty", "--seed", str(2**63 - 1), "--seconds", "0.05")
    assert code == 0 and "empty: 3 frames" in out


# -- what validate must catch: bodies that cannot spawn or become NaN ------------------------------


TWO_NODES = (
    "nodes:\n  a: {at: [0, 0.5, 0]}\n  b: {at: [0, 1.0, 0]}\nlinks:\n  - {nodes: [a, b], radius: 0.05}\n"
)
WHEEL = ("nodes:\n  hub: {at: [0, 0.5, 0], locked: true}\n  top: {at: [0, %s, 0], locked: true}\n"
         "  rim: {at: [1, 0.5, 0]}\nlinks:\n  - {nodes: [hub, rim]}\n  - {nodes: [top, rim]}\n")  # fmt: skip


@pytest.mark.parametrize(
    ("template", "height", "where", "says"),
    [
        ("reference_height: 1e-300\n" + TWO_NODES, "", ("body", 3),
         "reference_height: expected a number from 0.01 to 100"),
        ("reference_height: 0.01\ndefaults: {height: 10}\n" + TWO_NODES, "", ("scene", 10),
         "at its default height 10 m body 'thing' would be 600 m across, over the 30 m limit"),
        (TWO_NODES, ", height: 90", ("scene", 10), "at height 90 m body 'thing' would be 54 m across"),
        (WHEEL % "1.5" + "axle: [hub, hub]\n", "", ("body", 10), "an axle needs two different nodes"),
        (WHEEL % "0.5" + "axle: [hub, top]\n", "", ("body", 10), "nodes 'hub' and 'top' are at the same"),
        (TWO_NODES.replace("0.5, 0]}", "0.5, 0], mass: 5e-324}"), "", ("body", 4),
         "mass: expected a number from 1e-06 to 1e+06"),
    ],
    ids=["tiny-reference-height", "too-big-at-default-height", "too-big-at-entity-height", "axle-hub-hub",
         "axle-at-one-point", "denormal-mass"],
)  # fmt: skip
def test_validate_catches_a_body_that_would_fail_to_spawn_or_turn_nan(tmp_path, capsys, template, height,
                                                                      where, says):  # fmt: skip
    content = tmp_path / "content"
    content.mkdir()
    files = {"body": content / "thing.yaml", "scene": tmp_path / "scene.yaml"}
    files["body"].write_text("twig: 1\ntemplate: thing\n" + template)
    files["scene"].write_text(SCENE + "entities:\n" + "\n" * 6 + f"  - {{name: t, body: thing{height}}}\n")
    code, err, _, _ = cli(capsys, "validate", "--content", str(content), str(files["scene"]))
    error = one_error(err)
    assert code == 1 and error.startswith(f"error: {files[where[0]]}:{where[1]}: ") and says in error
    with pytest.raises(SceneError, match=re.escape(says)):
        Scene.load(files["scene"], content=[content])


def test_the_built_in_wheel_and_bodies_still_validate_and_stay_finite(capsys):
    code, err, _, _ = cli(capsys, "validate", "playground", "schoolyard", "crowd")
    assert code == 0, err
    with Scene.load("playground") as scene:
        scene.step(60)
        assert np.isfinite(scene.state.nodes.pos[: scene.state.nodes.count]).all()


def test_a_lone_surrogate_name_is_refused_where_the_file_says_it(tmp_path, capsys):
    scene = tmp_path / "names.yaml"
    scene.write_text(SCENE + 'entities:\n  - {name: "kid\\ud800", body: humanoid, character: true}\n')
    code, err, _, _ = cli(capsys, "validate", str(scene))
    assert code == 1 and f"{scene}:4: " in one_error(err) and "lone surrogate" in err[0]
    code, err, _, _ = cli(capsys, "run", str(scene), "--seconds", "0.1", "--trace", str(tmp_path / "t.csv"))
    assert code == 2 and "lone surrogate" in one_error(err)


def test_a_formula_stays_exact_within_its_bounds():
    from twig_ecs.parameters import _evaluate

    def fail(message: str) -> None:
        raise AssertionError(message)

    assert _evaluate("$(round(1234.5, -2))", {}, fail) == 1200.0
    assert _evaluate("$(round(2, 64))", {}, fail) == 2
    assert math.isclose(_evaluate("$(2 ** 64 / 2 ** 63)", {}, fail), 2.0)


def test_a_long_run_reports_progress_even_when_stderr_is_a_log(capsys, monkeypatch):
    """`twig run ... 2> log` said nothing until it ended (progress was for terminals only)."""
    monkeypatch.setattr(Progress, "QUIET", 0.0)
    monkeypatch.setattr(Progress, "EVERY", 0.0)
    code, err, out, _ = cli(capsys, "run", "empty", "--seconds", "2", "--report", "json")
    assert code == 0 and json.loads(out)["frames"] == 120  # stdout: the report alone
    assert "empty: frame 60 of 120 (50%, 1 s simulated)" in err  # err: its lines, one a report
    assert not any("\r" in line for line in err)
