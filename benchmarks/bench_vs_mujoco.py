"""The schoolyard, crowds and ragdoll piles, beside MuJoCo: a thin wrapper of ``twig bench``.

Run: ``python benchmarks/bench_vs_mujoco.py [--sizes 10,100,1000] [--steps N] [--json]``
(every ``twig bench`` option works; MuJoCo from ``pip install -e '.[bench]'``).
"""

from __future__ import annotations

import sys

from twig_ecs.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
