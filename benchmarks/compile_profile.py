"""Where a first run's compile goes: each kernel's compile time, with and without what it compiles inside.

Compiles a scene's kernels in this one process (as the Python API does; a first ``twig run``
splits the same work over two worker processes), in an empty kernel cache, and prints per
kernel:

- ``total``: the seconds its compile took, including the kernels it compiled inside it (numba
  compiles a called kernel when it first types the call);
- ``own``: ``total`` less those kernels' own totals;
- ``llvm``: the seconds LLVM spent on its library (optimisation passes and machine code;
  numba's ``NUMBA_LLVM_PASS_TIMINGS``, which this script turns on). Numba links the optimised
  code of each kernel it calls into its library and works on it again there, so this can
  exceed ``own``. Counted for our kernels only (0 for numba's own);
- ``kind``: ``helper`` for a :func:`~twig_ecs.kernelmath.kernel_helper` (no entry point for
  Python), ``kernel`` for one Python calls, ``numba`` for numba's own implementations
  (``np.empty``'s, say), compiled once per signature like ours.

Then the LLVM time split by stage and kind, numba's own time by compiler pass (``native_lowering``
includes LLVM's work on the kernel's library), and the process's CPU seconds. What numba spends
outside LLVM is its type inference and lowering to LLVM IR. The CPU seconds move with the
machine's speed; compare two commits in turns (a worktree of each), not with a figure from
another day::

    python benchmarks/compile_profile.py                 # the schoolyard
    python benchmarks/compile_profile.py --top 15 melee
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections import Counter


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", nargs="?", default="schoolyard", help="a built-in scene or a YAML file")
    parser.add_argument("--top", type=int, default=30, help="kernels to list, by own time (default 30)")
    args = parser.parse_args()
    # before numba is imported: an empty cache (a first run), and LLVM's timings recorded
    os.environ["TWIG_CACHE_DIR"] = tempfile.mkdtemp(prefix="twig-compile-profile-")
    os.environ["NUMBA_LLVM_PASS_TIMINGS"] = "1"

    from numba.core import event

    from twig_ecs import kernels
    from twig_ecs.kernelmath import HelperKernel
    from twig_ecs.scene import Scene

    totals: Counter = Counter()
    inside: Counter = Counter()  # seconds of the kernels compiled inside each one
    kinds: dict[str, str] = {}
    stack: list[tuple[str, float]] = []

    class Timer(event.Listener):
        """Times each compile, and charges it to the compile it happened inside."""

        def on_start(self, ev) -> None:
            stack.append((ev.data["dispatcher"].py_func.__qualname__, time.perf_counter()))

        def on_end(self, ev) -> None:
            name, began = stack.pop()
            seconds = time.perf_counter() - began
            totals[name] += seconds
            dispatcher = ev.data["dispatcher"]
            if isinstance(dispatcher, HelperKernel):
                kinds[name] = "helper"
            else:
                kinds[name] = "kernel" if dispatcher.py_func.__module__.startswith("twig_ecs") else "numba"
            if stack:
                inside[stack[-1][0]] += seconds

    passes: Counter = Counter()  # each compiler pass's seconds, less the compiles nested in it
    running: list[list] = []  # [pass, its start, nested seconds]

    class PassTimer(event.Listener):
        """Times numba's compiler passes (a pass that types a call compiles the callee inside it)."""

        def on_start(self, ev) -> None:
            running.append([ev.data["name"].split(" [")[0], time.perf_counter(), 0.0])

        def on_end(self, ev) -> None:
            name, began, nested = running.pop()
            seconds = time.perf_counter() - began
            passes[name] += seconds - nested
            if running:
                running[-1][2] += seconds

    kernels.announce_no_compile()
    cpu = time.process_time()
    with (
        event.install_listener("numba:compile", Timer()),
        event.install_listener("numba:run_pass", PassTimer()),
    ):
        scene = Scene.load(args.scene)
        scene.step(1)
    cpu = time.process_time() - cpu

    llvm_own: Counter = Counter()
    stages: Counter = Counter()
    for kernel in kernels.InterimKernels().kernels():
        name = kernel.py_func.__qualname__
        for result in kernel.overloads.values():
            for record in (result.metadata or {}).get("llvm_pass_timings") or ():
                seconds = record.timings.get_total_time()
                llvm_own[name] += seconds
                stage = "function passes" if record.name.startswith("Function passes") else record.name
                stages[(stage, kinds.get(name, "kernel"))] += seconds

    own = {name: totals[name] - inside[name] for name in totals}
    print(f"{args.scene}: {len(totals)} kernels compiled, {cpu:.1f} s of CPU in all\n")
    print(f"{'kernel':28s} {'kind':6s} {'total':>7s} {'own':>7s} {'llvm':>7s}")
    for name in sorted(own, key=own.get, reverse=True)[: args.top]:
        print(f"{name:28s} {kinds[name]:6s} {totals[name]:7.2f} {own[name]:7.2f} {llvm_own[name]:7.2f}")
    print(f"\nLLVM, {sum(stages.values()):.1f} s in all:")
    for (stage, kind), seconds in sorted(stages.items()):
        print(f"  {stage:52s} {kind:6s} {seconds:6.2f}")
    print(f"\nnumba's passes, {sum(passes.values()):.1f} s in all (those over 0.1 s):")
    for name, seconds in passes.most_common():
        if seconds >= 0.1:
            print(f"  {name:59s} {seconds:6.2f}")


if __name__ == "__main__":
    main()
