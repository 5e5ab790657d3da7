"""Server round trips while the schoolyard runs: latency (median, p99) and sustained requests/s.

Run: ``python benchmarks/bench_server.py [--requests N] [--seconds S] [--clients K] [--json]``.
Starts ``twig serve schoolyard`` in its own process (running at 60 Hz, characters
autonomous) on a free port, then measures from this process:

- latency: N sequential round trips by one client of ``ping`` (answered at once),
  ``status`` and ``get_state`` of one character (both applied by the simulation loop
  between steps);
- throughput: K asyncio clients, each keeping 16 ``status`` requests in flight, for S
  seconds; requests answered per second, and the simulation's step rate meanwhile
  (it should stay at 60 frames per second).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import time

from twig_ecs.client import AsyncClient, Client, spawn_server


def latency(port: int, requests: int) -> dict[str, dict[str, float]]:
    """Median and p99 round trip (ms) of a few methods, one request at a time."""
    out = {}
    with Client(port=port) as twig:
        for method, params in (("ping", {}), ("status", {}), ("get_state", {"name": "big_child"})):
            for _ in range(50):  # warm up
                twig.call(method, **params)
            times = []
            for _ in range(requests):
                t0 = time.perf_counter()
                twig.call(method, **params)
                times.append((time.perf_counter() - t0) * 1000.0)
            times.sort()
            p99 = times[int(0.99 * (len(times) - 1))]
            out[method] = {"median_ms": statistics.median(times), "p99_ms": p99}
    return out


async def throughput(port: int, clients: int, seconds: float, window: int = 16) -> dict[str, float]:
    """Requests answered per second by ``clients`` pipelining clients, and the step rate meanwhile."""
    conns = [await AsyncClient.connect(port=port) for _ in range(clients)]
    answered = 0
    stop_at = 0.0

    async def worker(twig: AsyncClient) -> None:
        nonlocal answered
        while time.monotonic() < stop_at:
            await twig.call("status")
            answered += 1

    frame0 = (await conns[0].call("status"))["frame"]
    start = time.monotonic()
    stop_at = start + seconds
    await asyncio.gather(*(worker(c) for c in conns for _ in range(window)))
    elapsed = time.monotonic() - start
    frames = (await conns[0].call("status"))["frame"] - frame0
    for c in conns:
        await c.close()
    return {"requests_per_s": answered / elapsed, "steps_per_s": frames / elapsed, "clients": clients}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--requests", type=int, default=2000, help="round trips per method (default 2000)")
    parser.add_argument("--seconds", type=float, default=5.0, help="throughput run length (default 5)")
    parser.add_argument("--clients", type=int, default=8, help="throughput clients (default 8)")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    proc, port = spawn_server("schoolyard")
    try:
        lat = latency(port, args.requests)
        thr = asyncio.run(throughput(port, args.clients, args.seconds))
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    if args.json:
        print(json.dumps({"latency": lat, "throughput": thr}, indent=2))
        return 0
    print(f"schoolyard served at 60 Hz; {args.requests} sequential round trips per method:")
    for method, r in lat.items():
        print(f"  {method:<10} median {r['median_ms']:.3f} ms   p99 {r['p99_ms']:.3f} ms")
    print(f"{thr['clients']} clients x 16 in flight for {args.seconds:g} s: "
          f"{thr['requests_per_s']:.0f} requests/s answered; "
          f"the simulation meanwhile ran {thr['steps_per_s']:.1f} steps/s")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
