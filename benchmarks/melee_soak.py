"""The goal melee under the soak limits (issue 31): 16 characters and 4 ragdolls, goals at each other.

Run: ``python benchmarks/melee_soak.py [--seconds 300] [--seeds 0,1,2,3] [--json]``. The
driver (tests/melee.py) loads ``content/scenes/melee.yaml`` and keeps every character busy
with grapple, hug, carry and drag goals at a random other body, chosen by the seed; every
step is checked as ``twig run --soak`` checks it. Exits 1 if a seed crossed a limit.
``tests/test_melee_soak.py`` runs a shorter melee in CI.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from melee import run_melee  # noqa: E402

from twig_ecs.soak import SoakLimits  # noqa: E402


def main() -> int:
    """Run the melee once per seed and print the worst figures of each."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--seeds", default="0,1,2,3")
    parser.add_argument("--count", type=int, default=16, help="characters (half of them children)")
    parser.add_argument("--dolls", type=int, default=4)
    parser.add_argument("--json", action="store_true", help="one JSON line per seed")
    parser.add_argument(
        "--measure-only",
        action="store_true",
        help="run the whole time and report the worst figures, stopping at no limit",
    )
    args = parser.parse_args()
    failed = 0
    for seed in (int(s) for s in args.seeds.split(",")):
        t0 = time.perf_counter()
        limits = SoakLimits(math.inf, -math.inf, math.inf, math.inf, math.inf) if args.measure_only else None
        run = run_melee(seed, args.seconds, limits, count=args.count, dolls=args.dolls)
        wall = time.perf_counter() - t0
        failed += run.violation is not None or run.figures["nan"]
        if args.json:
            print(json.dumps({"seed": seed, "frames": run.frames, "wall_s": round(wall, 1), **run.figures,
                              "violation": run.violation and run.violation.message(), "given": run.given,
                              "ended": run.ended, "state_hash": run.state_hash}), flush=True)  # fmt: skip
            continue
        f = run.figures
        print(f"seed {seed}: {run.frames} steps in {wall:.0f} s wall; max speed {f['max_speed_m_s']:.1f} "
              f"m/s, energy {f['max_kinetic_energy_j']:.0f} J, penetration {f['max_penetration_m']:.3f} m, "
              f"link error {f['max_link_error']:.2f}, min y {f['min_node_y']:.3f} m; goals {run.given}",
              flush=True)  # fmt: skip
        if run.violation is not None:
            print(f"  soak failed: {run.violation.message()}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
