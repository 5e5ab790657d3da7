"""The original Twig line protocol: ``objectname: methodname arg1 arg2 ...`` over TCP.

On connect the server sends ``TwigServer`` and a version line. Each line the client sends
is one call, answered in order by one line: ``ok <result as JSON>`` or ``error <code>
<message>``. Notifications arrive as ``event <kind> <params as JSON>`` lines.

Arguments are whitespace-separated: numbers (``1.5``, ``-2``), vectors (``[1 0 2]``,
``[1, 0, 2]`` or ``(1, 0, 2)``), ``true`` / ``false``, ``null``, double-quoted strings
(``"a b"``) and bare words (entity names, hands, gesture names). ``key=value`` gives a
parameter by name. The object name fills the method's subject (the character for a
character method, the entity for ``get_state``, ``remove`` and ``spawn``); ``server``
(or ``world``) calls a method with positional arguments in the order of its parameters
- see docs/server.md for the table.
"""

from __future__ import annotations

import json
import re
from typing import Any

from twig_ecs.server import protocol as rpc
from twig_ecs.server.methods import find_method
from twig_ecs.server.protocol import RPCError
from twig_ecs.server.session import MAX_ANSWER, Session
from twig_ecs.version import __version__

#: Object names that address the server itself rather than an entity.
SERVER_OBJECTS = ("server", "world", "twig")
GREETING = f"TwigServer\ntwig-ecs {__version__}\n".encode()

_TOKEN = re.compile(
    r'\s*(?:(?P<str>"(?:[^"\\]|\\.)*")|(?P<open>[\[(])|(?P<close>[\])])|(?P<comma>,)|(?P<word>[^\s\[\]()",]+))'
)
#: Deepest nesting of brackets an argument may have (a vector needs 1).
MAX_DEPTH = 8
_WORDS = {"true": True, "false": False, "null": None, "nil": None, "none": None}


def _atom(word: str) -> Any:
    low = word.lower()
    if low in _WORDS:
        return _WORDS[low]
    try:
        return int(word) if re.fullmatch(r"[+-]?\d{1,20}", word) else float(word)
    except ValueError:
        return word


def parse_args(text: str) -> tuple[list[Any], dict[str, Any]]:
    """Positional and ``key=value`` arguments of a line's tail."""
    args: list[Any] = []
    named: dict[str, Any] = {}
    stack: list[list[Any]] = []
    key: str | None = None
    pos = 0
    text = text.rstrip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise RPCError(rpc.INVALID_REQUEST, f"cannot read the arguments from {text[pos : pos + 20]!r}")
        pos = m.end()
        if m["comma"]:
            continue
        if m["open"]:
            if len(stack) >= MAX_DEPTH:
                raise RPCError(rpc.INVALID_REQUEST, f"brackets nested more than {MAX_DEPTH} deep")
            stack.append([])
            continue
        if m["close"]:
            if not stack:
                raise RPCError(rpc.INVALID_REQUEST, "unbalanced ']' or ')'")
            value: Any = stack.pop()
        elif m["str"]:
            try:
                value = json.loads(m["str"])
            except ValueError:
                raise RPCError(rpc.INVALID_REQUEST, f"bad string {m['str'][:40]}") from None
        else:
            word = m["word"]
            if not stack and key is None and "=" in word:
                key, _, rest = word.partition("=")
                if not rest:
                    continue  # key= [1 2 3]: the value follows
                word = rest
            value = _atom(word)
        if stack:
            stack[-1].append(value)
        elif key is not None:
            named[key] = value
            key = None
        else:
            args.append(value)
    if stack:
        raise RPCError(rpc.INVALID_REQUEST, "unclosed '[' or '('")
    if key is not None:
        raise RPCError(rpc.INVALID_REQUEST, f"'{key}=' has no value")
    return args, named


def parse_line(line: str, scene: Any = None) -> tuple[str, dict[str, Any]]:
    """``objectname: methodname args`` as a method name and its parameters by name.

    ``scene``: the served scene, whose plug-in goal behaviours are methods too.
    """
    head, sep, tail = line.partition(":")
    obj = head.strip()
    if not sep or not obj or " " in obj:
        raise RPCError(rpc.INVALID_REQUEST, "expected 'objectname: methodname arg1 arg2 ...'")
    parts = tail.strip().split(None, 1)
    if not parts:
        raise RPCError(rpc.INVALID_REQUEST, f"'{obj}:' names no method")
    name = parts[0]
    args, named = parse_args(parts[1] if len(parts) > 1 else "")
    method = find_method(name, scene)
    if method is None:
        return name, named  # the call reports the unknown method
    slots = [p for p in method.params]
    params = dict(named)
    if obj.lower() not in SERVER_OBJECTS:
        if method.subject is None:
            raise RPCError(rpc.INVALID_PARAMS, f"'{name}' is a server method: write 'server: {name} ...'")
        params[method.subject] = obj
        slots = [p for p in slots if p.name != method.subject]
    if slots and slots[-1].kind == "kinds" and len(args) > len(slots):  # subscribe a b c
        args = args[: len(slots) - 1] + [args[len(slots) - 1 :]]
    if len(args) > len(slots):
        raise RPCError(rpc.INVALID_PARAMS, f"{name} takes at most {len(slots)} argument(s), got {len(args)}")
    for p, value in zip(slots, args, strict=False):
        if p.name in params:
            raise RPCError(rpc.INVALID_PARAMS, f"'{p.name}' is given twice")
        params[p.name] = value
    return name, params


def _json(value: Any) -> str:
    return rpc.dumps(value).decode().rstrip("\n")


class TwigSession(Session):
    """A line-protocol client (netcat will do): one call per line, answers in order."""

    inflight_limit = 1

    async def greet(self) -> None:
        self.write(GREETING)

    def send_event(self, kind: str, params: dict[str, Any]) -> None:
        try:
            text = _json(params)
        except ValueError:  # NaN from a broken world: sent as null rather than not at all
            text = _json(rpc.finite(params))
        self.write(f"event {kind} {text}\n".encode())

    def _answer(self, result: Any, error: RPCError | None) -> None:
        text = None
        if error is None and result is not None:
            try:
                text = _json(result)
            except (ValueError, TypeError) as exc:  # never broken JSON: the error in its place
                error = rpc.unwritable(exc)
        if error is not None:
            message = " ".join(error.message.split())
            # backslashreplace: a lone surrogate a client sent (or a name holding one) comes back
            # escaped instead of breaking the encoder
            self.write(f"error {error.code} {message}\n".encode(errors="backslashreplace"))
        elif text is None:
            self.write(b"ok\n")
        elif len(text) > MAX_ANSWER:
            size = f"{len(text) / (1 << 20):.1f} MiB"
            message = f"error {rpc.INTERNAL_ERROR} the answer is {size}, over the limit: ask for less\n"
            self.write(message.encode())
        else:
            self.write(f"ok {text}\n".encode())
        self.inflight.release()

    def handle_too_long(self) -> None:
        self._answer(None, RPCError(rpc.INVALID_REQUEST, f"line longer than {rpc.MAX_LINE} bytes: refused"))

    def handle_line(self, line: bytes) -> None:
        try:
            text = line.decode()
        except UnicodeDecodeError:
            self._answer(None, RPCError(rpc.PARSE_ERROR, "the line is not UTF-8 text"))
            return
        if not text.strip() or text.lstrip().startswith("#"):
            self.inflight.release()
            return
        try:
            name, params = parse_line(text, self.server.scene)
        except RPCError as exc:
            self._answer(None, exc)
            return
        self.call(name, params, self._answer)
