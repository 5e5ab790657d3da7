"""Numba kernel bookkeeping: say so once when the physics kernels must be compiled.

Kernels are ``@njit(cache=True)``: the first run on a machine compiles them (a few
seconds) and stores machine code next to the sources; later runs load it in a blink.
``NUMBA_DISABLE_JIT=1`` runs the very same code as plain Python, for debugging.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

_checked = False


def _kernels() -> list:
    from twig_ecs.systems import collide, constrain, integrate, sense

    return [
        integrate.integrate_nodes,
        constrain.solve_constraints,
        collide.broad_phase,
        collide.solve_collisions,
        sense.feel_impacts,
    ]


def ensure_compiled() -> None:
    """Print one line to stderr if the kernels have no on-disk cache yet (first run)."""
    global _checked
    if _checked:
        return
    _checked = True
    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return
    for kernel in _kernels():
        cache = getattr(kernel, "_cache", None)
        index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
        if index is None or not Path(index).exists():
            print(
                "twig: compiling physics kernels, first run only (a few seconds)...",
                file=sys.stderr,
                flush=True,
            )
            return
