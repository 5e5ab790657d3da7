"""Numba kernel bookkeeping: where compiled kernels are cached, and compiling them up front.

Kernels are ``@njit(cache=True)``: the first run compiles them and stores the machine
code; later runs load it in a blink. Three things are ours rather than numba's:

- **Where.** Numba keys a cached kernel on its own file only, so a change to a helper it
  inlines from another file (or to a flag constant) would leave a stale kernel in place,
  and it files kernels under a hash of the install path, so every new venv compiled
  again. :class:`KernelCacheLocator` files our kernels under
  ``<user cache dir>/kernels-<version>``, where the version hashes every kernel source
  file with the numba, numpy and Python versions: venvs with the same sources and
  versions share one compiled set; any change compiles afresh. When that folder is not
  writable (a read-only HOME) a temporary folder serves, with one warning.
- **When.** :class:`KernelBuild` compiles a scene's kernels into the cache in worker
  processes before the scene is loaded, so ``twig play`` can draw the progress in its
  window and ``run``/``render``/``serve`` print it. Two workers step the scene's
  systems, one in the schedule's order and one starting with the systems that are
  slowest as plain Python (so a window's slow motion speeds up soonest); numba looks in
  the cache before it compiles, so they meet in the middle and the compile takes about
  half the time on two cores. Only the kernels the scene's systems call are compiled,
  and the build knows how many before the first one ends: one worker first steps the
  scene once as plain Python, noting the kernels called (:func:`kernels_to_compile`).
- **Saying so.** :func:`ensure_compiled` prints one line when a scene is stepped with
  kernels still to compile (the Python API path, which compiles in-process).

``NUMBA_DISABLE_JIT=1`` runs the very same code as plain Python, for debugging;
``NUMBA_CACHE_DIR`` (numba's own setting) and ``TWIG_CACHE_DIR`` choose the folder.
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import types
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

from twig_ecs import kernelcache
from twig_ecs.kernelcache import (  # noqa: F401 - the cache's public names, here as before
    KernelCacheLocator,
    cache_base,
    cache_folder,
    configure_cache,
    jit_disabled,
    kernel_dirs,
    kernel_modules,
)

_PACKAGE = kernelcache._PACKAGE

#: What a :class:`KernelBuild` worker process runs.
_WORKER_CODE = "import sys, json; from twig_ecs.kernelworker import run; run(json.loads(sys.argv[1]))"
_checked = False


def worker_environment() -> dict[str, str]:
    """The environment of a worker process of ours (a kernel build's, a sweep's): this one's,
    importing the very twig_ecs this process runs (a checkout or an install) and sharing its
    kernel cache folder (the fallback one included)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(_PACKAGE.parent), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    if cache_folder() is not None:
        env["TWIG_CACHE_DIR"] = str(cache_folder().parent)
    return env


# -- is everything compiled? ---------------------------------------------------------------


def _kernels() -> list:
    """The kernels every scene runs (a crowd's wander kernel compiles on its first use only,
    so a scene without one would never find it cached and announce a compile each run)."""
    from twig_ecs.systems.control import arms, gait, gaze, posture, respiration
    from twig_ecs.systems.physics import collide, constrain, integrate, sense

    return [integrate.integrate_nodes, constrain.solve_constraints, collide.collider_pairs,
            collide.solve_collisions, sense.feel_impacts, gait.control_gait, gaze.control_gaze,
            posture.control_posture, arms.control_arms, respiration.breathe]  # fmt: skip


def is_cached() -> bool:
    """Do all kernels have compiled code on disk (or is JIT off)?"""
    if jit_disabled():
        return True
    for kernel in _kernels():
        cache = getattr(kernel, "_cache", None)
        index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
        if index is None or not Path(index).exists():
            return False
    return True


def ensure_compiled() -> None:
    """Print one line to stderr if the kernels have no on-disk cache yet (first run)."""
    global _checked
    if _checked:
        return
    _checked = True
    if not is_cached():
        where = f" (cached in {cache_folder()})" if cache_folder() else ""
        print(f"twig: compiling physics kernels, first run only{where}...", file=sys.stderr, flush=True)


def announce_no_compile() -> None:
    """Skip the first-run notice in this process (it compiles on purpose, or already built)."""
    global _checked
    _checked = True


# -- compiling up front, in worker processes -------------------------------------------------


class KernelBuild:
    """Compiles a scene's kernels into the cache in worker processes, and reports progress.

    Each worker loads the scene and runs its systems once (the compile happens on the
    first call of each kernel), one from the start of the schedule and one from its end.
    Nothing of the workers' worlds is kept: only the cache. :meth:`poll` reads their
    progress without blocking, for a window's frame loop; :meth:`wait` blocks.
    """

    def __init__(self, source: str | os.PathLike = "schoolyard", seed: int = 0,
                 content: list | tuple = (), parameters: dict | None = None,
                 workers: int | None = None) -> None:  # fmt: skip
        from twig_ecs.trust import is_trusted

        self.source = str(source)
        self.started = time.perf_counter()
        self.compiled: dict[str, float] = {}  # kernel name -> seconds it took
        #: every compile as (worker number, kernel name), repeats kept: a kernel one worker
        #: compiles twice has a second type specialisation, paid again on every first run
        self.compiles: list[tuple[int, str]] = []
        self.errors: list[str] = []
        #: the names of the kernels this build compiles, once a worker has counted them (None before)
        self.expected: frozenset[str] | None = None
        self.finished = False
        self._lines: queue.Queue = queue.Queue()
        self._claims = tempfile.mkdtemp(prefix="twig-ecs-claims-")
        job = {"source": self.source, "seed": seed, "content": [str(c) for c in content],
               "parameters": dict(parameters or {}), "claims": self._claims,
               "trust": is_trusted()}  # fmt: skip  # the workers trust the scene as this process does
        count = workers or min(2, os.cpu_count() or 1)
        env = worker_environment()
        self._procs = []
        for k in range(count):
            # the last worker counts the kernels (a plain-Python step first) and, one of two,
            # compiles the systems slowest as plain Python first; the first keeps the schedule's order
            order = "cost" if k % 2 else "forward"
            proc = subprocess.Popen(
                [sys.executable, "-P", "-c", _WORKER_CODE,
                 json.dumps({**job, "order": order, "count": k == count - 1})],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
            )  # fmt: skip
            self._procs.append(proc)
            threading.Thread(target=self._read, args=(k, proc), daemon=True).start()

    def _read(self, worker: int, proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            self._lines.put((worker, line))
        err = proc.stderr.read()
        proc.wait()
        self._lines.put(("exit", proc.returncode, err))

    def poll(self) -> bool:
        """Take in the workers' news; True once they have all finished."""
        while True:
            try:
                item = self._lines.get_nowait()
            except queue.Empty:
                break
            if item[0] == "exit":
                _, code, err = item
                self._exited = getattr(self, "_exited", 0) + 1
                if code:
                    self.errors.append(err.strip().splitlines()[-1] if err.strip() else f"exit {code}")
                continue
            worker, line = item
            parts = line.split()
            if len(parts) == 3 and parts[0] == "compiled":
                self.compiled.setdefault(parts[1], float(parts[2]))
                self.compiles.append((worker, parts[1]))
            elif len(parts) == 2 and parts[0] == "expect" and self.expected is None:
                self.expected = frozenset(parts[1].split(","))
        if not self.finished and getattr(self, "_exited", 0) == len(self._procs):
            self.finished = True
            shutil.rmtree(self._claims, ignore_errors=True)
        return self.finished

    @property
    def done(self) -> int:
        """How many of the expected kernels are compiled (0 until they are counted)."""
        return len(self.expected & self.compiled.keys()) if self.expected is not None else 0

    def wait(self, on_progress: Callable[[KernelBuild], None] | None = None, every: float = 0.1) -> None:
        """Block until the workers finish, calling ``on_progress`` as kernels complete."""
        seen = -1
        while not self.poll():
            if on_progress is not None and len(self.compiled) != seen:
                seen = len(self.compiled)
                on_progress(self)
            time.sleep(every)
        if on_progress is not None:
            on_progress(self)

    @property
    def fraction(self) -> float:
        """How far along the build is, 0..1 (1 only when finished)."""
        if self.finished:
            return 1.0
        if not self.expected:
            return 0.0
        return min(0.95, self.done / len(self.expected))

    @property
    def elapsed(self) -> float:
        """Seconds since the build started."""
        return time.perf_counter() - self.started

    def status(self) -> str:
        """One line for a person: what is being compiled and how far along it is."""
        latest = next(reversed(self.compiled)) if self.compiled else "starting"
        if self.finished:
            return f"compiled {len(self.compiled)} physics kernels in {self.elapsed:.1f} s"
        if self.expected is None:  # the total is shown once it is known, and never changes
            return (
                f"compiling physics kernels (first run only): counting them  {latest}  {self.elapsed:.0f} s"
            )
        return (f"compiling physics kernels (first run only): {self.done}/{len(self.expected)}  "
                f"{latest}  {self.elapsed:.0f} s")  # fmt: skip

    def cancel(self) -> None:
        """Stop the workers (the window was closed while compiling)."""
        for proc in self._procs:
            if proc.poll() is None:
                proc.kill()
        for proc in self._procs:
            proc.wait()
        shutil.rmtree(self._claims, ignore_errors=True)


# -- stepping while the kernels compile -----------------------------------------------------


def _ours(kernel) -> bool:
    """Is ``kernel`` a numba dispatcher of one of our kernel sources?"""
    from numba.core.dispatcher import Dispatcher

    if not isinstance(kernel, Dispatcher):
        return False
    try:
        return Path(kernel.py_func.__code__.co_filename).resolve().parent in kernel_dirs()
    except (AttributeError, OSError):
        return False


def _import_kernel_modules() -> None:
    """Import every module that defines kernels, so none is imported while names are swapped."""
    import importlib

    importlib.import_module("twig_ecs.kernelmath")
    for name in kernel_modules():
        importlib.import_module(name)


def _cached_on_disk(kernel) -> bool:
    """Has this kernel compiled code in the cache, index and data both written?"""
    cache_file = getattr(getattr(kernel, "_cache", None), "_cache_file", None)
    if cache_file is None:
        return False
    try:
        overloads = cache_file._load_index()
    except Exception:  # noqa: BLE001 - a half-written or foreign index: not cached yet
        return False
    folder = Path(cache_file._cache_path)
    return bool(overloads) and all((folder / name).exists() for name in overloads.values())


def callees(kernel) -> list:
    """Our kernels that ``kernel``'s body calls (by a global name, or an attribute of a module).

    Numba compiles each of them with the caller, whichever branch the call is in.
    """
    codes, names = [kernel.py_func.__code__], set()
    while codes:
        code = codes.pop()
        names.update(code.co_names)
        codes.extend(c for c in code.co_consts if isinstance(c, types.CodeType))
    space = kernel.py_func.__globals__
    modules = [v for v in space.values() if isinstance(v, types.ModuleType)]
    found = [space[name] for name in names if name in space]
    found += [getattr(m, name) for m in modules for name in names if hasattr(m, name)]
    return [value for value in found if _ours(value)]


def kernels_to_compile(called) -> frozenset[str]:
    """The names of the kernels a build compiles for the kernels ``called`` from Python: those and
    everything their bodies call, less the ``inline="always"`` ones (compiled into their callers)."""
    seen: dict[str, object] = {}
    todo = list(called)
    while todo:
        kernel = todo.pop()
        name = kernel.py_func.__name__  # the name the workers report
        if name not in seen:
            seen[name] = kernel
            todo.extend(callees(kernel))
    return frozenset(n for n, k in seen.items() if k.targetoptions.get("inline", "never") == "never")


class _FirstCall:
    """A kernel the workers have just cached, until its first call has loaded it.

    The call runs with every kernel name restored, so that should numba have to compile
    after all (a signature the workers did not meet) it sees kernels, not Python functions.
    """

    def __init__(self, interim: InterimKernels, kernel) -> None:
        self.interim, self.kernel = interim, kernel

    def __call__(self, *args, **kwargs):
        with self.interim.restored():
            out = self.kernel(*args, **kwargs)
        self.interim.point(self.kernel, self.kernel)  # loaded: call it directly from now on
        return out


class InterimKernels:
    """Lets a scene step while its kernels compile: plain Python until each one is cached.

    A first run's :class:`KernelBuild` takes 20 s to a few minutes. Meanwhile every reference
    to one of our kernels in a loaded ``twig_ecs`` module is pointed at the kernel's Python
    function (what ``NUMBA_DISABLE_JIT=1`` runs): nothing compiles in this process and the
    scene steps at once, in slow motion (the schoolyard: 0.2 s a step on a quiet machine
    instead of 2 ms, 80% of it ``solve_collisions``). :meth:`update` points a kernel's
    references back at the compiled kernel as soon as the workers have cached it (a kernel
    that others call waits for :meth:`finish`), so the scene speeds up as the build goes
    on; :meth:`finish` restores every reference. Both forms compute the same floats (no
    fastmath), so a run's state hash does not depend on when each kernel switched.
    """

    def __init__(self) -> None:
        _import_kernel_modules()
        self._refs: dict[int, list[tuple[dict, str]]] = {}  # id(kernel) -> (namespace, name) holding it
        self._kernels: dict[int, object] = {}
        for namespace in self._namespaces():
            for name, value in list(namespace.items()):
                if _ours(value):
                    self._refs.setdefault(id(value), []).append((namespace, name))
                    self._kernels[id(value)] = value
        self.pending = set(self._kernels)  # kernels still stepped as plain Python
        #: kernels other kernels call: they stay plain Python until :meth:`finish`. Called from a
        #: parent's Python form they would get Python's argument types, not the compiled parent's,
        #: and compile here, for seconds, instead of loading from the cache
        self.nested = {id(c) for k in self._kernels.values() for c in callees(k)}
        self.active = False
        self._checked = 0.0

    @staticmethod
    def _namespaces(everywhere: bool = False) -> list[dict]:
        spaces = [(name, getattr(m, "__dict__", None)) for name, m in list(sys.modules.items())]
        mine = [ns for name, ns in spaces if everywhere or name.split(".")[0] == "twig_ecs"]
        return [ns for ns in mine if isinstance(ns, dict)]

    def kernels(self) -> list:
        """Every kernel whose references this object swaps."""
        return list(self._kernels.values())

    def start(self) -> InterimKernels:
        """Point every kernel reference at its Python function."""
        global _checked
        _checked = True  # nothing compiles in this process: no "compiling" notice
        self.active = True
        for key in self.pending:
            self.point(self._kernels[key], self._kernels[key].py_func)
        return self

    def point(self, kernel, target) -> None:
        """Make every reference to ``kernel`` refer to ``target``."""
        for namespace, name in self._refs.get(id(kernel), ()):
            namespace[name] = target

    def update(self, every: float = 0.25) -> int:
        """Switch to compiled kernels the workers have cached since the last look; how many now."""
        now = time.perf_counter()
        if not self.active or now - self._checked < every:
            return 0
        self._checked = now
        ready = [key for key in self.pending - self.nested if _cached_on_disk(self._kernels[key])]
        for key in ready:
            self.pending.discard(key)
            self.point(self._kernels[key], _FirstCall(self, self._kernels[key]))
        return len(ready)

    @property
    def interpreted(self) -> int:
        """How many kernels still run as plain Python."""
        return len(self.pending) if self.active else 0

    @contextmanager
    def restored(self):
        """A context in which every reference is the compiled kernel again."""
        saved = [(ns, name, ns[name]) for refs in self._refs.values() for ns, name in refs]
        for kernel in self._kernels.values():
            self.point(kernel, kernel)
        try:
            yield
        finally:
            for ns, name, value in saved:
                ns[name] = value

    def finish(self) -> None:
        """Restore every kernel reference (the build is over), also in modules imported meanwhile."""
        if not self.active:
            return
        self.active = False
        for kernel in self._kernels.values():
            self.point(kernel, kernel)
        by_func = {id(k.py_func): k for k in self._kernels.values()}
        # every module, not only ours: a plug-in imported meanwhile may hold a Python form
        for namespace in self._namespaces(everywhere=True):
            for name, value in list(namespace.items()):
                if isinstance(value, _FirstCall):
                    namespace[name] = value.kernel
                elif id(value) in by_func and value is by_func[id(value)].py_func:
                    namespace[name] = by_func[id(value)]
        self.pending.clear()


def needs_build() -> bool:
    """Would a scene compile kernels now (none cached for this version, JIT on)?"""
    return not jit_disabled() and cache_folder() is not None and not is_cached()


def prepare(source, seed: int = 0, content=(), parameters: dict | None = None,
            say: Callable[[str], None] | None = None) -> KernelBuild | None:  # fmt: skip
    """Compile a scene's kernels up front when they are not cached, printing progress.

    ``say`` gets status lines (default: stderr, overwritten in place on a terminal).
    Returns the finished build, or None when there was nothing to compile.
    """
    if not needs_build():
        return None
    say = say or _stderr_progress()
    build = KernelBuild(source, seed, content, parameters)
    build.wait(lambda b: say(b.status()))
    global _checked
    _checked = True  # the cache is filled: no in-process notice
    if sys.stderr.isatty():
        sys.stderr.write("\n")
    return build


def _stderr_progress() -> Callable[[str], None]:
    tty = sys.stderr.isatty()

    def say(line: str) -> None:
        sys.stderr.write(f"\r\033[K{line}" if tty else line + "\n")
        sys.stderr.flush()

    return say
