"""Untrusted files stay data (issue 16, items 3, 9, 10; issue 31): replays, snapshots and scenes run
no code and write nothing outside their temporary folder unless the user passes --trust, and
`twig validate` runs no plug-in code at all."""

from __future__ import annotations

import hashlib
import json
import pickle
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.errors import TwigError
from twig_ecs.replay import ReplayError, replay
from twig_ecs.snapshot import FORMAT_VERSION, MAGIC, SnapshotError
from twig_ecs.trust import is_trusted, trusting

PLUGIN = """
from pathlib import Path
from twig_ecs.system import System
Path({marker!r}).write_text("ran")

class Evil(System):
    def process(self, dt):
        pass
"""


def _scene_text(use: str) -> str:
    return f"twig: 1\nname: lure\nsystems:\n  - use: {use}\nentities:\n  - {{name: b, body: ball}}\n"


# -- what ran: an audit hook (it cannot be removed, so it records only while a test watches) ------------

_RUNS_CODE = ("exec", "compile", "import", "subprocess.Popen", "os.system", "os.exec", "os.posix_spawn",
              "os.spawn", "os.fork", "ctypes.dlopen")  # fmt: skip
_watching: dict[int, list] = {}


def _audit(event: str, args: tuple) -> None:
    seen = _watching.get(threading.get_ident())
    if seen is not None and event in _RUNS_CODE:
        seen.append((event, repr(args)[:120]))


sys.addaudithook(_audit)


class watch_code:  # noqa: N801 - used as `with watch_code() as ran:`
    """Within the block, record every import, exec, compile or process start on this thread."""

    def __enter__(self) -> list:
        self.seen: list = []
        _watching[threading.get_ident()] = self.seen
        return self.seen

    def __exit__(self, *exc: object) -> None:
        _watching.pop(threading.get_ident(), None)


# -- scenes ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("where", ["beside", "parent", "absolute"])
def test_a_scene_runs_no_plugin_file_without_trust_and_validate_runs_none(tmp_path, capsys, where):
    marker = tmp_path / "ran.txt"
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    folder = scenes if where == "beside" else tmp_path
    (folder / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    use = {"beside": "evil.py:Evil", "parent": "../evil.py:Evil", "absolute": f"{tmp_path / 'evil.py'}:Evil"}
    (scenes / "lure.yaml").write_text(_scene_text(use[where]))
    with pytest.raises(TwigError, match="is a plug-in file: Python code.*--trust"):
        Scene.load(scenes / "lure.yaml")
    assert main(["run", str(scenes / "lure.yaml"), "--seconds", "0.1"]) == 2
    assert "--trust" in capsys.readouterr().err
    for trust in ([], ["--trust"]):  # checking is not running, trusted or not
        assert main(["validate", str(scenes / "lure.yaml"), *trust]) == 0
        out = capsys.readouterr().out
        assert "plug-in code not run" in out and ("runs only with --trust" in out) == (not trust)
    assert not marker.exists()
    with Scene.load(scenes / "lure.yaml", trust=True) as scene:  # the user vouches for it
        scene.step(2)
    assert marker.exists()


def test_validate_reads_a_plugin_file_to_check_its_class_without_running_it(tmp_path, capsys):
    marker = tmp_path / "ran.txt"
    (tmp_path / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    (tmp_path / "lure.yaml").write_text(_scene_text("evil.py:Evill"))
    assert main(["validate", str(tmp_path / "lure.yaml"), "--trust"]) == 1
    assert "has no 'Evill' (did you mean 'Evil'?)" in capsys.readouterr().err
    (tmp_path / "lure.yaml").write_text(_scene_text("nowhere.py:Evil"))
    assert main(["validate", str(tmp_path / "lure.yaml")]) == 1
    assert "no such file" in capsys.readouterr().err
    assert not marker.exists()


def test_a_scene_may_not_import_any_module_only_twig_and_installed_plugins(tmp_path, capsys):
    (tmp_path / "lure.yaml").write_text(_scene_text("http.server:HTTPServer"))
    assert main(["validate", str(tmp_path / "lure.yaml")]) == 1
    assert "neither part of twig_ecs nor an installed twig plug-in" in capsys.readouterr().err
    with pytest.raises(TwigError, match="neither part of twig_ecs"):
        Scene.load(tmp_path / "lure.yaml")


_MODULES = ("os", "subprocess", "builtins", "shutil", "importlib", "pickle", "twig_ecs.kernels", "ctypes",
            "twig_ecs.kernelworker", "twig_ecs.replay", "twig_ecs.server", "twig_ecs.trust", "x")  # fmt: skip
_NAMES = ("system", "Popen", "exec", "eval", "rmtree", "import_module", "loads", "KernelBuild", "Recorder",
          "subprocess.Popen", "os.system", "CDLL", "Evil", "__import__")  # fmt: skip


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(module=st.sampled_from(_MODULES) | st.from_regex(r"[a-z_]{1,8}(\.[a-z_]{1,8}){0,2}", fullmatch=True),
       name=st.sampled_from(_NAMES) | st.from_regex(r"[A-Za-z_]{1,10}", fullmatch=True),
       file=st.booleans())  # fmt: skip
def test_fuzz_no_plugin_reference_runs_code_without_trust(tmp_path, module, name, file):
    """Any `use:` - a module and name, or a file beside the scene - runs nothing without --trust."""
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    marker = folder / "ran.txt"
    (folder / "evil.py").write_text(PLUGIN.format(marker=str(marker)).replace("Evil", name))
    use = f"evil.py:{name}" if file else f"{module}:{name}"
    (folder / "lure.yaml").write_text(_scene_text(use))
    assert main(["validate", "empty"]) == 0  # twig's own modules imported before watching
    with watch_code() as ran:
        with pytest.raises(TwigError):
            Scene.load(folder / "lure.yaml")
        assert main(["validate", str(folder / "lure.yaml")]) in (0, 1)
    imported = [args for event, args in ran if event == "import"]
    assert all(args.startswith("('twig_ecs") for args in imported), imported
    assert not [e for e in ran if e[0] not in ("import", "compile")], ran  # compile: validate's ast.parse
    assert not marker.exists()


# -- item 3: replays -----------------------------------------------------------------------------------


def _replay_file(tmp_path: Path, scene_text: str, content: dict[str, str]) -> Path:
    header = {"twig_replay": 1, "scene": "lure", "seed": 0, "content": ["elsewhere"], "autonomous": True,
              "files": {"scene": {"path": "/nowhere/lure.yaml", "text": scene_text},
                        "content": {"elsewhere": content}}}  # fmt: skip
    path = tmp_path / "session.twigreplay"
    path.write_text(json.dumps(header) + "\n" + json.dumps({"end": 10, "state_hash": "x"}) + "\n")
    return path


def test_a_replay_writes_nothing_outside_its_folder_and_runs_no_plugin(tmp_path, capsys):
    marker = tmp_path / "ran.txt"
    outside = tmp_path / "outside.yaml"
    plain = "twig: 1\nname: lure\nentities:\n  - {name: b, body: ball}\n"
    evil = {"../evil.py": PLUGIN.format(marker=str(marker))}
    with pytest.raises(ReplayError, match="outside its folder"):
        replay(_replay_file(tmp_path, _scene_text("evil.py:Evil"), evil))
    with pytest.raises(ReplayError, match="outside its folder"):
        replay(_replay_file(tmp_path, plain, {str(outside): "x: 1\n"}))
    with pytest.raises(ReplayError, match="only .yaml"):
        replay(_replay_file(tmp_path, plain, {"evil.py": "x = 1\n"}))
    assert not marker.exists() and not outside.exists()
    (tmp_path / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    use = f"{tmp_path / 'evil.py'}:Evil"
    assert main(["run", "--replay", str(_replay_file(tmp_path, _scene_text(use), {}))]) == 2
    assert "inside a replay may not run plug-in files" in capsys.readouterr().err
    assert not marker.exists()


def test_a_replay_with_bad_field_types_or_huge_frames_gets_a_clear_error(tmp_path):
    path = tmp_path / "r.twigreplay"
    cases = [
        ({"twig_replay": 1, "scene": "empty", "seed": "zero"}, [], "'seed' has the wrong type"),
        ({"twig_replay": 1, "scene": 5}, [], "'scene' has the wrong type"),
        ({"twig_replay": 1, "scene": "empty"}, [{"frame": 10**30, "method": "ping"}], "not a command record"),
        ({"twig_replay": 1, "scene": "empty"}, [{"frame": 1, "method": ["x"]}], "not a command record"),
        ({"twig_replay": 1, "scene": "empty"}, [{"end": 10**30, "state_hash": "x"}], "'end' must be"),
    ]
    for header, rest, says in cases:
        path.write_text("\n".join(json.dumps(x) for x in [header, *rest]) + "\n")
        with pytest.raises(ReplayError, match=says):
            replay(path)


# -- snapshots ---------------------------------------------------------------------------------------


def _rebuild(payload: bytes, meta: dict) -> bytes:
    """A well-formed snapshot file (right checksum) around any payload: what an attacker can write."""
    meta_bytes = json.dumps(meta).encode()
    body = struct.pack(">8sHI", MAGIC, FORMAT_VERSION, len(meta_bytes)) + meta_bytes
    body += struct.pack(">Q", len(payload)) + payload
    return body + hashlib.sha256(body).digest()


def _crafted(structure, blob: bytes = b"", plugins: list | None = None) -> bytes:
    """A snapshot whose object graph is ``structure`` (worlddata's JSON form), checksum and all."""
    text = json.dumps(structure).encode()
    return _rebuild(struct.pack(">Q", len(text)) + text + blob, {"plugins": plugins or [], "state_hash": "x"})


class _Call:
    """Pickles as a call of ``fn(*args)`` (how a pickle runs code while being read)."""

    def __init__(self, fn, *args) -> None:
        self.fn, self.args = fn, args

    def __reduce__(self):
        return self.fn, self.args


def _object(name: str, attrs: dict | None = None, ident: int = 0) -> list:
    return ["o", ident, name, attrs or {}, None]


def test_a_snapshot_cannot_build_objects_that_run_programs_or_write_files(tmp_path):
    marker = str(tmp_path / "written")
    touch = ["l", 1, ["touch", marker]]
    attacks = [
        pickle.dumps((_Call(subprocess.Popen, ["touch", marker]), {})),  # the old format: a pickle
        _object("twig_ecs.kernels:subprocess.Popen", {"args": touch}),  # a dotted name through a twig module
        _object("subprocess:Popen", {"args": touch}),
        ["T", "twig_ecs.kernels:KernelBuild"],  # builds compile workers that load a scene
        _object("twig_ecs.kernels:KernelBuild", {"scene": marker}),
        _object("twig_ecs.replay:Recorder", {"path": ["p", marker]}),
        _object("numpy:memmap", {"filename": marker}),
        _object("builtins:eval"),
        ["k", "os", "system"],
        ["m", _object("twig_ecs.scene:Scene"), "__init__"],
        ["m", _object("twig_ecs.store:PhysicsState"), "__class__"],
        ["l", 0, [_object("twig_ecs.scene:Scene", {"__class__": ["T", "twig_ecs.kernels:KernelBuild"]}, 1)]],
    ]
    for attack in attacks:
        data = (
            _rebuild(attack, {"plugins": [], "state_hash": "x"})
            if isinstance(attack, bytes)
            else _crafted(attack)
        )
        with watch_code() as ran, pytest.raises(SnapshotError, match="snapshot (unreadable|corrupt)"):
            Scene.restore(data)
        assert ran == [], ran
    with pytest.raises(SnapshotError, match="snapshots are data"):
        Scene.restore(_crafted(_object("subprocess:Popen"), plugins=[{"module": "subprocess", "file": None}]))
    assert not Path(marker).exists()


def test_a_snapshot_naming_a_plugin_file_needs_trust(tmp_path):
    marker = tmp_path / "ran.txt"
    (tmp_path / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    data = _crafted(
        ["d", 0, []], plugins=[{"module": "twig_plugin_evil_x", "file": str(tmp_path / "evil.py")}]
    )
    with pytest.raises(SnapshotError, match="--trust"):
        Scene.restore(data)
    assert not marker.exists()
    with trusting(), pytest.raises(SnapshotError, match="does not hold a scene"):
        Scene.restore(data)  # trusted: the plug-in is imported (and the junk payload refused)
    assert marker.exists()


@pytest.fixture(scope="module")
def real_structure() -> str:
    """The JSON structure of a real snapshot (the schoolyard, mid-story): mutations start from it."""
    with Scene.load("schoolyard", seed=0) as scene:
        scene.run(0.5)
        data = scene.snapshot()
    meta_len = struct.unpack_from(">I", data, 10)[0]
    at = 14 + meta_len + 8
    (length,) = struct.unpack_from(">Q", data, at)
    return data[at + 8 : at + 8 + length].decode()


@pytest.fixture(scope="module")
def real_tree(real_structure) -> tuple[list, list]:
    """``real_structure`` decoded, and its :func:`_slots`: decoded and walked once, not once an
    example (0.1 s each). An example swaps one node in and puts it back after (see below)."""
    tree = json.loads(real_structure)
    return tree, _slots(tree, [])


def _slots(tree, out: list) -> list:
    """Every place in a decoded structure that holds a tagged node, as (container, key)."""
    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for key, value in items:
        if isinstance(value, list) and value and isinstance(value[0], str):
            out.append((tree, key))
        if isinstance(value, list | dict):
            _slots(value, out)
    return out


_DANGEROUS = [f"{m}:{n}" for m in _MODULES for n in _NAMES] + [
    "twig_ecs.kernels:subprocess.Popen", "twig_ecs.snapshot:importlib.import_module", "numpy:memmap",
    "numpy:load", "builtins:exec"]  # fmt: skip


@settings(max_examples=80, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(pick=st.integers(0, 10**6), name=st.sampled_from(_DANGEROUS), tag=st.sampled_from("oTkm"))
def test_fuzz_a_crafted_snapshot_runs_nothing(real_tree, pick, name, tag):
    """A real snapshot with one node swapped for any class, kernel or method by name builds nothing."""
    module, _, attr = name.partition(":")
    tree, slots = real_tree
    container, key = slots[pick % len(slots)]
    old = container[key]
    container[key] = {
        "o": ["o", 10**9, name, old[3] if old[0] == "o" else {}, None],  # an object's class swapped
        "T": ["T", name],
        "k": ["k", module, attr],
        "m": ["m", ["r", 0], attr],  # a method of the root list, or of whatever comes first
    }[tag]
    try:
        crafted = _crafted(tree)
    finally:  # the shared tree is the real snapshot's again for the next example
        container[key] = old
    with watch_code() as ran:
        with pytest.raises(SnapshotError):
            Scene.restore(crafted)
    assert ran == [], ran


def test_the_windows_loading_threads_trust_as_the_command_does():
    # before: `twig play SCENE --trust` with a plug-in file failed on every first run ("run
    # again with --trust"): the window loads the scene on a thread while the kernels compile,
    # and a new thread started from a blank context, untrusted
    import threading

    from twig_ecs.trust import thread_trusting_as_now

    def seen_from(make) -> bool:
        seen = []
        thread = make(lambda: seen.append(is_trusted()))
        thread.start()
        thread.join()
        return seen[0]

    with trusting(True):
        assert seen_from(lambda f: thread_trusting_as_now(f, name="t"))
        assert not seen_from(lambda f: threading.Thread(target=f)), "(a plain thread: why it failed)"
    with trusting(False):
        assert not seen_from(lambda f: thread_trusting_as_now(f, name="t"))
