"""The Python examples in the README, ARCHITECTURE.md and docs/ run as written.

Each file's ```python blocks run in order in one namespace (a later block may use what
an earlier one made, as a reader would). Blocks that talk to a server get one: the
schoolyard served on an ephemeral port, which is put in place of the documented 7470.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import types
from pathlib import Path

import pytest
from server_helpers import running_server

from twig_ecs.scene import open_scenes

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"```python\n(.*?)```", re.S)


def snippets(path: Path) -> list[tuple[int, str]]:
    """(line, code) of every ```python block in a Markdown file."""
    text = path.read_text(encoding="utf-8")
    return [(text[: m.start()].count("\n") + 2, m.group(1)) for m in BLOCK.finditer(text)]


DOCS_WITH_SNIPPETS = [p for p in DOCS if snippets(p)]


def test_the_readme_and_the_guides_have_python_examples():
    names = {p.name for p in DOCS_WITH_SNIPPETS}
    assert {"README.md", "ARCHITECTURE.md", "authoring-behaviours.md", "characters.md", "server.md"} <= names


@pytest.mark.slow  # the README and server.md ones wait for hugs in real time
@pytest.mark.parametrize("doc", DOCS_WITH_SNIPPETS, ids=lambda p: p.name)
def test_python_snippets_run_as_written(doc, capsys):
    module = types.ModuleType("docs_snippet")  # a real module: dataclasses look their own up
    sys.modules[module.__name__] = module
    namespace = module.__dict__
    before = set(open_scenes())
    try:
        for line, code in snippets(doc):
            if "twig_ecs.client" in code:
                with running_server("schoolyard") as server:
                    code = code.replace("Client()", f"Client(port={server.port})")
                    code = code.replace("7470", str(server.port))
                    exec(compile(code, f"{doc.name}:{line}", "exec"), namespace)
            else:
                exec(compile(code, f"{doc.name}:{line}", "exec"), namespace)
    finally:
        del sys.modules[module.__name__]
        for scene in open_scenes():  # every scene the snippets made, those a later one replaced too
            if scene not in before:
                scene.close()
    out = capsys.readouterr().out
    if doc.name == "README.md":
        assert "hug done" in out  # the hug example ends within the time it runs
        assert "goal.done" in out or "'goal':" in out  # the client's hug came back
    if doc.name == "server.md":
        assert "goal.done" in out or "goal.failed" in out


_TWIG = r"twig (?:play|render|run|validate) "
COMMAND = re.compile(rf"`({_TWIG}[^`]+)`|^({_TWIG}.+?)(?:  +#.*)?$", re.M)


def commands_on_repo_files() -> list[str]:
    """The docs' ``twig play/render/run/validate`` commands whose scene is a file in this
    repository (``examples/dance/scene.yaml``): a reader runs them as written, from here."""
    found = []
    for doc in DOCS:
        for inline, fenced in COMMAND.findall(doc.read_text(encoding="utf-8")):
            command = (inline or fenced).strip()
            words = shlex.split(command)
            if len(words) > 2 and (ROOT / words[2]).is_file() and command not in found:
                found.append(command)
    return found


@pytest.mark.parametrize("command", commands_on_repo_files())
def test_commands_on_the_repositorys_examples_run_as_written(command, tmp_path):
    argv = shlex.split(command)[1:]
    if argv[0] == "play":  # a window: drawn headless, for a few frames
        argv += ["--headless", "--frames", "5", "--screenshot-dir", str(tmp_path)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "twig_ecs", *argv], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr


def test_the_dance_example_is_among_the_commands_run():
    assert "twig play examples/dance/scene.yaml --trust" in commands_on_repo_files()
