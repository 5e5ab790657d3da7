"""Untrusted files stay data (issue 16, items 3, 9, 10): replays, snapshots and scenes run no code
and write nothing outside their temporary folder unless the user passes --trust."""

from __future__ import annotations

import hashlib
import json
import pickle
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.errors import TwigError
from twig_ecs.replay import Recorder, ReplayError, replay
from twig_ecs.snapshot import FORMAT_VERSION, MAGIC, SnapshotError
from twig_ecs.trust import trusting

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


# -- item 10: scenes ---------------------------------------------------------------------------------


@pytest.mark.parametrize("where", ["parent", "absolute"])
def test_a_scene_may_not_run_a_plugin_file_outside_its_folder(tmp_path, capsys, where):
    marker = tmp_path / "ran.txt"
    (tmp_path / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    use = "../evil.py:Evil" if where == "parent" else f"{tmp_path / 'evil.py'}:Evil"
    (scenes / "lure.yaml").write_text(_scene_text(use))
    assert main(["validate", str(scenes / "lure.yaml")]) == 1
    err = capsys.readouterr().err
    assert "inside the scene's folder" in err and "--trust" in err
    with pytest.raises(TwigError, match="inside the scene's folder"):
        Scene.load(scenes / "lure.yaml")
    assert not marker.exists()
    assert main(["validate", str(scenes / "lure.yaml"), "--trust"]) == 0  # the user vouches for it
    assert marker.exists()


def test_a_scene_may_not_import_any_module_only_twig_and_installed_plugins(tmp_path, capsys):
    (tmp_path / "lure.yaml").write_text(_scene_text("http.server:HTTPServer"))
    assert main(["validate", str(tmp_path / "lure.yaml")]) == 1
    assert "neither part of twig_ecs nor an installed twig plug-in" in capsys.readouterr().err


def test_a_plugin_file_beside_the_scene_still_loads(tmp_path):
    marker = tmp_path / "ran.txt"
    (tmp_path / "good.py").write_text(PLUGIN.format(marker=str(marker)).replace("Evil", "Good"))
    (tmp_path / "lure.yaml").write_text(_scene_text("good.py:Good"))
    with Scene.load(tmp_path / "lure.yaml") as scene:
        scene.step(2)
    assert marker.exists()


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


# -- item 9: snapshots ---------------------------------------------------------------------------------


def _rebuild(payload: bytes, meta: dict) -> bytes:
    """A well-formed snapshot file (right checksum) around any payload: what an attacker can write."""
    meta_bytes = json.dumps(meta).encode()
    body = struct.pack(">8sHI", MAGIC, FORMAT_VERSION, len(meta_bytes)) + meta_bytes
    body += struct.pack(">Q", len(payload)) + payload
    return body + hashlib.sha256(body).digest()


class _Call:
    """Pickles as a call of ``fn(*args)`` (how a hostile snapshot runs code while being read)."""

    def __init__(self, fn, *args) -> None:
        self.fn, self.args = fn, args

    def __reduce__(self):
        return self.fn, self.args


def test_a_snapshot_cannot_build_objects_that_run_programs_or_write_files(tmp_path):
    marker = tmp_path / "written"
    attacks = [
        (_Call(subprocess.Popen, ["touch", str(marker)]), [{"module": "subprocess", "file": None}]),
        (_Call(np.memmap, str(marker), "uint8", "w+", 0, (16,)), []),
        (_Call(Recorder, str(marker), "empty", 0), []),
    ]
    for attack, plugins in attacks:
        data = _rebuild(pickle.dumps((attack, {})), {"plugins": plugins, "state_hash": "x"})
        with pytest.raises(SnapshotError, match="may not load|snapshots are data"):
            Scene.restore(data)
    assert not marker.exists()


def test_a_snapshot_naming_a_plugin_file_needs_trust(tmp_path):
    marker = tmp_path / "ran.txt"
    (tmp_path / "evil.py").write_text(PLUGIN.format(marker=str(marker)))
    data = _rebuild(pickle.dumps(({}, {})), {"plugins": [{"module": "twig_plugin_evil_x",
                                                          "file": str(tmp_path / "evil.py")}]})  # fmt: skip
    with pytest.raises(SnapshotError, match="--trust"):
        Scene.restore(data)
    assert not marker.exists()
    with trusting(), pytest.raises(SnapshotError, match="does not hold a scene"):
        Scene.restore(data)  # trusted: the plug-in is imported (and the junk payload refused)
    assert marker.exists()
