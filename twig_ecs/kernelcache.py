"""Where compiled kernels are cached: the folder, numba's cache locator, light cache loads.

The lowest-level part of the kernel bookkeeping (:mod:`twig_ecs.kernels` holds the rest:
building, progress, stepping while compiling). It imports no kernel and no scene, so
:mod:`twig_ecs.kernelmath` and the ``systems`` package can call :func:`configure_cache`
before they define a kernel: numba binds a kernel to a cache locator when the kernel is
decorated, so the locator must be in place first. See :mod:`twig_ecs.kernels` for why
the locator is ours.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
import time
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


def kernel_dirs() -> list[Path]:
    """Folders whose ``.py`` files hold kernels: the package and its systems."""
    systems = _PACKAGE / "systems"  # an installed package holds its systems
    if not systems.is_dir():  # a checkout: systems/ beside twig_ecs/
        systems = _PACKAGE.parent / "systems"
    return [_PACKAGE, systems]


def kernel_version() -> str:
    """A short hash of every kernel source and the numba, numpy and Python versions."""
    import numba
    import numpy

    digest = hashlib.sha256()
    digest.update(f"{numba.__version__} {numpy.__version__} {sys.version}".encode())
    systems = kernel_dirs()[1]
    for path in sorted(systems.glob("*.py")) + [_PACKAGE / "kernelmath.py", _PACKAGE / "store.py"]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


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
    configure_threads()  # before numba loads its OpenMP pool: idle threads sleep (twig_ecs.threads)
    if os.environ.get("NUMBA_CACHE_DIR") or jit_disabled():
        return None
    version = kernel_version()
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
    try:
        os.utime(current)  # in use now
        cutoff = time.time() - STALE_DAYS * 86400
        old = sorted((p for p in base.glob("kernels-*") if p != current), key=lambda p: p.stat().st_mtime)
        for path in old[:-KEEP_OLD] if len(old) > KEEP_OLD else []:
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


def _locator_base():
    from numba.core.caching import _CacheLocator, _SourceFileBackedLocatorMixin

    return _SourceFileBackedLocatorMixin, _CacheLocator


class KernelCacheLocator(*_locator_base()):
    """Files kernels from our sources under the version folder, by source folder name.

    Numba's own locators file them under a hash of the install path; this one does not,
    so the same sources in another venv find them. The source stamp is numba's content
    hash of the file.
    """

    def __init__(self, py_func, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(_folder / Path(py_file).parent.name)

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file: str):
        if _folder is None or Path(py_file).resolve().parent not in kernel_dirs():
            return None
        return super().from_function(py_func, py_file)
