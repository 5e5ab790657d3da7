"""A long soak of the schoolyard: 60 simulated minutes within the soak limits (not a CI test).

Run: ``python benchmarks/soak.py [--minutes 60] [--seed 0] [--json]``. It runs the same
function as ``twig run schoolyard --seconds S --soak`` (every figure checked after
every step) and prints the worst figures, the wall time and the step times; it exits 1
at the first limit crossed, naming the frame and the body. CI runs 5 minutes of the
same (tests/test_soak.py).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from twig_ecs.report import run_with_report
from twig_ecs.soak import SoakLimits


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="simulated minutes (default 60)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scene", default="schoolyard")
    parser.add_argument("--json", action="store_true", help="print the whole report as JSON")
    args = parser.parse_args()

    limits = SoakLimits()
    t0 = time.perf_counter()
    report = run_with_report(args.scene, args.minutes * 60.0, seed=args.seed, limits=limits,
                             progress=sys.stderr.isatty())  # fmt: skip
    wall = time.perf_counter() - t0
    report["wall_s"] = round(wall, 1)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        min_y = report["min_node_y"]
        steps = report["step_ms"]
        print(f"{report['scene']} soak, seed {args.seed}: {report['seconds'] / 60:.1f} simulated minutes "
              f"({report['frames']} steps) in {wall:.0f} s wall; step median {steps['median']:.3f} ms, "
              f"p95 {steps['p95']:.3f} ms")  # fmt: skip
        rows = [("max node speed", report["max_speed_m_s"], limits.max_speed, "m/s"),
                ("min node y", min_y, limits.min_y, "m"),
                ("max penetration", report["max_penetration_m"], limits.max_penetration, "m"),
                ("max link error", report["max_link_error"], limits.max_link_error, "(|len-rest|/rest)"),
                ("max kinetic energy", report["max_kinetic_energy_j"], limits.max_energy, "J")]  # fmt: skip
        for label, value, limit, unit in rows:
            print(f"  {label:<20} {value:>12.4f}   limit {limit:>10g} {unit}")
        print(f"  nan                  {str(report['nan']).lower():>12}")
        print(f"  state {report['state_hash']}")
    if report["violation"]:
        print(f"soak failed: {report['violation']['message']}", file=sys.stderr)
        return 1
    return 1 if report["nan"] else 0


if __name__ == "__main__":
    sys.exit(main())
