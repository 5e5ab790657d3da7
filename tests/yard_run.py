"""The five-minute schoolyard that several test files read, simulated once per session.

``twig run schoolyard --seconds 300 --soak --report json --trace ... --plot ...`` is the
slowest thing the suite does (about a minute); the story tests (test_schoolyard.py) and
the soak test (test_soak.py) used to run it once each. The conftest's session fixture
runs it here once and hands every test the same frozen figures: mappings that cannot be
changed and tuples, so no test can alter what the next one reads.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from twig_ecs.cli import main

#: The xdist group of every test that reads the shared run: they all run in one worker.
YARD_GROUP = "yard_five_minutes"
FIVE_MINUTES = 300.0
SEED = 0


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


def run_the_yard(folder: Path) -> YardRun:
    """Run the schoolyard for five minutes through the CLI, soak-checked and traced."""
    trace, plot = folder / "trace.csv", folder / "plot.png"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["run", "schoolyard", "--seconds", str(FIVE_MINUTES), "--seed", str(SEED), "--soak",
                     "--report", "json", "--trace", str(trace), "--plot", str(plot)])  # fmt: skip
    with open(trace, newline="") as f:
        everyone = freeze(list(csv.DictReader(f)))
    small = tuple(row for row in everyone if row["character"] == "small_child")
    return YardRun(code, freeze(json.loads(out.getvalue())), everyone, small, plot)
