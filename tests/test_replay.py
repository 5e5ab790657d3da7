"""Record a served session over a real loopback socket, replay it headless: the same final state."""

from __future__ import annotations

import json
import time

import pytest
from server_helpers import RawLines, running_server

from twig_ecs.cli import main
from twig_ecs.client import Client, RemoteError
from twig_ecs.replay import ReplayError, read_replay, replay


def drive(twig: Client, raw: RawLines) -> None:
    """A short session: goals, commands, spawns and removals, some of them invalid, in real time."""
    twig.hug(character="small_child", target="parent", duration=1.0)
    with pytest.raises(RemoteError, match="no entity named 'nobody'"):
        twig.hug(character="nobody", target="parent")  # queued, fails when applied
    with pytest.raises(RemoteError, match="must be"):
        twig.walk(character="big_child", velocity="fast")  # refused before the queue
    raw.send(b'{"jsonrpc": "2.0", "id": 9, "method": "walk", "params": {"character": "big_child"\n')
    assert b"error" in raw.line()
    twig.walk(character="big_child", velocity=[0.8, 0.0, 0.3])
    time.sleep(0.25)
    twig.spawn(template="ball", name="ball2", position=[1.0, 1.5, 0.0])
    twig.approach(character="big_child", target="ball2")
    with pytest.raises(RemoteError):
        twig.grab(character="parent", target="ball2")  # out of reach
    twig.pause()
    twig.step(n=30)
    twig.look_at(character="parent", target="big_child")
    twig.resume()
    time.sleep(0.25)
    twig.remove(name="ball2")
    twig.set_autonomous(character="small_child", autonomous=False)
    twig.do(character="small_child", behavior="gesture", params={"name": "wave", "duration": 0.5})
    time.sleep(0.2)


def test_a_recorded_session_replays_headless_to_the_same_state(tmp_path):
    path = tmp_path / "session.twigreplay"
    with running_server(record=str(path)) as srv, Client(port=srv.port) as twig:
        drive(twig, RawLines(srv.port))
    header, commands, end = read_replay(path)
    assert header["scene"] == "schoolyard" and header["seed"] == 0 and header["autonomous"] is True
    assert "twig: 1" in header["files"]["scene"]["text"]  # the replay carries the scene itself
    methods = [c["method"] for c in commands]
    assert methods[:2] == ["hug", "hug"] and "remove" in methods and "step" in methods
    assert commands[1]["error"] and commands[0]["error"] is None
    assert [c["frame"] for c in commands] == sorted(c["frame"] for c in commands)
    assert end is not None and end["end"] > commands[-1]["frame"] >= 30

    result = replay(path)
    assert result["match"] and result["diverged"] == 0
    assert result["frames"] == end["end"] and result["state_hash"] == end["state_hash"]


def test_twig_run_replay_says_whether_the_state_matches(tmp_path, capsys):
    path = tmp_path / "session.twigreplay"
    with running_server(record=str(path), paused=True) as srv, Client(port=srv.port) as twig:
        twig.walk(character="parent", velocity=[0.5, 0.0, 0.0])
        twig.step(n=60)
        twig.stop(character="parent")
        twig.step(n=30)
    assert main(["run", "--replay", str(path)]) == 0
    assert "replayed 4 commands over 90 frames" in capsys.readouterr().out

    lines = path.read_text().splitlines()
    walk = json.loads(lines[1])
    walk["params"]["velocity"] = [0.9, 0.0, 0.0]  # not what was sent: the replay must notice
    lines[1] = json.dumps(walk)
    path.write_text("\n".join(lines) + "\n")
    assert main(["run", "--replay", str(path)]) == 1
    assert "DIFFERS from the recorded" in capsys.readouterr().out


def test_a_file_that_is_not_a_replay_gets_a_clear_error(tmp_path, capsys):
    path = tmp_path / "notes.txt"
    path.write_text("hello\n")
    with pytest.raises(ReplayError, match="not a replay file"):
        read_replay(path)
    assert main(["run", "--replay", str(path)]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_twig_serve_record_writes_a_replay_that_twig_run_replays(tmp_path):
    from twig_ecs.client import spawn_server

    path = tmp_path / "served.twigreplay"
    proc, port = spawn_server("schoolyard", "--scripted", "--paused", "--record", str(path))
    try:
        with Client(port=port) as twig:
            twig.carry(character="big_child", target="ball", to=[0.0, 0.0, 3.0])
            twig.step(n=45)
    finally:
        proc.terminate()  # SIGTERM: the server stops cleanly and writes the end line
        proc.wait(timeout=30)
    header, commands, end = read_replay(path)
    assert header["autonomous"] is False and [c["method"] for c in commands] == ["carry", "step"]
    assert end is not None and end["end"] == 45
    result = replay(path)
    assert result["match"] and result["state_hash"] == end["state_hash"]


def test_a_replay_carries_its_scene_file_when_the_original_is_gone(tmp_path):
    scene_file = tmp_path / "duo.yaml"
    scene_file.write_text(
        "twig: 1\nname: duo\nentities:\n"
        "  - {name: ann, body: humanoid, character: true}\n"
        "  - {name: toy, body: ball, position: [1, 0.5, 1]}\n"
    )
    path = tmp_path / "duo.twigreplay"
    with running_server(scene=str(scene_file), record=str(path), paused=True) as srv:
        with Client(port=srv.port) as twig:
            twig.carry(character="ann", target="toy", to=[-1.0, 0.0, 0.0])
            twig.step(n=120)
    scene_file.unlink()
    result = replay(path)
    assert result["scene"] == "duo" and result["frames"] == 120 and result["match"]
