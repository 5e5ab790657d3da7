"""JSON-RPC 2.0 framing: error codes, parsing a request line, and a bounded line reader.

One JSON object (or a batch array) per line, UTF-8, ``\\n``-terminated. Lines longer than
:data:`MAX_LINE` bytes are refused as they arrive: the reader keeps at most that much
of a line in memory and skips the rest up to the next newline.
"""

from __future__ import annotations

import asyncio
import json
import math
from dataclasses import dataclass
from typing import Any

PARSE_ERROR = -32700
INVALID_REQUEST = -32600
METHOD_NOT_FOUND = -32601
INVALID_PARAMS = -32602
INTERNAL_ERROR = -32603
#: A request that is well formed but not allowed now (``step`` while running, ...).
NOT_NOW = -32001
#: A token is needed and the client has not sent it (or sent a wrong one).
UNAUTHORIZED = -32002
#: The world holds non-finite numbers (NaN, infinity) where an answer would report them.
BROKEN_WORLD = -32003

#: The longest request line accepted (bytes, newline excluded).
MAX_LINE = 1 << 20


class RPCError(Exception):
    """An error answered to the client: a JSON-RPC code and a message for a person."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def to_json(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.message}


def loads(line: bytes | str) -> Any:
    """Decode one JSON document; RPCError(-32700) if it is not JSON.

    ``NaN`` and ``Infinity`` (which Python's json writes) are read as floats so that the
    parameter checks can name them; integers stay exact (a 30-digit request id comes back
    as sent; the parameter checks refuse huge values).
    """
    try:
        return json.loads(line)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        detail = str(exc) if not isinstance(exc, RecursionError) else "nested too deeply"
        raise RPCError(PARSE_ERROR, f"parse error: not valid JSON ({detail})") from None


def dumps(obj: Any) -> bytes:
    """One JSON line (compact, ASCII-safe, NaN refused: ValueError)."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).encode() + b"\n"


def finite(obj: Any) -> Any:
    """``obj`` with every non-finite float (NaN, infinity) as None: a notification must go out."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite(v) for v in obj]
    return obj


def unwritable(exc: Exception) -> RPCError:
    """The error to answer in place of a result that ``dumps`` refused (NaN in it: a broken world)."""
    if isinstance(exc, ValueError):  # json: "Out of range float values are not JSON compliant"
        message = ("the answer holds non-finite numbers (NaN or infinity), which JSON cannot carry: part "
                   "of the world has broken down (get_state names the bodies)")  # fmt: skip
        return RPCError(BROKEN_WORLD, message)
    return RPCError(INTERNAL_ERROR, f"internal error: the answer is not JSON ({exc})")


@dataclass(slots=True)
class Request:
    """A checked JSON-RPC request: ``id`` is absent (``notify=True``) for a notification."""

    method: str
    params: dict[str, Any] | list[Any]
    id: Any = None
    notify: bool = False


def parse_request(obj: Any) -> Request:
    """Check the shape of one request object; RPCError(-32600) says what is wrong."""
    if not isinstance(obj, dict):
        raise RPCError(INVALID_REQUEST, f"invalid request: expected a JSON object, got {type(obj).__name__}")
    if obj.get("jsonrpc") != "2.0":
        raise RPCError(INVALID_REQUEST, 'invalid request: "jsonrpc" must be "2.0"')
    notify = "id" not in obj
    rid = obj.get("id")
    if not notify and not (rid is None or isinstance(rid, str) or _is_number(rid)):
        raise RPCError(INVALID_REQUEST, 'invalid request: "id" must be a string, a number or null')
    method = obj.get("method")
    if not isinstance(method, str) or not method:
        raise RPCError(INVALID_REQUEST, 'invalid request: "method" must be a non-empty string')
    params = obj.get("params", {})
    if not isinstance(params, dict | list):
        raise RPCError(INVALID_REQUEST, 'invalid request: "params" must be an object (by name) or an array')
    extra = set(obj) - {"jsonrpc", "id", "method", "params"}
    if extra:
        raise RPCError(INVALID_REQUEST, f"invalid request: unknown member(s) {', '.join(sorted(extra))}")
    return Request(method, params, rid, notify)


def _is_number(value: Any) -> bool:
    """A usable id number: not a boolean, and finite (an infinite id could not be written back)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    return isinstance(value, int) or math.isfinite(value)


def request_id(obj: Any) -> Any:
    """The id to answer an invalid request with: its own if readable, else null."""
    if isinstance(obj, dict):
        rid = obj.get("id")
        if rid is None or isinstance(rid, str) or _is_number(rid):
            return rid
    return None


def response(rid: Any, result: Any) -> dict[str, Any]:
    return {"jsonrpc": "2.0", "id": rid, "result": result}


def error_response(rid: Any, error: RPCError) -> dict[str, Any]:
    return {"jsonrpc": "2.0", "id": rid, "error": error.to_json()}


def notification(method: str, params: dict[str, Any]) -> dict[str, Any]:
    return {"jsonrpc": "2.0", "method": method, "params": params}


#: What :meth:`LineReader.next` returns for a line over the limit.
TOO_LONG = object()


class LineReader:
    """Newline-delimited lines from a stream, holding at most ``limit`` bytes of a line.

    :meth:`next` returns the next line (bytes, without ``\\r\\n``), :data:`TOO_LONG` as
    soon as a line passes the limit (its remainder is then read and thrown away), or
    None at the end of the stream.
    """

    def __init__(self, reader: asyncio.StreamReader, limit: int = MAX_LINE, chunk: int = 65536) -> None:
        self.reader = reader
        self.limit = limit
        self.chunk = chunk
        self._buffer = bytearray()
        self._scanned = 0  # bytes of the buffer known to hold no newline
        self._skipping = False
        self._eof = False

    async def next(self) -> bytes | object | None:
        while True:
            i = self._buffer.find(b"\n", self._scanned)
            if i >= 0:
                line = bytes(self._buffer[:i])
                del self._buffer[: i + 1]
                self._scanned = 0
                if self._skipping:  # the tail of a refused line
                    self._skipping = False
                    continue
                if len(line) > self.limit:
                    return TOO_LONG
                return line.removesuffix(b"\r")
            if self._skipping:
                self._buffer.clear()
            elif len(self._buffer) > self.limit:
                self._buffer.clear()
                self._skipping = True
                self._scanned = 0
                return TOO_LONG
            self._scanned = len(self._buffer)
            if self._eof:
                if self._buffer and not self._skipping:  # a last line without a newline
                    line = bytes(self._buffer)
                    self._buffer.clear()
                    self._scanned = 0
                    return line.removesuffix(b"\r")
                return None
            data = await self.reader.read(self.chunk)
            if not data:
                self._eof = True
            self._buffer += data
