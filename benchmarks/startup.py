"""Startup time of a ``twig`` command: from launching the process to its first stepped frame.

Runs ``python -m twig_ecs <command...>`` in a fresh process, as a person would, with one hook:
the first ``Scene.step`` that advances the scene prints the wall-clock time when it returns.
The figure is that time minus the moment the process was launched, so it counts the
interpreter's start, every import, loading the scene, any kernel compile or cache load and
the first step itself. ``--cold`` gives the run an empty kernel cache (a first run).

The child runs with ``PYTHONDONTWRITEBYTECODE`` unset and one untimed run goes first, as on
a person's install (pip writes the ``.pyc`` files): with it set, each start would compile
every twig-ecs module from source again (~0.1 s), which no user pays.

    python benchmarks/startup.py                       # twig run schoolyard --seconds 1, cached
    python benchmarks/startup.py --cold                # ... with an empty kernel cache
    python benchmarks/startup.py --cold -- play schoolyard --headless --frames 60
    python benchmarks/startup.py --cold --burners 1    # a first run beside one CPU-bound process
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time

from busy_machine import burn  # (this folder is on the path of a script run from it)

#: The child: mark the end of the first step that advances time, then run the real CLI.
_CHILD = """
import sys, time
from twig_ecs.scene import Scene
_step = Scene.step
def step(self, *args, **kw):
    out = _step(self, *args, **kw)
    if self.frame > 0 and not getattr(Scene, "_marked", False):
        Scene._marked = True
        print(f"FIRST-STEP {time.time():.6f} {time.process_time():.6f}", file=sys.stderr, flush=True)
    return out
Scene.step = step
from twig_ecs.cli import main
sys.exit(main(sys.argv[1:]))
"""


def measure(command: list[str], cold: bool = False) -> tuple[float, float, float, float, str]:
    """Seconds from launch to the first stepped frame; the CPU seconds the process had used by
    then (less sensitive to a busy machine than the wall clock; kernel-compiling workers not
    counted); seconds to the process's exit; the CPU seconds of the whole run, workers
    included; and what ``twig play --frames`` says of its own start."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a person's install has its bytecode cached
    if cold:
        env["TWIG_CACHE_DIR"] = tempfile.mkdtemp(prefix="twig-startup-")
    before = _children_cpu()
    start = time.time()
    proc = subprocess.run([sys.executable, "-c", _CHILD, *command], env=env, capture_output=True, text=True)
    end = time.time()
    total_cpu = _children_cpu() - before
    marks = [line for line in proc.stderr.splitlines() if line.startswith("FIRST-STEP ")]
    if proc.returncode or not marks:
        sys.exit(f"the command failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    said = [line for line in proc.stderr.splitlines() if line.startswith("twig play: first frame after")]
    _, wall, cpu = marks[0].split()
    return float(wall) - start, float(cpu), end - start, total_cpu, said[0] if said else ""


def _children_cpu() -> float:
    """User + system CPU seconds of finished child processes (and the children they waited for)."""
    try:
        import resource
    except ImportError:  # not on Windows
        return float("nan")
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    """Measure a command's startup a few times and print each figure with the load average."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cold", action="store_true", help="an empty kernel cache each time (first run)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--burners", type=int, default=0, help="CPU-bound processes beside it")
    parser.add_argument("command", nargs="*", default=["run", "schoolyard", "--seconds", "1"])
    args = parser.parse_args()
    if not args.cold:
        measure(args.command)  # untimed: writes the bytecode and fills the OS file cache
    stop = multiprocessing.Event()
    burners = [multiprocessing.Process(target=burn, args=(stop,), daemon=True) for _ in range(args.burners)]
    for proc in burners:
        proc.start()
    try:
        _measure_repeatedly(args)
    finally:
        stop.set()
        for proc in burners:
            proc.join()


def _measure_repeatedly(args: argparse.Namespace) -> None:
    firsts, cpus = [], []
    for _ in range(args.repeat):
        first, cpu, total, total_cpu, said = measure(args.command, args.cold)
        firsts.append(first)
        cpus.append(cpu)
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        kind = "cold" if args.cold else "cached"
        print(f"{kind}: first step {first:.2f} s after launch ({cpu:.2f} s CPU), "
              f"exit {total:.2f} s ({total_cpu:.1f} s CPU in all)  "
              f"(load average {load:.2f})  {said}")  # fmt: skip
    print(f"median: first step {statistics.median(firsts):.2f} s after launch "
          f"({statistics.median(cpus):.2f} s CPU) over {len(firsts)} runs")  # fmt: skip


if __name__ == "__main__":
    main()
