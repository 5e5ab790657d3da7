"""Numba kernel bookkeeping: where compiled kernels are cached, and saying so on compile.

Kernels are ``@njit(cache=True)``: the first run compiles them (a few seconds) and
stores the machine code; later runs load it in a blink. Numba keys each cached kernel
on its own file only, so a change to a helper it inlines from another file (or to a
flag constant) would leave a stale kernel in place. We therefore cache in a folder
named after a hash of every kernel source file: any change compiles afresh.
``NUMBA_DISABLE_JIT=1`` runs the very same code as plain Python, for debugging.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_checked = False
#: Cache folders of other kernel versions kept besides the current one.
KEEP_OLD = 3


def configure_cache() -> Path | None:
    """Point numba's cache at a folder for this exact kernel source (unless the user chose one).

    Must run before the kernel modules are imported. Returns the folder, or None when
    ``NUMBA_CACHE_DIR`` is set by the user or JIT is off.
    """
    if os.environ.get("NUMBA_CACHE_DIR") or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return None
    import numba

    digest = hashlib.sha256()
    systems_dir = _PACKAGE / "systems"  # an installed package holds its systems
    if not systems_dir.is_dir():  # a checkout (editable install): systems/ beside it
        systems_dir = _PACKAGE.parent / "systems"
    for path in sorted(systems_dir.glob("*.py")) + [_PACKAGE / "kernelmath.py", _PACKAGE / "store.py"]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "twig-ecs"
    folder = base / f"kernels-{digest.hexdigest()[:16]}"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None  # not writable: numba falls back to its own places
    numba.config.CACHE_DIR = str(folder)
    _prune(base, folder)
    return folder


def _prune(base: Path, current: Path) -> None:
    """Delete all but the newest few cache folders of older kernel versions."""
    try:
        old = sorted((p for p in base.glob("kernels-*") if p != current), key=lambda p: p.stat().st_mtime)
        for path in old[:-KEEP_OLD] if len(old) > KEEP_OLD else []:
            shutil.rmtree(path, ignore_errors=True)
    except OSError:
        pass


def _kernels() -> list:
    """The kernels every scene runs (a crowd's wander kernel compiles on its first use only,
    so a scene without one would never find it cached and announce a compile each run)."""
    from twig_ecs.systems import (
        arms,
        collide,
        constrain,
        gait,
        gaze,
        integrate,
        posture,
        respiration,
        sense,
    )

    return [integrate.integrate_nodes, constrain.solve_constraints, collide.collider_pairs,
            collide.solve_collisions, sense.feel_impacts, gait.control_gait, gaze.control_gaze,
            posture.control_posture, arms.control_arms, respiration.breathe]  # fmt: skip


def is_cached() -> bool:
    """Do all kernels have compiled code on disk (or is JIT off)?"""
    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
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
        print(
            "twig: compiling physics kernels, first run only (a few seconds)...", file=sys.stderr, flush=True
        )
