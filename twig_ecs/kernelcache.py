"""Where compiled kernels are cached: the folder, numba's cache locator, light cache loads.

The lowest-level part of the kernel bookkeeping (:mod:`twig_ecs.kernels` holds the rest:
building, progress, stepping while compiling). It imports no kernel and no scene, so
:mod:`twig_ecs.kernelmath` and the ``systems`` package can call :func:`configure_cache`
before they define a kernel: numba binds a kernel to a cache locator when the kernel is
decorated, so the locator must be in place first. See :mod:`twig_ecs.kernels` for why
the locator is ours.
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
from functools import cache
from pathlib import Path

from twig_ecs.threads import configure_threads

_PACKAGE = Path(__file__).resolve().parent
#: Cache folders of other kernel versions kept besides the current one.
KEEP_OLD = 3
#: ...and older ones are deleted only when unused for this many days.
STALE_DAYS = 7
_configured = False
_folder: Path | None = None
_warnings: list[str] = []


def jit_disabled() -> bool:
    """Is numba's JIT off (``NUMBA_DISABLE_JIT=1``)?"""
    return os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")


@cache
def _source_roots() -> dict[str, Path]:
    """Where the package's parts live: ``systems`` and ``components`` are folders of their
    own in a checkout (beside ``twig_ecs/``) and inside the package once installed."""
    roots = {}
    for part in ("systems", "components"):
        inside = _PACKAGE / part
        roots[part] = inside if inside.is_dir() else _PACKAGE.parent / part
    return roots


@cache  # asked once per kernel as numba decorates it
def kernel_dirs() -> tuple[Path, ...]:
    """Folders whose ``.py`` files may hold kernels: the package and every systems folder."""
    systems = _source_roots()["systems"].resolve()
    return (_PACKAGE, systems, *sorted(p.parent for p in systems.glob("*/__init__.py")))


def kernel_modules() -> list[str]:
    """The names of the systems modules, every sub-package's included (they may hold kernels)."""
    systems = _source_roots()["systems"].resolve()
    names = []
    for path in sorted(systems.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        parts = path.relative_to(systems).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names.append(".".join(("twig_ecs.systems", *parts)))
    return names


@cache
def module_file(name: str) -> Path | None:
    """The source file of one of our modules by its dotted name (None if not ours)."""
    parts = name.split(".")
    if parts[0] != "twig_ecs":
        return None
    roots = _source_roots()
    if len(parts) > 1 and parts[1] in roots:
        path = roots[parts[1]].joinpath(*parts[2:])
    else:
        path = _PACKAGE.joinpath(*parts[1:])
    for candidate in (path.with_suffix(".py"), path / "__init__.py"):
        if candidate.is_file():
            return candidate.resolve()
    return None


@cache  # each file read once however many closures hold it
def _imported_by(path: Path) -> frozenset[Path]:
    """Our source files that ``path`` imports (anywhere in it, but not for type checking only)."""
    source = path.read_bytes()
    key = hashlib.sha256(source).hexdigest()[:32]
    index = _import_index()
    names = index["known"].get(key)
    if names is None:
        names = index["known"][key] = _imported_names(source)
        index["dirty"] = True
    index["used"].add(key)
    return frozenset(f for f in map(module_file, names) if f is not None)


def _imported_names(source: bytes) -> list[str]:
    """The dotted names a module's source imports that may be ours (a syntax-tree walk)."""
    import ast

    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue  # never runs: it cannot change what a kernel compiles to
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                # ``from pkg import mod`` imports the submodule when there is one
                names = [child.module] + [f"{child.module}.{alias.name}" for alias in child.names]
            else:
                visit(child)
                continue
            found.update(n for n in names if n.split(".")[0] == "twig_ecs")

    visit(ast.parse(source))
    return sorted(found)


#: The file, in the environment's kernel folder, that keeps each source's imported names by a
#: hash of its bytes: a start walks the syntax tree of no file it has seen (the walk over the
#: kernel modules and what they import was 0.2-0.4 s of every cached start, every sweep worker's
#: and every CLI call's). Most entries kept beyond those this process used:
IMPORT_INDEX = "imports.json"
IMPORT_INDEX_KEEP = 2000


@cache
def _import_index() -> dict:
    """The imported names known by source hash (``known``), read from :data:`IMPORT_INDEX`
    once a process; a lost or broken file is only a slower start."""
    known: dict[str, list[str]] = {}
    if _folder is not None:
        try:
            loaded = json.loads((_folder / IMPORT_INDEX).read_text())
            if isinstance(loaded, dict):
                known = {k: v for k, v in loaded.items()
                         if isinstance(v, list) and all(isinstance(n, str) for n in v)}  # fmt: skip
        except (OSError, ValueError):
            pass
    return {"known": known, "used": set(), "dirty": False}


def _save_import_index() -> None:
    """Write the index back if this process parsed a new source (whole, by a rename: a start
    beside this one reads the old index or the new, never half of one)."""
    index = _import_index()
    if not index["dirty"] or _folder is None:
        return
    known = index["known"]
    if len(known) > IMPORT_INDEX_KEEP:
        known = {k: v for k, v in known.items() if k in index["used"]}
    written = None
    try:
        with tempfile.NamedTemporaryFile("w", dir=_folder, suffix=".tmp", delete=False) as f:
            written = f.name
            json.dump(known, f)
        os.replace(written, _folder / IMPORT_INDEX)
        index["dirty"] = False
    except OSError:
        if written is not None:  # (a full disk: no half-written file left behind)
            Path(written).unlink(missing_ok=True)


#: Our modules that kernel modules import but that cannot change what a compiled kernel
#: computes: where the cache is and how threads wait (this module's compile options only
#: leave out code twig never calls, or a duplicate specialisation). Left out of
#: :func:`source_closure`, so editing them recompiles nothing.
NOT_COMPILED_FROM = ("kernelcache.py", "threads.py")


def source_closure(path: Path) -> list[Path]:
    """``path`` and every one of our modules it imports, directly or through others, sorted.

    A kernel compiles from its own module's source and from what that module brings in
    (kernels it calls, constants it bakes in), so this is all a compiled kernel can depend
    on among our files; a module outside it cannot change the compiled code.
    """
    seen: set[Path] = set()
    todo = [path.resolve()]
    while todo:
        here = todo.pop()
        if here in seen:
            continue
        seen.add(here)
        todo.extend(f for f in _imported_by(here) - seen
                    if not (f.parent == _PACKAGE and f.name in NOT_COMPILED_FROM))  # fmt: skip
    return sorted(seen)


def environment_version() -> str:
    """A short hash of the numba, numpy and Python versions: compiled code fits only these."""
    import numba
    import numpy

    text = f"{numba.__version__} {numpy.__version__} {sys.version}"
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def module_version(path: Path) -> str:
    """A short hash of the sources a kernel module's kernels compile from (:func:`source_closure`)."""
    digest = hashlib.sha256()
    # by folder and file name, not by full path: the same sources elsewhere hash the same
    for source in sorted(source_closure(path), key=lambda p: (p.parent.name, p.name)):
        digest.update(f"{source.parent.name}/{source.name}".encode())
        digest.update(source.read_bytes())
    _save_import_index()
    return digest.hexdigest()[:12]


def cache_base() -> Path:
    """The folder of all cached kernel versions: ``TWIG_CACHE_DIR`` or the user cache dir."""
    chosen = os.environ.get("TWIG_CACHE_DIR")
    if chosen:
        return Path(chosen)
    import platformdirs

    return Path(platformdirs.user_cache_dir("twig-ecs", appauthor=False))


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def configure_cache() -> Path | None:
    """Choose this kernel version's cache folder and route our kernels to it.

    Must run before the kernel modules are imported: :mod:`twig_ecs.kernelmath` and the
    ``systems`` package call it first thing, so importing any kernel does. Later calls
    return the same folder. Returns the folder, or None when ``NUMBA_CACHE_DIR`` is set
    by the user or JIT is off.
    """
    global _folder, _configured
    if _configured:
        return _folder
    _configured = True
    _plain_compile_errors()
    configure_threads()  # before numba loads its OpenMP pool: idle threads sleep (twig_ecs.threads)
    if os.environ.get("NUMBA_CACHE_DIR") or jit_disabled():
        return None
    version = environment_version()
    base = cache_base()
    folder = base / f"kernels-{version}"
    if _writable(folder):
        _prune(base, folder)
    else:
        fallback = Path(tempfile.gettempdir()) / f"twig-ecs-{_user_tag()}" / f"kernels-{version}"
        if not _writable(fallback):
            fallback = Path(tempfile.mkdtemp(prefix="twig-ecs-kernels-"))
        _warn(f"twig: cannot write the kernel cache in {base}; using {fallback} for now "
              "(set TWIG_CACHE_DIR to a writable folder to keep compiled kernels)")  # fmt: skip
        folder = fallback
    _folder = folder
    _install_locator()
    return folder


#: numba's switch for colouring its error messages (any value turns the colour off).
PLAIN_ERRORS = "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"


def _plain_compile_errors() -> None:
    """Have numba write its compile errors without terminal colours: a fifth of the first compile's
    time went on colouring messages nobody reads.

    Typing a kernel tries many candidate signatures, and numba words an error message for each
    one that does not fit; with colours on, each message also starts and stops colorama's
    terminal wrapper (100 000 times in a schoolyard compile). With them off, a first run's
    compile in two workers took 15.4 s where it took 19.4 s (quiet 2-core box). Set before numba
    is imported (its errors module reads the switch once); a user's own setting is kept.
    """
    if PLAIN_ERRORS in os.environ:
        return
    os.environ[PLAIN_ERRORS] = "1"
    errors = sys.modules.get("numba.core.errors")
    if errors is not None and hasattr(errors, "_DummyColorScheme"):  # numba came first: set its scheme

        class PlainScheme(errors._DummyColorScheme):
            """Every part of a message as it is."""

            def code(self, msg):
                return msg

            errmsg = filename = indicate = highlight = reset = code

        errors._termcolor_inst = PlainScheme()


def cache_folder() -> Path | None:
    """The folder compiled kernels go to (None when numba chooses, or JIT is off)."""
    return configure_cache()


def _user_tag() -> str:
    getuid = getattr(os, "getuid", None)
    return str(getuid()) if getuid else os.environ.get("USERNAME", "user")


def _warn(message: str) -> None:
    """Print a warning once per process."""
    if message not in _warnings:
        _warnings.append(message)
        print(message, file=sys.stderr, flush=True)


def _prune(base: Path, current: Path) -> None:
    """Delete cache folders of kernel versions unused for ``STALE_DAYS``, beyond the newest few.

    Several checkouts or venvs of different versions may share the cache folder and run at
    once; a version still in use (its folder touched at each start) is never deleted.
    """
    _delete_unused(current, base.glob("kernels-*"), KEEP_OLD, STALE_DAYS * 86400)


def _delete_unused(current: Path, folders, keep: int, unused_for: float) -> None:
    """Touch ``current`` (in use now) and delete the other ``folders`` past the newest
    ``keep`` that were last used over ``unused_for`` seconds ago."""
    try:
        if current.is_dir():
            os.utime(current)
        cutoff = time.time() - unused_for
        old = sorted((p for p in folders if p != current), key=lambda p: p.stat().st_mtime)
        for path in old[:-keep] if len(old) > keep else []:
            if path.stat().st_mtime < cutoff:
                shutil.rmtree(path, ignore_errors=True)
    except OSError:
        pass


def _install_locator() -> None:
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # renamed in numba 0.6x
    if KernelCacheLocator not in impl._locator_classes:
        impl._locator_classes.insert(0, KernelCacheLocator)
    _install_light_loads(caching.Cache)
    from numba.core import dispatcher

    _install_plain_calls(dispatcher.Dispatcher)
    _install_lean_options(dispatcher.Dispatcher)
    _install_light_collector()


#: The garbage collector's thresholds while numba compiles. Its compiler makes millions of
#: short-lived objects, and at Python's default (700, 10, 10) the collector's full passes over
#: the growing heap took a fifth of a first run's compile (one process, the schoolyard: 40.0 ->
#: 31.1 s of CPU with it off; peak memory 336 MB at the default, 515 MB with these, 738 MB off).
COMPILE_GC_THRESHOLD = (100_000, 50, 1000)
_collector_installed = False


def _install_light_collector() -> None:
    """Raise the garbage collector's thresholds to COMPILE_GC_THRESHOLD while numba compiles in
    this process (the outermost compile; nested ones are inside it), and put back what they
    were when it ends: the build workers run at these thresholds throughout, and a compile in
    a program's own process (the Python API's first steps) gets the same saving."""
    global _collector_installed
    if _collector_installed:
        return
    _collector_installed = True
    from numba.core import event

    state = {"depth": 0, "saved": None}

    class LightCollector(event.Listener):
        def on_start(self, ev) -> None:
            if state["depth"] == 0:
                state["saved"] = gc.get_threshold()
                gc.set_threshold(*COMPILE_GC_THRESHOLD)
            state["depth"] += 1

        def on_end(self, ev) -> None:
            state["depth"] = max(0, state["depth"] - 1)
            if state["depth"] == 0 and state["saved"] is not None:
                gc.set_threshold(*state["saved"])
                state["saved"] = None

    event.register("numba:compile", LightCollector())


def _install_light_loads(cache_class) -> None:
    """Load our cached kernels without numba's compiler set-up (a cached start's largest cost).

    Numba's ``Cache.load_overload`` first refreshes the target context: it imports and
    registers every typing and lowering implementation numba has (linalg, random, typed
    containers, jitclass, ...), about 0.2 s of a 1 s cached start, all of it needed to
    *compile* a kernel and none of it to link a cached one. For kernels filed by
    :class:`KernelCacheLocator` this loads with only the runtime (NRT) initialised, which
    the cached machine code links against. A miss (no entry for the signature) falls
    through to numba's compile, which does the full refresh itself, so nothing compiles
    with a partial context.
    """
    full = cache_class.load_overload
    if getattr(full, "twig_light", False):
        return

    def load_overload(self, sig, target_context):
        if not isinstance(getattr(self._impl, "locator", None), KernelCacheLocator):
            return full(self, sig, target_context)
        from numba.core.runtime import rtsys

        rtsys.initialize(target_context)  # the runtime the cached code calls (allocation, refcounts)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    load_overload.twig_light = True
    load_overload.__doc__ = full.__doc__
    cache_class.load_overload = load_overload


def _ours(dispatcher) -> bool:
    """Is ``dispatcher`` one of our kernels (filed by :class:`KernelCacheLocator`)?"""
    impl = getattr(getattr(dispatcher, "_cache", None), "_impl", None)
    return isinstance(getattr(impl, "locator", None), KernelCacheLocator)


def _install_plain_calls(dispatcher_class) -> None:
    """Compile our kernels for the plain types of the arguments a kernel passes, not their literals.

    When a kernel calls another with a constant (``project_limit_rows(..., 0, n)``, a
    ternary's ``-1``), numba types the argument as that literal (``Literal[int](0)``) and
    compiles the callee again for it: a second specialisation of the same code, paid on every
    first run (``landing_target``, ``_skipped``: 0.7 s of CPU; a hinge-limit pass would have
    been 2.5 s). Here the callee is compiled for the plain types (``int64``), which the
    literal call then uses as any ``int64`` call does. No kernel of ours asks for a literal
    (``numba.literally``); a kernel of someone else's is compiled as numba does.
    """
    full = dispatcher_class.get_call_template
    if getattr(full, "twig_plain", False):
        return
    from numba.core import types

    def get_call_template(self, args, kws):
        if _ours(self):
            args = tuple(types.unliteral(a) for a in args)
            kws = {k: types.unliteral(v) for k, v in kws.items()}
        return full(self, args, kws)

    get_call_template.twig_plain = True
    get_call_template.__doc__ = full.__doc__
    dispatcher_class.get_call_template = get_call_template


def _install_lean_options(dispatcher_class) -> None:
    """Compile our kernels without the C-callable wrapper numba adds to every compile.

    Numba gives each compiled kernel two entry points besides its own: the one Python calls
    and one with a C signature, used only to hand the kernel to C code or to another kernel as
    a first-class function value, neither of which twig does. That one costs each kernel's
    compile 10-20 ms of lowering and LLVM work (over a first run's forty kernels, most of a
    second). Kernels of someone else's are left as numba makes them.
    """
    full = dispatcher_class.enable_caching
    if getattr(full, "twig_lean", False):
        return

    def enable_caching(self):
        full(self)
        if _ours(self):  # (the options are read at each compile: set before the first)
            self.targetoptions["no_cfunc_wrapper"] = True

    enable_caching.twig_lean = True
    enable_caching.__doc__ = full.__doc__
    dispatcher_class.enable_caching = enable_caching


def _locator_base():
    from numba.core.caching import _CacheLocator, _SourceFileBackedLocatorMixin

    return _SourceFileBackedLocatorMixin, _CacheLocator


class KernelCacheLocator(*_locator_base()):
    """Files kernels from our sources under the environment's folder, one folder per module.

    Numba's own locators file them under a hash of the install path; this one does not,
    so the same sources in another venv find them. Each kernel module's folder is named by
    the module and a hash of the sources its kernels compile from (:func:`module_version`),
    so editing a module recompiles only the kernels that depend on it: a pure-Python
    behaviour's edit compiles nothing. Numba's source stamp inside the folder is its
    content hash of the file.
    """

    def __init__(self, py_func, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(_folder / module_folder_name(Path(py_file)))

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file: str):
        if _folder is None or Path(py_file).resolve().parent not in kernel_dirs():
            return None
        return super().from_function(py_func, py_file)


_folder_names: dict[Path, str] = {}


def module_folder_name(path: Path) -> str:
    """The cache folder name of one kernel module: where it lives, then its version."""
    path = path.resolve()
    if path not in _folder_names:
        where = f"{path.parent.name}.{path.stem}"  # "physics.collide", "twig_ecs.kernelmath"
        _folder_names[path] = f"{where}-{module_version(path)}"
        if _folder is not None:
            _prune_module(where, _folder / _folder_names[path])
    return _folder_names[path]


@cache
def _module_folders() -> dict[str, list[Path]]:
    """The environment folder's kernel-module folders, by module (``"physics.collide"``)."""
    found: dict[str, list[Path]] = {}
    try:
        for entry in os.scandir(_folder):
            where, dash, version = entry.name.rpartition("-")
            if dash and len(version) == 12 and entry.is_dir():
                found.setdefault(where, []).append(Path(entry.path))
    except OSError:
        pass
    return found


#: Versions of one kernel module kept besides the current one ...
KEEP_OLD_MODULE = 4
#: ... and older ones deleted only when unused for this many hours (a program started before
#: the edit, still running, compiles into its folder).
STALE_MODULE_HOURS = 1


def _prune_module(where: str, current: Path) -> None:
    """Mark this module's folder in use, and delete its other versions beyond the newest
    ``KEEP_OLD_MODULE`` unused for ``STALE_MODULE_HOURS``, as :func:`_prune` does for whole
    environments. Every edit of a kernel module's sources compiles a new version: a
    developer's folder kept them all (1270 module folders, 643 MB on the project's box after a
    week; hours, not days, as a week of edits is hundreds of versions)."""
    _delete_unused(current, _module_folders().get(where, []), KEEP_OLD_MODULE, STALE_MODULE_HOURS * 3600)
