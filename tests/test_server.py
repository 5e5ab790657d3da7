"""Server mode (SPEC 6) over real loopback sockets: goals, notifications, bad input, many and slow clients."""

from __future__ import annotations

import asyncio
import json
import os
import socket
import subprocess
import sys
import time

import pytest
from server_helpers import RawLines, ask, request, running_server

from twig_ecs.cli import main
from twig_ecs.client import AsyncClient, Client, RemoteError
from twig_ecs.errors import TwigError
from twig_ecs.server.cli import check_binding
from twig_ecs.server.twigline import parse_line


def test_a_goal_returns_its_id_at_once_and_ends_with_goal_done():
    with running_server(paused=True, autonomous=False) as srv, Client(port=srv.port) as twig:
        goal = twig.gesture(character="parent", name="wave", duration=0.5)
        assert goal["behavior"] == "gesture" and isinstance(goal["goal"], int)
        assert twig.get_state(name="parent")["goals"][0]["goal"] == goal["goal"]
        assert twig.next_notification(timeout=0.05) is None  # paused: nothing happens yet
        with pytest.raises(TimeoutError, match=f"goal {goal['goal']} did not end within 0.05 s"):
            twig.wait_goal(goal["goal"], timeout=0.05)  # paused: still going - an error, not None
        twig.step(n=40)
        done = twig.wait_goal(goal["goal"], timeout=5)
        assert done is not None and done.kind == "goal.done"
        assert done["character"] == "parent" and done["behavior"] == "gesture"
        assert 30 <= done["frame"] <= 40 and done["time"] == pytest.approx(done["frame"] / 60)


def test_a_goal_that_cannot_be_done_ends_with_goal_failed_and_the_reason():
    with running_server(paused=True, autonomous=False) as srv, Client(port=srv.port) as twig:
        goal = twig.approach(character="big_child", target="ball")["goal"]
        twig.cancel_goals(character="big_child")  # the end arrives before the answer
        failed = twig.wait_goal(goal, timeout=1)
        assert failed.kind == "goal.failed" and failed["reason"] == "cancelled"


def test_notifications_arrive_in_step_order():
    with running_server(paused=True, autonomous=False) as srv, Client(port=srv.port) as twig:
        assert twig.subscribe(events="*")["subscribed"] == sorted(
            ["goal.done", "goal.failed", "behavior.changed", "pain", "contact", "grab", "release"]
        )
        long = twig.gesture(character="parent", name="wave", duration=1.0)["goal"]
        short = twig.gesture(character="small_child", name="wave", duration=0.4)["goal"]
        for _ in range(4):
            twig.step(n=20)
        notes = []
        while (note := twig.next_notification(timeout=0.2)) is not None:
            notes.append(note)
        frames = [n["frame"] for n in notes]
        assert frames == sorted(frames)
        ends = [n["goal"] for n in notes if n.kind == "goal.done"]
        assert ends == [short, long]
        changed = [n for n in notes if n.kind == "behavior.changed" and n["character"] == "parent"]
        assert changed[0]["new"] == "gesture" and changed[0]["frame"] < frames[-1]


#: A fixed command script: (method, params) run in order, paused, then the state hash.
SCRIPT = [
    ("walk", {"character": "big_child", "velocity": [0.8, 0, 0.3]}),
    ("step", {"n": 30}),
    ("look_at", {"character": "parent", "target": "ball"}),
    ("gesture", {"character": "small_child", "name": "wave", "duration": 0.3}),
    ("step", {"n": 30}),
    ("stop", {"character": "big_child"}),
    ("step", {"n": 20}),
]


def _line(rid: int, method: str, params: str) -> bytes:
    """A request line with its params written out as JSON text (which may hold NaN)."""
    return f'{{"jsonrpc": "2.0", "id": {rid}, "method": "{method}", "params": {{{params}}}}}'.encode()


#: Bad lines and the error code each must get (None: a notification, which gets no answer).
BAD_INPUT = [
    (b'{"jsonrpc": "2.0", "id": 1, "method": "status"', -32700),
    (b"\xff\xfe not utf-8", -32700),
    (b"[" * 100_000, -32700),
    (b'"a string"', -32600),
    (b"[]", -32600),
    (b'{"jsonrpc": "1.0", "id": 2, "method": "status"}', -32600),
    (b'{"jsonrpc": "2.0", "id": 3, "method": 12}', -32600),
    (b'{"jsonrpc": "2.0", "id": 4, "method": "status", "params": 5}', -32600),
    (b'{"jsonrpc": "2.0", "id": 5, "method": "explode"}', -32601),
    (_line(6, "walk", '"character": "nobody", "velocity": [1, 0]'), -32602),
    (_line(7, "walk", '"character": "big_child", "velocity": "fast"'), -32602),
    (_line(8, "walk", '"character": "big_child", "velocity": [NaN, 0]'), -32602),
    (_line(9, "walk", '"character": "big_child", "velocity": [1e400, 0]'), -32602),
    (_line(10, "step", '"n": 100000000000000000000000000'), -32602),
    (_line(11, "walk", '"character": "big_child", "velocity": [50, 0]'), -32602),
    (_line(12, "hug", '"character": "ball", "target": "parent"'), -32602),
    (_line(13, "hug", '"character": "parent", "taget": "ball"'), -32602),
    (_line(14, "hug", '"character": "parent"'), -32602),
    (_line(15, "spawn", '"template": "humanod"'), -32602),
    (b'{"jsonrpc": "2.0", "method": "explode"}', None),
]


def _run_script(raw: RawLines, bad: bool) -> str:
    rid = 100
    for method, params in SCRIPT:
        if bad:
            for line, code in BAD_INPUT:
                raw.send(line + b"\n")
                if code is not None:
                    answer = json.loads(raw.line())
                    while "method" in answer:  # a notification: skip it
                        answer = json.loads(raw.line())
                    assert answer["error"]["code"] == code, (line[:80], answer)
        rid += 1
        answer = ask(raw, request(method, rid, **params))
        assert answer["id"] == rid and "result" in answer, answer
    return ask(raw, request("status", 999))["result"]["state_hash"]


def test_each_bad_input_gets_its_error_and_the_world_is_as_without_it():
    with running_server(paused=True, autonomous=False) as srv, RawLines(srv.port) as raw:
        clean = _run_script(raw, bad=False)
    with running_server(paused=True, autonomous=False) as srv, RawLines(srv.port) as raw:
        assert _run_script(raw, bad=True) == clean


def test_error_messages_name_the_problem():
    with running_server(paused=True, autonomous=False) as srv, RawLines(srv.port) as raw:
        messages = {}
        for line, code in BAD_INPUT:
            if code == -32602:
                raw.send(line + b"\n")
                answer = json.loads(raw.line())
                messages[answer["id"]] = answer["error"]["message"]
        assert "no entity named 'nobody'" in messages[6]
        assert "'velocity' must be a list of 3 numbers" in messages[7]
        assert "'velocity[0]' must be a finite number, got NaN" in messages[8]
        assert "got Infinity" in messages[9]
        assert "'n' must be between 1 and 3600" in messages[10]
        assert "walk speed 50.00 m/s" in messages[11]
        assert "'ball' is not a character" in messages[12]
        assert "unknown parameter(s) 'taget'" in messages[13]
        assert "missing parameter 'target'" in messages[14]
        assert "humanod" in messages[15] and "humanoid" in messages[15]


def test_a_line_over_one_mebibyte_is_refused_and_the_connection_goes_on():
    with running_server(paused=True) as srv, RawLines(srv.port) as raw:
        huge = b'{"jsonrpc": "2.0", "id": 1, "method": "status", "params": {"x": "' + b"a" * (3 << 20)
        raw.send(huge[: 1 << 20] + b"a" * 200_000)
        answer = json.loads(raw.line(timeout=5))  # refused before the line ends
        assert answer["error"]["code"] == -32600 and "longer than 1048576 bytes" in answer["error"]["message"]
        raw.send(huge[(1 << 20) :] + b'"}}\n')  # the rest is skipped up to its newline
        assert ask(raw, request("ping", 2)) == {"jsonrpc": "2.0", "id": 2, "result": "pong"}


def test_a_batch_gets_one_answer_per_request_and_none_for_notifications():
    with running_server(paused=True) as srv, RawLines(srv.port) as raw:
        answers = ask(raw, [request("ping", 1), {"jsonrpc": "2.0", "method": "ping"}, request("nope", 2), 5])
        assert [a.get("id") for a in answers] == [1, 2, None]
        assert answers[0]["result"] == "pong" and answers[1]["error"]["code"] == -32601
        assert answers[2]["error"]["code"] == -32600


def test_twenty_clients_with_a_hundred_requests_each_all_get_answers():
    async def one(port: int, k: int) -> int:
        async with await AsyncClient.connect(port=port, timeout=20) as twig:
            answered = 0
            for i in range(100):
                if i % 10 == 0:
                    state = await twig.call("get_state", name="big_child")
                    answered += state["name"] == "big_child"
                else:
                    answered += (await twig.call("ping")) == "pong"
            return answered

    async def all_of(port: int) -> list[int]:
        return await asyncio.wait_for(asyncio.gather(*(one(port, k) for k in range(20))), 60)

    with running_server() as srv:
        assert asyncio.run(all_of(srv.port)) == [100] * 20


def test_a_client_that_stops_reading_does_not_hold_up_the_steps():
    with running_server(paused=True) as srv, Client(port=srv.port) as watcher:
        stalled = socket.create_connection(("127.0.0.1", srv.port))
        try:
            stalled.sendall(json.dumps(request("subscribe", 0, events="*")).encode() + b"\n")
            stalled.setblocking(False)
            flood = (json.dumps(request("get_state", 1)).encode() + b"\n") * 200_000  # 14 MB of requests
            # feed it until the server stops reading it: then the socket buffers stay full, and
            # every send is refused although the server answers the watcher in between
            sent, refused = 0, 0
            while refused < 20 and sent < len(flood):
                try:
                    sent += stalled.send(flood[sent : sent + 65536])
                    refused = 0
                except BlockingIOError:
                    refused += 1
                assert watcher.ping() == "pong"  # others are still answered
            assert sent < len(flood)  # the server stopped reading it, rather than buffering without end
            # two seconds of steps, each step's events queued for the client that reads nothing:
            # writing to it never waits, so the steps are done and answered
            at = watcher.status()["frame"]
            assert watcher.step(n=120)["frame"] == at + 120
            # and the clock goes on stepping the world (a deadline for a slow machine, not a speed)
            watcher.resume()
            deadline = time.monotonic() + 60
            while watcher.status()["frame"] < at + 150 and time.monotonic() < deadline:
                time.sleep(0.02)
            assert watcher.status()["frame"] >= at + 150
        finally:
            stalled.close()


def test_a_client_leaving_mid_goal_leaves_the_world_running():
    with running_server(paused=True, autonomous=False) as srv:
        with Client(port=srv.port) as leaver:
            leaver.approach(character="big_child", target="ball")
        with Client(port=srv.port) as twig:
            twig.step(n=60)
            state = twig.get_state(name="big_child")
            assert state["behaviour"] == "approach" and state["goals"][0]["behavior"] == "approach"
            assert twig.status()["clients"] == 1


def test_removing_an_entity_fails_the_goals_that_name_it():
    with running_server(paused=True, autonomous=False) as srv, Client(port=srv.port) as twig:
        goal = twig.carry(character="big_child", target="ball")["goal"]
        twig.step(n=10)
        twig.remove(name="ball")
        failed = twig.wait_goal(goal, timeout=1)
        assert failed.kind == "goal.failed" and failed["reason"] == "'ball' was removed"
        twig.step(n=10)
        assert "ball" not in [e["name"] for e in twig.list_entities()]


def test_spawn_control_and_remove_a_character():
    with running_server("empty", paused=True, autonomous=False) as srv, Client(port=srv.port) as twig:
        ann = twig.spawn(name="ann", template="humanoid", position=[0, 0, 0], character=True)
        assert ann == {"name": "ann"}
        twig.spawn(template="ball", position=[2, 0.2, 0])
        assert [e["name"] for e in twig.list_entities()] == ["ann", "ball1"]
        assert twig.get_state(name="ann")["autonomous"] is False
        twig.set_autonomous(character="ann", autonomous=True)
        twig.walk(character="ann", velocity=[1, 0])
        twig.step(n=60)
        state = twig.get_state(name="ann")
        assert state["autonomous"] is True and state["position"][0] > 0.5
        with pytest.raises(RemoteError, match="already exists"):
            twig.spawn(name="ann", template="ball")
        twig.remove(name="ball1")
        assert [e["name"] for e in twig.list_entities()] == ["ann"]


def test_step_needs_a_paused_world_and_pause_resume_switch_the_clock():
    with running_server() as srv, Client(port=srv.port) as twig:
        with pytest.raises(RemoteError) as err:
            twig.step(n=1)
        assert err.value.code == -32001
        at = twig.pause()["frame"]
        time.sleep(0.1)
        assert twig.status()["frame"] == at
        assert twig.step(n=5)["frame"] == at + 5
        twig.resume()
        deadline = time.monotonic() + 5
        while twig.status()["frame"] < at + 10 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert twig.status()["frame"] >= at + 10


def test_with_a_window_the_server_draws_every_frame_and_keeps_the_clock():
    with running_server(window=True) as srv, Client(port=srv.port) as twig:
        viewer = srv.server.window.viewer  # read-only peeks from this thread
        frame0, drawn0 = twig.status()["frame"], viewer.frames
        # it steps and draws as it runs (a deadline for a slow machine, not a speed)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (
            twig.status()["frame"] < frame0 + 20 or viewer.frames < drawn0 + 10
        ):
            time.sleep(0.02)
        frames, drawn = twig.status()["frame"] - frame0, viewer.frames - drawn0
        assert frames >= 20 and drawn >= 10
        at = twig.pause()["frame"]
        assert twig.step(n=3)["frame"] == at + 3
        time.sleep(0.1)
        assert viewer.paused and viewer.frames > drawn0 + drawn


def test_the_twig_line_protocol_works_from_a_raw_socket():
    with running_server(twig=True, paused=True, autonomous=False) as srv, RawLines(srv.twig_port) as nc:
        assert nc.line() == b"TwigServer"
        assert nc.line().startswith(b"twig-ecs ")
        nc.send(b"server: subscribe goal.done goal.failed\n")
        assert nc.line() == b'ok {"subscribed":["goal.done","goal.failed"]}'
        nc.send(b"parent: gesture wave duration=0.25\n")
        reply = nc.line()
        assert reply.startswith(b"ok ") and json.loads(reply[3:])["behavior"] == "gesture"
        nc.send(b"big_child: look_at [1, 0.5, 4]\r\nbig_child: walk (0.5 0)\nparent: hug\n")
        assert nc.line() == b"ok"
        assert nc.line() == b"ok"
        assert nc.line() == b"error -32602 hug: missing parameter 'target'"
        nc.send(b"server: step 20\n")
        event, ok = nc.line(), nc.line()
        assert event.startswith(b"event goal.done ")
        assert json.loads(event.split(b" ", 2)[2])["character"] == "parent"
        assert ok.startswith(b"ok ") and json.loads(ok[3:])["frame"] == 20
        nc.send(b"ball: get_state\nnobody: stop\nparent: pause\njust words\nserver: explode\n")
        assert json.loads(nc.line()[3:])["name"] == "ball"
        assert nc.line().startswith(b"error -32602 no entity named 'nobody'")
        assert nc.line() == b"error -32602 'pause' is a server method: write 'server: pause ...'"
        assert nc.line().startswith(b"error -32600 expected 'objectname: methodname")
        assert nc.line().startswith(b"error -32601 unknown method 'explode'")


def test_twig_line_arguments_map_onto_method_parameters():
    assert parse_line("ann: walk [1 0 2]") == ("walk", {"character": "ann", "velocity": [1, 0, 2]})
    assert parse_line('ann: gesture point target="ball" duration=1.5') == (
        "gesture",
        {"character": "ann", "name": "point", "target": "ball", "duration": 1.5},
    )
    assert parse_line("ann: approach (1, 0, 2) 0.5 direction=[0 1] curl=false arms=null") == (
        "approach",
        {"character": "ann", "target": [1, 0, 2], "stop_distance": 0.5, "direction": [0, 1], "curl": False,
         "arms": None},
    )  # fmt: skip
    assert parse_line("server: get_state ann") == ("get_state", {"name": "ann"})
    assert parse_line("ball2: spawn ball [0 2 0]") == ("spawn", {"name": "ball2", "template": "ball",
                                                                 "position": [0, 2, 0]})  # fmt: skip
    assert parse_line("world: subscribe pain contact") == ("subscribe", {"events": ["pain", "contact"]})


def test_a_non_loopback_address_needs_a_token(capsys):
    with pytest.raises(TwigError, match="--token"):
        check_binding("0.0.0.0", None)
    check_binding("0.0.0.0", "secret")
    check_binding("127.0.0.1", None)
    check_binding("::1", None)
    assert main(["serve", "empty", "--host", "0.0.0.0"]) == 2
    assert "not loopback" in capsys.readouterr().err


def test_a_token_must_come_first_when_the_server_has_one():
    with running_server(token="s3cret", paused=True) as srv:
        with RawLines(srv.port) as raw:
            answer = ask(raw, request("status", 1))
            assert answer["error"]["code"] == -32002
            assert raw.closed_by_server()
        with RawLines(srv.port) as raw:
            assert ask(raw, request("auth", 1, token="guess"))["error"]["message"] == "wrong token"
            assert raw.closed_by_server()
        with Client(port=srv.port, token="s3cret") as twig:
            assert twig.status()["scene"] == "schoolyard"


def test_twig_serve_runs_as_a_command_and_stops_on_sigterm():
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "twig_ecs", "serve", "empty", "--port", "0", "--paused"],
                            stderr=subprocess.PIPE, text=True, env=env)  # fmt: skip
    try:
        line = ""
        deadline = time.monotonic() + 60
        while "port" not in line and time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line and proc.poll() is not None:
                break
        assert "JSON-RPC" in line, line
        port = int(line.split(" port ")[1].split()[0])
        with Client(port=port) as twig:
            assert twig.status()["paused"] is True
        proc.terminate()
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stderr.close()
