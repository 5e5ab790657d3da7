"""The goal tables of the docs, made from the goal schemas: ``python -m twig_ecs.goaldocs``.

docs/characters.md lists each goal as a Python call, docs/server.md as an RPC method;
both tables are written here from the same :class:`~twig_ecs.goals.GoalSchema` s that make
the methods, between marker comments in the Markdown. ``--check`` exits 1 when a committed
file differs from what the schemas make (the test suite runs that check).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from pathlib import Path

from twig_ecs.arguments import Param
from twig_ecs.goals import GoalSchema
from twig_ecs.plugins import builtin_goal_schemas

#: The marker comments round a generated table in a Markdown file.
BEGIN = "<!-- {name}: generated from the goal schemas by `python -m twig_ecs.goaldocs`; edit those -->"
END = "<!-- end of {name} -->"


def _value(value, python: bool = False) -> str:
    """A default as the reader writes it: Python (None, True) or JSON (null, true)."""
    if value is None:
        return "None" if python else "null"
    if isinstance(value, bool):
        return str(value) if python else str(value).lower()
    if isinstance(value, float) and value.is_integer() and not python:
        return f"{value:g}"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def _what(p: Param) -> str:
    """A parameter's kind in a few words: ``m, 0-1000``, ``left or right``, ``name or point``."""
    if p.kind == "choice":
        return " or ".join(f"`{c}`" for c in p.choices)
    if p.kind == "number":
        return f"{p.unit + ', ' if p.unit else ''}{p.low:g}-{p.high:g}"
    if p.kind == "name":
        return "a character or ragdoll" if p.figure else "an entity name"
    words = {"target": "name or point", "vector": "[x, y, z] or [x, z]", "bool": "yes/no"}
    return words.get(p.kind, p.kind)


def _params(schema: GoalSchema, python: bool = False) -> str:
    """Each parameter with what it takes, its default and its one-line doc."""
    out = []
    for p in schema.params:
        default = "" if p.required else f"; default {_value(p.default, python)}"
        out.append(f"`{p.name}` ({_what(p)}{default}): {p.doc}")
    return "; ".join(out) if out else "no parameters"


def python_table(schemas: list[GoalSchema]) -> str:
    """The Python goal calls: ``ann.drag(...)``, or ``do("sit", ...)`` where the name is a control."""
    rows = ["| call | what it does; its parameters |", "|---|---|"]
    for s in schemas:
        args = ", ".join(p.name if p.required else f"{p.name}={_value(p.default, True)}" for p in s.params)
        call = f"{s.name}({args})" if s.handle_method else f'do("{s.name}"{", " if args else ""}{args})'
        rows.append(f"| `{call}` | {s.doc} {_params(s, python=True)} |")
    return "\n".join(rows)


def rpc_table(schemas: list[GoalSchema]) -> str:
    """The server's goal methods: ``character``, then the schema's parameters in order."""
    rows = ["| method | what it does; params after `character`, in order |", "|---|---|"]
    for s in schemas:
        rows.append(f"| `{s.name}` | {s.doc} {_params(s)} |")
    return "\n".join(rows)


#: The generated tables: file (relative to the repository) -> (marker name, table maker).
TABLES: dict[str, tuple[str, Callable[[list[GoalSchema]], str]]] = {
    "docs/characters.md": ("goal-calls", python_table),
    "docs/server.md": ("goal-methods", rpc_table),
}


def render(text: str, name: str, table: str, where: str = "") -> str:
    """``text`` with the block between ``name``'s markers replaced by ``table``."""
    begin, end = BEGIN.format(name=name), END.format(name=name)
    pattern = re.compile(re.escape(begin) + r"\n.*?" + re.escape(end), re.S)
    if not pattern.search(text):
        raise ValueError(f"{where or 'the text'} has no '{name}' markers: add\n{begin}\n{end}")
    return pattern.sub(lambda m: f"{begin}\n{table}\n{end}", text, count=1)


def stale(root: Path, schemas: list[GoalSchema] | None = None) -> dict[str, str]:
    """{file: what it should hold} for each doc whose goal table differs from the schemas."""
    schemas = builtin_goal_schemas() if schemas is None else schemas
    out = {}
    for rel, (name, maker) in TABLES.items():
        path = root / rel
        text = path.read_text(encoding="utf-8")
        fresh = render(text, name, maker(schemas), rel)
        if fresh != text:
            out[rel] = fresh
    return out


def main(argv: list[str] | None = None) -> int:
    """Rewrite the goal tables (or, with ``--check``, report the stale ones and exit 1)."""
    parser = argparse.ArgumentParser(prog="python -m twig_ecs.goaldocs", description=__doc__.split("\n")[0])
    parser.add_argument("--root", type=Path, default=Path.cwd(), help="the repository (default: here)")
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a table is stale")
    args = parser.parse_args(argv)
    changed = stale(args.root)
    for rel, text in changed.items():
        if args.check:
            print(f"{rel}: the goal table differs from the schemas (run python -m twig_ecs.goaldocs)")
        else:
            (args.root / rel).write_text(text, encoding="utf-8")
            print(f"{rel}: goal table rewritten")
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
