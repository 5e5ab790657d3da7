"""The content library (twig_ecs/library.py): the built-in body files are parsed once a process,
not once a library - every scene loaded makes a library - and again only when one changes."""

from __future__ import annotations

import shutil

from twig_ecs import library
from twig_ecs.library import ContentLibrary, builtin_dir


def count_parses(monkeypatch) -> list[str]:
    """The files parse_yaml is asked to parse from now on, in order."""
    parsed: list[str] = []
    real = library.parse_yaml

    def counting(source, where, **kw):
        parsed.append(where)
        return real(source, where, **kw)

    monkeypatch.setattr(library, "parse_yaml", counting)
    return parsed


def test_a_second_library_parses_no_built_in_body_file_again(monkeypatch):
    ContentLibrary()
    parsed = count_parses(monkeypatch)
    second = ContentLibrary()
    assert parsed == []
    assert {"humanoid", "ball", "fence"} <= set(second.template_names)
    assert second.template("humanoid").node_names == ContentLibrary().template("humanoid").node_names


def test_a_changed_built_in_file_is_parsed_again(monkeypatch, tmp_path):
    content = tmp_path / "content"
    shutil.copytree(builtin_dir(), content, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(library, "builtin_dir", lambda: content)
    monkeypatch.setattr(library, "_BUILTIN", None)
    ContentLibrary()
    parsed = count_parses(monkeypatch)
    ball = content / "bodies" / "ball.yaml"
    ball.write_text(ball.read_text().replace("template: ball", "template: beach_ball"))
    changed = ContentLibrary()
    assert parsed == [str(ball)]
    assert changed.has_template("beach_ball") and not changed.has_template("ball")
