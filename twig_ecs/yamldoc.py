"""YAML documents that remember where each value came from (file and line).

``parse_yaml`` returns plain-looking dicts and lists (:class:`YDict`, :class:`YList`)
that also carry the file name and the line of every key and item, so validation
errors can say ``scene.yaml:12: entities[2].body: ...``. Duplicate keys are errors.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import yaml

from twig_ecs.errors import SceneError


class YDict(dict):
    """A mapping from YAML with the source (file, line) of each key."""

    file: str = "<string>"
    line: int = 0
    key_lines: dict

    def where(self, key: Any = None) -> tuple[str, int]:
        """(file, 1-based line) where ``key`` stands, or where the mapping starts."""
        return getattr(self, "key_lines", {}).get(key, (self.file, self.line))


class YList(list):
    """A sequence from YAML with the source line of each item."""

    file: str = "<string>"
    line: int = 0
    item_lines: list

    def where(self, index: int | None = None) -> tuple[str, int]:
        """(file, 1-based line) of item ``index``, or where the sequence starts."""
        lines = getattr(self, "item_lines", [])
        if index is not None and 0 <= index < len(lines):
            return self.file, lines[index]
        return self.file, self.line


#: Caps on the work one document may cost. PyYAML's pure-Python parser reads about
#: 100-200 KiB/s, so a file at each cap is read (or refused) in about a second: the file's
#: size, its nodes as written (each key, value and item), its values once aliases are
#: expanded (a "billion laughs" document is refused without expanding it), its nesting,
#: the length of any one scalar and of a number (a 5000-digit integer would take seconds to
#: convert; 100 characters hold any float). The largest built-in file is 6 KiB, 500 nodes.
MAX_BYTES = 256 * 1024
MAX_NODES = 20_000
MAX_VALUES = 100_000
#: Deepest nesting of mappings and lists (a scene needs about 6).
MAX_DEPTH = 64
#: Longest text (characters) and number (characters as written) one value may be.
MAX_SCALAR = 10_000
MAX_NUMBER = 100


def _convert(node: yaml.Node, file: str, constructor: yaml.constructor.SafeConstructor) -> Any:
    """The node as YDict/YList/scalars (its size and depth already checked by
    :func:`_expanded_size`)."""
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out = YDict()
        out.file, out.line, out.key_lines = file, line, {}
        for key_node, value_node in node.value:
            key = _convert(key_node, file, constructor)
            if isinstance(key, (YDict, YList)):
                raise SceneError("mapping keys must be plain values", file, key_node.start_mark.line + 1)
            if key in out:
                shown = key if len(str(key)) <= 60 else f"{str(key)[:57]}..."
                raise SceneError(f"duplicate key '{shown}'", file, key_node.start_mark.line + 1)
            out[key] = _convert(value_node, file, constructor)
            out.key_lines[key] = (file, key_node.start_mark.line + 1)
        return out
    if isinstance(node, yaml.SequenceNode):
        out = YList()
        out.file, out.line = file, line
        out.item_lines = [item.start_mark.line + 1 for item in node.value]
        out.extend(_convert(item, file, constructor) for item in node.value)
        return out
    try:
        value = constructor.construct_object(node, deep=True)
    except (ValueError, TypeError, KeyError, AttributeError, IndexError, OverflowError):
        # PyYAML's own constructors fail so on explicit tags: !!timestamp x, !!bool x, !!int _
        tag = node.tag.rpartition(":")[2] or node.tag
        raise SceneError(f"not a valid {tag} value: {str(node.value)[:40]!r}", file, line) from None
    if isinstance(value, str) and not value.isascii():
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:  # "\ud800": a name that no trace, report or socket could write
            raise SceneError(
                f"{value[:40]!r} is not valid Unicode text (a lone surrogate such as \\ud800)", file, line
            ) from None
    return value


def _expanded_size(node: yaml.Node, file: str, memo: dict[int, int | None], depth: int = 0) -> int:
    """How many values ``node`` holds once its aliases are expanded, counted without expanding.

    An alias is the same node object in several places, so each node is counted once and
    its count reused: a "billion laughs" document is refused in microseconds instead of
    after a million values have been built. Deep nesting and self-reference are refused here too.
    """
    known = memo.get(id(node), -1)
    if known is None:
        raise SceneError(f"nested more than {MAX_DEPTH} deep (or an alias refers to itself)", file,
                         node.start_mark.line + 1)  # fmt: skip
    if known >= 0:
        return known
    if depth > MAX_DEPTH:
        raise SceneError(f"nested more than {MAX_DEPTH} deep (or an alias refers to itself)", file,
                         node.start_mark.line + 1)  # fmt: skip
    memo[id(node)] = None  # being counted: meeting it again below means it contains itself
    total = 1
    if isinstance(node, yaml.MappingNode):
        for key_node, value_node in node.value:
            total += _expanded_size(key_node, file, memo, depth + 1)
            total += _expanded_size(value_node, file, memo, depth + 1)
    elif isinstance(node, yaml.SequenceNode):
        for item in node.value:
            total += _expanded_size(item, file, memo, depth + 1)
    memo[id(node)] = total
    return total


class _NoBase60:
    """A resolver pattern that never matches YAML 1.1's base-60 numbers (``1:30``, ``1:30.5``).

    YAML 1.2 dropped them, and PyYAML reads them in quadratic time (a 1.2 MB one took
    minutes) or overflows on a long float; so ``1:30`` is the text '1:30', as in YAML 1.2.
    """

    def __init__(self, pattern: re.Pattern) -> None:
        self.pattern = pattern

    def match(self, value: str) -> re.Match | None:
        """The wrapped pattern's match, None for anything with a colon."""
        return None if ":" in value else self.pattern.match(value)


def _construct_number(convert):
    """A number constructor that refuses a literal over MAX_NUMBER characters first (with its line)."""

    def construct(self, node: yaml.ScalarNode) -> int | float:
        if len(node.value) > MAX_NUMBER:
            raise SceneError(f"number too long: {len(node.value)} characters (at most {MAX_NUMBER})",
                             self.twig_file, node.start_mark.line + 1)  # fmt: skip
        try:
            return convert(self, node)
        except (ValueError, OverflowError):  # an explicit !!int or !!float on something else
            raise SceneError(f"not a number: {node.value[:40]!r}", self.twig_file,
                             node.start_mark.line + 1) from None  # fmt: skip

    return construct


class _Bounded:
    """Counts what a document costs while it is composed: refuses it at :data:`MAX_NODES`
    nodes or a scalar over :data:`MAX_SCALAR` characters, before reading further."""

    twig_file = "<string>"
    twig_nodes = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        self.twig_nodes += 1
        if self.twig_nodes > MAX_NODES:
            line = self.peek_event().start_mark.line + 1
            raise SceneError(f"document too large: more than {MAX_NODES} nodes", self.twig_file, line)
        return super().compose_node(parent, index)

    def compose_scalar_node(self, anchor: str | None) -> yaml.ScalarNode:
        node = super().compose_scalar_node(anchor)
        if len(node.value) > MAX_SCALAR:
            raise SceneError(f"text too long: {len(node.value)} characters (at most {MAX_SCALAR})",
                             self.twig_file, node.start_mark.line + 1)  # fmt: skip
        return node


class _Loader(_Bounded, yaml.SafeLoader):
    """SafeLoader that reads numbers as YAML 1.2 does, within the caps above.

    ``1e3`` and ``-2.5E-4`` are floats (PyYAML follows YAML 1.1, where an exponent without
    a dot makes a string); ``1:30`` is text, not a base-60 number.
    """


_Loader.yaml_implicit_resolvers = {
    first: [
        (tag, _NoBase60(pattern) if tag.endswith((":int", ":float")) else pattern)
        for tag, pattern in resolvers
    ]  # fmt: skip
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)
for _tag, _convert_number in (("int", yaml.SafeLoader.construct_yaml_int),
                              ("float", yaml.SafeLoader.construct_yaml_float)):  # fmt: skip
    _Loader.add_constructor(f"tag:yaml.org,2002:{_tag}", _construct_number(_convert_number))


if yaml.__with_libyaml__:

    class _FastLoader(yaml.CSafeLoader):
        """The same reading with libyaml's parser: about 5x faster, for our own files only.

        libyaml recurses in C on nested brackets and crashes the process on a few hundred
        thousand of them, where the Python parser raises RecursionError; so files from
        users (and the server's clients) always go through :class:`_Loader`.
        """

        twig_file = "<string>"

    _FastLoader.yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers
    _FastLoader.yaml_constructors = _Loader.yaml_constructors
else:  # pragma: no cover - PyYAML built without libyaml
    _FastLoader = _Loader


def _refuse_deep_brackets(text: str, file: str) -> None:
    """Refuse a document whose ``[``/``{`` brackets nest deeper than :data:`MAX_DEPTH`.

    PyYAML's parser would read thousands of nested brackets for seconds before it gave
    up with a RecursionError; one vectorised pass over the bytes finds them at once.
    Brackets inside quotes and comments count too: a real scene never has dozens open.
    """
    if text.count("[") + text.count("{") <= MAX_DEPTH:
        return
    raw = np.frombuffer(text.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    step = ((raw == ord("[")) | (raw == ord("{"))).astype(np.int32)
    step -= (raw == ord("]")) | (raw == ord("}"))
    depth = np.cumsum(step)
    if depth.max() > MAX_DEPTH:
        where = int(np.argmax(depth > MAX_DEPTH))
        line = raw[:where].tobytes().count(b"\n") + 1
        raise SceneError(f"invalid YAML: brackets nested more than {MAX_DEPTH} deep", file, line)


def parse_yaml(text: str, file: str = "<string>", trusted_source: bool = False) -> Any:
    """Parse one YAML document into YDict/YList/scalars; syntax errors become SceneError.

    ``trusted_source``: the text is twig-ecs's own (built-in content), so libyaml's faster
    parser may read it (it halves a scene's load time).
    """
    if len(text) > MAX_BYTES:
        raise SceneError(f"file too large: {len(text)} characters, at most {MAX_BYTES // 1024} KiB", file)
    _refuse_deep_brackets(text, file)
    try:
        loader = (_FastLoader if trusted_source else _Loader)(text)
        loader.twig_file = file
        try:
            root = loader.get_single_node()
            if root is None:
                return None
            if _expanded_size(root, file, {}) > MAX_VALUES:
                raise SceneError(
                    f"document too large: more than {MAX_VALUES} values (aliases expanded)", file
                )
            return _convert(root, file, loader)
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        problem = exc.problem or exc.context or "invalid YAML"
        raise SceneError(f"invalid YAML: {problem}", file, line) from None
    except yaml.YAMLError as exc:
        raise SceneError(f"invalid YAML: {exc}", file) from None
    except RecursionError:  # the YAML parser itself, on thousands of nested brackets
        raise SceneError(f"invalid YAML: nested more than {MAX_DEPTH} deep", file) from None


def compose_yaml(text: str, file: str = "<string>") -> yaml.Node | None:
    """The document's node tree, for edits that keep the rest of the text as written.

    Each node's ``start_mark.index``/``end_mark.index`` are character offsets into
    ``text``. Read by the same loader as :func:`parse_yaml` (so ``1e3`` is a float here
    too), after :func:`parse_yaml` has checked the text: the same limits, the same errors.
    An alias is the very node object it refers to, so a node met twice is shared.
    """
    parse_yaml(text, file)
    loader = _Loader(text)
    try:
        return loader.get_single_node()
    finally:
        loader.dispose()


def merge(base: Any, override: Any) -> Any:
    """Deep-merge two YAML values: mappings merge key by key, anything else replaces.

    Line information follows each value to the document it came from.
    """
    if isinstance(base, YDict) and isinstance(override, YDict):
        out = YDict()
        out.file, out.line, out.key_lines = override.file, override.line, {}
        for key, value in base.items():
            out[key] = value
            out.key_lines[key] = base.where(key)
        for key, value in override.items():
            out[key] = merge(out[key], value) if key in out else value
            out.key_lines[key] = override.where(key)
        return out
    return override
