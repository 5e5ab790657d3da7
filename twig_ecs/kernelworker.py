"""A :class:`~twig_ecs.kernels.KernelBuild` worker process: load a scene, run its systems once.

The worker that counts (the last) first runs them once as plain Python and prints
``expect NAME,NAME,...``: the kernels the build will compile, known before any compiles.

It is its own module (an app-level one: it loads scenes) so that the kernel cache
module stays below the scene; ``KernelBuild`` starts it with ``python -c``.
"""

from __future__ import annotations

import gc
import os
import sys
import time
from pathlib import Path

from numba.core import event

from twig_ecs import kernels
from twig_ecs.kernelcache import COMPILE_GC_THRESHOLD
from twig_ecs.scene import Scene
from twig_ecs.trust import trusting


class _Claimed(Exception):
    """The other worker is compiling this kernel: skip to the next system."""


def work(job: dict) -> int:
    """Compile a scene's kernels by running its systems once (a :class:`KernelBuild` worker).

    A kernel is claimed (a file made with O_EXCL in the build's claims folder) before it
    compiles, whether a system calls it or another kernel does: one the other worker has
    claimed makes this worker give up the compile under way (a kernel nested in the other's,
    as the constraint passes are in both ``solve_constraints`` and ``solve_collisions``, was
    compiled twice, 30 s of a loaded 2-core machine) and skip the rest of that system; it
    comes back to it after its first pass, when the other's kernel is cached. A compile
    given up releases its own claim, so no worker waits for a kernel nobody compiles.
    """
    kernels.announce_no_compile()  # this process compiles on purpose: no first-run notice
    gc.set_threshold(*COMPILE_GC_THRESHOLD)
    claims = Path(job["claims"]) if job.get("claims") else None
    state = {"depth": 0, "second_pass": False}
    owned: set[str] = set()  # kernels this worker claimed (a second specialisation is ours too)
    unsaved: list[tuple[str, object]] = []  # compiled here, NAME.done not yet written

    def mark_saved() -> None:
        """Write NAME.done for each kernel compiled here whose cache entry is on disk: numba saves
        it after the compile event ends, and the other worker, told too soon, compiled it again."""
        for item in list(unsaved):
            if kernels._cached_on_disk(item[1]):
                (claims / f"{item[0]}.done").touch()
                unsaved.remove(item)

    def claimed_elsewhere(name: str) -> bool:
        """Is the other worker compiling ``name`` now (claimed by it, not yet done)?"""
        if name in owned or (claims / f"{name}.done").exists():
            return False
        try:
            os.close(os.open(claims / name, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return True
        owned.add(name)
        return False

    class Report(event.Listener):
        """Claims each of our kernels as it starts compiling; prints ``compiled NAME SECONDS`` after."""

        def on_start(self, ev) -> None:
            mark_saved()
            dispatcher = ev.data["dispatcher"]
            name = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}"
            if claims is not None and name.startswith("twig_ecs") and claimed_elsewhere(name):
                if state["second_pass"]:  # the other worker is on it: load it from the cache after
                    _wait_for(claims / f"{name}.done", released=claims / name)
                state["aborted"] = True
                raise _Claimed(name)
            state["depth"] += 1
            dispatcher._twig_t0 = time.perf_counter()

        def on_end(self, ev) -> None:
            if state.pop("aborted", False):
                return  # numba ends the event even when its start raised: nothing compiled
            state["depth"] -= 1
            dispatcher = ev.data["dispatcher"]
            name = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}"
            if not name.startswith("twig_ecs"):
                return
            details = getattr(ev, "_exc_details", None)  # (numba's own is_failed reads it backwards)
            if details is not None and details[0] is not None:  # given up: a kernel inside was claimed
                if claims is not None and name in owned and not (claims / f"{name}.done").exists():
                    owned.discard(name)
                    (claims / name).unlink(missing_ok=True)
                return
            if claims is not None:
                unsaved.append((name, dispatcher))
            seconds = time.perf_counter() - getattr(dispatcher, "_twig_t0", time.perf_counter())
            print(f"compiled {dispatcher.py_func.__name__} {seconds:.2f}", flush=True)

    event.register("numba:compile", Report())
    with trusting(job.get("trust", False)):
        scene = Scene.load(job["source"], seed=job["seed"], content=job["content"], **job["parameters"])
    scene.step(0)  # install the systems
    if scene.state.colliders_dirty:
        scene.state.rebuild_colliders()
    systems = scene.schedule.systems()
    in_order = job["order"] == "forward"
    if job.get("count") or not in_order:
        expected, cost = dry_run(scene, systems)
        if job.get("count"):
            print(f"expect {','.join(sorted(expected))}", flush=True)
        if not in_order:  # the slowest as plain Python first: a window's slow motion speeds up soonest
            systems.sort(key=lambda system: -cost[system])
    skipped = []
    for system in systems:
        try:
            system.run(scene.step_context())
            mark_saved()
        except _Claimed:
            skipped.append(system)
        except Exception:  # noqa: BLE001 - out of order a system may trip; the other worker runs it in order
            if in_order:
                raise
    state["second_pass"] = True
    for system in skipped:  # what the other worker compiled now loads from the cache
        for _ in range(100):  # each try waits for one kernel the other worker is compiling
            try:
                system.run(scene.step_context())
                mark_saved()
                break
            except _Claimed:
                continue
            except Exception:  # noqa: BLE001 - as above
                if in_order:
                    raise
                break
    mark_saved()
    return 0


def run(job: dict) -> None:
    """A worker process's whole life: :func:`work`, then exit at once with its status.

    Without the interpreter's teardown: a compile leaves a heap of numba's objects (hundreds of
    MB) that Python would free one by one, 0.2-0.4 s at the end of a first run that waits for
    it. Everything the build needs is on disk by then (:func:`work` checks each cache entry).
    """
    code = work(job)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def dry_run(scene, systems: list) -> tuple[frozenset[str], dict]:
    """Run each system once with every kernel as plain Python, compiling nothing.

    Returns the names of the kernels a build compiles for them (those called from Python
    and what those call: :func:`~twig_ecs.kernels.kernels_to_compile`) and each system's
    seconds. About 0.3 s for the schoolyard on a quiet machine.
    """
    interim = kernels.InterimKernels()
    called: dict[int, object] = {}
    depth = [0]

    def recorder(kernel):
        def call(*args, **kwargs):
            if depth[0] == 0:  # called from Python (a kernel's body calls the rest)
                called[id(kernel)] = kernel
            depth[0] += 1
            try:
                return kernel.py_func(*args, **kwargs)
            finally:
                depth[0] -= 1

        return call

    interim.start()
    for kernel in interim.kernels():
        interim.point(kernel, recorder(kernel))
    cost = {}
    try:
        for system in systems:
            began = time.perf_counter()
            try:
                system.run(scene.step_context())
            except Exception:  # noqa: BLE001 - out of order a system may trip; what it called counts
                pass
            cost[system] = time.perf_counter() - began
    finally:
        interim.finish()
    return kernels.kernels_to_compile(called.values()), cost


def _wait_for(path: Path, released: Path, timeout: float = 120.0) -> None:
    """Wait until ``path`` exists (the other worker finished a kernel) or ``released`` no longer
    does (it gave that compile up), at most ``timeout`` s."""
    end = time.monotonic() + timeout
    while not path.exists() and released.exists() and time.monotonic() < end:
        time.sleep(0.05)
