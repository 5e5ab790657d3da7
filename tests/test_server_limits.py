"""What one client can make the server do is bounded (issue 31, the server's items).

Every test talks to a real server over loopback sockets. The latency bound is the one
the issue states (``ping`` and ``status`` within 100 ms whatever is queued); it is
measured on every ping sent while the pile is worked through.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest
from server_helpers import RawLines, ask, request, running_server

from twig_ecs import Scene
from twig_ecs.client import Client, RemoteError
from twig_ecs.errors import SceneError
from twig_ecs.replay import replay
from twig_ecs.server.methods import MAX_CROWD
from twig_ecs.spawn import MAX_EXTENT

#: The issue's bound on a control request's answer (s).
ANSWER_BOUND = 0.100
#: What a shared, loaded test machine may add to a single answer now and then (s): every
#: ping must still come within ANSWER_BOUND + this, and nine in ten within ANSWER_BOUND.
LOADED_MACHINE_SLACK = 0.150


def _pile(port: int, positions: list[list[float]]) -> RawLines:
    """A client that sends ``spawn humanoid`` at each position, in batch lines of 250."""
    pile = RawLines(port, timeout=300)
    for first in range(0, len(positions), 250):
        batch = [request("spawn", k, template="humanoid", position=positions[k])
                 for k in range(first, min(first + 250, len(positions)))]  # fmt: skip
        pile.send(json.dumps(batch).encode() + b"\n")
    return pile


def _answer_times_while(pile: RawLines, batches: int, port: int, within: float) -> tuple[list, list, list]:
    """Ping and ask status from another client until the pile's ``batches`` answers are in.

    Returns (ping seconds, status seconds, the pile's answers).
    """
    pings, statuses, answers = [], [], []
    deadline = time.monotonic() + within
    with RawLines(port, timeout=60) as probe:
        k = 0
        while len(answers) < batches:
            assert time.monotonic() < deadline, f"the pile was not done in {within:g} s"
            k += 1
            started = time.perf_counter()
            assert ask(probe, request("ping", k))["result"] == "pong"
            pings.append(time.perf_counter() - started)
            started = time.perf_counter()
            assert "frame" in ask(probe, request("status", k))["result"]
            statuses.append(time.perf_counter() - started)
            try:
                answers.append(json.loads(pile.line(timeout=0.02)))
            except TimeoutError:
                pass
    return pings, statuses, answers


def _check_answer_times(seconds: list[float], what: str) -> None:
    worst, typical = max(seconds), statistics.quantiles(seconds, n=10, method="inclusive")[-1]
    report = (
        f"{what}: {len(seconds)} answers, 90% within {typical * 1000:.1f} ms, worst {worst * 1000:.1f} ms"
    )
    print(report)
    assert typical <= ANSWER_BOUND, report
    assert worst <= ANSWER_BOUND + LOADED_MACHINE_SLACK, report


# -- item 1: one client's pile of spawns -------------------------------------------------------------


def test_ping_and_status_come_within_100_ms_while_one_client_piles_1000_spawns_at_one_spot():
    # before: ping took 107 s, then 4-6 s, and the world stepped at 0.75 frames/s
    with running_server("empty") as srv:
        pile = _pile(srv.port, [[0.0, 0.0, 0.0]] * 1000)
        pings, statuses, answers = _answer_times_while(pile, 4, srv.port, within=120)
        pile.close()
        _check_answer_times(pings, "ping")
        _check_answer_times(statuses, "status")
        results = [a for batch in answers for a in batch]
        made = [a for a in results if "result" in a]
        refused = [a["error"]["message"] for a in results if "error" in a]
        # a few at a time: the next ones only once the pile has pushed itself apart
        assert MAX_CROWD <= len(made) < 100 and len(made) + len(refused) == 1000
        assert "MAX_CROWD" in refused[0] and "spawn it somewhere free" in refused[0]
        with Client(port=srv.port, timeout=60) as twig:  # the world goes on at a real-time pace
            frame = twig.status()["frame"]
            deadline = time.monotonic() + 30
            while twig.status()["frame"] < frame + 60 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert twig.status()["frame"] >= frame + 60


@pytest.mark.slow  # a world of 1000 humanoids
def test_ping_and_status_come_within_100_ms_while_1000_spawns_fill_the_world():
    # the same pile spread out: all 1000 are made, and the steps grow slow meanwhile
    # (each rebuilds the colliders, 0.1 s at 1000 bodies); the answers do not wait for them
    with running_server("empty") as srv:
        spots = [[(k % 32) * 1.5, 0.0, (k // 32) * 1.5] for k in range(1000)]
        pile = _pile(srv.port, spots)
        pings, statuses, answers = _answer_times_while(pile, 4, srv.port, within=240)
        pile.close()
        _check_answer_times(pings, "ping")
        _check_answer_times(statuses, "status")
        assert all("result" in a for batch in answers for a in batch)
        with Client(port=srv.port, timeout=60) as twig:
            assert len(twig.list_entities()) == 1000


def test_spawns_queued_by_a_client_that_left_are_dropped():
    with running_server("empty", paused=True) as srv:
        spots = [[(k % 32) * 1.5, 0.0, (k // 32) * 1.5] for k in range(1000)]
        _pile(srv.port, spots).close()  # four batch lines of 250, then gone
        with Client(port=srv.port, timeout=60) as twig:
            counts = [-1]
            deadline = time.monotonic() + 60
            while (count := len(twig.list_entities())) != counts[-1] and time.monotonic() < deadline:
                counts.append(count)
                time.sleep(0.5)  # until no more come
            assert count < 500, counts  # the rest were dropped, never applied
        assert any("queued command(s) dropped" in line for line in srv.log), srv.log


# -- item 2: body size, contact radii included ----------------------------------------------------------


def test_a_spawned_body_may_not_be_wider_than_max_extent_radii_included():
    with running_server("empty", paused=True) as srv, Client(port=srv.port, timeout=60) as twig:
        with pytest.raises(RemoteError, match="MAX_EXTENT") as refused:
            twig.spawn(template="ball", name="moon", height=100.0)
        assert "100 m across" in refused.value.message
        assert twig.list_entities() == []
        twig.spawn(template="ball", name="beach_ball", height=1.0)  # an ordinary big ball still goes
        assert twig.step(n=2)["frame"] == 2


def test_a_scene_with_a_node_radius_of_250_is_refused_before_it_runs(tmp_path: Path):
    # before: the scene loaded and its first step raised MemoryError (the broad phase's grid)
    scene = tmp_path / "boulder.yaml"
    scene.write_text("""twig: 1
name: boulder
templates:
  boulder:
    template: boulder
    nodes:
      centre: {at: [0, 0.5, 0], radius: 250, sphere: true}
entities:
  - {name: rock, body: boulder}
  - {name: ball, body: ball, position: [3, 1, 0]}
""")
    with pytest.raises(SceneError, match=r"boulder.yaml:9: entities\[0\].body: .* 500 m across.*MAX_EXTENT"):
        Scene.load(scene)
    run = subprocess.run([sys.executable, "-m", "twig_ecs", "run", str(scene), "--seconds", "0.1"],
                         capture_output=True, text=True, timeout=120)  # fmt: skip
    assert run.returncode == 2 and run.stderr.startswith("error: "), run.stderr
    assert "Traceback" not in run.stderr and f"{MAX_EXTENT:.0f} m limit" in run.stderr


# -- item 3: what a recording stores ---------------------------------------------------------------------


def _huge_character() -> dict:
    """A spawn's ``character`` mapping of about 0.9 MiB that the world refuses."""
    return {f"k{k:06d}": 0 for k in range(70_000)}


def test_a_recording_keeps_failed_requests_short(tmp_path: Path):
    # before: each refused ~1 MiB spawn was stored whole (475 MB in 20 s from one client)
    path = tmp_path / "session.twigreplay"
    with running_server(paused=True, record=str(path)) as srv, RawLines(srv.port, timeout=60) as raw:
        header = path.stat().st_size
        for k in range(5):
            line = json.dumps(request("spawn", k, template="humanoid", character=_huge_character()))
            assert len(line) > 900_000
            assert "error" in ask(raw, line)
        assert path.stat().st_size - header < 5 * 2000
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    failed = [item for item in lines[1:-1] if item.get("method") == "spawn"]
    assert len(failed) == 5 and all(
        item["params"] is None and item["params_cut"] > 900_000 for item in failed
    )
    assert replay(path)["match"]


def test_a_recording_stops_at_its_size_limit_and_the_server_goes_on(tmp_path: Path):
    path = tmp_path / "session.twigreplay"
    limit = 64 << 10
    with running_server(paused=True, record=str(path), record_limit=limit) as srv:
        with Client(port=srv.port, timeout=60) as twig:
            for k in range(800):  # about 130 bytes each: past the limit half-way
                twig.walk(character="parent", velocity=[0.1 * (k % 7), 0.0])
                if k % 50 == 0:
                    twig.step(n=1)
            assert twig.ping() == "pong" and twig.step(n=1)["frame"] == 17
        assert any("recording stopped" in line for line in srv.log), srv.log
    assert path.stat().st_size <= limit
    end = json.loads(path.read_text().splitlines()[-1])
    assert "recording stopped" in end["note"] and "limit of 0.0625 MiB" in end["note"]
    result = replay(path)
    assert result["match"] and result["frames"] == end["end"] < 17


def test_a_recording_stops_at_the_last_frame_a_replay_may_name(tmp_path: Path, monkeypatch):
    """A server recording past an hour of frames wrote files `twig run --replay` refuses."""
    from twig_ecs.server import replay as recording

    monkeypatch.setattr(recording, "MAX_FRAMES", 30)  # an hour, shortened
    path = tmp_path / "session.twigreplay"
    with running_server(paused=True, record=str(path)) as srv:
        with Client(port=srv.port, timeout=60) as twig:
            twig.walk(character="parent", velocity=[0.3, 0.0])
            assert twig.step(n=45)["frame"] == 45 and twig.ping() == "pong"
        assert any("a replay holds at most 30 frames" in line for line in srv.log), srv.log
    end = json.loads(path.read_text().splitlines()[-1])
    assert end["end"] == 30 and "at most 30 frames" in end["note"]
    assert replay(path)["match"]


def test_a_record_limit_past_what_a_replay_holds_is_refused(tmp_path: Path):
    command = [sys.executable, "-m", "twig_ecs", "serve", "empty", "--port", "0", "--record",
               str(tmp_path / "r.twigreplay"), "--record-limit", "100"]  # fmt: skip
    run = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "a replay holds at most 8 MiB" in run.stderr, run.stderr


# -- item 4: tokens and logging in ------------------------------------------------------------------------


def test_a_token_longer_than_200_characters_is_refused_at_start():
    # before: the server started, and nobody could log in (auth takes at most 200 characters)
    command = [sys.executable, "-m", "twig_ecs", "serve", "empty", "--port", "0", "--token", "t" * 201]
    run = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("error: the token is 201 characters long") and "at most 200" in run.stderr


def test_an_unauthenticated_client_sending_empty_lines_is_dropped_at_the_login_limit():
    with running_server(token="s3cret", paused=True) as srv:
        srv.loop.call_soon_threadsafe(setattr, srv.server, "auth_timeout", 1.0)
        time.sleep(0.1)
        with RawLines(srv.port) as chatty:
            started = time.monotonic()
            dropped = False
            while not dropped and time.monotonic() - started < 10:
                try:
                    chatty.send(b"\n")  # an empty line: nothing to answer, and no token either
                except ConnectionError:
                    dropped = True
                    break
                dropped = chatty.closed_by_server(timeout=0.2)
            assert dropped and time.monotonic() - started < 5


# -- item 5: what spawn's character mapping may hold -------------------------------------------------


def test_spawn_refuses_starting_commands_in_character_naming_them():
    with running_server(paused=True) as srv, Client(port=srv.port, timeout=60) as twig:
        # before: the body was made, standing still and looking ahead
        with pytest.raises(RemoteError) as refused:
            twig.spawn(template="humanoid", name="kid", position=[5, 0, 5],
                       character={"walk": [1, 0], "look_at": "ball"})  # fmt: skip
        assert refused.value.code == -32602
        message = refused.value.message
        assert "'walk', 'look_at'" in message and "starting commands" in message and "max_speed" in message
        with pytest.raises(RemoteError, match="unknown key.*'bogus'"):
            twig.spawn(template="humanoid", name="kid", position=[5, 0, 5], character={"bogus": 1})
        assert "kid" not in [e["name"] for e in twig.list_entities()]
        twig.spawn(template="humanoid", name="kid", position=[5, 0, 5], character={"max_speed": 3.0})
        twig.walk(character="kid", velocity=[1, 0])  # what walk in the mapping meant
        assert twig.get_state(name="kid")["walk_velocity"][0] == 1.0


# -- item 6: a world with NaN in it --------------------------------------------------------------------


def _break_the_ball(server) -> None:
    """A body whose simulation broke down (as a bad template makes one): NaN positions."""
    body = server.scene.entity("ball").body
    server.scene.state.nodes.pos[body.rows] = math.nan


def test_a_world_with_nan_is_reported_never_sent_as_broken_json():
    # before: a whole-world get_state dropped the client without an answer
    with running_server(paused=True, twig=True) as srv, RawLines(srv.port) as raw:
        srv.loop.call_soon_threadsafe(_break_the_ball, srv.server)
        time.sleep(0.1)
        answer = ask(raw, request("get_state", 1))
        assert answer["id"] == 1 and answer["error"]["code"] == -32003
        assert (
            "non-finite positions" in answer["error"]["message"]
            and "'ball' (position" in answer["error"]["message"]
        )
        both = ask(raw, [request("get_state", 2, name="ball"), request("get_state", 3, name="parent")])
        assert both[0]["error"]["code"] == -32003 and both[1]["result"]["name"] == "parent"
        assert ask(raw, request("ping", 4))["result"] == "pong"
        with RawLines(srv.twig_port) as nc:
            nc.line(), nc.line()
            nc.send(b"ball: get_state\n")
            assert nc.line().startswith(b"error -32003 the world has non-finite positions")
        # a notification carrying NaN (a contact's energy) arrives with null in its place
        srv.loop.call_soon_threadsafe(
            _notify_everyone, srv.server, "contact", {"body": "ball", "energy": math.nan}
        )
        note = json.loads(raw.line())
        assert note["method"] == "contact" and note["params"]["energy"] is None


def _notify_everyone(server, kind: str, params: dict) -> None:
    for session in server.sessions:
        session.send_event(kind, params)
