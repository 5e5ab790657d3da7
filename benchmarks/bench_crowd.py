"""Crowds of autonomous wandering characters only (no MuJoCo): a thin wrapper of ``twig bench``.

Run: ``python benchmarks/bench_crowd.py [--sizes 100,300,1000] [--steps N] [--json]``.
"""

from __future__ import annotations

import sys

from twig_ecs.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "--cases", "crowd", "--no-mujoco", *sys.argv[1:]]))
