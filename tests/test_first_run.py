"""A newcomer's first run: the kernel cache, the window while compiling, and clear messages."""

from __future__ import annotations

import inspect
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from twig_ecs import Scene, TwigError, kernels
from twig_ecs.cli import builtin_scenes, main
from twig_ecs.graphics.app import Loading, _window_class, load_pyglet_window
from twig_ecs.graphics.overlay import text_panel
from twig_ecs.handles import PassiveBodyError

ROOT = Path(__file__).resolve().parent.parent


def run_python(*args: str, env: dict | None = None, cwd: Path | None = None, timeout: float = 300):
    """Run this Python with -P (the cwd is not put on sys.path), return the finished process."""
    full = {**os.environ, **(env or {})}
    return subprocess.run([sys.executable, "-P", *args], capture_output=True, text=True, env=full,
                          cwd=cwd or ROOT, timeout=timeout)  # fmt: skip


# -- the kernel cache ---------------------------------------------------------------------------


@pytest.fixture
def balls_scene(tmp_path) -> Path:
    """Two balls falling onto each other: they need the physics kernels, the contact ones too."""
    scene = tmp_path / "balls.yaml"
    scene.write_text("twig: 1\nname: balls\nentities:\n"
                     "  - {name: a, body: ball, position: [0, 0.3, 0]}\n"
                     "  - {name: b, body: ball, position: [0.05, 0.6, 0]}\n")  # fmt: skip
    return scene


@pytest.mark.slow  # compiles kernels in an empty cache (the one test that does)
def test_a_first_build_shows_one_true_total_compiles_each_kernel_once_and_is_shared(tmp_path, balls_scene):
    cache = tmp_path / "cache"
    # the progress is polled as a window does: it used to guess 20 (or the count an earlier
    # build remembered) and grow past it: x/20, then 21/21 ... 40/40; now a worker counts the
    # kernels first, stepping the scene once as plain Python
    probe = (
        "import time; from twig_ecs import kernels\n"
        f"b = kernels.KernelBuild({str(balls_scene)!r})\n"
        "shown = []\n"
        "while not b.poll():\n"
        "    shown.append(b.status().split(': ', 1)[1].split()[0])\n"
        "    time.sleep(0.02)\n"
        "print(repr((shown, b.compiles, b.errors, str(kernels.cache_folder()))))\n"
    )
    build = run_python("-c", probe, env={"TWIG_CACHE_DIR": str(cache)})
    assert build.returncode == 0, build.stderr
    shown, compiles, errors, folder = eval(build.stdout)  # noqa: S307 - our own probe's printout
    assert errors == []
    compiled = {name for _, name in compiles}
    assert {"resolve_contacts", "solve_collisions", "relax_once", "integrate_nodes"} <= compiled
    totals = [progress.split("/")[1] for progress in shown if "/" in progress]
    # one total, from its first showing to the end: the kernels the build then compiled
    assert set(totals) == {str(len(compiled))}
    assert {progress for progress in shown if "/" not in progress} <= {"counting"}  # no guess before
    assert {worker for worker, _ in compiles} == {0, 1}  # both workers compiled a share
    # a kernel one worker compiles twice has a second type specialisation, compiled again
    # on every first run (resolve_contacts had one, for a literal False)
    assert [(w, name) for w, name in set(compiles) if compiles.count((w, name)) > 1] == []

    folder = Path(folder)
    assert folder.parent == cache and folder.name.startswith("kernels-")
    # kernels are filed by module and a hash of its sources, not by where they are installed
    filed = {p.name for p in folder.iterdir() if p.is_dir()}
    assert filed and all(re.fullmatch(r"[a-z_]+\.[a-z_]+-[0-9a-f]{12}", name) for name in filed), filed
    assert any(name.startswith("physics.collide-") for name in filed)

    other = _copy_of_the_sources(tmp_path / "elsewhere")  # the same sources at another path
    probe = (
        "import twig_ecs; from numba.core import event; from twig_ecs import Scene\n"
        "compiled = []\n"
        "class L(event.Listener):\n"
        "    def on_start(self, ev): compiled.append(ev.data['dispatcher'].py_func.__name__)\n"
        "    def on_end(self, ev): pass\n"
        "event.register('numba:compile', L())\n"
        f"with Scene.load({str(balls_scene)!r}) as s: s.step(20)\n"
        "print(twig_ecs.__file__, compiled)\n"
    )
    reuse = run_python("-c", probe, env={"TWIG_CACHE_DIR": str(cache), "PYTHONPATH": str(other)})
    assert reuse.returncode == 0, reuse.stderr
    assert reuse.stdout.startswith(str(other))  # it really ran the copy
    # and compiled nothing: the cache was shared, and the build left no specialisation out
    assert reuse.stdout.strip().endswith("[]")


def _copy_of_the_kernel_cache(where: Path) -> None:
    """Copy this session's compiled kernels into ``where``: each kernel module's folder for its
    present sources, and the folder's own files (the kernel counts).

    Not the whole folder: the user's cache folder keeps every version of each module compiled
    since (on a developer's box 1257 module folders, 639 MB, of which 14 are the sources' own;
    copying it all took 4 s of a test).
    """
    from twig_ecs.kernelcache import module_folder_name

    warm = kernels.cache_folder()
    where.mkdir(parents=True, exist_ok=True)
    for path in warm.iterdir():
        if path.is_file():
            shutil.copy2(path, where / path.name)
    ours = kernels.InterimKernels().kernels()  # every kernel of every kernel module (it imports them)
    for name in {module_folder_name(Path(inspect.getfile(kernel.py_func))) for kernel in ours}:
        if (warm / name).is_dir():
            shutil.copytree(warm / name, where / name, dirs_exist_ok=True)


def _copy_of_the_sources(where: Path) -> Path:
    for part in ("twig_ecs", "systems", "components", "content"):
        # symlinks as they are: the checkout's twig_ecs/systems points at the top-level systems/
        shutil.copytree(
            ROOT / part, where / part, symlinks=True, ignore=shutil.ignore_patterns("__pycache__")
        )
    shutil.copy(ROOT / "pyproject.toml", where / "pyproject.toml")
    return where


def _kernels_compiled_by_a_schoolyard_run(sources: Path, cache: Path) -> list[str]:
    probe = (
        "import twig_ecs; from numba.core import event; from twig_ecs import Scene\n"
        "compiled = []\n"
        "class L(event.Listener):\n"
        "    def on_start(self, ev): compiled.append(ev.data['dispatcher'].py_func.__name__)\n"
        "    def on_end(self, ev): pass\n"
        "event.register('numba:compile', L())\n"
        "with Scene.load('schoolyard') as s: s.step(30)\n"
        "print(twig_ecs.__file__, compiled)\n"
    )
    run = run_python("-c", probe, env={"TWIG_CACHE_DIR": str(cache), "PYTHONPATH": str(sources)})
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(str(sources))  # it really ran that copy
    return eval(run.stdout.split(" ", 1)[1])  # noqa: S307 - our own probe's printout


@pytest.mark.slow  # copies the sources and the cache, compiles one kernel
def test_editing_a_pure_python_behaviour_compiles_no_kernel_and_a_kernel_module_only_its_own(tmp_path):
    # kernels are cached per kernel module, keyed by the sources they compile from (issue 32)
    if kernels.jit_disabled():
        pytest.skip("NUMBA_DISABLE_JIT=1: there are no kernels to compile")
    warm = kernels.cache_folder()
    cache = tmp_path / "cache"
    _copy_of_the_kernel_cache(cache / warm.name)  # the suite's compiled kernels, schoolyard's included

    def filed() -> set[str]:
        return {p.name for p in (cache / warm.name).iterdir() if p.is_dir()}

    before = filed()
    sources = _copy_of_the_sources(tmp_path / "src")
    # (no run of the unedited copy first: the edited copy's run compiling nothing and filing
    # nothing new says more - an unedited kernel module that compiled would compile there too)
    watch = sources / "systems" / "behaviours" / "watch.py"  # plain Python: no kernel in it
    watch.write_text(watch.read_text() + "\n\ndef a_new_helper():\n    return 1\n")
    assert _kernels_compiled_by_a_schoolyard_run(sources, cache) == []
    assert filed() == before

    # a kernel module's edit compiles its own kernels again (here, in the kernel build's
    # worker processes: the run's own listener sees nothing) and no other module's
    breathing = sources / "systems" / "control" / "respiration.py"
    breathing.write_text(breathing.read_text() + "\n\nEDITED = True\n")
    _kernels_compiled_by_a_schoolyard_run(sources, cache)
    new = filed() - before
    assert len(new) == 1 and new.pop().startswith("control.respiration-")


def test_every_kernel_is_filed_by_our_cache_locator():
    # numba binds a kernel to a cache locator when it is decorated: a kernel module imported
    # before configure_cache (a new module that skips kernelmath and the systems package,
    # say) would cache under a hash of the install path, or crash on a read-only HOME
    from numba.core.dispatcher import Dispatcher

    from twig_ecs.kernelcache import KernelCacheLocator

    if kernels.jit_disabled():
        pytest.skip("NUMBA_DISABLE_JIT=1: there are no kernels to file")
    kernels._import_kernel_modules()
    found = {f"{m.__name__}.{k}": type(v._cache._impl.locator).__name__
             for m in list(sys.modules.values()) if (getattr(m, "__name__", "") or "").startswith("twig_ecs")
             for k, v in vars(m).items() if isinstance(v, Dispatcher) and v._can_compile}  # fmt: skip
    assert len(found) >= 20 and "twig_ecs.systems.physics.collide.solve_collisions" in found
    assert {name: kind for name, kind in found.items() if kind != KernelCacheLocator.__name__} == {}


def test_a_start_walks_no_source_it_walked_before_and_a_broken_index_only_costs_a_walk(tmp_path, monkeypatch):
    # every start hashes the kernel modules' import closures; their syntax-tree walk (0.2-0.4
    # s of each cached start, each sweep worker's and CLI call's) is kept by source hash
    import ast

    from twig_ecs import kernelcache as kc

    paths = [p for p in map(kc.module_file, kc.kernel_modules()) if p is not None]
    monkeypatch.setattr(kc, "_folder", tmp_path)
    walks = []
    monkeypatch.setattr(
        ast, "parse", lambda source, *a, parse=ast.parse, **k: walks.append(1) or parse(source, *a, **k)
    )

    def versions_in_a_fresh_start() -> list[str]:
        kc._import_index.cache_clear()
        kc._imported_by.cache_clear()
        walks.clear()
        return [kc.module_version(p) for p in paths]

    first = versions_in_a_fresh_start()
    assert len(walks) >= len(paths), "the first start walks every source"
    assert versions_in_a_fresh_start() == first and walks == [], "the next walks none"
    (tmp_path / kc.IMPORT_INDEX).write_text("{not json")
    assert versions_in_a_fresh_start() == first and len(walks) >= len(paths), "a broken index: walked again"
    assert versions_in_a_fresh_start() == first and walks == [], "and written again"


def test_old_versions_of_a_kernel_module_are_pruned_beyond_the_newest_few_unused_for_an_hour(
    tmp_path, monkeypatch
):
    # each edit of a kernel module's sources compiles a new version of its folder: a
    # developer's cache kept every one (643 MB on this box)
    from twig_ecs import kernelcache as kc

    monkeypatch.setattr(kc, "_folder", tmp_path)
    kc._module_folders.cache_clear()
    now = __import__("time").time()
    # five versions used within the hour (the oldest of them past the newest four, but maybe
    # still in use: a program started before the edits) and three unused for 2, 4 and 6 hours
    ages = {f"{k:012x}": 600.0 * (k + 1) for k in range(5)} | {
        f"{k:012x}": 7200.0 * (k - 4) for k in range(5, 8)
    }
    for version, age in ages.items():
        folder = tmp_path / f"physics.fake-{version}"
        folder.mkdir()
        os.utime(folder, (now - age, now - age))
    (tmp_path / "physics.other-000000000000").mkdir()  # another module's: not this one's to prune
    os.utime(tmp_path / "physics.other-000000000000", (now - 1e6, now - 1e6))
    current = tmp_path / f"physics.fake-{'c' * 12}"
    current.mkdir()
    os.utime(current, (now - 1e6, now - 1e6))  # in use now: touched, kept
    try:
        kc._prune_module("physics.fake", current)
    finally:
        kc._module_folders.cache_clear()
    kept = sorted(p.name.rpartition("-")[2] for p in tmp_path.glob("physics.fake-*"))
    assert kc.KEEP_OLD_MODULE < 5 and kept == sorted([*(f"{k:012x}" for k in range(5)), "c" * 12])
    assert current.stat().st_mtime > now - 60 and (tmp_path / "physics.other-000000000000").is_dir()


def test_a_kernel_called_with_a_constant_compiles_once_for_the_plain_type(tmp_path):
    # numba types a constant argument of a call from one kernel to another as its literal
    # (Literal[int](0)) and compiled the callee again for it: a second specialisation of the
    # same code on every first run (landing_target for a -1, _skipped for a 1). Ours compile
    # once, for int64, whatever their callers pass.
    if kernels.jit_disabled():
        pytest.skip("NUMBA_DISABLE_JIT=1: there are no kernels to compile")
    (tmp_path / "probe_kernels.py").write_text(
        "from numba import njit\n"
        "@njit(cache=True)\n"
        "def callee(a, k):\n"
        "    return a[k]\n"
        "@njit(cache=True)\n"
        "def caller(a, n):\n"
        "    return callee(a, 0) + callee(a, -1) + callee(a, n - 1)\n"
    )
    probe = (
        "import sys; import numpy as np; from twig_ecs import kernelcache\n"
        "from pathlib import Path\n"
        "dirs = kernelcache.kernel_dirs()\n"
        f"kernelcache.kernel_dirs = lambda: (*dirs, Path({str(tmp_path)!r}))  # a folder of ours\n"
        "kernelcache.configure_cache()\n"
        f"sys.path.insert(0, {str(tmp_path)!r})\n"
        "from probe_kernels import callee, caller\n"
        "print(caller(np.arange(4.0), 4), type(callee._cache._impl.locator).__name__)\n"
        "print([str(sig) for sig in callee.signatures])\n"
    )
    run = run_python("-c", probe, env={"TWIG_CACHE_DIR": str(tmp_path / "cache")})
    assert run.returncode == 0, run.stderr
    result, signatures = run.stdout.splitlines()
    assert result == "6.0 KernelCacheLocator"  # 0 + 3 + 3, filed as one of ours
    assert eval(signatures) == ["(Array(float64, 1, 'C', False, aligned=True), int64)"]  # noqa: S307


def test_version_and_help_start_without_numba_or_the_scene():
    # one fresh process for the three commands, each checked after it has run (a module
    # once imported stays: a command that imported one fails its own line and the later
    # ones), then the lazy public names: one Python start, not four
    probe = ("import json, sys; from twig_ecs.cli import main\n"
             "heavy = ('numba', 'twig_ecs.scene', 'twig_ecs.kernels')\n"
             "for args in (['--version'], ['--help'], ['run', '--help']):\n"
             "    try: main(args)\n"
             "    except SystemExit: pass\n"
             "    print('after', json.dumps(args), sorted(m for m in heavy if m in sys.modules))\n"
             "import twig_ecs\n"
             "print('lazy', 'numba' in sys.modules, twig_ecs.Scene.__name__)")  # fmt: skip
    result = run_python("-c", probe)
    assert result.returncode == 0, result.stderr
    checks = [line for line in result.stdout.splitlines() if line.startswith(("after ", "lazy "))]
    assert checks == [
        'after ["--version"] []',
        'after ["--help"] []',
        'after ["run", "--help"] []',
        "lazy False Scene",  # and the public names still import on use
    ], result.stdout[-600:]


def test_unwritable_cache_falls_back_to_a_temporary_folder_with_one_warning(tmp_path):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder would go")
    env = {"TWIG_CACHE_DIR": str(blocker / "twig-ecs"), "TMPDIR": str(tmp_path / "tmp")}
    (tmp_path / "tmp").mkdir()
    version = run_python("-m", "twig_ecs", "--version", env=env)
    assert version.returncode == 0, version.stderr
    assert version.stdout.strip().startswith("twig-ecs ")
    assert "cannot write the kernel cache" not in version.stderr  # --version never touches the cache
    # the fallback is a real cache: seed it with this session's compiled kernels (when another
    # checkout sharing the cache folder has not just pruned them), then run
    here = kernels.cache_folder()
    fallback = tmp_path / "tmp" / f"twig-ecs-{os.getuid()}" / here.name
    if here.is_dir():
        _copy_of_the_kernel_cache(fallback)
    run = run_python("-m", "twig_ecs", "run", "schoolyard", "--seconds", "1", env=env)
    assert run.returncode == 0, run.stderr
    assert "schoolyard: 60 frames" in run.stdout
    assert run.stderr.count("cannot write the kernel cache") == 1
    assert str(fallback) in run.stderr


def test_checkout_package_finds_components_systems_and_content_beside_it():
    # as after `pip install .`: the checkout's twig_ecs/ first on sys.path, no editable mapping
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r})\n"
        "sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in repr(f).lower()]\n"
        "import runpy; sys.argv = ['twig', '--help']; runpy.run_module('twig_ecs', run_name='__main__')\n"
    )
    result = run_python("-c", code)
    assert result.returncode == 0, result.stderr
    assert "validate" in result.stdout and "play" in result.stdout


# -- the window while kernels compile ---------------------------------------------------------


class FakeBuild:
    """A kernel build that finishes after a few polls (the real one: test above)."""

    def __init__(self, polls: int) -> None:
        self.polls, self.cancelled = polls, False
        self.fraction = 0.4

    def poll(self) -> bool:
        self.polls -= 1
        return self.polls < 0

    def status(self) -> str:
        return "compiling physics kernels (first run only): 8/20  control_gait  6 s"

    def cancel(self) -> None:
        self.cancelled = True


def frames_until(window, done, seconds: float = 60.0) -> None:
    """Draw the window's frames until ``done()`` (what a thread of the window does meanwhile)."""
    import time

    end = time.monotonic() + seconds
    while not done():
        assert time.monotonic() < end, "not done after a minute of frames"
        window.frame()


def test_window_draws_compile_progress_at_once_then_runs_the_scene():
    window_class = _window_class(load_pyglet_window(headless=True))
    from twig_ecs.graphics.app import Viewer

    build = FakeBuild(polls=2)
    loading = Loading(build, lambda: Viewer("schoolyard"), "twig - schoolyard")
    window = window_class(None, (480, 270), visible=False, loading=loading)
    try:
        window.frame()
        assert window.viewer is None  # still compiling: no scene yet, but a frame drawn
        frame = window.read_frame().astype(int)
        sky = frame[0, 0]
        panel = np.abs(frame - sky).sum(axis=2) > 60
        rows = np.nonzero(panel.any(axis=1))[0]
        assert panel.mean() > 0.05 and 60 < rows.mean() < 210  # a panel in the middle of the window
        window.frame()
        window.frame()
        assert window.viewer is not None  # the build finished: the scene is loaded...
        for _ in range(3):
            window.frame(elapsed=1 / 60)
        assert window.viewer.scene.frame >= 2  # ...and steps
    finally:
        window.close()
    assert not build.cancelled


def test_closing_the_window_while_compiling_stops_the_build():
    window_class = _window_class(load_pyglet_window(headless=True))
    build = FakeBuild(polls=100)
    window = window_class(None, (160, 90), visible=False, loading=Loading(build, None, "twig - x"))
    window.frame()
    window.close()
    assert build.cancelled


def test_scene_steps_in_slow_motion_while_the_kernels_compile_then_at_full_speed(monkeypatch):
    window_class = _window_class(load_pyglet_window(headless=True))
    from twig_ecs.graphics.app import Viewer
    from twig_ecs.systems.physics import collide

    build = FakeBuild(polls=10_000)  # until told to end, below
    # as on a first run: the workers cache the kernels only as the build ends
    monkeypatch.setattr(kernels, "_cached_on_disk", lambda kernel: build.polls <= 1)
    loading = Loading(build, lambda: Viewer("schoolyard"), "twig - schoolyard", interim=True)
    window = window_class(None, (480, 270), visible=False, loading=loading)
    try:
        window.frame()
        assert window.viewer is None  # the first frame is the progress panel alone
        frames_until(window, lambda: window.viewer is not None)  # the scene loads in a thread meanwhile
        assert window.loading is not None  # the scene, the build still on
        assert not kernels._ours(collide.solve_collisions)  # stepped as plain Python: nothing compiles here
        frames_until(window, lambda: window.viewer.scene.frame >= 1)  # stepped in a thread of its own
        assert build.polls >= 2  # it steps before the build ends
        assert not kernels._ours(collide.solve_collisions)
        build.polls = 4  # the workers cache every kernel as the build ends, a few frames from now
        assert window.viewer.notice is not None  # under the progress panel
        names = {key for key, *_ in window.viewer.panels((480, 270), 1.0)}
        assert {"notice", "status"} <= names
        while window.loading is not None:
            window.frame()
        assert kernels._ours(collide.solve_collisions)  # every kernel compiled again
        assert window.viewer.notice is None and window.first_step < window.full_speed
        before = window.viewer.scene.frame
        for _ in range(3):
            window.frame(elapsed=1 / 60)
        assert window.viewer.scene.frame >= before + 2
    finally:
        window.close()
    assert kernels._ours(collide.solve_collisions) and not build.cancelled


def test_closing_the_window_during_slow_motion_restores_the_kernels(monkeypatch):
    window_class = _window_class(load_pyglet_window(headless=True))
    from twig_ecs.graphics.app import Viewer
    from twig_ecs.systems.physics import constrain

    monkeypatch.setattr(kernels, "_cached_on_disk", lambda kernel: False)  # none compiled yet
    build = FakeBuild(polls=100)
    loading = Loading(build, lambda: Viewer("empty"), "twig - empty", interim=True)
    window = window_class(None, (160, 90), visible=False, loading=loading)
    frames_until(window, lambda: window.viewer is not None and window.viewer.scene.frame >= 1)
    assert not kernels._ours(constrain.solve_constraints)
    window.close()
    assert build.cancelled and kernels._ours(constrain.solve_constraints)


def test_a_run_begun_in_plain_python_ends_in_the_same_state_as_a_compiled_one():
    from numba.core import event

    from twig_ecs.systems.physics import collide

    with Scene.load("schoolyard") as reference:  # compiled (and so cached) the usual way
        reference.step(45)
        expected = reference.state_hash()
    compiles = []

    class Count(event.Listener):
        def on_start(self, ev) -> None:
            compiles.append(ev.data["dispatcher"].py_func.__name__)

        def on_end(self, ev) -> None:
            pass

    interim = kernels.InterimKernels().start()
    listener = Count()
    event.register("numba:compile", listener)
    try:
        with Scene.load("schoolyard") as scene:
            scene.step(15)  # every kernel as plain Python
            assert not kernels._ours(collide.solve_collisions)
            assert interim.update(every=0.0) >= 10  # the cached ones switch back...
            scene.step(15)  # ...and load on their first call
            assert kernels._ours(collide.solve_collisions)
            interim.finish()
            scene.step(15)
            assert scene.state_hash() == expected
    finally:
        event.unregister("numba:compile", listener)
        interim.finish()
    assert compiles == []  # nothing compiled in this process while the names were swapped


def test_a_cached_start_links_kernels_without_numbas_compiler_set_up_and_compiles_after():
    # numba's cache load first imports and registers everything its compiler knows (~0.2 s of
    # a 1 s start); ours links cached kernels with the runtime only. A kernel compiled later in
    # the same process (a plug-in's, a new signature) must still get the full set-up.
    if kernels.jit_disabled():
        pytest.skip("NUMBA_DISABLE_JIT=1: there are no compiled kernels to load")
    compile_only = ("numba.typed.typedlist", "numba.np.polynomial.polynomial_core",
                    "numba.experimental.jitclass.base", "numba.np.random.generator_methods")  # fmt: skip
    probe = (
        "import sys; from numba.core import event; from twig_ecs import Scene\n"
        "seen = []\n"
        "class L(event.Listener):\n"
        "    def on_start(self, ev): seen.append(ev.data['dispatcher'].py_func.__qualname__)\n"
        "    def on_end(self, ev): pass\n"
        "event.register('numba:compile', L())\n"
        "with Scene.load('schoolyard') as s: s.step(3)\n"
        f"print([m for m in {compile_only!r} if m in sys.modules], seen)\n"
        "import numba, numpy as np\n"
        "@numba.njit\n"
        "def later(n):\n"
        "    items = numba.typed.List(); items.append(1.5); return np.ones(n).sum() + items[0]\n"
        "print(later(3))\n"
    )
    with Scene.load("schoolyard") as scene:  # the kernels are in the cache (the session compiled them)
        scene.step()
    result = run_python("-c", probe)
    assert result.returncode == 0, result.stderr
    first, second = result.stdout.splitlines()
    assert first == "[] []"  # no compiler modules imported, nothing compiled: only linked
    assert float(second) == 4.5  # compiling afterwards works (typed lists need the full set-up)


def test_serve_window_status_line_shows_server_steps_and_wall_clock_fps():
    window_class = _window_class(load_pyglet_window(headless=True))
    from twig_ecs.graphics.app import Viewer

    window = window_class(Viewer("schoolyard"), (320, 180), visible=False)
    try:
        scene = window.viewer.scene
        for _ in range(4):  # as the server does: it steps the scene, the window only draws
            scene.step(2)
            window.viewer.accumulator = 0.0
            window.frame(0.0)
        status = window.viewer.status_text()
        assert "served" in status and "sim  0.00 ms/step" not in status
        fps = float(status.split("fps")[1].split("|")[0])
        assert fps < 1000  # not the 9332 fps of a zero elapsed time
    finally:
        window.close()


def test_inspector_and_long_messages_fit_a_1280_by_720_window():
    from twig_ecs.graphics.app import Viewer

    viewer = Viewer("schoolyard")
    try:
        viewer.show_inspector = True
        viewer.say("reload failed: " + "x.yaml:12: entities[3].character.look_at: unknown entity " * 4)
        panels = {key: image for key, image, _, _ in viewer.panels((1280, 720), 1.0)}
        assert panels["inspector"].size[0] <= 1280 - 20
        assert panels["status"].size[0] <= 1280 - 20
        assert panels["status"].size[1] > text_panel(["one line"]).size[1]  # the message wrapped
    finally:
        viewer.close()


# -- messages a newcomer meets ----------------------------------------------------------------


def test_walk_on_a_passive_body_says_to_spawn_a_character():
    with Scene.load("empty") as scene:
        kid = scene.spawn("humanoid", name="kid")
        with pytest.raises(PassiveBodyError, match=r"spawn\('humanoid', name='kid', character=True\)"):
            kid.walk((0, 0, 1))
        assert not hasattr(kid, "hug")  # still an AttributeError for hasattr
        with pytest.raises(AttributeError, match="no attribute 'nope'"):
            kid.nope  # noqa: B018


def test_bad_seconds_and_unknown_options_get_the_subcommands_words(capsys):
    with pytest.raises(SystemExit):
        main(["run", "schoolyard", "--seconds", "abc"])
    err = capsys.readouterr().err
    assert "expected a number of seconds" in err and "_positive_seconds" not in err
    with pytest.raises(SystemExit):
        main(["run", "--secs", "1"])
    err = capsys.readouterr().err
    assert err.startswith("usage: twig run") and "did you mean --seconds?" in err


def test_help_lists_every_built_in_scene(capsys):
    with pytest.raises(SystemExit):
        main(["play", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert set(builtin_scenes()) >= {"schoolyard", "playground", "crowd", "empty"}
    assert ", ".join(builtin_scenes()) in out


def test_validate_reports_every_error_in_a_file(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "twig: 1\nname: bad\nsettings: {gravity: [0, x, 0]}\nentities:\n"
        "  - {name: a, body: humanod}\n  - {name: b, body: ball, position: [1, 2]}\n"
        "  - {name: c, body: humanoid, character: {look_at: nobody}}\n"
    )
    assert main(["validate", str(bad)]) == 1
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 4 and all(line.startswith("error: ") for line in errors)
    assert any("entities[0].body" in e and "humanoid" in e for e in errors)
    assert any("entities[1].position" in e for e in errors)
    assert any("entities[2].character.look_at" in e for e in errors)
    assert any("settings.gravity" in e for e in errors)


def test_plot_has_a_clear_title_and_y_ticks(tmp_path):
    from PIL import Image

    from twig_ecs.report import run_with_report

    path = tmp_path / "p.png"
    run_with_report("schoolyard", 3.0, plot=str(path))
    image = np.asarray(Image.open(path).convert("RGB")).astype(int)
    dark = image.sum(axis=2) < 400
    title_rows = np.nonzero(dark[:56, 70:700].any(axis=1))[0]
    assert len(title_rows) > 8 and title_rows.max() < 50  # a title, with a gap above the axes
    left_labels = dark[56:460, :62] | (np.abs(image[56:460, :62] - [30, 60, 160]).sum(axis=2) < 120)
    label_rows = np.nonzero(left_labels.any(axis=1))[0]
    clusters = 1 + np.count_nonzero(np.diff(label_rows) > 5)
    assert clusters >= 5  # tick labels down the distance axis


def test_serve_record_on_a_busy_port_fails_clearly_and_writes_nothing(tmp_path, capsys):
    import socket

    replay = tmp_path / "s.replay"
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["serve", "schoolyard", "--port", str(port), "--record", str(replay)]) == 2
    assert f"port {port}" in capsys.readouterr().err
    assert not replay.exists()


# -- the cached start --------------------------------------------------------------------------


def _lines(value):
    """Every line number a parsed document carries, in order."""
    from twig_ecs.yamldoc import YDict, YList

    if isinstance(value, YDict):
        return [(value.file, value.line, value.key_lines)] + [_lines(v) for v in value.values()]
    if isinstance(value, YList):
        return [(value.file, value.line, value.item_lines)] + [_lines(v) for v in value]
    return repr(value)


def test_built_in_content_reads_the_same_with_the_fast_parser_and_only_it_gets_it(tmp_path):
    from twig_ecs import library
    from twig_ecs.yamldoc import parse_yaml

    files = sorted(library.builtin_dir().rglob("*.yaml"))
    assert len(files) >= 5
    for path in files:
        text = path.read_text()
        fast, slow = parse_yaml(text, str(path), trusted_source=True), parse_yaml(text, str(path))
        assert fast == slow and _lines(fast) == _lines(slow), path
    assert library._builtin(files[0])
    mine = tmp_path / "deep.yaml"  # a user's file: the Python parser, which fails cleanly when deep
    mine.write_text("twig: 1\nentities: " + "[" * 5000 + "]" * 5000 + "\n")
    assert not library._builtin(mine)
    with pytest.raises(TwigError, match="nested"):
        library.read_document(mine)


def test_a_compile_in_this_process_raises_the_collectors_thresholds_until_it_ends():
    # the build workers compile at kernelcache.COMPILE_GC_THRESHOLD throughout; a program that
    # compiles in its own process (the Python API's first steps) had the default's full passes
    # over numba's growing heap, a fifth of the compile. Raised while a compile runs, put back after.
    if kernels.jit_disabled():
        pytest.skip("NUMBA_DISABLE_JIT=1: there is nothing to compile")
    import gc

    from numba import njit
    from numba.core import event

    from twig_ecs.kernelcache import COMPILE_GC_THRESHOLD

    seen = []

    class Watch(event.Listener):
        def on_start(self, ev) -> None:
            seen.append(gc.get_threshold())

        def on_end(self, ev) -> None:
            pass

    before = gc.get_threshold()
    watch = Watch()
    event.register("numba:compile", watch)
    try:

        @njit
        def probe(x):
            return x + 1

        assert probe(1) == 2  # compiled now, in this process
    finally:
        event.unregister("numba:compile", watch)
    assert seen and seen[0] == COMPILE_GC_THRESHOLD
    assert gc.get_threshold() == before, "put back when the compile ended"


@pytest.mark.parametrize("numba_first", [False, True])
def test_numba_words_its_compile_errors_without_terminal_colours(numba_first):
    # typing a kernel words an error message for every candidate signature that does not fit;
    # coloured, each message started and stopped colorama's terminal wrapper (100 000 times in a
    # schoolyard compile): a fifth of a first run's compile, for messages nobody reads
    imports = ["import numba.core.errors as errors", "import twig_ecs.kernelmath"]
    worded = "print(repr(errors.termcolor().errmsg('x') + errors.termcolor().code('y')))"
    probe = "; ".join([*(imports if numba_first else imports[::-1]), worded])
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == repr("xy")  # no escape codes round either part


def test_no_code_of_ours_calls_a_kernel_helper_from_python():
    # a helper is compiled without Python's entry point (kernelmath.kernel_helper): called from
    # Python it runs as plain Python, correct but a hundred times slower - a silent slowdown
    # for whoever calls one from a system's Python code. Only kernels may call them.
    import ast

    from twig_ecs.kernelcache import kernel_dirs
    from twig_ecs.kernelmath import HelperKernel

    every_kernel = kernels.InterimKernels().kernels()  # (made, not started: it swaps nothing)
    helpers = {k.py_func.__name__ for k in every_kernel if isinstance(k, HelperKernel)}
    assert {"relax_once", "aim_foot", "project_by_body", "step_length"} <= helpers

    def compiled(function: ast.FunctionDef) -> bool:
        return any(
            ("njit" in ast.unparse(d)) or ("kernel_helper" in ast.unparse(d)) for d in function.decorator_list
        )

    calls = []
    sources = [
        p for folder in {*kernel_dirs(), Path(kernels.__file__).parent} for p in Path(folder).rglob("*.py")
    ]
    for path in sources:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        inside = {
            id(n)
            for f in ast.walk(tree)
            if isinstance(f, ast.FunctionDef) and compiled(f)
            for n in ast.walk(f)
        }
        for node in ast.walk(tree):
            name = (
                node.id
                if isinstance(node, ast.Name)
                else node.attr
                if isinstance(node, ast.Attribute)
                else None
            )
            if (
                name in helpers
                and id(node) not in inside
                and isinstance(getattr(node, "ctx", None), ast.Load)
            ):
                calls.append(f"{path.name}:{node.lineno} {name}")
    assert calls == []
