"""Sweeps (issue 38): many runs over seeds and values, each the row `twig run` would report."""

from __future__ import annotations

import csv
import json
import os
import signal
import threading
import time
from pathlib import Path

import pytest

from twig_ecs import Scene, sweep
from twig_ecs.cli import main
from twig_ecs.errors import SceneError, TwigError
from twig_ecs.sweep import SweepRun, plan_runs, run_cluster, run_local

SECONDS = 4.0


def twig_run(capsys, *args: str) -> dict:
    """`twig run ... --report json` through the CLI, as a user would: its report."""
    capsys.readouterr()
    assert main(["run", *args, "--report", "json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.slow  # six schoolyard runs in two worker processes, then four of them one by one
def test_a_sweep_table_has_the_rows_twig_run_gives_one_by_one_and_an_error_row_for_a_bad_value(
    tmp_path, capsys
):
    table = tmp_path / "sweep.csv"
    code = main(["sweep", "schoolyard", "--seeds", "0-1", "--set", "attachment.safe_distance=1.5,4,-x",
                 "--seconds", str(SECONDS), "-o", str(table), "--workers", "2"])  # fmt: skip
    assert code == 0
    said = capsys.readouterr().out
    assert "6 of 6 runs" in said and "attachment.safe_distance=-x: 0 run(s), 2 failed" in said
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(r["seed"], r["attachment.safe_distance"]) for r in rows] == [
        ("0", "1.5"), ("1", "1.5"), ("0", "4"), ("1", "4"), ("0", "-x"), ("1", "-x")]  # fmt: skip
    for row in rows[:4]:
        report = twig_run(capsys, "schoolyard", "--seed", row["seed"], "--seconds", str(SECONDS),
                          "--set", f"attachment.safe_distance={row['attachment.safe_distance']}")  # fmt: skip
        assert row["error"] == "" and row["state_hash"] == report["state_hash"]
        assert row["frames"] == str(report["frames"])
        assert row["max_link_error"] == str(report["max_link_error"])
        assert row["characters.small_child.hugs"] == str(report["characters"]["small_child"]["hugs"])
        assert "step_ms.median" not in row  # wall time: the same sweep gives the same table
    assert len({r["state_hash"] for r in rows[:4]}) >= 2, "the seeds give other runs"
    for row in rows[4:]:
        assert "safe_distance" in row["error"] and "expected a finite number" in row["error"]
        assert row["state_hash"] == ""


def sweep_workers() -> list[int]:
    """The pids of this process's sweep workers (Linux: /proc)."""
    pids = []
    for children in Path(f"/proc/{os.getpid()}/task").glob("*/children"):
        for pid in children.read_text().split():
            cmdline = Path(f"/proc/{pid}/cmdline")
            if cmdline.exists() and b"twig_ecs.sweep import serve" in cmdline.read_bytes():
                pids.append(int(pid))
    return pids


def killing(workers: int, times: int, killed: list[int]) -> threading.Thread:
    """A thread that kills a busy sweep worker ``times`` times (when ``workers`` are up and
    a run is under way), noting each pid in ``killed``."""

    def kill() -> None:
        deadline = time.monotonic() + 120
        while len(killed) < times and time.monotonic() < deadline:
            time.sleep(0.5)
            alive = [pid for pid in sweep_workers() if pid not in killed]
            if len(alive) == workers:
                time.sleep(0.5)  # its kernels loaded, a run under way
                try:
                    os.kill(alive[0], signal.SIGKILL)
                except ProcessLookupError:
                    continue  # it had finished its runs and gone: try another
                killed.append(alive[0])

    thread = threading.Thread(target=kill)
    thread.start()
    return thread


#: Simulated seconds of each run in the killed-worker test: a run of the schoolyard takes more
#: than a second of wall time (half a second of CPU on a quiet machine), far longer than the
#: killer's 0.2 s wait, so a warm worker is killed while its run is under way.
KILLED_SECONDS = 8.0


@pytest.mark.slow  # four runs in two workers, one of them killed once
def test_a_worker_killed_mid_run_loses_only_its_run_which_is_run_again(monkeypatch):
    # The killer waits for the first row (a worker warm, its kernels loaded), then kills the
    # worker given the next run, run 2, 0.2 s into it: a run truly under way, and the same one
    # every time (it used to kill whichever worker came first 0.5 s after both were started,
    # often while it was still starting up, and compared run 2: the killed one was run 0, 3 tries of 3)
    given: dict[int, tuple[int, float]] = {}  # run index -> (worker pid, when it was first given)
    gives: list[int] = []  # the run of every give, in order
    give = sweep._Worker.give

    def noting_give(worker, run):
        give(worker, run)
        gives.append(run.index)
        given.setdefault(run.index, (worker.process.pid, time.monotonic()))

    monkeypatch.setattr(sweep._Worker, "give", noting_give)
    first_row = threading.Event()
    killed: list[int] = []

    def kill_run_2() -> None:
        first_row.wait(timeout=120)
        deadline = time.monotonic() + 60
        while 2 not in given and time.monotonic() < deadline:
            time.sleep(0.01)
        pid, since = given[2]
        time.sleep(max(0.0, since + 0.2 - time.monotonic()))
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    killer = threading.Thread(target=kill_run_2)
    killer.start()
    done = run_local("schoolyard", KILLED_SECONDS, plan_runs([0, 1, 2, 3], {}), workers=2,
                     on_row=lambda row: first_row.set())  # fmt: skip
    killer.join()
    assert killed == [given[2][0]]
    assert sorted(gives) == [0, 1, 2, 2, 3], gives  # the killed run, and only it, was given again
    assert [r["run"] for r in done] == [0, 1, 2, 3] and all(r["error"] == "" for r in done), done
    with Scene.load("schoolyard", seed=2) as scene:  # the run done again is the same run
        scene.run(KILLED_SECONDS)
        assert done[2]["state_hash"] == scene.state_hash()


@pytest.mark.long  # three worker processes, two killed: 3 s
def test_a_run_whose_worker_dies_twice_is_an_error_row():
    killed: list[int] = []
    killer = killing(1, 2, killed)
    done = run_local("schoolyard", 60.0, [SweepRun(0, 0)], workers=1, retries=1)
    killer.join()
    assert len(killed) == 2 and len(done) == 1
    assert "its worker died 2 times (exit -9" in done[0]["error"]


def test_sweep_arguments_and_dotted_overrides_fail_clearly(capsys, tmp_path):
    assert main(["sweep", "schoolyard", "--seeds", "3-x"]) == 2
    assert "--seeds: '3-x' is not a seed or a range" in capsys.readouterr().err
    assert main(["sweep", "schoolyard", "--set", "attachment.safe_distance"]) == 2
    assert "expected NAME=VALUE[,VALUE...]" in capsys.readouterr().err
    table = tmp_path / "x.csv"
    assert main(["sweep", "schoolyard", "--set", "atachment.safe_distance=3", "-o", str(table)]) == 2
    assert "(did you mean 'attachment'?)" in capsys.readouterr().err
    assert not table.exists(), "a typo fails the sweep before any run or table"
    with pytest.raises(SceneError, match="'settings.iterations' is not a mapping"):
        Scene.load("schoolyard", **{"settings.iterations.x": 3})


@pytest.mark.slow  # a local Dask cluster of two worker processes, four runs on it and four here
def test_the_same_sweep_on_a_local_dask_cluster_gives_the_same_table():
    distributed = pytest.importorskip("distributed", reason="Dask's distributed is in the dev extras")
    runs = plan_runs([0, 1], {"attachment.safe_distance": ["2", "4"]})
    # the rows a local worker answers, computed here: a worker's row is run_one's (sweep.serve),
    # and the table test checks the local workers' rows against `twig run` one by one
    here = [sweep.run_one("schoolyard", SECONDS, [], run) for run in runs]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:  # fmt: skip
        there = run_cluster(cluster.scheduler_address, "schoolyard", SECONDS, runs)
    assert there == here
    assert all(row["error"] == "" for row in there)


def test_an_unreachable_cluster_is_one_clear_error():
    with pytest.raises(TwigError, match="cannot reach a Dask scheduler at tcp://127.0.0.1:9"):
        run_cluster("tcp://127.0.0.1:9", "schoolyard", 1.0, plan_runs([0], {}), connect_timeout=1.0)


def test_the_plot_draws_the_share_of_runs_with_a_figure_above_zero_by_value(tmp_path):
    from PIL import Image

    from twig_ecs.sweepplot import chance_by_value, plot_chance

    runs = [(2, 1), (2, 0), (4, 0), (4, 0)]  # (value, hugs)
    rows = [{"run": k, "v": v, "hugs": h, "error": ""} for k, (v, h) in enumerate(runs)]
    rows.append({"run": 4, "v": 4, "hugs": "", "error": "refused"})  # a failed run is left out
    assert chance_by_value(rows, "v", "hugs") == [("2", 0.5, 0.5, 2), ("4", 0.0, 0.0, 2)]
    with Image.open(plot_chance(rows, "v", "hugs", tmp_path / "chance.png")) as image:
        assert image.size == (900, 500)
        # the first bar (half way up) is drawn in its blue; the second (none) is not
        assert image.getpixel((int(70 + 830 * 0.5 / 2), 440 - 100)) == (90, 140, 200)
    with pytest.raises(TwigError, match="no finished run reported 'kicks'"):
        plot_chance(rows, "v", "kicks", tmp_path / "none.png")


def _ctrl_c_at_its_default() -> None:
    """In the sweep's process, before it starts: SIGINT at its default, as in a terminal.

    A suite started in the background of a script (``pytest ... &``, or a tool that runs it
    so) inherits SIGINT ignored, as POSIX shells do for background jobs, and every process it
    starts would too; Python then keeps ignoring it, rightly (what ``nohup`` asks), and the
    sweep ran all its runs and exited 0. The test is about a Ctrl-C that reaches the sweep.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow  # a sweep in a fresh process, stopped by Ctrl-C after its first row
def test_ctrl_c_stops_a_sweep_and_keeps_the_rows_it_finished(tmp_path):
    import subprocess
    import sys

    table = tmp_path / "table.csv"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    sweep = subprocess.Popen([sys.executable, "-m", "twig_ecs", "sweep", "schoolyard", "--seeds", "0-9",
                              "--seconds", "5", "-o", str(table)], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, env=env,
                             preexec_fn=_ctrl_c_at_its_default)  # fmt: skip
    said = []
    for line in sweep.stdout:  # the progress: stop it once a run is in
        said.append(line)
        if line.startswith("sweep: 1/10"):
            sweep.send_signal(signal.SIGINT)
            break
    said += sweep.stdout.readlines()
    assert sweep.wait(timeout=60) == 130, said
    kept = list(csv.DictReader(table.open()))
    assert 1 <= len(kept) < 10 and all(row["error"] == "" and row["state_hash"] for row in kept)
    assert f"{len(kept)} of 10 runs in {table} (stopped: the finished runs are kept)" in "".join(said)
