"""State hashes of the runs a refactor must not change: the schoolyard and every bench case.

A move of code that is meant to change no result (issue 32: the architecture step) is
checked by running this before and after and comparing the two outputs::

    python benchmarks/state_hashes.py -o before.json
    ... change the code ...
    python benchmarks/state_hashes.py -o after.json --compare before.json

The schoolyard runs seeds 0-3 for 300 simulated seconds (``--seconds``); each ``twig bench``
case is built as the bench builds it and stepped 360 times (the bench's 60 warm-up and 300
timed steps) at sizes 10 and 100. Every line printed is one run's hash; ``--compare``
lists the runs whose hash moved and exits 1 if any did.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from twig_ecs.bench import cases
from twig_ecs.scene import Scene

#: The bench cases by name, as ``twig bench --cases`` names them (the schoolyard is run apart).
BENCH_CASES = {
    "crowd": cases.crowd,
    "approach": cases.approach_crowd,
    "hug": cases.hugging_pairs,
    "brawl": cases.brawl,
    "plugin": cases.plugin_strollers,
    "ragdolls": cases.ragdoll_pile,
}


def run_hashes(seconds: float, sizes: list[int], steps: int, seeds: list[int]) -> dict[str, str]:
    """Every run's state hash by run name, printing each as it ends."""
    out: dict[str, str] = {}

    def record(name: str, scene: Scene, started: float) -> None:
        out[name] = scene.state_hash()
        scene.close()
        print(f"{name:24s} {out[name]}  ({time.perf_counter() - started:.1f} s)", flush=True)

    for seed in seeds:
        started = time.perf_counter()
        scene = Scene.load("schoolyard", seed=seed)
        scene.run(seconds)
        record(f"schoolyard-seed{seed}-{seconds:g}s", scene, started)
    for case, build in BENCH_CASES.items():
        for size in sizes:
            started = time.perf_counter()
            scene = build(size)
            for _ in range(steps):
                scene.step()
            record(f"{case}-{size}", scene, started)
    return out


def main(argv: list[str] | None = None) -> int:
    """Run, print, optionally save and compare."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=300.0, help="schoolyard seconds (default 300)")
    parser.add_argument("--seeds", default="0,1,2,3", help="schoolyard seeds (default 0,1,2,3)")
    parser.add_argument("--sizes", default="10,100", help="bench case sizes (default 10,100)")
    parser.add_argument("--steps", type=int, default=360, help="steps per bench case (default 360)")
    parser.add_argument("-o", "--output", help="write the hashes to this JSON file")
    parser.add_argument("--compare", help="a JSON file written before: list the runs that differ")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",") if s]
    sizes = [int(s) for s in args.sizes.split(",") if s]
    hashes = run_hashes(args.seconds, sizes, args.steps, seeds)
    if args.output:
        with open(args.output, "w") as f:
            json.dump(hashes, f, indent=1)
    if args.compare:
        with open(args.compare) as f:
            before = json.load(f)
        moved = [name for name in hashes if name in before and before[name] != hashes[name]]
        for name in moved:
            print(f"moved: {name}: {before[name]} -> {hashes[name]}")
        print(f"{len(hashes) - len(moved)} of {len(hashes)} runs unchanged")
        return 1 if moved else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
