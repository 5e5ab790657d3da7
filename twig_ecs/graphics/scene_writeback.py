"""Writing tuned behaviour parameters back into a scene file, keeping its layout and comments.

The inspector's sliders change a character's behaviour components while the scene runs;
:func:`write_parameters` puts the values into the scene's YAML, in the entity's
``behaviors:`` item of that behaviour (``- {use: play, joy: 0.55}`` or a block mapping).
Only the numbers change: the file is edited line by line where the YAML parser says each
key stands (:mod:`twig_ecs.yamldoc`), so comments and order survive. A key the item does
not have yet is added to it.
"""

from __future__ import annotations

import re
from pathlib import Path

from twig_ecs.errors import TwigError
from twig_ecs.yamldoc import parse_yaml


class WriteBackError(TwigError):
    """The scene file cannot take the values (no such entity or behaviour item, not a file)."""


def _number(value: float) -> str:
    return f"{value:.6g}"


def _behaviour_item(doc, entity: str, behaviour: str, path: Path):
    entities = doc.get("entities") if isinstance(doc, dict) else None
    for item in entities or ():
        if isinstance(item, dict) and item.get("name") == entity:
            for behaviour_item in item.get("behaviors") or ():
                if isinstance(behaviour_item, dict) and behaviour_item.get("use") == behaviour:
                    return behaviour_item
            raise WriteBackError(f"{path}: entity '{entity}' has no '{behaviour}' item to write into")
    raise WriteBackError(f"{path}: no entity '{entity}' in its entities list")


def write_parameters(path: str | Path, values: dict[tuple[str, str, str], float]) -> int:
    """Set ``{(entity, behaviour, parameter): value}`` in the scene file at ``path``; returns lines changed.

    Raises :class:`WriteBackError` (and leaves the file as it was) when one cannot be placed.
    """
    path = Path(path)
    if not path.is_file():
        raise WriteBackError(f"cannot write parameters to '{path}': not a scene file on disk "
                             "(a built-in scene: copy its YAML and play the copy)")  # fmt: skip
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    doc = parse_yaml(text, str(path))
    inserts: dict[int, list[str]] = {}
    changed = 0
    for (entity, behaviour, key), value in values.items():
        item = _behaviour_item(doc, entity, behaviour, path)
        number = _number(float(value))
        if key in item:
            row = item.where(key)[1] - 1
            pattern = re.compile(rf"(\b{re.escape(key)}\s*:\s*)([-+.\w]+)")
            new, count = pattern.subn(lambda m, n=number: m.group(1) + n, lines[row], count=1)
            if count != 1:
                raise WriteBackError(f"{path}:{row + 1}: cannot find '{key}:' with a number on this line")
            lines[row] = new
        else:
            row = item.where("use")[1] - 1
            line = lines[row]
            closing = line.rfind("}")
            if closing > line.find("{") >= 0:  # a flow mapping on one line: add before its brace
                lines[row] = f"{line[:closing].rstrip()}, {key}: {number}{line[closing:]}"
            else:  # a block mapping: a line under 'use:', at its indentation
                indent = len(line) - len(line.lstrip(" -"))  # past a leading '- ' too
                inserts.setdefault(row, []).append(" " * indent + f"{key}: {number}\n")
        changed += 1
    out = []
    for k, line in enumerate(lines):
        out.append(line)
        out.extend(inserts.get(k, ()))
    new_text = "".join(out)
    parse_yaml(new_text, str(path))  # still valid YAML, or nothing is written
    path.write_text(new_text, encoding="utf-8")
    return changed
