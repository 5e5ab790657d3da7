"""Server sessions: one connected client each, speaking JSON-RPC (here) or the Twig line protocol.

A session reads lines, checks each request and queues it as a :class:`Command` for the
server's simulation loop (never waiting for it), and writes answers and notifications.
"""

from __future__ import annotations

import asyncio
import hmac
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from twig_ecs.server import protocol as rpc
from twig_ecs.server.methods import METHODS, Method, bind, find_method
from twig_ecs.server.protocol import RPCError
from twig_ecs.validate import suggest


class Server(Protocol):
    """What a session uses of the server it belongs to (:class:`twig_ecs.server.core.Server`)."""

    token: str | None
    auth_timeout: float
    scene: Any

    def log(self, message: str) -> None: ...
    def submit(self, command: Command) -> None: ...


#: Unanswered requests one JSON-RPC client may have queued before it is no longer read.
MAX_INFLIGHT = 64
#: Unsent bytes to one client beyond which it is disconnected as too slow.
MAX_UNSENT = 8 << 20
#: Longest answer line (bytes): a bigger one is replaced by an error saying to ask for less.
MAX_ANSWER = 4 << 20
#: Most requests in one JSON-RPC batch.
MAX_BATCH = 256

_session_ids = itertools.count(1)


@dataclass(slots=True)
class Command:
    """A checked request waiting for the simulation loop."""

    session: Session
    method: Method
    params: dict[str, Any]
    done: Callable[[Any, RPCError | None], None]


class Session:
    """One connected client. Subclasses speak JSON-RPC or the Twig line protocol."""

    inflight_limit = MAX_INFLIGHT

    def __init__(self, server: Server, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.server = server
        self.reader = reader
        self.writer = writer
        self.id = next(_session_ids)
        self.peer = writer.get_extra_info("peername")
        self.subscriptions: set[str] = set()
        self.authenticated = server.token is None
        self.inflight = asyncio.Semaphore(self.inflight_limit)
        self.closed = False
        self.ending = False  # a wrong token (or a call before auth): the connection is closing

    # -- output (never waits) --------------------------------------------------------------

    def write(self, data: bytes) -> None:
        if self.closed:
            return
        behind = self.writer.transport.get_write_buffer_size()  # before this answer: it may be big
        self.writer.write(data)
        unsent = self.writer.transport.get_write_buffer_size()
        if behind > MAX_UNSENT:
            self.server.log(f"client {self.peer} is {unsent >> 20} MiB behind: disconnected")
            self.abort()

    @property
    def gone(self) -> bool:
        """Has the connection ended (closed here, or found broken when writing to it)?"""
        return self.closed or self.writer.transport.is_closing()

    def abort(self) -> None:
        if not self.closed:
            self.closed = True
            self.writer.transport.abort()

    def send_event(self, kind: str, params: dict[str, Any]) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    # -- input -------------------------------------------------------------------------------

    async def greet(self) -> None:
        """Anything sent on connect."""

    async def serve(self) -> None:
        """Read lines until the client goes; each is handled without waiting for its answer."""
        lines = rpc.LineReader(self.reader)
        loop = asyncio.get_running_loop()
        # a connection that has not authenticated by then is closed, whatever it sends meanwhile
        # (empty lines, comments): it does not hold a socket for ever
        auth_deadline = loop.time() + self.server.auth_timeout
        try:
            await self.greet()
            while not self.closed and not self.ending:
                if self.writer.transport.get_write_buffer_size() > 1 << 20:
                    await self.writer.drain()  # it is not reading: stop reading it too
                await self.inflight.acquire()
                if self.authenticated:
                    line = await lines.next()
                else:
                    try:
                        line = await asyncio.wait_for(lines.next(), max(0.0, auth_deadline - loop.time()))
                    except TimeoutError:
                        self.server.log(f"client {self.peer} sent no token in {self.server.auth_timeout:g} s")
                        break
                if line is None:
                    break
                if line is rpc.TOO_LONG:
                    self.handle_too_long()
                    continue
                self.handle_line(line)
        except (ConnectionError, asyncio.IncompleteReadError):
            pass
        finally:
            self.closed = True
            self.writer.close()

    def handle_too_long(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def handle_line(self, line: bytes) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def call(
        self, name: str, params: dict[str, Any] | list[Any], done: Callable[[Any, RPCError | None], None]
    ) -> None:
        """Check and run (or queue) one call; ``done(result, error)`` is called exactly once."""
        if self.ending:  # refused once: nothing more from this connection runs, batch included
            done(None, RPCError(rpc.UNAUTHORIZED, "refused: this connection is closing"))
            return
        if not self.authenticated and name != "auth":  # before auth, not even the method list
            done(None, RPCError(rpc.UNAUTHORIZED, "this server needs a token: send auth first"))
            self.close_soon()
            return
        method = find_method(name, self.server.scene)
        if method is None:
            done(None, RPCError(rpc.METHOD_NOT_FOUND, f"unknown method '{name}'" + suggest(name, METHODS)))
            return
        try:
            params = bind(method, params)
        except RPCError as exc:
            done(None, exc)
            return
        except RecursionError:  # JSON nested just under the parser's limit
            done(None, RPCError(rpc.INVALID_PARAMS, f"{name}: parameters nested too deeply"))
            return
        if name == "auth":
            token = self.server.token
            if token is not None and not hmac.compare_digest(params["token"].encode(), token.encode()):
                done(None, RPCError(rpc.UNAUTHORIZED, "wrong token"))
                self.close_soon()
                return
            self.authenticated = True
        if method.queued:
            self.server.submit(Command(self, method, params, done))
        else:
            done(method.fn(self.server, self, **params), None)

    def close_soon(self) -> None:
        """Run nothing more; close once the answers to the current line are written."""
        self.ending = True
        asyncio.get_running_loop().call_soon(self._close_now)

    def _close_now(self) -> None:
        if not self.closed:
            self.closed = True
            self.writer.close()


def _too_big(obj: Any, size: int) -> Any:
    """An error answer (or batch of them) in place of an answer of ``size`` bytes."""
    message = (f"the answer is {size / (1 << 20):.1f} MiB, over the {MAX_ANSWER >> 20} MiB limit: "
               "ask for less (get_state NAME for one entity, list_entities for names)")  # fmt: skip
    error = RPCError(rpc.INTERNAL_ERROR, message)
    if isinstance(obj, list):
        return [rpc.error_response(a.get("id"), error) for a in obj if isinstance(a, dict)]
    return rpc.error_response(obj.get("id") if isinstance(obj, dict) else None, error)


def _writable(answer: Any) -> Any:
    """``answer`` if it can be written as JSON, else the error answer that says why not."""
    try:
        rpc.dumps(answer)
    except (ValueError, TypeError) as exc:
        return rpc.error_response(answer.get("id") if isinstance(answer, dict) else None, rpc.unwritable(exc))
    return answer


class JsonSession(Session):
    """A JSON-RPC 2.0 client: one request (or batch) per line, answers by id."""

    def send_event(self, kind: str, params: dict[str, Any]) -> None:
        try:
            data = rpc.dumps(rpc.notification(kind, params))
        except ValueError:  # NaN from a broken world: sent as null rather than not at all
            data = rpc.dumps(rpc.notification(kind, rpc.finite(params)))
        self.write(data)

    def _send(self, obj: Any) -> None:
        try:
            data = rpc.dumps(obj)
        except (ValueError, TypeError):  # never broken JSON, never a dropped client: an error in its place
            data = rpc.dumps([_writable(a) for a in obj] if isinstance(obj, list) else _writable(obj))
        if len(data) > MAX_ANSWER:  # one answer must not swamp the client (nor the server's memory)
            data = rpc.dumps(_too_big(obj, len(data)))
        self.write(data)

    def handle_too_long(self) -> None:
        error = RPCError(rpc.INVALID_REQUEST, f"request line longer than {rpc.MAX_LINE} bytes: refused")
        self._send(rpc.error_response(None, error))
        self.inflight.release()

    def handle_line(self, line: bytes) -> None:
        if not line.strip():
            self.inflight.release()
            return
        try:
            obj = rpc.loads(line)
        except RPCError as exc:
            self._send(rpc.error_response(None, exc))
            self.inflight.release()
            return
        if isinstance(obj, list):
            self._batch(obj)
        else:
            self._one(obj, self._finish_line)

    def _finish_line(self, answer: dict[str, Any] | None) -> None:
        if answer is not None:
            self._send(answer)
        self.inflight.release()

    def _one(self, obj: Any, done: Callable[[dict[str, Any] | None], None]) -> None:
        try:
            request = rpc.parse_request(obj)
        except RPCError as exc:
            done(rpc.error_response(rpc.request_id(obj), exc))
            return

        def answer(result: Any, error: RPCError | None) -> None:
            if request.notify:
                done(None)
            elif error is not None:
                done(rpc.error_response(request.id, error))
            else:
                done(rpc.response(request.id, result))

        self.call(request.method, request.params, answer)

    def _batch(self, items: list[Any]) -> None:
        if not items:
            self._finish_line(rpc.error_response(None, RPCError(rpc.INVALID_REQUEST, "empty batch")))
            return
        if len(items) > MAX_BATCH:
            message = f"a batch of {len(items)} requests: at most {MAX_BATCH} (send several lines)"
            self._finish_line(rpc.error_response(None, RPCError(rpc.INVALID_REQUEST, message)))
            return
        answers: list[dict[str, Any] | None] = [None] * len(items)
        left = [len(items)]

        def one_done(k: int, answer: dict[str, Any] | None) -> None:
            answers[k] = answer
            left[0] -= 1
            if left[0] == 0:
                out = [a for a in answers if a is not None]
                if out:
                    self._send(out)
                self.inflight.release()

        for k, item in enumerate(items):
            self._one(item, lambda answer, k=k: one_done(k, answer))
