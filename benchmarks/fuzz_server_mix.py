"""1,000 (or more) random Twig lines and JSON-RPC requests mixed with spawns and removals of
every body kind, against a served schoolyard; then the server must answer and no position or
velocity may be NaN. The CI test (tests/test_fuzz_mix.py) runs 250 operations.

    python benchmarks/fuzz_server_mix.py --operations 1000 --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from fuzz_mix import run_mix, world_is_finite  # noqa: E402
from server_helpers import running_server  # noqa: E402

from twig_ecs.client import Client  # noqa: E402


def main() -> int:
    """Run the mix once per seed; exit 1 if the server stopped answering or the world went NaN."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--operations", type=int, default=1000)
    parser.add_argument("--seeds", default="0")
    args = parser.parse_args()
    failed = 0
    for seed in (int(s) for s in args.seeds.split(",")):
        start = time.perf_counter()
        with running_server(twig=True, paused=True, timeout=300) as srv:
            result = run_mix(srv.port, srv.twig_port, args.operations, seed)
            with Client(port=srv.port, timeout=300) as twig:
                answering = twig.call("ping") == "pong"
                state = twig.call("get_state")
        nan = world_is_finite(state)
        ok = answering and not nan and not result.internal
        failed += not ok
        print(f"seed {seed}: {args.operations} operations, {result.sent} answers ({result.ok} ok, "
              f"errors by code {dict(sorted(result.errors.items()))}), {len(state['entities'])} entities at "
              f"frame {state['frame']}, answering {answering}, NaN in {nan or 'none'}, internal errors "
              f"{len(result.internal)}, simulation errors {len(result.simulation_errors)}, "
              f"{time.perf_counter() - start:.1f} s: {'ok' if ok else 'FAILED'}")  # fmt: skip
        for message in result.internal[:5] + result.simulation_errors[:5]:
            print(f"  {message}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
