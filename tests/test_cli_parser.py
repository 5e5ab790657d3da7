"""``twig_ecs.cli.main`` builds its argument parser once a process (2.7 ms a call, most of an
in-process ``twig validate``), and each call still parses only its own arguments."""

from __future__ import annotations

from twig_ecs import cli


def test_main_builds_its_parser_once_and_calls_do_not_share_arguments(monkeypatch, tmp_path, capsys):
    built = []
    real = cli.build_parser
    monkeypatch.setattr(cli, "build_parser", lambda: built.append(1) or real())
    cli._parser.cache_clear()
    (tmp_path / "mine.yaml").write_text("twig: 1\nentities: []\n")
    assert cli.main(["validate", "--content", str(tmp_path), "mine"]) == 0
    assert cli.main(["validate", "mine"]) == 1, "the --content of the call before is not this one's"
    assert cli.main(["validate", "--content", str(tmp_path), "mine", "empty"]) == 0
    out, err = capsys.readouterr()
    assert "unknown scene 'mine'" in err and out.count("ok: ") == 3
    assert len(built) == 1
