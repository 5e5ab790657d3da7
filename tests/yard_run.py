"""The five-minute schoolyard that several test files read, simulated once per session.

``twig run schoolyard --seconds 300 --soak --report json --trace ... --plot ...`` is the
slowest thing the suite does (about a minute); the story tests (test_schoolyard.py) and
the soak test (test_soak.py) used to run it once each. The conftest's session fixture
runs it here once and hands every test the same frozen figures: mappings that cannot be
changed and tuples, so no test can alter what the next one reads.

With workers (pytest-xdist) every test that reads it must run in the worker that ran it,
or each worker would simulate the five minutes again. xdist's own ``xdist_group`` marker
does not group with pytest 9.2 (xdist 3.8 renames the item's ``_nodeid``, which pytest 9.2
no longer reads), so the fixture is parametrised with one id, :data:`YARD_ID`, that
appears in every such test's id, and :func:`scope_of` groups tests by it.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from twig_ecs.cli import main

FIVE_MINUTES = 300.0
SEED = 0
#: The shared run's parameter id: every test that reads it has ``[yard-300s-seed0]`` in its
#: id, and with workers the conftest's scheduler sends all those tests to one worker.
YARD_ID = f"yard-{FIVE_MINUTES:.0f}s-seed{SEED}"


def freeze(value):
    """A read-only deep copy of parsed JSON or CSV: dicts become mapping proxies, lists tuples."""
    if isinstance(value, dict):
        return MappingProxyType({key: freeze(item) for key, item in value.items()})
    if isinstance(value, list | tuple):
        return tuple(freeze(item) for item in value)
    return value


@dataclass(frozen=True)
class YardRun:
    """What one five-minute schoolyard run left: the exit code, the JSON report, the
    per-step trace (every character's rows, and the small child's alone) and the plot."""

    code: int
    report: MappingProxyType
    everyone: tuple[MappingProxyType, ...]
    small_child: tuple[MappingProxyType, ...]
    plot: Path


def run_the_yard(folder: Path, seed: int = SEED) -> YardRun:
    """Run the schoolyard for five minutes through the CLI, soak-checked and traced."""
    trace, plot = folder / "trace.csv", folder / "plot.png"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["run", "schoolyard", "--seconds", str(FIVE_MINUTES), "--seed", str(seed), "--soak",
                     "--report", "json", "--trace", str(trace), "--plot", str(plot)])  # fmt: skip
    with open(trace, newline="") as f:
        everyone = freeze(list(csv.DictReader(f)))
    small = tuple(row for row in everyone if row["character"] == "small_child")
    return YardRun(code, freeze(json.loads(out.getvalue())), everyone, small, plot)


def scope_of(nodeid: str) -> str | None:
    """The worker-scheduling group of a test id: :data:`YARD_ID` for a test that reads the
    shared run (its parameter ids, joined by ``-`` in brackets, include it), else None."""
    params = nodeid[nodeid.find("[") :] if nodeid.endswith("]") else ""
    return YARD_ID if re.search(rf"[\[-]{re.escape(YARD_ID)}[\]-]", params) else None
