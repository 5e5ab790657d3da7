"""A mixed hostile session for a running server: random Twig lines and JSON-RPC requests,
spawns and removals of every body kind (names reused across kinds), goals, steps.

Used by ``tests/test_fuzz_mix.py`` (a short run in CI) and ``benchmarks/fuzz_server_mix.py``
(1,000 operations or more). :func:`run_mix` returns what happened; the caller checks that
the server still answers and that no position or velocity is NaN.
"""

from __future__ import annotations

import json
import math
import random
from dataclasses import dataclass, field

from server_helpers import RawLines

TEMPLATES = ("ball", "bench", "humanoid", "merry_go_round", "post", "ragdoll")
GOALS = ("hug", "grapple", "carry", "drag", "approach", "sit", "stand", "freeze", "gesture")
CONTROLS = ("walk", "stop", "look_at", "reach", "grab", "release", "cancel_goals", "set_autonomous")
WORDS = ("parent", "small_child", "big_child", "ball", "ragdoll", "merry_go_round", "nobody", "x", "",
         "true", "null", "1e308", "-0", "[1 2]", "(0,0,0)", '"\\ud800"', "[[[1]]]", "key=", "=1")  # fmt: skip

#: Lines that are not requests, or not good ones (all answered except the notification).
JUNK = (b"{", b"[]", b'{"jsonrpc":"2.0","method":"walk","params":{"character":1}}',
        b'[{"jsonrpc":"2.0","id":1,"method":"ping"}, 5, {"id": null}]', b"\xff\xfe")  # fmt: skip


@dataclass
class MixResult:
    """Counts of what the session sent and got back."""

    sent: int = 0
    ok: int = 0
    errors: dict[int, int] = field(default_factory=dict)
    internal: list[str] = field(default_factory=list)  # -32603 messages (bugs, or failed steps)
    simulation_errors: list[str] = field(default_factory=list)


def _vec(rng: random.Random, spread: float = 8.0) -> list[float]:
    return [round(rng.uniform(-spread, spread), 2), round(rng.uniform(0.0, 2.0), 2),
            round(rng.uniform(-spread, spread), 2)]  # fmt: skip


class _Mixer:
    def __init__(self, port: int, twig_port: int, seed: int) -> None:
        self.rng = random.Random(seed)
        self.json = RawLines(port, timeout=120)
        self.twig = RawLines(twig_port, timeout=120)
        self.twig.line(), self.twig.line()  # greeting
        self.names = ["parent", "small_child", "big_child", "ball", "ragdoll", "merry_go_round"]
        self.result = MixResult()
        self.ids = 0

    def call(self, method: str, **params) -> dict:
        """One JSON-RPC call; notifications met on the way are noted."""
        self.ids += 1
        rid = self.ids
        self.json.send(json.dumps({"jsonrpc": "2.0", "id": rid, "method": method, "params": params}).encode()
                       + b"\n")  # fmt: skip
        return self._answer(rid)

    def _answer(self, rid) -> dict:
        while True:
            answer = json.loads(self.json.line())
            if isinstance(answer, dict) and answer.get("method") == "simulation.error":
                self.result.simulation_errors.append(answer["params"]["message"])
                continue
            if isinstance(answer, dict) and "method" in answer:
                continue
            self._count(answer)
            if not isinstance(answer, dict) or answer.get("id") == rid or rid is None:
                return answer

    def _count(self, answer) -> None:
        self.result.sent += 1
        items = answer if isinstance(answer, list) else [answer]
        for item in items:
            if "error" in item:
                code = item["error"]["code"]
                self.result.errors[code] = self.result.errors.get(code, 0) + 1
                if code == -32603:
                    self.result.internal.append(item["error"]["message"])
            else:
                self.result.ok += 1

    def twig_line(self, text: str) -> bytes:
        self.twig.send(text.encode("utf-8", "surrogatepass") + b"\n")
        while True:
            line = self.twig.line()
            if not line.startswith(b"event "):
                self.result.sent += 1
                if line.startswith(b"error -32603"):
                    self.result.internal.append(line.decode(errors="replace"))
                return line

    # -- one random operation -------------------------------------------------------------

    def step(self) -> None:
        rng = self.rng
        roll = rng.random()
        name = rng.choice(self.names) if self.names else "nobody"
        if roll < 0.15:
            template = rng.choice(TEMPLATES)
            fresh = rng.choice([f"{template}_{self.ids}", rng.choice(self.names or ["x"]), "parent"])
            params = {"template": template, "name": fresh, "position": _vec(rng)}
            if rng.random() < 0.3:
                params["height"] = round(rng.uniform(0.05, 12.0), 2)
            answer = self.call("spawn", **params)
            if "result" in answer:
                self.names.append(answer["result"]["name"])
        elif roll < 0.25:
            answer = self.call("remove", name=name)
            if "result" in answer and name in self.names:
                self.names.remove(name)
        elif roll < 0.45:
            goal = rng.choice(GOALS)
            params = {"character": name}
            if goal in ("hug", "grapple", "carry", "drag"):
                params["target"] = rng.choice(self.names or ["x"])
            elif goal == "approach":
                params["target"] = rng.choice([rng.choice(self.names or ["x"]), _vec(rng)])
            elif goal == "sit" and rng.random() < 0.5:
                params["on"] = rng.choice(self.names or ["x"])
            elif goal == "gesture":
                params.update(name=rng.choice(["wave", "point"]), target=rng.choice(self.names or ["x"]))
            self.call(goal, **params)
        elif roll < 0.6:
            control = rng.choice(CONTROLS)
            params = {"character": name}
            if control == "walk":
                params["velocity"] = [round(rng.uniform(-3, 3), 2), 0.0, round(rng.uniform(-3, 3), 2)]
            elif control in ("look_at", "reach"):
                params["target"] = rng.choice([rng.choice(self.names or ["x"]), _vec(rng)])
            elif control == "grab":
                params["target"] = rng.choice(self.names or ["x"])
            elif control == "set_autonomous":
                params["autonomous"] = rng.random() < 0.5
            self.call(control, **params)
        elif roll < 0.8:
            method = rng.choice(["get_state", "walk", "hug", "spawn", "remove", "look_at", "step", "status",
                                 "do", "grab", "sit", rng.choice(WORDS)])  # fmt: skip
            obj = rng.choice([name, "server", rng.choice(WORDS) or "x"])
            args = " ".join(rng.choice(WORDS) for _ in range(rng.randint(0, 4)))
            self.twig_line(f"{obj}: {method} {args}")
        elif roll < 0.9:
            self.call("step", n=rng.randint(1, 30))
        else:
            junk = rng.choice(JUNK)
            self.json.send(junk + b"\n")
            if b'"method":"walk"' not in junk:  # a notification (no id) gets no answer, even a bad one
                self._answer(None)

    def close(self) -> None:
        self.json.close()
        self.twig.close()


def run_mix(port: int, twig_port: int, operations: int, seed: int = 0) -> MixResult:
    """Run ``operations`` random operations against a paused server, then step it a second."""
    mixer = _Mixer(port, twig_port, seed)
    try:
        for _ in range(operations):
            mixer.step()
        mixer.call("step", n=60)
        return mixer.result
    finally:
        mixer.close()


def world_is_finite(state: dict) -> list[str]:
    """Names of entities whose position or velocity holds a NaN or an infinity."""
    bad = []
    for name, entity in state["entities"].items():
        numbers = [*entity["position"], *entity["velocity"]]
        if not all(math.isfinite(x) for x in numbers):
            bad.append(name)
    return bad
