"""Applied commands as records, and applying them again: one way for recordings and rollbacks.

A record is what one command line of a replay file holds (:mod:`twig_ecs.server.replay`)::

    {"frame": 120, "method": "hug", "params": {"character": "small_child", ...}, "error": null}

the frame it was applied at (after that many steps), its checked parameters as JSON values
and the error it gave, if any. :func:`apply_records` applies records to a server's scene
again, through the same method functions and between the same two steps, which gives
the same world (steps and commands are deterministic): ``twig run --replay`` replays a
recording with it, and the server's rollback (:mod:`twig_ecs.server.rollback`) the
commands applied since its last checkpoint.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from twig_ecs.errors import TwigError
from twig_ecs.server.methods import Method, bind, find_method
from twig_ecs.server.protocol import RPCError

#: Methods whose effect on the world is only the passing of time (already in the frame numbers).
CLOCK_METHODS = ("pause", "resume", "step")
#: Longest parameters (bytes of JSON) a failed command's record keeps.
MAX_FAILED_PARAMS = 1024
#: Longest error message a record keeps (characters).
MAX_RECORDED_ERROR = 1000


class HeadlessSession:
    """Stands in for a client session when commands are applied without a socket (replay)."""

    def __init__(self) -> None:
        self.subscriptions: set[str] = set()
        self.authenticated = True


def _jsonable(value: Any) -> Any:
    """Bound parameters as JSON values (vectors are tuples); a copy, never the caller's lists."""
    if isinstance(value, tuple | list):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return value


def command_record(frame: int, method: str, params: dict[str, Any], error: str | None) -> dict[str, Any]:
    """The record of an applied command (see the module docstring).

    A failed command's parameters longer than :data:`MAX_FAILED_PARAMS` are left out
    (``"params": null, "params_cut": BYTES``): it changed nothing, its error is enough,
    and :func:`apply_records` skips it.
    """
    error = None if error is None else error[:MAX_RECORDED_ERROR]
    record: dict[str, Any] = {"frame": frame, "method": method, "params": _jsonable(params), "error": error}
    if error is not None and (size := len(json.dumps(record["params"]))) > MAX_FAILED_PARAMS:
        record["params"], record["params_cut"] = None, size
    return record


def apply_command(server: Any, session: Any, method: Method, params: dict[str, Any]) -> str | None:
    """Apply one command to ``server.scene`` as the server applies it; its error message, or None."""
    error = None
    try:
        method.fn(server, session, **bind(method, params))
    except RPCError as exc:
        error = str(exc)
    except KeyError as exc:
        error = str(exc.args[0]) if exc.args else "unknown name"
    except TwigError as exc:
        error = str(exc)
    except Exception as exc:  # a bug, which the server answers as an internal error and records
        error = f"internal error in {method.name}: {exc!r}"
    server._flush()  # noqa: SLF001 - as the server does after every command (goal.done bookkeeping)
    return error


def apply_records(
    server: Any,
    records: list[dict[str, Any]],
    step_to: Callable[[int], None],
    unknown: Callable[[str], Exception],
    after: Callable[[dict[str, Any], str | None], None] | None = None,
) -> int:
    """Apply ``records`` (in frame order) to ``server.scene``; returns how many diverged.

    Before each, ``step_to(frame)`` steps the scene to its frame. Clock methods and
    records whose parameters were cut are skipped (their effect is in the frame numbers,
    or they changed nothing). A command that now fails where it did not (or the other way
    round) counts as diverged. ``unknown(name)`` is the exception raised for a method the
    scene does not have; ``after(record, error)`` is called after each applied command.
    """
    session = HeadlessSession()
    diverged = 0
    for item in records:
        step_to(item["frame"])
        method = find_method(item["method"], server.scene)
        if method is None:
            raise unknown(item["method"])
        if method.name in CLOCK_METHODS or item.get("params_cut"):
            continue
        error = apply_command(server, session, method, item.get("params") or {})
        if (error is None) != (item.get("error") is None):
            diverged += 1
        if after is not None:
            after(item, error)
    return diverged
