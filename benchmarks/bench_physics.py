"""Median physics step time: the schoolyard and piles of 10 / 100 / 1000 ragdolls.

Run: ``python benchmarks/bench_physics.py [--steps N] [--json]``. Each case is loaded,
settled for a moment, then stepped; we report the median and 95th percentile of the
wall time per 1/60 s step (integrate + constrain + collide + sense), and the ratio of
each case to the schoolyard measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from twig_ecs import Scene
from twig_ecs.bench.cases import ragdoll_pile


def measure(scene: Scene, steps: int, warmup: int) -> dict:
    """Step ``warmup`` times untimed, then time ``steps`` single steps."""
    scene.step(warmup)
    times = []
    for _ in range(steps):
        t0 = time.perf_counter()
        scene.step()
        times.append((time.perf_counter() - t0) * 1000.0)
    times.sort()
    return {
        "median_ms": statistics.median(times),
        "p95_ms": times[int(0.95 * (len(times) - 1))],
        "nodes": scene.state.nodes.count,
        "links": scene.state.links.count,
        "candidate_pairs": int(scene.state.n_pairs),
    }


def main() -> None:
    """Run every case and print a table (or JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300, help="timed steps per case")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = parser.parse_args()

    t0 = time.perf_counter()
    with Scene.load("empty") as warm:  # compile (or load) the kernels outside the timings
        warm.spawn("humanoid", name="w")
        warm.step(2)
    startup = time.perf_counter() - t0

    cases = [("schoolyard", lambda: Scene.load("schoolyard"))]
    cases += [(f"{n} ragdolls", lambda n=n: ragdoll_pile(n)) for n in (10, 100, 1000)]
    results = {}
    for name, make in cases:
        t0 = time.perf_counter()
        scene = make()
        build = time.perf_counter() - t0
        steps = args.steps if scene.state.nodes.count < 5000 else max(60, args.steps // 3)
        results[name] = measure(scene, steps, warmup=60) | {"build_s": build}
        scene.close()
    base = results["schoolyard"]["median_ms"]
    if args.json:
        print(json.dumps({"startup_s": startup, "cases": results}, indent=2))
        return
    print(f"kernel start-up (compile or cache load): {startup:.2f} s")
    print(f"{'case':<16}{'nodes':>7}{'links':>7}{'median ms':>11}{'p95 ms':>9}"
          f"{'x schoolyard':>14}{'build s':>9}")  # fmt: skip
    for name, r in results.items():
        print(f"{name:<16}{r['nodes']:>7}{r['links']:>7}{r['median_ms']:>11.3f}{r['p95_ms']:>9.3f}"
              f"{r['median_ms'] / base:>14.1f}{r['build_s']:>9.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
