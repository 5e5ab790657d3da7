"""Shared fixtures: scenes that are always closed, so no test sees another's world; the
kernels made ready once per session; and the five-minute schoolyard, simulated once.

How to run the tests (the fast loop, the ``slow`` marker, the two workers): docs/testing.md.
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from yard_run import SEED, YARD_ID, YardRun, run_the_yard, scope_of

from twig_ecs import Scene, Settings, kernels
from twig_ecs.scene import open_scenes
from twig_ecs.threads import usable_cpus

# The tests start many Python processes (the CLI, servers, fresh-process probes). Where the
# environment says PYTHONDONTWRITEBYTECODE (some containers and CI images do), each of them
# would compile every twig-ecs module from source again; a user's installed twig does not.
# Let the workers and those processes write and reuse bytecode, as a user's would.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

# -- the kernels: compiled before the first test, not inside it --------------------------------------


def pytest_sessionstart(session: pytest.Session) -> None:
    """Compile the kernels into the cache before any test, when they are not there yet.

    Runs once, in the process that starts the run (with ``-n 2``, before the workers start,
    so they both find the cache full instead of compiling the same kernels side by side).
    The time it took is a line of the summary, not a part of whichever test ran first.
    """
    if hasattr(session.config, "workerinput"):  # an xdist worker: the controller did this
        return
    started = time.perf_counter()
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    say = reporter.write_line if reporter is not None else None
    build = kernels.prepare("schoolyard", say=say)
    seconds = time.perf_counter() - started
    if build is None:
        line = f"kernels: found in the cache ({seconds:.1f} s to check)"
        if kernels.jit_disabled():
            line = "kernels: NUMBA_DISABLE_JIT=1, every kernel runs as plain Python"
    else:
        line = f"kernels: compiled {len(build.compiled)} before the tests in {seconds:.1f} s"
        if build.errors:
            line += f"; the build failed ({'; '.join(build.errors)}), each test compiles what it needs"
    session.config.stash[_KERNEL_LINE] = line


_KERNEL_LINE = pytest.StashKey[str]()


def pytest_terminal_summary(terminalreporter, config: pytest.Config) -> None:
    """Say how the kernels were made ready (compiled, or found in the cache)."""
    line = config.stash.get(_KERNEL_LINE, None)
    if line is not None:
        terminalreporter.write_line(line)


@pytest.fixture(scope="session", autouse=True)
def loaded_kernels() -> None:
    """Load every kernel the schoolyard runs from the cache into this process, once.

    The load (about half a second) is this fixture's setup, not a part of the first test
    that happens to step a scene.
    """
    with Scene.load("schoolyard") as scene:
        scene.step()


# -- scenes -----------------------------------------------------------------------------------------


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """Keep each phase's report on the test (``item.phase_call``...) for the fixtures' teardown."""
    report = yield
    setattr(item, f"phase_{report.when}", report)
    return report


@pytest.fixture(autouse=True)
def no_scene_left_open(request: pytest.FixtureRequest):
    """Every scene a test opens is closed after it, whether it passed or failed, so that one
    failure never leaves scenes for the next tests to trip over (their ``scenes`` teardown
    used to error: issue 33). A test that *passed* with scenes of its own still open is an
    error here: it should close them (the ``scenes`` fixture, ``with Scene.load(...)``)."""
    before = set(open_scenes())  # (scenes of module and session fixtures are open before: kept)
    yield
    left = [scene for scene in open_scenes() if scene not in before]
    for scene in left:
        scene.close()
    call = getattr(request.node, "phase_call", None)
    if left and call is not None and call.passed:
        names = ", ".join(sorted(scene.name for scene in left))
        what = f"this test left {len(left)} scene(s) open ({names}): close them"
        pytest.fail(what, pytrace=False)


@pytest.fixture
def scenes():
    """A list to put scenes in; every scene in it is closed after the test, pass or fail."""
    made: list[Scene] = []
    yield made
    for scene in made:
        scene.close()


@pytest.fixture
def empty_scene(scenes):
    """An empty scene with default settings (gravity on, ground plane)."""
    scene = Scene.load("empty")
    scenes.append(scene)
    return scene


@pytest.fixture
def pair(empty_scene):
    """Two characters 2.5 m apart, facing each other: ``a`` (1.75 m) and ``b`` (1.6 m)."""
    empty_scene.spawn("humanoid", name="a", character=True)
    empty_scene.spawn("humanoid", name="b", character=True, position=(0.2, 0.0, 2.5), facing=180, height=1.6)
    empty_scene.run(0.3)
    return empty_scene


@pytest.fixture
def zero_g_scene(scenes):
    """An empty scene without gravity."""
    scene = Scene(settings=Settings(gravity=np.zeros(3)))
    scenes.append(scene)
    return scene


# -- the five-minute schoolyard ---------------------------------------------------------------------


@pytest.fixture(scope="session", params=[pytest.param(SEED, id=YARD_ID)])
def yard_five_minutes(request, tmp_path_factory) -> YardRun:
    """Five minutes of the schoolyard (seed 0) run once for the whole session, through
    ``twig run --soak --report json --trace --plot``: its report, trace and plot, read-only.

    Its one parameter puts ``[yard-300s-seed0]`` in the id of every test that uses it, by
    which :func:`pytest_xdist_make_scheduler` keeps those tests in one worker.
    """
    return run_the_yard(tmp_path_factory.mktemp("yard"), seed=request.param)


# -- workers ---------------------------------------------------------------------------------------


#: The order tests start in: ``slow`` and ``soak`` ones, then ``long`` ones, then the rest.
START_FIRST = (("slow", "soak"), ("long",))


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The ``slow`` and ``soak`` tests first, then the ``long`` ones, each in their own order
    (a stable sort).

    With workers the longest units start first and the many short ones fill in at the end,
    so no worker is left finishing a long test while the other has nothing to do (a worker
    holds its next two tests: two X-window tests of 7-10 s left last in one worker kept it
    busy 11 s after the other had finished). It runs after pytest's own ordering, which keeps
    the shared run's readers next to each other.
    """

    def rank(item: pytest.Item) -> int:
        marks = [k for k, names in enumerate(START_FIRST) if any(item.get_closest_marker(n) for n in names)]
        return marks[0] if marks else len(START_FIRST)

    items.sort(key=rank)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """With ``--dist loadgroup`` (pyproject's addopts): xdist's scheduler, but the tests that
    read the shared five-minute run are one unit of work, handed to one worker first.

    Every other test is a unit of its own (or of its ``xdist_group``), handed out as the
    workers come free; the biggest unit goes first, so the five minutes start at once.
    """
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class SharedRunScheduling(LoadGroupScheduling):
        """Load-group scheduling that also groups the shared run's readers (by their id)."""

        def _split_scope(self, nodeid: str) -> str:
            return scope_of(nodeid) or super()._split_scope(nodeid)

    return SharedRunScheduling(config, log)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto``: one worker more than the cores this process may use.

    A fifth of the suite's tests wait on wall-clock time (windows drawing at 4-5 frames a
    second, servers stepping in real time, a hug answered over the socket), and while one
    worker waits a core sits idle; a third worker on this 2-core box fills it (the suite
    124 -> 108-109 s, the same CPU seconds).
    """
    return usable_cpus() + 1
