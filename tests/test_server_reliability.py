"""The server survives hostile clients and failing steps (issue 16: items 1, 2, 4, 5, 6, 11).

Every test talks to a real server over loopback sockets and waits with bounded timeouts.
"""

from __future__ import annotations

import json

import pytest
from server_helpers import RawLines, running_server

from twig_ecs.client import Client, RemoteError
from twig_ecs.scene import Scene

_REAL_STEP = Scene.step


def ask(raw: RawLines, payload: bytes | str | dict | list) -> dict | list:
    """Send one line, return the decoded answer line (notifications skipped)."""
    if isinstance(payload, dict | list):
        payload = json.dumps(payload)
    if isinstance(payload, str):
        payload = payload.encode()
    raw.send(payload + b"\n")
    while True:
        answer = json.loads(raw.line())
        if not (isinstance(answer, dict) and "method" in answer):
            return answer


def request(method: str, rid: int = 1, **params) -> dict:
    return {"jsonrpc": "2.0", "id": rid, "method": method, "params": params}


# -- item 1: text that cannot be encoded ---------------------------------------------------------


def test_a_lone_surrogate_in_a_twig_line_gets_an_error_and_the_server_keeps_answering():
    with running_server(twig=True, paused=True) as srv, RawLines(srv.twig_port) as nc:
        assert nc.line() == b"TwigServer"
        nc.line()
        nc.send(b'server: get_state "\\ud800"\n')
        reply = nc.line()
        assert reply.startswith(b"error -32602 "), reply
        reply.decode("utf-8")  # what comes back is valid UTF-8
        nc.send(b"server: ping\n")
        assert nc.line() == b'ok "pong"'


def test_a_name_that_is_not_unicode_text_is_refused_by_json_rpc():
    with running_server(twig=True, paused=True) as srv, RawLines(srv.port) as raw:
        answer = ask(raw, '{"jsonrpc":"2.0","id":1,"method":"spawn","params":{"template":"ball",'
                          '"name":"\\udcff"}}')  # fmt: skip
        assert answer["error"]["code"] == -32602
        assert "not valid Unicode" in answer["error"]["message"]
        with RawLines(srv.twig_port) as nc:
            nc.line(), nc.line()
            nc.send(b"server: get_state balll\n")
            assert nc.line().startswith(b"error -32602 no entity named 'balll'")
        assert ask(raw, request("ping", 2))["result"] == "pong"


# -- item 2: an exception inside a step ---------------------------------------------------------


def test_a_body_reusing_a_characters_name_does_not_stop_the_server():
    """`remove parent`, `spawn ball named parent`: the watcher must not break on the ball."""
    with running_server(paused=True) as srv, Client(port=srv.port) as twig:
        twig.call("remove", name="parent")
        twig.call("spawn", template="ball", name="parent", position=[0, 1, 0])
        twig.call("step", n=900)  # the small child glances back at its caregiver near frame 520
        twig.call("resume")
        twig.call("pause")
        assert twig.call("ping") == "pong"
        assert twig.call("get_state", name="parent")["template"] == "ball"


def test_a_failing_step_rolls_the_world_back_pauses_and_reports_simulation_error():
    with running_server(paused=True) as srv, Client(port=srv.port) as twig:
        twig.call("step", n=10)
        before = twig.call("status")
        srv.loop.call_soon_threadsafe(_break_next_step, srv.server)
        twig.call("resume")
        note = twig.wait_for(lambda n: n.kind == "simulation.error", timeout=30)
        assert note is not None
        assert "boom" in note["message"]
        after = twig.call("status")
        assert after["paused"] is True
        assert after["frame"] == note["frame"]
        assert twig.call("ping") == "pong"
        # the failed step left nothing half-done: the state hash is that of a clean run
        with running_server(paused=True) as clean_srv, Client(port=clean_srv.port) as clean:
            clean.call("step", n=after["frame"])
            assert clean.call("status")["state_hash"] == after["state_hash"]
        assert before["frame"] <= after["frame"]


def _break_next_step(server, every: bool = False) -> None:
    """Make the next step (``every``: each step) move the nodes, then raise (a bug mid-step)."""
    cls = Scene
    real_step = cls.step

    def broken(self, n=1):
        if self is not server.scene:
            return real_step(self, n)
        if not every:
            cls.step = real_step
        self.state.nodes.pos[: self.state.nodes.count] += 0.5  # half a step's work
        raise RuntimeError("boom")

    cls.step = broken


def test_resume_after_a_failed_step_does_not_stop_the_server():
    with running_server(paused=True) as srv, Client(port=srv.port) as twig:
        srv.loop.call_soon_threadsafe(_break_next_step, srv.server, True)
        try:
            _fail_twice(twig)
        finally:
            Scene.step = _REAL_STEP


def _fail_twice(twig: Client) -> None:
    with pytest.raises(RemoteError, match="boom"):
        twig.call("step", n=5)
    assert twig.call("status")["frame"] == 0
    twig.call("resume")  # fails again at once: rolled back, paused, still answering
    assert twig.wait_for(lambda n: n.kind == "simulation.error", timeout=30) is not None
    status = twig.call("status")
    assert status["paused"] is True and status["frame"] == 0
    assert twig.call("ping") == "pong"


# -- item 4: auth -----------------------------------------------------------------------------------


def test_a_wrong_token_in_a_batch_ends_the_connections_work():
    with running_server(token="s3cret", paused=True) as srv, RawLines(srv.port) as raw:
        batch = [request("auth", 1, token="guess"), request("auth", 2, token="s3cret"),
                 request("spawn", 3, template="ball", name="smuggled")]  # fmt: skip
        answers = ask(raw, batch)
        assert answers[0]["error"]["message"] == "wrong token"
        assert all(a.get("error") for a in answers), answers
        assert raw.closed_by_server()
        with Client(port=srv.port, token="s3cret") as twig:
            names = [e["name"] for e in twig.call("list_entities")]
            assert "smuggled" not in names
