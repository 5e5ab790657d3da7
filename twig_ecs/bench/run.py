"""``twig bench``: time our cases and, when MuJoCo is installed, its ragdolls beside them."""

from __future__ import annotations

import platform
import sys
import time
from collections.abc import Callable

CASES = ("schoolyard", "crowd", "approach", "hug", "brawl", "plugin", "plugin_batch", "ragdolls")
#: The cases of N characters, with the name of each one's scene maker in bench.cases
#: (names, not functions: the cases import the whole scene, and `twig`'s parser reads this module).
SIZED = {"crowd": "crowd", "approach": "approach_crowd", "hug": "hugging_pairs",
         "brawl": "brawl", "plugin": "plugin_strollers", "plugin_batch": "plugin_batch_strollers",
         "ragdolls": "ragdoll_pile"}  # fmt: skip
SIZES = (10, 100, 1000)


def startup() -> dict:
    """Seconds to get the kernels ready (compile on a first run, else load the cache)."""
    from twig_ecs import Scene, kernels

    cached = kernels.is_cached()
    t0 = time.perf_counter()
    with Scene.load("empty") as scene:
        scene.spawn("humanoid", name="w", character=True)
        scene.step(2)
    return {"seconds": time.perf_counter() - t0, "compiled": not cached}


def run_bench(which: tuple[str, ...] = CASES, sizes: tuple[int, ...] = SIZES, steps: int = 300,
              warmup: int = 60, mujoco: bool = True,
              say: Callable[[str], None] | None = None) -> dict:  # fmt: skip
    """Time every case; returns a JSON-ready dict (see docs/performance.md).

    ``say`` gets progress lines. Each crowd and ragdoll case is stepped in turn with a
    MuJoCo model of as many ragdolls (when MuJoCo is installed), so both meet the same
    machine load; the case gets MuJoCo's times and ``vs_mujoco`` = ours / MuJoCo (below
    1: we are faster).
    """
    # here, not at the top: `twig`'s parser reads CASES and SIZES for every command,
    # and the cases import the whole scene (numba included)
    from twig_ecs.bench import cases, mujoco_ragdolls, timing

    say = say or (lambda line: None)
    out: dict = {"machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
                 "python": platform.python_version(), "steps": steps, "warmup": warmup}  # fmt: skip
    say("kernels: loading (compiling on a first run)...")
    out["startup"] = startup()
    jobs: list[tuple[str, int | None, Callable]] = []
    if "schoolyard" in which:
        jobs.append(("schoolyard", None, cases.schoolyard))
    for size in sizes:
        for kind, maker in SIZED.items():
            make = getattr(cases, maker)
            if kind in which:
                jobs.append((kind, size, lambda n=size, make=make: make(n)))
    if mujoco and not mujoco_ragdolls.available():
        say("mujoco: not installed (pip install 'twig-ecs[bench]'): no comparison")
        mujoco = False
    models: dict[int, mujoco_ragdolls.Ragdolls] = {}
    results = []
    for kind, size, make in jobs:
        label = kind if size is None else f"{kind} {size}"
        say(f"{label}: building...")
        t0 = time.perf_counter()
        scene = make()
        build = time.perf_counter() - t0
        other = None
        if mujoco and size is not None and size not in models and not mujoco_ragdolls.affordable(size):
            say(f"{label}: no MuJoCo comparison: compiling its model of {size} ragdolls would take "
                f"hours (over {mujoco_ragdolls.COMPILE_LIMIT}: see docs/performance.md)")  # fmt: skip
        elif mujoco and size is not None:
            if size not in models:
                say(f"{label}: building MuJoCo's {size} ragdolls...")
                models[size] = mujoco_ragdolls.Ragdolls(size)
            other = models[size]
            other.reset()
        tick = max(1, steps // 10)
        beside = " (and MuJoCo's, in turn)" if other else ""

        def progress(i: int, label: str = label, tick: int = tick, beside: str = beside) -> None:
            if (i + 1) % tick == 0:
                say(f"{label}: step {i + 1}/{steps}{beside}")

        try:
            r = timing.measure(scene, steps, warmup, progress, beside=other.step if other else None)
        finally:
            scene.close()
        r = {"case": label, "kind": kind, "size": size, "build_s": build} | r
        if other is not None:
            r["mujoco"] = r.pop("beside") | other.info()
            r["vs_mujoco"] = r["median_ms"] / r["mujoco"]["median_ms"]
        results.append(r)
    out["cases"] = results
    return out


def progress_printer(stream=sys.stderr) -> Callable[[str], None]:
    """A ``say`` that rewrites one status line on a terminal, or prints lines otherwise."""
    tty = stream.isatty()

    def say(line: str) -> None:
        if tty:
            stream.write("\r\033[K" + line)
        else:
            if "step " in line:
                return  # a log: only the stage lines
            stream.write(line + "\n")
        stream.flush()

    return say
