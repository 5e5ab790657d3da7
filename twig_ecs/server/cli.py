"""``twig serve``: run a scene as a server for a drama manager (JSON-RPC 2.0, optionally Twig lines)."""

from __future__ import annotations

import argparse
import ipaddress
import os
import signal
import sys
from collections.abc import Callable

from twig_ecs.errors import TwigError
from twig_ecs.server.access import TOKEN_ENV, check_token
from twig_ecs.server.ports import DEFAULT_PORT, DEFAULT_TWIG_PORT  # not .core: asyncio, for every command


def register_commands(subparsers, add_scene_args: Callable[..., None]) -> None:
    """Add ``serve`` to the ``twig`` parser's subcommands."""
    p = subparsers.add_parser(
        "serve",
        help="serve a scene to RPC clients (a drama manager)",
        description="Run a scene at 60 Hz (or stepped, with --paused) and take "
        "commands over JSON-RPC 2.0, one JSON object per line over TCP.",
    )
    add_scene_args(p, scene_default="schoolyard")
    p.add_argument(
        "--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; any other needs --token)"
    )
    p.add_argument("--port", type=_port, default=DEFAULT_PORT, help=f"JSON-RPC port (default {DEFAULT_PORT})")
    p.add_argument(
        "--twig-port",
        type=_port,
        nargs="?",
        const=DEFAULT_TWIG_PORT,
        default=None,
        metavar="PORT",
        help=f"also accept the Twig line protocol on this port ({DEFAULT_TWIG_PORT} if no PORT is given)",
    )
    p.add_argument("--window", action="store_true", help="also show the scene in a window")
    p.add_argument("--paused", action="store_true", help="start paused: time moves only on 'step'")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--autonomous",
        dest="autonomous",
        action="store_true",
        default=True,
        help="characters act on their own as well as on command (default)",
    )
    mode.add_argument(
        "--scripted",
        dest="autonomous",
        action="store_false",
        help="characters move only on goals (and reflexes such as pain)",
    )
    p.add_argument(
        "--token",
        default=None,
        help=f"clients must send this first (auth); needed off loopback (or set {TOKEN_ENV})",
    )
    p.add_argument(
        "--record",
        metavar="FILE",
        default=None,
        help="log every applied command with its frame (replay with: twig run --replay FILE)",
    )
    p.add_argument(
        "--record-limit",
        metavar="MIB",
        type=_mebibytes,
        default=None,
        help="stop recording when the file reaches this size (default and most: 8 MiB, what a replay "
        "holds); the server goes on",
    )
    p.set_defaults(func=cmd_serve)


def _mebibytes(text: str) -> int:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a size in MiB, such as 64 (got {text!r})") from None
    from twig_ecs.server.replay import MAX_REPLAY_BYTES

    most = MAX_REPLAY_BYTES >> 20
    if not 0.01 <= value <= most:
        raise argparse.ArgumentTypeError(f"between 0.01 and {most} MiB (a replay holds at most {most} MiB)")
    return int(value * (1 << 20))


def _port(text: str) -> int:
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError("a port is between 0 and 65535 (0: any free port)")
    return value


def is_loopback(host: str) -> bool:
    """Is ``host`` a loopback address (127.0.0.0/8, ::1) or ``localhost``?"""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_binding(host: str, token: str | None) -> None:
    """Refuse a non-loopback address without a token (TwigError saying how to fix it)."""
    if not is_loopback(host) and not token:
        raise TwigError(
            f"serving on {host} (not loopback) lets other machines control the scene: give "
            f"--token SECRET (or set {TOKEN_ENV}), which clients must send first"
        )


def check_ports_free(host: str, ports) -> None:
    """Fail with a clear error when a port to serve on is taken (port 0 or None: any port)."""
    import socket

    for port in ports:
        if not port:
            continue
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio's server does
            try:
                probe.bind((host, port))
            except OSError as exc:
                raise TwigError(f"cannot serve on {host} port {port}: {exc.strerror} (another twig serve? "
                                "choose a free one with --port, or --port 0 for any); nothing was started "
                                "or recorded") from None  # fmt: skip


def cmd_serve(args: argparse.Namespace) -> int:
    """Load the scene and serve it until interrupted (or the window closes)."""
    token = args.token or os.environ.get(TOKEN_ENV) or None
    check_token(token)
    check_binding(args.host, token)
    check_ports_free(args.host, (args.port, args.twig_port))  # before a replay file is written
    from twig_ecs.server.core import Server

    window = None
    if args.window:
        from twig_ecs.graphics.app import open_window

        window = open_window(args.scene, seed=args.seed, content=args.content, paused=args.paused,
                             parameters=args.parameters)  # fmt: skip
        scene = window.viewer.scene
    else:
        from twig_ecs import Scene

        scene = Scene.load(args.scene, seed=args.seed, content=args.content, **args.parameters)
    try:
        recorder = None
        if args.record:
            from twig_ecs.server.replay import Recorder

            limit = {"limit": args.record_limit} if args.record_limit else {}
            recorder = Recorder(args.record, args.scene, args.seed, args.content, args.autonomous, **limit)
        server = Server(
            scene,
            host=args.host,
            port=args.port,
            twig_port=args.twig_port,
            token=token,
            paused=args.paused,
            autonomous=args.autonomous,
            window=window,
            recorder=recorder,
        )
    except BaseException:
        (window or scene).close()
        raise
    import asyncio

    return asyncio.run(_serve(server))


async def _serve(server) -> int:
    import asyncio

    loop = asyncio.get_running_loop()
    try:
        await server.start()
    except OSError as exc:
        await server.stop()
        raise TwigError(f"cannot listen on {server.host}:{server.port}: {exc.strerror or exc}") from None
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, server.request_stop)
        except (NotImplementedError, RuntimeError):  # pragma: no cover - not on this platform
            pass
    twig = f", Twig line protocol on port {server.twig_port}" if server.twig_port is not None else ""
    mode = "paused" if server.paused else "running at 60 Hz"
    who = "autonomous" if server.autonomous else "scripted"
    print(
        f"twig serve: '{server.scene.name}' on {server.host} port {server.port} (JSON-RPC){twig}; "
        f"{mode}; characters {who}; Ctrl+C stops",
        file=sys.stderr,
        flush=True,
    )
    await server.serve_forever()
    print("twig serve: stopped", file=sys.stderr, flush=True)
    return 0
