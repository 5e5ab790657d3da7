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

    class NestedTimes(event.Listener):
        """Seconds of numba's events by ``key(event)``: ``totals``, and ``inside``, those of the
        events nested in each (a compile types a call and compiles the callee within it; a
        compiler pass of one kernel holds the compiles of those it calls)."""

        def __init__(self, key) -> None:
            self.key = key
            self.totals: Counter = Counter()
            self.inside: Counter = Counter()
            self._open: list[tuple[str, float]] = []

        def on_start(self, ev) -> None:
            self._open.append((self.key(ev), time.perf_counter()))

        def on_end(self, ev) -> None:
            name, began = self._open.pop()
            seconds = time.perf_counter() - began
            self.totals[name] += seconds
            if self._open:
                self.inside[self._open[-1][0]] += seconds
            self.ended(ev, name)

        def ended(self, ev, name: str) -> None:
            """Called after each event with its key (nothing here)."""

        def own(self) -> dict[str, float]:
            """Each key's seconds less those nested in it."""
            return {name: self.totals[name] - self.inside[name] for name in self.totals}

    kinds: dict[str, str] = {}

    class Compiles(NestedTimes):
        """Times each kernel's compile, and notes what kind of kernel it was."""

        def ended(self, ev, name: str) -> None:
            dispatcher = ev.data["dispatcher"]
            if isinstance(dispatcher, HelperKernel):
                kinds[name] = "helper"
            else:
                kinds[name] = "kernel" if dispatcher.py_func.__module__.startswith("twig_ecs") else "numba"

    compiles = Compiles(lambda ev: ev.data["dispatcher"].py_func.__qualname__)
    passes = NestedTimes(lambda ev: ev.data["name"].split(" [")[0])  # (less the kernel's name)

    kernels.announce_no_compile()
    cpu = time.process_time()
    with (
        event.install_listener("numba:compile", compiles),
        event.install_listener("numba:run_pass", passes),
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

    totals, own = compiles.totals, compiles.own()
    print(f"{args.scene}: {len(totals)} kernels compiled, {cpu:.1f} s of CPU in all\n")
    print(f"{'kernel':28s} {'kind':6s} {'total':>7s} {'own':>7s} {'llvm':>7s}")
    for name in sorted(own, key=own.get, reverse=True)[: args.top]:
        print(f"{name:28s} {kinds[name]:6s} {totals[name]:7.2f} {own[name]:7.2f} {llvm_own[name]:7.2f}")
    print(f"\nLLVM, {sum(stages.values()):.1f} s in all:")
    for (stage, kind), seconds in sorted(stages.items()):
        print(f"  {stage:52s} {kind:6s} {seconds:6.2f}")
    by_pass = Counter(passes.own())
    print(f"\nnumba's passes, {sum(by_pass.values()):.1f} s in all (those over 0.1 s):")
    for name, seconds in by_pass.most_common():
        if seconds >= 0.1:
            print(f"  {name:59s} {seconds:6.2f}")


if __name__ == "__main__":
    main()
