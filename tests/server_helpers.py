"""Run a ``twig serve`` server in-process (in a thread, on ephemeral ports) for tests and benchmarks."""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass

from twig_ecs import Scene
from twig_ecs.server.core import Server


@dataclass
class Running:
    """A server running in a thread: its ports and the server object (touch only via clients)."""

    server: Server
    port: int
    twig_port: int | None
    loop: asyncio.AbstractEventLoop
    log: list[str]


@contextlib.contextmanager
def running_server(
    scene: str = "schoolyard",
    seed: int = 0,
    twig: bool = False,
    token: str | None = None,
    paused: bool = False,
    autonomous: bool = True,
    window: bool = False,
    timeout: float = 60.0,
    record: str | None = None,
    record_limit: int | None = None,
    trust: bool = False,
) -> Iterator[Running]:
    """Serve ``scene`` on 127.0.0.1 (ephemeral ports) in a thread until the block ends.

    ``record``: a replay file to log the applied commands to (as ``twig serve --record``),
    at most ``record_limit`` bytes (``--record-limit``). The server's log lines are in
    ``running.log``. ``trust``: the scene may run its plug-in files (``--trust``).
    """
    ready = threading.Event()
    box: dict = {"log": []}

    def main() -> None:
        async def serve() -> None:
            shown = None
            if window:  # pyglet's headless EGL window: no display needed
                from twig_ecs.graphics.app import open_window

                shown = open_window(scene, seed=seed, size=(160, 90), headless=True)
                loaded = shown.viewer.scene
            else:
                loaded = Scene.load(scene, seed=seed, trust=trust)
            try:
                recorder = None
                if record is not None:
                    from twig_ecs.replay import Recorder

                    limit = {} if record_limit is None else {"limit": record_limit}
                    recorder = Recorder(record, scene, seed, (), autonomous, **limit)
                server = Server(
                    loaded,
                    port=0,
                    twig_port=0 if twig else None,
                    token=token,
                    paused=paused,
                    autonomous=autonomous,
                    window=shown,
                    log=box["log"].append,
                    recorder=recorder,
                )
            except BaseException:
                (shown or loaded).close()
                raise
            await server.start()
            box["running"] = Running(
                server, server.port, server.twig_port, asyncio.get_running_loop(), box["log"]
            )
            ready.set()
            await server.serve_forever()

        try:
            asyncio.run(serve())
        except BaseException as exc:  # pragma: no cover - reported by the waiting test
            box["error"] = exc
            ready.set()

    thread = threading.Thread(target=main, name="twig-test-server", daemon=True)
    thread.start()
    if not ready.wait(timeout):
        raise TimeoutError("the test server did not start")
    if "error" in box:
        raise box["error"]
    running: Running = box["running"]
    try:
        yield running
    finally:
        running.loop.call_soon_threadsafe(running.server.request_stop)
        thread.join(timeout)
        assert not thread.is_alive(), "the test server did not stop"


class RawLines:
    """A plain TCP socket to the server (as netcat would use it), read line by line."""

    def __init__(self, port: int, timeout: float = 10.0) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.timeout = timeout
        self._buffer = b""

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def line(self, timeout: float | None = None) -> bytes:
        """The next line (without its newline), waiting at most ``timeout`` seconds."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while b"\n" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no full line within the time; have {self._buffer[:200]!r}")
            self.sock.settimeout(left)
            data = self.sock.recv(65536)
            if not data:
                raise ConnectionError(f"closed; have {self._buffer[:200]!r}")
            self._buffer += data
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line

    def closed_by_server(self, timeout: float = 5.0) -> bool:
        """True once the server has closed the connection (within ``timeout``)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.sock.settimeout(max(0.01, deadline - time.monotonic()))
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                return False
            except ConnectionError:
                return True
            if not data:
                return True
        return False

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> RawLines:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
    """A JSON-RPC 2.0 request object."""
    return {"jsonrpc": "2.0", "id": rid, "method": method, "params": params}
