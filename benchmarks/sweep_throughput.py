"""A sweep against the same runs done by hand: `twig run`s, two at a time, as a shell loop would.

Times ``twig sweep SCENE --seeds ... --set NAME=V1,V2,... --seconds N`` and then every run of
it as its own ``twig run SCENE --seed S --set NAME=V --seconds N --report json`` process,
as many at once as the sweep has workers; prints both wall times, their ratio, and whether
every row's state hash and figures equal its ``twig run``'s (issue 38):

    python benchmarks/sweep_throughput.py                      # 4 seeds x 3 values, 60 s each
    python benchmarks/sweep_throughput.py --seeds 0-1 --seconds 20
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from twig_ecs.sweep import flatten, parse_seeds, parse_values, plan_runs


def twig(*args: str) -> subprocess.CompletedProcess:
    """A ``twig`` command in a fresh process (this interpreter), as a user's shell runs it."""
    command = [sys.executable, "-m", "twig_ecs", *args]
    return subprocess.run(command, capture_output=True, text=True, check=True)


def main() -> None:
    """Run the sweep, then the same runs one by one; print the times and compare the rows."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="schoolyard")
    parser.add_argument("--seeds", default="0-3")
    parser.add_argument("--set", default="attachment.safe_distance=2,3,4")
    parser.add_argument("--seconds", default="60")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    name, values = parse_values(args.set)
    runs = plan_runs(parse_seeds(args.seeds), {name: values})
    table = Path(tempfile.mkdtemp(prefix="twig-sweep-")) / "table.csv"

    started = time.perf_counter()
    twig("sweep", args.scene, "--seeds", args.seeds, "--set", args.set, "--seconds", args.seconds,
         "--workers", str(args.workers), "-o", str(table))  # fmt: skip
    sweep_wall = time.perf_counter() - started
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))

    def by_hand(run) -> dict:
        out = twig("run", args.scene, "--seed", str(run.seed), "--set", f"{name}={run.values[name]}",
                   "--seconds", args.seconds, "--report", "json").stdout  # fmt: skip
        return dict(flatten(json.loads(out)))

    started = time.perf_counter()
    with ThreadPoolExecutor(args.workers) as pool:
        reports = list(pool.map(by_hand, runs))
    hand_wall = time.perf_counter() - started

    differ = [row["run"] for row, report in zip(rows, reports, strict=True)
              if any(str(report[key]) != row[key] for key in report if key in row)]  # fmt: skip
    print(f"{len(runs)} runs of {args.seconds} s, {args.workers} at a time")
    print(f"twig sweep:              {sweep_wall:7.1f} s")
    print(f"twig run, {args.workers} at a time: {hand_wall:7.1f} s")
    print(f"sweep / by hand:         {sweep_wall / hand_wall:7.2f}")
    print("rows equal to their twig run: " + ("all" if not differ else f"not runs {differ}"))
    if os.name == "posix":
        print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
