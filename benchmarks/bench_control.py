"""Cost of character control per character per step: gait, gaze, posture, arms, breathing.

Run: ``python benchmarks/bench_control.py [--steps N] [--json]``. For 1, 10 and 100
walking characters (spread out so they do not meet), each controller system and the
physics systems are timed separately over the same steps; we report the median ms per
step and the controllers' microseconds per character per step.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time

import numpy as np

from twig_ecs import Scene

CONTROLLERS = ("patrol", "gait", "gaze", "posture", "arms", "respiration")
PHYSICS = ("integrate", "constrain", "collide", "sense")


def crowd(count: int) -> Scene:
    """``count`` characters on a grid 3 m apart, each walking a small square."""
    scene = Scene.load("empty")
    side = math.ceil(math.sqrt(count))
    rng = np.random.default_rng(2)
    for k in range(count):
        x, z = (k % side) * 3.0, (k // side) * 3.0
        c = scene.spawn("humanoid", name=f"c{k}", position=(x, 0.0, z), character=True)
        c.patrol([(x + 1, z), (x + 1, z + 1), (x, z + 1), (x, z)], speed=float(rng.uniform(0.6, 1.4)))
        c.look_at((x + 5.0, 1.5, z + 5.0))
    return scene


def measure(scene: Scene, steps: int) -> dict[str, float]:
    """Median ms per step of each system, stepping by hand in schedule order."""
    scene.step(60)  # settle, compile
    times: dict[str, list[float]] = {}
    systems = scene.schedule.systems()
    for _ in range(steps):
        ctx = scene.step_context()
        for system in systems:
            t0 = time.perf_counter()
            system.run(ctx)
            times.setdefault(system.name, []).append((time.perf_counter() - t0) * 1000.0)
        scene.frame += 1
    return {name: statistics.median(ms) for name, ms in times.items()}


def main() -> None:
    """Time each crowd size and print a table (or JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    results = {}
    for count in (1, 10, 100):
        scene = crowd(count)
        ms = measure(scene, args.steps)
        scene.close()
        control = sum(ms.get(n, 0.0) for n in CONTROLLERS)
        physics = sum(ms.get(n, 0.0) for n in PHYSICS)
        results[count] = {"systems_ms": ms, "control_ms": control, "physics_ms": physics,
                          "control_us_per_character": 1000.0 * control / count}  # fmt: skip
    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(f"{'characters':>10}{'control ms':>12}{'us/char':>9}{'physics ms':>12}   per controller (ms)")
    for count, r in results.items():
        parts = "  ".join(f"{n} {r['systems_ms'].get(n, 0.0):.3f}" for n in CONTROLLERS)
        print(f"{count:>10}{r['control_ms']:>12.3f}{r['control_us_per_character']:>9.1f}"
              f"{r['physics_ms']:>12.3f}   {parts}")  # fmt: skip


if __name__ == "__main__":
    main()
