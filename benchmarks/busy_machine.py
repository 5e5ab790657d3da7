"""Step times on a busy machine and a quiet one: twig's thread choice against one thread.

Users' machines are never quiet. This runs ``twig bench`` cases in fresh processes, in
turn (alternating, so every setting meets the same moments of the machine's load), under
each thread setting, once with nothing beside it and once with ``--burners`` CPU-bound
processes beside it, and prints the median step times, their ratio to one thread, and the
share of timed steps the default ran on more than one thread:

    python benchmarks/busy_machine.py                          # approach 100 and 1000, crowd 300
    python benchmarks/busy_machine.py --cases crowd --sizes 1000 --rounds 5 --json
    python benchmarks/busy_machine.py --settings default,one,all,spin

Settings: ``default`` is what a user gets (each scene measures whether threads pay:
``twig_ecs.threads``), ``one`` is ``NUMBA_NUM_THREADS=1``, ``all`` is every thread on every
step (``TWIG_THREADS``: twig's behaviour before the measured choice, threads asleep when
idle), ``spin`` the same with libgomp's busy-wait forced on (``OMP_WAIT_POLICY=ACTIVE``:
the behaviour before twig chose a passive wait). The thread variables of the calling shell
(``NUMBA_NUM_THREADS``, ``TWIG_THREADS``, ``OMP_WAIT_POLICY``) are not passed on: each
setting is only its own. The target (issue 33): with two burners, no case is more than
1.15x its one-thread time, and on a quiet machine threads still help where they helped.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import subprocess
import sys
import time

ALL = str(os.cpu_count() or 1)
SETTINGS = {
    "default": {},
    "one": {"NUMBA_NUM_THREADS": "1"},
    "all": {"TWIG_THREADS": ALL},
    "spin": {"TWIG_THREADS": ALL, "OMP_WAIT_POLICY": "ACTIVE"},
}
#: Left out of the environment the runs inherit: a setting is only its own.
THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "TWIG_THREADS", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT")


def burn(stop: multiprocessing.Event) -> None:  # type: ignore[valid-type]
    """A CPU-bound process: what another program on the user's machine does."""
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x = (x * 1103515245 + 12345) & 0x7FFFFFFF


def bench_once(case: str, size: int, steps: int, setting: str) -> tuple[float, float]:
    """Median ms per step of one case in a fresh process under one thread setting, and the
    share of its steps on more than one thread."""
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES} | SETTINGS[setting]
    command = [sys.executable, "-m", "twig_ecs", "bench", "--cases", case, "--sizes", str(size),
               "--steps", str(steps), "--warmup", "30", "--no-mujoco", "--json"]  # fmt: skip
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=1800, check=True)
    (result,) = json.loads(done.stdout)["cases"]
    return result["median_ms"], result["threads"]["threaded_share"]


#: Steps each setting takes in a row in ``--interleave`` runs (a setting switch costs a little).
BLOCK = 10


def interleaved_child(case: str, size: int, steps: int, settings: list[str]) -> dict:
    """In this process: one scene of the case, its settings taking turns a block of steps at a
    time (each setting a thread choice of its own), so every setting meets the same moments
    of the load. ``one`` is one thread (``TWIG_THREADS=1``'s choice, not ``NUMBA_NUM_THREADS``:
    the pool exists but sleeps). Returns {setting: [step seconds]} and the default's share."""
    from twig_ecs.bench import cases
    from twig_ecs.bench.run import SIZED
    from twig_ecs.threads import ThreadChoice, usable_threads

    scene = getattr(cases, SIZED[case])(size)
    most = usable_threads()
    choices = {"default": ThreadChoice(), "one": ThreadChoice(fixed=1), "all": ThreadChoice(fixed=most)}
    times: dict[str, list[float]] = {s: [] for s in settings}
    scene.thread_choice = choices["default"]
    scene.step(30)  # warm-up (the default's first trial)
    counted = choices["default"].steps, choices["default"].threaded
    rotation = 0
    while min(len(t) for t in times.values()) < steps:
        for setting in settings[rotation:] + settings[:rotation]:
            scene.thread_choice = choices[setting]
            scene.step(1)  # (a switch rebuilds the constraint plan: untimed)
            for _ in range(BLOCK):
                started = time.perf_counter()
                scene.step(1)
                times[setting].append(time.perf_counter() - started)
        rotation = (rotation + 1) % len(settings)
    default = choices["default"]
    share = (default.threaded - counted[1]) / max(1, default.steps - counted[0])
    scene.close()
    return {"times": times, "threaded": share, "trials": default.trials}


def paired_ratios(times: dict[str, list[float]]) -> dict[str, float]:
    """Each setting's time over one thread's, as the median over the rounds of the ratio of the
    two blocks' medians in that round (blocks of one round are at most a few seconds apart:
    a load that comes and goes within a run meets both)."""
    blocks = {s: [statistics.median(t[i : i + BLOCK]) for i in range(0, len(t) - BLOCK + 1, BLOCK)]
              for s, t in times.items()}  # fmt: skip
    return {s: statistics.median(b / one for b, one in zip(blocks[s], blocks["one"], strict=False))
            for s in times if s != "one"}  # fmt: skip


def interleaved(cases: list[tuple[str, int]], settings: list[str], steps: int, burners: int) -> dict:
    """{case: {setting: [median ms]}, "threaded": {"default": [share]}} from one fresh process per
    case (:func:`interleaved_child`) with ``burners`` CPU-bound processes beside it."""
    if "spin" in settings:
        raise SystemExit("--interleave cannot run 'spin' (a wait policy is one per process)")
    stop = multiprocessing.Event()
    procs = [multiprocessing.Process(target=burn, args=(stop,), daemon=True) for _ in range(burners)]
    for p in procs:
        p.start()
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    try:
        out: dict = {}
        for case, size in cases:
            command = [sys.executable, __file__, "--child", case, str(size), str(steps), ",".join(settings)]
            done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=3600, check=True)
            result = json.loads(done.stdout)
            label = f"{case} {size}"
            out[label] = {s: [statistics.median(t) * 1000.0] for s, t in result["times"].items()}
            out[label]["threaded"] = {"default": [result["threaded"]]}
            out[label]["paired"] = paired_ratios(result["times"])
            meds = "  ".join(f"{s} {out[label][s][0]:.2f}" for s in settings)
            ratios = "  ".join(f"{s}/one {r:.2f}" for s, r in out[label]["paired"].items())
            line = f"{meds} ms/step ({ratios}), {result['threaded']:4.0%} threaded, {result['trials']} trials"
            print(f"  {label:14s} {line} (load {os.getloadavg()[0]:.1f})", file=sys.stderr, flush=True)
        return out
    finally:
        stop.set()
        for p in procs:
            p.join(timeout=5)


def measure(cases: list[tuple[str, int]], settings: list[str], rounds: int, steps: int, burners: int) -> dict:
    """{case: {setting: [median ms per round]}}, rounds alternating the settings; the shares of
    threaded steps under {case: {"threaded": {setting: [share per round]}}}."""
    stop = multiprocessing.Event()
    procs = [multiprocessing.Process(target=burn, args=(stop,), daemon=True) for _ in range(burners)]
    for p in procs:
        p.start()
    try:
        out: dict = {}
        for case, size in cases:
            label = f"{case} {size}"
            times: dict[str, list[float]] = {s: [] for s in settings}
            shares: dict[str, list[float]] = {s: [] for s in settings}
            for r in range(rounds):
                for setting in settings if r % 2 == 0 else reversed(settings):
                    ms, share = bench_once(case, size, steps, setting)
                    times[setting].append(ms)
                    shares[setting].append(share)
                    print(f"  {label:14s} {setting:8s} round {r + 1}/{rounds}: {ms:8.2f} ms/step, "
                          f"{share:4.0%} threaded (load {os.getloadavg()[0]:.1f})", file=sys.stderr,
                          flush=True)  # fmt: skip
            out[label] = times | {"threaded": shares}
        return out
    finally:
        stop.set()
        for p in procs:
            p.join(timeout=5)


def report(title: str, results: dict, settings: list[str]) -> None:
    """A table: median of the rounds' medians, the ratio to one thread (``--interleave``: the
    median of each round's ratio, :func:`paired_ratios`), and the share of the default's
    steps on more than one thread (all rounds)."""
    print(f"\n{title}")
    threaded = "default" in settings
    heads = [f"{s:>12s}" for s in settings] + [f"{s + '/one':>13s}" for s in settings if s != "one"]
    print(f"{'case':16s}" + "".join(heads) + ("   threaded" if threaded else ""))
    for label, times in results.items():
        med = {s: statistics.median(times[s]) for s in settings}
        ratio = times.get("paired") or {
            s: med[s] / med["one"] for s in settings if s != "one" and "one" in med
        }
        ratios = "".join(f"{ratio[s]:13.2f}" for s in settings if s in ratio)
        share = f"{statistics.mean(times['threaded']['default']):11.0%}" if threaded else ""
        print(f"{label:16s}" + "".join(f"{med[s]:12.2f}" for s in settings) + ratios + share)


def main() -> None:
    """Parse the command line, measure quiet and busy, print (or dump JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default="approach,approach,crowd", help="bench cases, paired with --sizes")
    parser.add_argument("--sizes", default="100,1000,300", help="one size per case")
    parser.add_argument("--settings", default="default,one", help=f"from {', '.join(SETTINGS)}")
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds per setting")
    parser.add_argument("--steps", type=int, default=150, help="timed steps per run")
    parser.add_argument("--burners", type=int, default=2, help="CPU-bound processes for the busy run")
    parser.add_argument("--busy-only", action="store_true", help="skip the quiet run")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parser.add_argument("--interleave", action="store_true",
                        help=f"one process per case, the settings taking turns {BLOCK} steps at a time "
                             "(less noise on a shared machine than whole runs in turn)")  # fmt: skip
    parser.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        case, size, steps, settings = args.child
        print(json.dumps(interleaved_child(case, int(size), int(steps), settings.split(","))))
        return
    cases = list(zip(args.cases.split(","), (int(s) for s in args.sizes.split(",")), strict=True))
    settings = args.settings.split(",")
    unknown = [s for s in settings if s not in SETTINGS]
    if unknown:
        parser.error(f"unknown setting(s) {', '.join(unknown)}; known: {', '.join(SETTINGS)}")
    started = time.time()
    runs = {}
    rounds = 1 if args.interleave else args.rounds
    for name, burners in ([] if args.busy_only else [("quiet", 0)]) + [("busy", args.burners)]:
        print(f"{name} ({burners} CPU-bound processes of ours beside it):", file=sys.stderr)
        if args.interleave:
            runs[name] = interleaved(cases, settings, args.steps, burners)
        else:
            runs[name] = measure(cases, settings, args.rounds, args.steps, burners)
    if args.json:
        print(json.dumps({"cpus": os.cpu_count(), "burners": args.burners, "interleave": args.interleave,
                          "runs": runs}, indent=1))  # fmt: skip
        return
    for name, results in runs.items():
        how = f"{rounds} alternating rounds"
        if args.interleave:
            how = f"{BLOCK}-step blocks in turn, one process"
        report(f"{name} ({os.cpu_count()} CPUs, median ms/step, {how})", results, settings)
    print(f"\n({time.time() - started:.0f} s)")


if __name__ == "__main__":
    main()
