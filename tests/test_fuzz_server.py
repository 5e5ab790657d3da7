"""Fuzzing the server over a real loopback socket: random JSON, random parameters for every method.

Two properties, checked after every example:

* the server never crashes: every request with an id is answered, no answer is an
  internal error, and ``ping`` still works;
* the world changes only through valid commands: a control scene in this process
  gets exactly the commands the server answered with success, and after two more
  steps both have the same ``state_hash``.

The budget is fixed and the examples derandomized; ``TWIG_FUZZ_EXAMPLES=N`` runs longer.
"""

from __future__ import annotations

import json
import math
import os

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from server_helpers import RawLines, running_server

from twig_ecs import Scene
from twig_ecs.replay import HeadlessSession
from twig_ecs.server.core import Server
from twig_ecs.server.methods import EVENT_KINDS, METHODS, Param, bind
from twig_ecs.server.protocol import INTERNAL_ERROR, RPCError, parse_request
from twig_ecs.server.twigline import parse_line

EXAMPLES = int(os.environ.get("TWIG_FUZZ_EXAMPLES", "0")) or None
FUZZ = settings(
    max_examples=EXAMPLES or 200,
    deadline=None,
    derandomize=EXAMPLES is None,
    database=None,
    suppress_health_check=list(HealthCheck),
)
#: ``resume`` would let the server run in real time, beyond the control's reach.
FUZZED = sorted(name for name in METHODS if name != "resume")
CHARACTERS = ("parent", "small_child", "big_child")
NAMES = ("parent", "small_child", "big_child", "ball", "ragdoll", "merry_go_round", "bench", "nobody", "")
TEMPLATES = ("ball", "ragdoll", "humanoid", "bench", "no_such_template")

json_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(min_value=10**19, max_value=10**40),
    st.floats(),
    st.text(max_size=30),
)
json_values = st.recursive(
    json_scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6), st.dictionaries(st.text(max_size=8), inner, max_size=6)
    ),
    max_leaves=30,
)
numbers = st.one_of(
    st.floats(-5, 5), st.integers(-3, 3), st.floats(), st.integers(), st.sampled_from([1e308, -1e7])
)
vectors = st.one_of(
    st.lists(st.floats(-5, 5), min_size=2, max_size=3),
    st.lists(numbers, min_size=0, max_size=5),
    st.just([0.0] * 100_000),
)
names = st.one_of(st.sampled_from(NAMES), st.text(max_size=6), st.just("x" * 5000))
BY_KIND = {
    "name": names,
    "str": st.one_of(
        st.sampled_from(TEMPLATES + ("hug", "approach", "gesture", "dance")), st.text(max_size=10)
    ),
    "number": numbers,
    "int": st.one_of(st.integers(-5, 40), st.integers(), st.floats(0, 50)),
    "bool": st.booleans(),
    "vector": vectors,
    "target": st.one_of(names, vectors),
    "choice": st.sampled_from(("left", "right", "both", "wave", "point", "reach", "hug", "grapple", "bogus")),
    "kinds": st.one_of(
        st.lists(st.sampled_from(EVENT_KINDS + ("*", "nope")), max_size=3), st.text(max_size=5)
    ),
    "object": st.one_of(
        st.booleans(),
        st.dictionaries(st.sampled_from(("target", "duration", "to", "x")), json_values, max_size=3),
    ),  # fmt: skip
    "color": st.one_of(st.lists(st.floats(0, 1), min_size=3, max_size=3), json_values),
}


GOALS = ("approach", "hug", "grapple", "carry", "drag", "sit", "stand", "freeze", "gesture", "dance")


def valid(p: Param) -> st.SearchStrategy:
    """Values that pass the parameter's own checks (the world may still refuse them)."""
    if p.kind == "name":
        return st.sampled_from(
            {"name": ("b1", "b2", "ragdoll"), "character": CHARACTERS}.get(p.name, NAMES[:-2])
        )
    if p.kind == "str":
        return st.sampled_from({"template": TEMPLATES, "behavior": GOALS}.get(p.name, ("t",)))
    if p.kind == "number":
        return st.floats(max(p.low, -5.0), min(p.high, 5.0))
    if p.kind == "int":
        return st.integers(max(int(p.low), 1), min(int(p.high), 40))
    if p.kind in ("vector", "target"):
        points = st.lists(st.floats(-4, 4), min_size=3, max_size=3)
        return st.one_of(points, st.sampled_from(NAMES[:-2])) if p.kind == "target" else points
    if p.kind == "choice":
        return st.sampled_from(p.choices)
    if p.kind == "kinds":
        return st.lists(st.sampled_from(EVENT_KINDS), min_size=1, max_size=3)
    if p.kind == "object":
        goal_params = {
            "target": st.sampled_from(NAMES[:-2]),
            "duration": st.floats(0, 2),
            "hand": valid(_HAND),
        }
        return st.one_of(st.booleans(), st.fixed_dictionaries({}, optional=goal_params))
    if p.kind == "color":
        return st.lists(st.floats(0, 1), min_size=3, max_size=3)
    return BY_KIND[p.kind]


_HAND = Param("hand", "choice", choices=("left", "right"))


@st.composite
def method_calls(draw) -> dict:
    """A request for a real method, with parameters mostly valid, sometimes of any kind or left out."""
    method = METHODS[draw(st.sampled_from(FUZZED))]
    params = {}
    for p in method.params:
        how = draw(st.integers(0, 19))
        if how == 0:
            continue  # left out
        params[p.name] = draw(json_values if how == 1 else BY_KIND[p.kind] if how < 4 else valid(p))
    if draw(st.integers(0, 19)) == 0:
        params[draw(st.text(max_size=6))] = draw(json_values)
    request = {"jsonrpc": "2.0", "id": draw(st.integers(1, 10**6)), "method": method.name, "params": params}
    if draw(st.integers(0, 9)) == 0:
        request["params"] = list(params.values())  # by position
    return request


lines = st.one_of(
    method_calls(),
    st.lists(method_calls(), min_size=1, max_size=4).map(lambda batch: _distinct_ids(batch)),
    json_values,
    st.fixed_dictionaries(
        {
            "jsonrpc": st.sampled_from(["2.0", "1.0", 2]),
            "id": json_values,
            "method": st.one_of(st.sampled_from(FUZZED), json_values),
        },
        optional={"params": json_values, "extra": json_values},
    ),  # fmt: skip
)


def _call(method: str, **params) -> dict:
    return {"jsonrpc": "2.0", "id": 1, "method": method, "params": params}


def _distinct_ids(batch: list[dict]) -> list[dict]:
    for k, item in enumerate(batch):
        item["id"] = k + 1
    return batch


class Control:
    """The same scene in this process, given only the commands the server accepted."""

    def __init__(self) -> None:
        self.scene = Scene.load("schoolyard", seed=0)
        self.server = Server(self.scene, paused=True, log=lambda text: None)

    def apply(self, request: dict) -> None:
        method = METHODS[request["method"]]
        params = bind(method, request.get("params", {}))
        if method.name == "step":
            self.scene.step(params["n"])
        elif method.name != "pause" and method.queued:
            method.fn(self.server, HeadlessSession(), **params)
            self.server._flush()  # noqa: SLF001 - as the server does after each command


@pytest.fixture(scope="module")
def served():
    with running_server(paused=True) as srv:
        raw = RawLines(srv.port, timeout=30.0)
        control = Control()
        try:
            yield raw, control
        finally:
            control.scene.close()
            raw.sock.close()


def exchange(raw: RawLines, payload: bytes, expect: int) -> list[dict]:
    """Send one line; collect ``expect`` answers (notifications skipped)."""
    raw.send(payload + b"\n")
    answers: list[dict] = []
    while len(answers) < expect:
        message = json.loads(raw.line())
        if isinstance(message, dict) and "method" in message and "id" not in message:
            continue  # a notification (a fuzzed subscribe)
        answers.extend(message if isinstance(message, list) else [message])
    return answers


def _is_notification(obj) -> bool:
    """A well-formed request without an id: the server never answers it."""
    try:
        return parse_request(obj).notify
    except RPCError:
        return False


def _expected_answers(obj) -> int:
    """How many answers a line gets: one, or one per batch item that is not a notification."""
    if isinstance(obj, list) and obj:
        return sum(not _is_notification(item) for item in obj)
    return 0 if _is_notification(obj) else 1


@pytest.mark.slow  # 200 requests to a served schoolyard
@FUZZ
@given(lines)
@example({"jsonrpc": "2.0", "id": math.inf, "method": "ping"})
@example({"jsonrpc": "2.0", "id": -math.inf, "method": "status"})
@example([{"jsonrpc": "2.0", "id": 1e400, "method": "ping"}])
@example(_call("do", character="parent", behavior="hug", params={"target": [1, 2]}))
@example(_call("do", character="parent", behavior="carry", params={"target": "ball", "hand": 3}))
@example(_call("grapple", character="big_child", target="merry_go_round"))
@example(_call("do", character="parent", behavior="freeze", params={"on_end": "x", "duration": 1}))
@example(_call("do", character="parent", behavior="sit", params={"behavior": "x", "character": "y"}))
@example(_call("spawn", template="ball", position=[0, 1e300, 0]))
@example(_call("walk", character="parent", velocity=[1e5, 0, 0]))
@example(_call("spawn", template="humanoid", name="kid", character={"walk": [1, 0], "bogus": 1}))
def test_random_requests_never_crash_the_server_nor_change_the_world_unasked(served, obj):
    raw, control = served
    if _is_notification(obj):
        obj = {**obj, "id": 0}  # a valid notification could change the world unanswered: ask instead
    payload = json.dumps(obj).encode()
    answers = exchange(raw, payload, _expected_answers(obj))
    by_id = {a.get("id"): a for a in answers}
    assert not [a for a in answers if a.get("error", {}).get("code") == INTERNAL_ERROR], answers
    requests = obj if isinstance(obj, list) else [obj]
    for request in requests:
        try:
            rid = parse_request(request).id  # only well-formed requests can have succeeded
        except RPCError:
            continue
        if "result" in by_id.get(rid, {}):
            control.apply(request)
    (status,) = exchange(raw, b'{"jsonrpc":"2.0","id":"s","method":"step","params":{"n":2}}', 1)
    control.scene.step(2)
    assert status["result"]["frame"] == control.scene.frame
    assert status["result"]["state_hash"] == control.scene.state_hash(), f"after {payload[:300]!r}"
    (pong,) = exchange(raw, b'{"jsonrpc":"2.0","id":"p","method":"ping"}', 1)
    assert pong["result"] == "pong"


def test_huge_and_deep_lines_are_refused_and_the_server_carries_on(served):
    raw, _control = served
    (deep,) = exchange(raw, b"[" * 200_000 + b"]" * 200_000, 1)
    assert deep["error"]["code"] == -32700
    (long,) = exchange(
        raw, b'{"jsonrpc":"2.0","id":1,"method":"ping","params":{"x":"' + b"y" * (2 << 20) + b'"}}', 1
    )
    assert long["error"]["code"] == -32600 and "longer than" in long["error"]["message"]
    (batch,) = exchange(raw, json.dumps([{"jsonrpc": "2.0", "method": "ping"}] * 20_000).encode(), 1)
    assert batch["error"]["code"] == -32600 and "at most 256" in batch["error"]["message"]
    (pong,) = exchange(raw, b'{"jsonrpc":"2.0","id":"p","method":"ping"}', 1)
    assert pong["result"] == "pong"


twig_words = st.one_of(
    st.sampled_from(("parent:", "server:", "ball:", "walk", "hug", "spawn", "[", "]", "(", ")", ",", '"',
                     "x=", "=", "true", "null", "1e400", "-0", "[1 0", "99999999999999999999999"),),
    st.text(max_size=6),
)  # fmt: skip


@FUZZ
@given(st.lists(twig_words, max_size=12).map(" ".join))
@example("parent: walk " + "[" * 50_000)
@example("server: spawn ball " + "]" * 100)
def test_random_twig_lines_parse_or_raise_rpc_error(line):
    try:
        name, params = parse_line(line)
    except RPCError as exc:
        assert exc.message
    else:  # an unknown method name comes back too: the call then reports it
        assert name and " " not in name and isinstance(params, dict)
