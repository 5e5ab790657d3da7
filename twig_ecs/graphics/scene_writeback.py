"""Writing tuned behaviour parameters back into a scene file: by path, or not at all.

The inspector's sliders change a character's behaviour components while the scene runs;
:func:`write_parameters` puts the values into the scene's YAML. Each value's place is
found in the document's node tree (:func:`twig_ecs.yamldoc.compose_yaml`) by its path:
the ``entities:`` item named after the character, its ``behaviors:`` item whose ``use:``
is the behaviour, and the key. Only the characters of that number change (the parser's
marks say where it starts and ends); a key the item lacks is added right after its
``use:`` value (``{use: play, joy: 0.6, toy: ball}``, or a line under ``use: play`` at
its indentation). Every other character of the file stays as written: comments, layout,
quotes, line endings.

A value that cannot be placed so is refused, with what and why, and nothing is written:
a formula of the scene's parameters (``$(pace * 2)``), a value or item shared through an
anchor, one copy of a ``repeat:`` entity, an entity or behaviour the file does not have.

The edited text is checked before it replaces the file: it reads as the old document with
exactly these values changed, the scene loads from it, and each behaviour reads back the
value asked. Only then does it take the file's place, in one rename (a temporary file
beside it, with the file's permissions); if a check fails the file is untouched.

Why not a round-trip YAML library (ruamel.yaml, MIT): it writes the whole document out
again, which re-indents lists, moves comment columns and respaces flow lists elsewhere in
the file, and it reads YAML 1.2 where the scene loader reads PyYAML's YAML 1.1, so what it
wrote could read differently when loaded. Marks from the loader's own parser have neither
problem and add no dependency.
"""

from __future__ import annotations

import math
import os
import re
import stat
import tempfile
from dataclasses import dataclass
from pathlib import Path

import yaml

from twig_ecs.errors import TwigError
from twig_ecs.library import ContentLibrary
from twig_ecs.scenefile import read_scene
from twig_ecs.yamldoc import compose_yaml, parse_yaml

#: A parameter's place: (entity name, behaviour name, key in its ``behaviors:`` item).
Key = tuple[str, str, str]

_STR = "tag:yaml.org,2002:str"
_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
#: After a value in block style, the rest of its line may hold only a comment.
_REST_OF_LINE = re.compile(r"[ \t]*(#.*)?\r?")
#: The spaces between a value and a comment on its line.
_GAP_BEFORE_COMMENT = re.compile(r" +(?=#)")


class WriteBackError(TwigError):
    """Values not written into a scene file, which is left as it was; ``reason`` says why."""

    def __init__(self, file: str | Path, reason: str) -> None:
        self.file = str(file)
        self.reason = reason
        super().__init__(f"{file}: not written (the file is unchanged): {reason}")


class _Refused(Exception):
    """One value that cannot be placed; the message says why, for a person."""


def format_number(value: float) -> str:
    """The shortest decimal that YAML reads back as exactly ``value`` (``2.5``, ``0``, ``1e-05``)."""
    for digits in range(1, 18):
        text = f"{value:.{digits}g}"
        if float(text) == value:
            return text
    return repr(value)


def _entry(mapping: yaml.Node, key: str) -> tuple[yaml.Node, yaml.Node] | None:
    """The (key node, value node) of ``key`` in a mapping node; None if absent or not a mapping."""
    if not isinstance(mapping, yaml.MappingNode):
        return None
    for key_node, value_node in mapping.value:
        if isinstance(key_node, yaml.ScalarNode) and key_node.tag == _STR and key_node.value == key:
            return key_node, value_node
    return None


def _text(mapping: yaml.Node, key: str) -> str | None:
    """The string value of ``key`` in a mapping node, or None."""
    found = _entry(mapping, key)
    if found is None or not isinstance(found[1], yaml.ScalarNode) or found[1].tag != _STR:
        return None
    return found[1].value


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1


def _occurrences(root: yaml.Node | None) -> dict[int, int]:
    """How many places in the document each node stands in (an alias is its anchor's node)."""
    counts: dict[int, int] = {}
    stack = [root] if root is not None else []
    while stack:
        node = stack.pop()
        counts[id(node)] = counts.get(id(node), 0) + 1
        if counts[id(node)] > 1:
            continue  # its children were counted the first time
        if isinstance(node, yaml.MappingNode):
            stack.extend(n for pair in node.value for n in pair)
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
    return counts


@dataclass
class _Edit:
    """Replace ``text[start:end]`` with ``new``."""

    start: int
    end: int
    new: str


class _Document:
    """A scene file's text and node tree, and the edits that set parameter values in it."""

    def __init__(self, text: str, file: str) -> None:
        self.text = text
        self.root = compose_yaml(text, file)
        self.uses = _occurrences(self.root)
        self.edits: list[_Edit] = []
        self.added: dict[int, _Edit] = {}  # new keys, one insertion per behaviour item (by id)

    def _unshared(self, node: yaml.Node, what: str) -> None:
        places = self.uses.get(id(node), 0)
        if places > 1:
            raise _Refused(f"{what} (line {_line(node)}) is an anchor used in {places} places: a value there "
                           "would change all of them; edit the file by hand")  # fmt: skip

    def _entity(self, name: str) -> yaml.MappingNode:
        found = _entry(self.root, "entities")
        if found is None or not isinstance(found[1], yaml.SequenceNode):
            raise _Refused("the file has no entities: list")
        entities = [item for item in found[1].value if isinstance(item, yaml.MappingNode)]
        for item in entities:
            if _text(item, "name") == name and _entry(item, "repeat") is None:
                self._unshared(item, f"entity '{name}'")
                return item
        for item in entities:
            base = _text(item, "name")
            if base and _entry(item, "repeat") and name.startswith(base) and name[len(base) :].isdigit():
                count = _entry(_entry(item, "repeat")[1], "count")
                copies = f"the {count[1].value} copies" if count else "the copies"
                raise _Refused(f"'{name}' is one of {copies} that repeat: makes of '{base}' "
                               f"(line {_line(item)}): a value there changes every copy; "
                               "edit the file by hand")  # fmt: skip
        raise _Refused(f"no entity '{name}' in the file's entities: list (added while playing?)")

    def _item(self, entity: str, behaviour: str) -> yaml.MappingNode:
        """The ``behaviors:`` item of ``entity`` whose ``use:`` is ``behaviour``."""
        owner = self._entity(entity)
        found = _entry(owner, "behaviors")
        if found is None or not isinstance(found[1], yaml.SequenceNode):
            raise _Refused(f"entity '{entity}' (line {_line(owner)}) has no behaviors: list")
        self._unshared(found[1], f"the behaviors: list of '{entity}'")
        items = [item for item in found[1].value if _text(item, "use") == behaviour]
        if not items:
            raise _Refused(f"entity '{entity}' has no '{behaviour}' item in its behaviors: list "
                           f"(line {_line(found[1])})")  # fmt: skip
        if len(items) > 1:
            lines = ", ".join(str(_line(item)) for item in items)
            raise _Refused(f"entity '{entity}' has {len(items)} '{behaviour}' items (lines {lines}): "
                           "which one is meant is unclear; edit the file by hand")  # fmt: skip
        self._unshared(items[0], f"its '{behaviour}' item")
        return items[0]

    def set(self, key: Key, value: float) -> None:
        """Plan the edit that sets one value; raises :class:`_Refused` when it cannot be placed."""
        entity, behaviour, name = key
        if not math.isfinite(value):
            raise _Refused(f"{value} is not a finite number")
        item = self._item(entity, behaviour)
        number = format_number(value)
        found = _entry(item, name)
        if found is not None:
            self._replace(found[1], number)
        else:
            self._add(item, name, number)

    def _replace(self, node: yaml.Node, number: str) -> None:
        """Put ``number`` where the scalar ``node`` stands, keeping a comment after it in its column."""
        self._unshared(node, "its value")
        if not isinstance(node, yaml.ScalarNode):
            raise _Refused(f"its value (line {_line(node)}) is a list or a mapping, not a number")
        if node.tag == _STR and node.value.startswith("$"):
            raise _Refused(f"'{node.value}' is a formula of the scene's parameters: change the parameter "
                           "or the formula by hand")  # fmt: skip
        start, end = node.start_mark.index, node.end_mark.index
        if node.tag not in _NUMBER_TAGS or node.style is not None or self.text[start:end] != node.value:
            raise _Refused(f"its value {self.text[start:end]!r} (line {_line(node)}) is not a plain number "
                           "(quoted, tagged or anchored); edit it by hand")  # fmt: skip
        spaces = _GAP_BEFORE_COMMENT.match(self.text, end)
        if spaces:
            gap = max(1, len(spaces.group()) - (len(number) - (end - start)))
            end, number = end + len(spaces.group()), number + " " * gap
        self.edits.append(_Edit(start, end, number))

    def _add(self, item: yaml.MappingNode, name: str, number: str) -> None:
        """Add ``name: number`` to ``item`` right after its ``use:`` value."""
        use_key, use_value = _entry(item, "use")
        if self.uses.get(id(use_value), 0) > 1:  # an alias: its marks are where its anchor stands
            raise _Refused(f"its 'use:' name is shared through an anchor (line {_line(use_value)}): "
                           f"add '{name}' by hand")  # fmt: skip
        at = use_value.end_mark.index
        if item.flow_style:  # {use: play, NAME: NUMBER, ...}
            new = f", {name}: {number}"
        else:  # a line of its own under 'use:', at the keys' indentation
            eol = self.text.find("\n", at)
            rest = self.text[at : eol if eol >= 0 else len(self.text)]
            if not _REST_OF_LINE.fullmatch(rest):
                raise _Refused(f"cannot add '{name}' under 'use:' (line {_line(use_value)}): more follows "
                               "on its line; add the key by hand")  # fmt: skip
            line = " " * use_key.start_mark.column + f"{name}: {number}"
            if eol >= 0:
                newline = "\r\n" if rest.endswith("\r") else "\n"
                at, new = eol + 1, line + newline
            else:  # the last line of a file without a final newline
                at, new = len(self.text), ("\r\n" if "\r\n" in self.text else "\n") + line
        edit = self.added.get(id(item))
        if edit is None:
            self.added[id(item)] = edit = _Edit(at, at, "")
            self.edits.append(edit)
        edit.new += new

    def edited(self) -> str:
        """The text with every planned edit made."""
        text = self.text
        last = len(text)
        for edit in sorted(self.edits, key=lambda e: e.start, reverse=True):
            assert edit.end <= last, "edits overlap"
            text = text[: edit.start] + edit.new + text[edit.end :]
            last = edit.start
        return text


def set_parameters(text: str, values: dict[Key, float], file: str = "<string>") -> str:
    """``text`` (a scene document) with each ``{(entity, behaviour, key): value}`` set, by path.

    Everything else stays character for character. Raises :class:`WriteBackError` naming
    every value that cannot be placed and why (then none is set).
    """
    try:
        doc = _Document(text, file)
    except TwigError as exc:
        raise WriteBackError(file, f"it does not read as a scene now: {exc}") from None
    problems = []
    for key, value in values.items():
        try:
            doc.set(key, float(value))
        except _Refused as why:
            problems.append(f"{key[0]}: {key[1]}.{key[2]}: {why}")
    if problems:
        raise WriteBackError(file, f"{len(problems)} of {len(values)} value(s) cannot be placed: "
                             + "; ".join(problems))  # fmt: skip
    return doc.edited()


def _with_values(doc, values: dict[Key, float]):
    """The parsed document ``doc`` with ``values`` set where their paths say (changed in place)."""
    for (entity, behaviour, name), value in values.items():
        owner = next(e for e in doc["entities"] if isinstance(e, dict) and e.get("name") == entity)
        item = next(b for b in owner["behaviors"] if isinstance(b, dict) and b.get("use") == behaviour)
        item[name] = value
    return doc


def _check(path: Path, old: str, new: str, values: dict[Key, float], library: ContentLibrary,
           parameters: dict | None, file: str) -> None:  # fmt: skip
    """Raise WriteBackError unless the scene at ``path`` (holding ``new``) loads with ``values``.

    ``new`` must read as ``old`` with these values changed and nothing else; then the scene
    is read as ``twig validate`` reads it, and each behaviour must hold the value asked.
    """
    if parse_yaml(new, file) != _with_values(parse_yaml(old, file), values):
        raise WriteBackError(file, "the edited text reads differently from the values asked (a bug in "
                             "twig-ecs: please report it with the scene file)")  # fmt: skip
    try:
        plan = read_scene(path, library, parameters)
    except TwigError as exc:
        asked = ", ".join(f"{e}: {b}.{k} = {format_number(v)}" for (e, b, k), v in values.items())
        raise WriteBackError(file, f"with {asked} the scene would not load: "
                             + str(exc).replace(str(path), file)) from None  # fmt: skip
    specs = {spec.name: spec for spec in plan.entities}
    for (entity, behaviour, name), value in values.items():
        components = [b.component for b in specs[entity].behaviors if b.name == behaviour]
        got = getattr(components[-1], name, None) if components else None
        if got != value:
            raise WriteBackError(file, f"{entity}: {behaviour}.{name} reads back as {got!r}, not {value!r}")


def write_parameters(path: str | Path, values: dict[Key, float], library: ContentLibrary | None = None,
                     parameters: dict | None = None) -> int:  # fmt: skip
    """Set ``{(entity, behaviour, key): value}`` in the scene file at ``path``; returns how many.

    Edits the YAML by path (:func:`set_parameters`), checks that the scene loads with exactly
    those values (with ``library`` and the scene ``parameters`` it was played with), then
    replaces the file in one rename. Raises :class:`WriteBackError`, the file untouched,
    when a value cannot be placed or the check fails.
    """
    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise WriteBackError(file, "not a scene file on disk (a built-in scene: copy its YAML and play "
                             "the copy)")  # fmt: skip
    target = path.resolve()  # through a link: the file it points at is edited, the link stays
    try:
        raw = target.read_bytes()
        old = raw.decode("utf-8")
    except OSError as exc:
        raise WriteBackError(file, f"cannot read it: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise WriteBackError(file, "not a UTF-8 text file") from None
    new = set_parameters(old, values, file)
    fd, temporary = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".writeback.yaml", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(new.encode("utf-8"))
            out.flush()
            os.fsync(out.fileno())
        _check(Path(temporary), old, new, values, library or ContentLibrary(), parameters, file)
        if target.read_bytes() != raw:
            raise WriteBackError(file, "it changed on disk while the values were being written; "
                                 "load it again and write again")  # fmt: skip
        os.chmod(temporary, stat.S_IMODE(target.stat().st_mode))
        os.replace(temporary, target)
    except OSError as exc:
        raise WriteBackError(file, f"cannot write beside it: {exc.strerror or exc}") from None
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return len(values)
