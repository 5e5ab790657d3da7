"""A small client for ``twig serve``: JSON-RPC 2.0, one JSON object per line over TCP.

Synchronous::

    from twig_ecs.client import Client

    with Client("127.0.0.1", 7470) as twig:
        goal = twig.call("hug", character="big_child", target="small_child")["goal"]
        print(twig.wait_goal(goal, timeout=30))      # the goal.done / goal.failed notification

asyncio::

    async with await AsyncClient.connect("127.0.0.1", 7470) as twig:
        await twig.call("subscribe", events=["pain"])
        note = await twig.next_notification(timeout=5)

Notifications that arrive while waiting for an answer are kept, in order, for
:meth:`Client.next_notification` / :meth:`Client.wait_for`. Errors the server answers
raise :class:`RemoteError` (``code`` and ``message``).
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import json
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

from twig_ecs.errors import TwigError

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 7470
_LIMIT = 64 << 20  # longest answer line accepted (a big get_state)


class RemoteError(TwigError):
    """The server answered with an error."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(f"{message} ({code})")
        self.code = code
        self.message = message


class Notification(dict):
    """A notification: its ``kind`` (the JSON-RPC method) and its params as dict items."""

    def __init__(self, kind: str, params: dict[str, Any]) -> None:
        super().__init__(params)
        self.kind = kind

    def __repr__(self) -> str:
        return f"Notification({self.kind!r}, {dict.__repr__(self)})"


def _request(rid: int, method: str, params: dict[str, Any]) -> bytes:
    return json.dumps({"jsonrpc": "2.0", "id": rid, "method": method, "params": params}).encode() + b"\n"


def _goal_end(goal: int) -> Callable[[Notification], bool]:
    return lambda n: n.kind in ("goal.done", "goal.failed") and n.get("goal") == goal


class Client:
    """A blocking client. ``token``: sent first (``auth``) when the server needs one."""

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        token: str | None = None,
        timeout: float = 30.0,
    ) -> None:
        self.timeout = timeout
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buffer = bytearray()
        self._ids = itertools.count(1)
        self.notifications: collections.deque[Notification] = collections.deque()
        self._answers: dict[Any, dict[str, Any]] = {}
        if token is not None:
            self.call("auth", token=token)

    # -- calls --------------------------------------------------------------------------

    def call(self, method: str, **params: Any) -> Any:
        """Call ``method`` with parameters by name; return its result (RemoteError on error)."""
        rid = next(self._ids)
        self._sock.sendall(_request(rid, method, params))
        return self._result(self._wait_answer(rid, self.timeout))

    def __getattr__(self, method: str) -> Callable[..., Any]:
        """``client.hug(character="a", target="b")`` is ``client.call("hug", ...)``."""
        if method.startswith("_"):
            raise AttributeError(method)
        return lambda **params: self.call(method, **params)

    @staticmethod
    def _result(answer: dict[str, Any]) -> Any:
        if "error" in answer:
            raise RemoteError(answer["error"].get("code", 0), answer["error"].get("message", ""))
        return answer.get("result")

    # -- notifications ---------------------------------------------------------------------

    def next_notification(self, timeout: float | None = None) -> Notification | None:
        """The next notification (oldest first), waiting up to ``timeout`` s; None if none came."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not self.notifications:
            if not self._read(deadline):
                return None
        return self.notifications.popleft()

    def wait_for(
        self,
        predicate: Callable[[Notification], bool],
        timeout: float | None = None,
        on_other: Callable[[Notification], None] | None = None,
    ) -> Notification | None:
        """The first notification for which ``predicate`` holds (others go to ``on_other``)."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while True:
            note = self.next_notification(max(0.0, deadline - time.monotonic()))
            if note is None:
                return None
            if predicate(note):
                return note
            if on_other is not None:
                on_other(note)

    def wait_goal(
        self, goal: int, timeout: float | None = None, on_other: Callable[[Notification], None] | None = None
    ) -> Notification:
        """Wait for goal ``goal``'s ``goal.done`` or ``goal.failed`` notification.

        Raises :class:`TimeoutError` if it has not ended within ``timeout`` seconds (default:
        the client's timeout, 30 s): a goal still going is not an answer.
        """
        limit = self.timeout if timeout is None else timeout
        note = self.wait_for(_goal_end(goal), limit, on_other)
        if note is None:
            raise TimeoutError(f"goal {goal} did not end within {limit:g} s (wait longer: timeout=...)")
        return note

    # -- the socket ------------------------------------------------------------------------

    def _wait_answer(self, rid: Any, timeout: float) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while rid not in self._answers:
            if not self._read(deadline):
                raise TimeoutError(f"no answer from the server within {timeout:g} s")
        return self._answers.pop(rid)

    def _read(self, deadline: float) -> bool:
        """Read and sort one line or more; False when the deadline passed first."""
        while b"\n" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self._sock.settimeout(left)
            try:
                data = self._sock.recv(65536)
            except TimeoutError:
                return False
            if not data:
                raise ConnectionError("the server closed the connection")
            self._buffer += data
            if len(self._buffer) > _LIMIT:
                raise ConnectionError("an answer longer than 64 MiB")
        while b"\n" in self._buffer:
            line, _, rest = bytes(self._buffer).partition(b"\n")
            self._buffer = bytearray(rest)
            self._sort(json.loads(line))
        return True

    def _sort(self, message: Any) -> None:
        if isinstance(message, list):
            for item in message:
                self._sort(item)
        elif "method" in message and "id" not in message:
            self.notifications.append(Notification(message["method"], message.get("params", {})))
        else:
            self._answers[message.get("id")] = message

    def close(self) -> None:
        self._sock.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class AsyncClient:
    """An asyncio client: :meth:`connect`, then ``await call(...)``; notifications queue up."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, timeout: float) -> None:
        self.timeout = timeout
        self._reader, self._writer = reader, writer
        self._ids = itertools.count(1)
        self._waiting: dict[Any, asyncio.Future] = {}
        self.notifications: asyncio.Queue[Notification] = asyncio.Queue()
        self._task = asyncio.create_task(self._read_loop())

    @classmethod
    async def connect(
        cls,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        token: str | None = None,
        timeout: float = 30.0,
    ) -> AsyncClient:
        reader, writer = await asyncio.wait_for(asyncio.open_connection(host, port, limit=_LIMIT), timeout)
        client = cls(reader, writer, timeout)
        if token is not None:
            await client.call("auth", token=token)
        return client

    async def call(self, method: str, **params: Any) -> Any:
        """Call ``method`` with parameters by name; return its result (RemoteError on error)."""
        rid = next(self._ids)
        future = asyncio.get_running_loop().create_future()
        self._waiting[rid] = future
        self._writer.write(_request(rid, method, params))
        try:
            answer = await asyncio.wait_for(future, self.timeout)
        finally:
            self._waiting.pop(rid, None)
        return Client._result(answer)

    async def next_notification(self, timeout: float | None = None) -> Notification | None:
        """The next notification, waiting up to ``timeout`` s; None if none came."""
        try:
            wait = self.timeout if timeout is None else timeout
            return await asyncio.wait_for(self.notifications.get(), wait)
        except TimeoutError:
            return None

    async def wait_goal(self, goal: int, timeout: float | None = None) -> Notification:
        """Wait for goal ``goal``'s end (other notifications are dropped on the way).

        Raises :class:`TimeoutError` if it has not ended within ``timeout`` seconds.
        """
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            note = await self.next_notification(max(0.0, deadline - time.monotonic()))
            if note is None:
                raise TimeoutError(f"goal {goal} did not end within {limit:g} s (wait longer: timeout=...)")
            if _goal_end(goal)(note):
                return note

    async def _read_loop(self) -> None:
        try:
            while True:
                line = await self._reader.readline()
                if not line:
                    break
                message = json.loads(line)
                for item in message if isinstance(message, list) else (message,):
                    if "method" in item and "id" not in item:
                        self.notifications.put_nowait(Notification(item["method"], item.get("params", {})))
                    else:
                        future = self._waiting.get(item.get("id"))
                        if future is not None and not future.done():
                            future.set_result(item)
        except (ConnectionError, ValueError):
            pass
        finally:
            for future in self._waiting.values():
                if not future.done():
                    future.set_exception(ConnectionError("the server closed the connection"))

    async def close(self) -> None:
        self._writer.close()
        self._task.cancel()
        try:
            await self._writer.wait_closed()
        except (ConnectionError, OSError):
            pass

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()


def spawn_server(*args: str, echo: bool = False, timeout: float = 120.0) -> tuple[subprocess.Popen, int]:
    """Start ``twig serve ARGS --port 0`` in a subprocess; return it and the port it took.

    The caller stops it (``proc.terminate()``). With ``echo`` the server's start-up lines
    are copied to stderr. Raises TwigError when it does not start in ``timeout`` s.
    """
    command = [sys.executable, "-m", "twig_ecs", "serve", *args, "--port", "0"]
    proc = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if echo:
            print(line, end="", file=sys.stderr)
        if " port " in line:
            return proc, int(line.split(" port ")[1].split()[0])
        if not line and proc.poll() is not None:
            break
    proc.kill()
    raise TwigError("the server did not start")
