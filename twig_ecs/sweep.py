"""Sweeps: one scene run over many seeds and parameter values, each run a row of a table.

``twig sweep schoolyard --seeds 0-199 --set attachment.safe_distance=2,3,4 --seconds 60``
runs the product of the seeds and the values - each run exactly what ``twig run SCENE
--seed S --set NAME=VALUE --seconds N --report json`` computes - in worker processes, one
per core, each loading the kernels once. A row holds the run's seed, its values, its state
hash and the report's figures (nested keys joined by dots: ``characters.small_child.hugs``);
wall-clock timings are left out so the same sweep gives the same table. A run that fails
(a value the scene refuses, a worker that died twice) is a row with its ``error``.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

from twig_ecs.errors import TwigError

#: Report figures left out of a row: wall-clock time, different on every run.
UNREPEATABLE = ("step_ms.",)
#: The first columns of every row, in this order; the values and the figures follow.
LEAD = ("run", "seed", "error", "state_hash")


@dataclass(frozen=True)
class SweepRun:
    """One run of a sweep: its index in the table, its seed and the values it sets."""

    index: int
    seed: int
    values: dict[str, Any] = field(default_factory=dict)


def parse_seeds(text: str) -> list[int]:
    """``"0-3,7"`` -> [0, 1, 2, 3, 7] (ranges inclusive)."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        low, dash, high = part.partition("-")
        try:
            seeds.extend(range(int(low), int(high) + 1) if dash else [int(part)])
        except ValueError:
            raise TwigError(f"--seeds: '{part}' is not a seed or a range such as 0-199") from None
    if not seeds or min(seeds) < 0:
        raise TwigError(f"--seeds '{text}': give seeds of 0 or more, such as 0-199 or 1,5,9")
    return seeds


def parse_values(text: str) -> tuple[str, list[str]]:
    """``"attachment.safe_distance=2,3,4"`` -> ("attachment.safe_distance", ["2", "3", "4"])."""
    name, sep, values = text.partition("=")
    items = [v.strip() for v in values.split(",") if v.strip()]
    if not sep or not name.strip() or not items:
        raise TwigError(f"--set '{text}': expected NAME=VALUE[,VALUE...]")
    return name.strip(), items


def plan_runs(seeds: Sequence[int], grid: dict[str, Sequence[Any]]) -> list[SweepRun]:
    """Every combination of the values, each with every seed (seeds vary fastest)."""
    names = list(grid)
    combos = list(itertools.product(*(grid[n] for n in names)))
    return [SweepRun(k, seed, dict(zip(names, combo, strict=True)))
            for k, (combo, seed) in enumerate(itertools.product(combos, seeds))]  # fmt: skip


def flatten(report: dict, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """The scalar figures of a report as (dotted key, value), timings left out."""
    for key, value in report.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            yield from flatten(value, name + ".")
        elif (value is None or isinstance(value, (bool, int, float, str))) and not name.startswith(
            UNREPEATABLE
        ):
            yield name, value


def row_of(run: SweepRun, error: str = "") -> dict[str, Any]:
    """A run's row before its figures: its index, seed and values, and its error (empty when
    it ran)."""
    return {"run": run.index, "seed": run.seed, **run.values, "error": error}


def run_one(scene: str, seconds: float, content: Sequence[str], run: SweepRun) -> dict[str, Any]:
    """One run as a row (in whichever process calls it): its figures, or its error."""
    from twig_ecs.report import run_with_report

    try:
        report = run_with_report(scene, seconds, seed=run.seed, content=list(content), parameters=run.values)
    except TwigError as exc:
        return row_of(run, str(exc))
    return row_of(run) | dict(flatten(report))


# -- local workers ---------------------------------------------------------------------------------

#: What a local worker process runs: :func:`serve` with the sweep's job.
_WORKER_CODE = "import sys, json; from twig_ecs.sweep import serve; serve(json.loads(sys.argv[1]))"


def serve(job: dict) -> None:
    """A worker process: load the kernels once, then run each run read from stdin (a JSON
    line), answering with its row (a JSON line), until stdin ends."""
    answers = os.fdopen(os.dup(1), "w")  # the rows' own channel; anything printed goes to stderr
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    from twig_ecs import Scene

    scene, seconds, content = job["scene"], job["seconds"], job["content"]
    try:
        with Scene.load(scene, content=content) as warm:
            warm.step()
    except TwigError:
        pass  # the runs will each say why
    for line in sys.stdin:
        run = SweepRun(**json.loads(line))
        try:
            row = run_one(scene, seconds, content, run)
        except Exception as exc:  # noqa: BLE001 - any failure of a run is its row, never a lost sweep
            row = row_of(run, f"{type(exc).__name__}: {exc}")
        answers.write(json.dumps(row) + "\n")
        answers.flush()


class _Worker:
    """A worker process (``python -c``: no ``__main__`` of the caller is run again in it, as
    multiprocessing's spawn would) and the run it has (None when idle)."""

    def __init__(self, scene: str, seconds: float, content: Sequence[str]) -> None:
        from twig_ecs.kernels import worker_environment

        env = worker_environment()
        env["NUMBA_NUM_THREADS"] = "1"  # a run per core: threads would only contend
        job = json.dumps({"scene": scene, "seconds": seconds, "content": [str(c) for c in content]})
        self.log = tempfile.TemporaryFile(mode="w+")
        command = [sys.executable, "-P", "-c", _WORKER_CODE, job]
        pipe = subprocess.PIPE
        self.process = subprocess.Popen(command, stdin=pipe, stdout=pipe, stderr=self.log, text=True, env=env)
        self.run: SweepRun | None = None

    def give(self, run: SweepRun) -> None:
        """Send it a run."""
        self.run = run
        self.process.stdin.write(
            json.dumps({"index": run.index, "seed": run.seed, "values": run.values}) + "\n"
        )
        self.process.stdin.flush()

    def answer(self) -> dict | None:
        """Its row, or None if it died (its output ended)."""
        line = self.process.stdout.readline()
        return json.loads(line) if line else None

    def death(self) -> str:
        """How it ended: its exit code and the last line it wrote to stderr."""
        code = self.process.wait()
        self.log.seek(0)
        lines = self.log.read().strip().splitlines()
        return f"exit {code}" + (f": {lines[-1][-300:]}" if lines else "")

    def stop(self) -> None:
        """End it (stdin closed: it returns), or kill it if it does not."""
        try:
            self.process.stdin.close()
            self.process.wait(timeout=5)
        except (OSError, subprocess.TimeoutExpired):
            self.process.kill()
            self.process.wait()
        self.log.close()


def run_local(scene: str, seconds: float, runs: Sequence[SweepRun], content: Sequence[str] = (),
              workers: int | None = None, on_row: Callable[[dict], None] | None = None,
              retries: int = 1) -> list[dict]:  # fmt: skip
    """Run every run in ``workers`` processes (default: one per core); rows in run order.

    A run whose worker dies (killed, out of memory) is given to a fresh worker ``retries``
    more times, then becomes an error row. ``on_row`` sees each row as it comes (progress);
    on Ctrl-C the rows finished so far are returned, and the workers stopped.
    """
    count = max(1, min(workers or os.cpu_count() or 1, len(runs)))
    todo = list(reversed(runs))
    tries: dict[int, int] = {}
    rows: dict[int, dict] = {}

    def done(row: dict) -> None:
        rows[row["run"]] = row
        if on_row is not None:
            on_row(row)

    pool = [_Worker(scene, seconds, content) for _ in range(count)]
    try:
        while len(rows) < len(runs):
            for worker in pool:
                if worker.run is None and todo:
                    worker.give(todo.pop())
            busy = [w for w in pool if w.run is not None]
            ready = wait([w.process.stdout for w in busy])
            for worker in [w for w in busy if w.process.stdout in ready]:
                row, run = worker.answer(), worker.run
                worker.run = None
                if row is not None:
                    done(row)
                    continue
                tries[run.index] = tries.get(run.index, 0) + 1  # it died with this run in hand
                if tries[run.index] > retries:
                    done(row_of(run, f"its worker died {tries[run.index]} times ({worker.death()})"))
                else:
                    todo.append(run)
                worker.stop()
                pool[pool.index(worker)] = _Worker(scene, seconds, content)
    except KeyboardInterrupt:
        pass
    finally:
        for worker in pool:
            worker.stop()
    return [rows[k] for k in sorted(rows)]


def check_names(scene: str, names: Sequence[str], content: Sequence[str] = ()) -> None:
    """Refuse a sweep whose scene is unknown or that sets a name the scene does not have
    (a typo fails the sweep at once; a value the scene refuses is one run's error row)."""
    from twig_ecs.library import ContentLibrary, read_document
    from twig_ecs.parameters import override, read_parameters

    library = ContentLibrary(list(content))
    doc = read_document(library.scene_path(scene))
    declared = read_parameters(doc)
    for name in names:
        if "." in name:
            override(doc, name, 0, scene)
        elif name not in declared:
            raise TwigError(f"scene '{scene}' has no parameter '{name}' (a dotted path such as "
                            "attachment.safe_distance sets any value of the file)")  # fmt: skip


# -- a cluster ---------------------------------------------------------------------------------------


def run_cluster(address: str, scene: str, seconds: float, runs: Sequence[SweepRun],
                content: Sequence[str] = (), on_row: Callable[[dict], None] | None = None,
                connect_timeout: float = 20.0) -> list[dict]:  # fmt: skip
    """Run every run on the Dask cluster whose scheduler is at ``address`` (``tcp://HOST:PORT``):
    the same rows as :func:`run_local`, in run order.

    Each run is one task; its workers import twig-ecs (the same version) and keep the
    kernels loaded between runs. A task that raises, or whose workers die more often than
    the scheduler allows (``distributed.scheduler.allowed-failures``), is an error row.
    """
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise TwigError("--cluster needs Dask's scheduler: pip install 'twig-ecs[cluster]'") from None
    try:
        client = Client(address, timeout=f"{connect_timeout}s")
    except (OSError, TimeoutError) as exc:
        raise TwigError(f"cannot reach a Dask scheduler at {address}: {exc}") from None
    rows: dict[int, dict] = {}
    with client:
        futures = {
            client.submit(run_one, scene, seconds, list(content), run, pure=False): run for run in runs
        }
        try:
            for future in as_completed(futures):
                run = futures[future]
                try:
                    row = future.result()
                except Exception as exc:  # noqa: BLE001 - a run's failure is its row (KilledWorker too)
                    row = row_of(run, f"{type(exc).__name__}: {exc}")
                rows[run.index] = row
                if on_row is not None:
                    on_row(row)
        except KeyboardInterrupt:
            client.cancel(list(futures))
    return [rows[k] for k in sorted(rows)]


# -- the table -------------------------------------------------------------------------------------


def columns(rows: Sequence[dict], names: Sequence[str] = ()) -> list[str]:
    """The table's columns: the lead ones, the swept names, then every figure met (first seen
    first), or only ``names`` of them when given."""
    figures: dict[str, None] = {}
    for row in rows:
        figures.update(dict.fromkeys(k for k in row if k not in LEAD and k not in names))
    return [LEAD[0], LEAD[1], *names, *LEAD[2:], *figures]


def write_table(rows: Sequence[dict], path: str | Path, swept: Sequence[str] = (),
                metrics: Sequence[str] = ()) -> Path:  # fmt: skip
    """Write the rows as CSV (``.csv``) or Parquet (``.parquet``, needs pyarrow)."""
    path = Path(path)
    cols = columns(rows, swept)
    if metrics:
        missing = [m for m in metrics if not any(m in row for row in rows)]
        if missing and rows and not all(row.get("error") for row in rows):
            raise TwigError(f"no run reported {', '.join(missing)} (a figure of `twig run --report json`, "
                            "nested keys joined by dots)")  # fmt: skip
        cols = [c for c in cols if c in (*LEAD, *swept, *metrics)]
    if path.suffix == ".parquet":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise TwigError("writing .parquet needs pyarrow (pip install pyarrow); or give a .csv") from None
        pq.write_table(pa.Table.from_pylist([{c: row.get(c) for c in cols} for row in rows]), path)
        return path
    if path.suffix != ".csv":
        raise TwigError(f"{path}: a sweep's table is a .csv or a .parquet file")
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


def summary(rows: Sequence[dict], swept: Sequence[str], metrics: Sequence[str]) -> list[str]:
    """Lines: per combination of swept values, the runs, errors and each metric's mean."""
    lines = []
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault(tuple(row.get(n) for n in swept), []).append(row)
    for key, group in groups.items():
        done = [r for r in group if not r.get("error")]
        label = ", ".join(f"{n}={v}" for n, v in zip(swept, key, strict=True)) or "all"
        parts = [f"{len(done)} run(s)"] + (
            [f"{len(group) - len(done)} failed"] if len(done) < len(group) else []
        )
        for metric in metrics:
            values = [float(r[metric]) for r in done if isinstance(r.get(metric), (int, float))]
            if values:
                above = sum(v > 0 for v in values) / len(values)
                parts.append(f"{metric} mean {sum(values) / len(values):.3g}, above 0 in {above:.0%}")
        lines.append(f"{label}: " + ", ".join(parts))
    return lines


class SweepProgress:
    """A progress line with an ETA on stderr (overwritten in place on a terminal)."""

    def __init__(self, total: int, stream=None) -> None:
        self.total, self.done, self.failed = total, 0, 0
        self.started = time.monotonic()
        self.stream = stream or sys.stderr

    def __call__(self, row: dict) -> None:
        self.done += 1
        self.failed += bool(row.get("error"))
        spent = time.monotonic() - self.started
        left = spent / self.done * (self.total - self.done)
        eta = f", about {math.ceil(left)} s left" if self.done < self.total else f" in {spent:.0f} s"
        failed = f", {self.failed} failed" if self.failed else ""
        line = f"sweep: {self.done}/{self.total} runs{failed}{eta}"
        tty = self.stream.isatty()
        self.stream.write(f"\r\033[K{line}" if tty else line + "\n")
        if tty and self.done == self.total:
            self.stream.write("\n")
        self.stream.flush()
