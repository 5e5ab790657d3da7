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


#: Most values one document may hold (after expanding aliases): a guard against
#: "billion laughs" documents that would otherwise expand without end.
MAX_VALUES = 1_000_000
#: Deepest nesting of mappings and lists (a scene needs about 6).
MAX_DEPTH = 64
#: Largest file read, in bytes.
MAX_BYTES = 16 * 1024 * 1024


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
                raise SceneError(f"duplicate key '{key}'", file, key_node.start_mark.line + 1)
            out[key] = _convert(value_node, file, constructor)
            out.key_lines[key] = (file, key_node.start_mark.line + 1)
        return out
    if isinstance(node, yaml.SequenceNode):
        out = YList()
        out.file, out.line = file, line
        out.item_lines = [item.start_mark.line + 1 for item in node.value]
        out.extend(_convert(item, file, constructor) for item in node.value)
        return out
    return constructor.construct_object(node, deep=True)


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


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``1e3`` and ``-2.5E-4`` as floats, as YAML 1.2 does.

    (PyYAML follows YAML 1.1, where an exponent without a dot makes a string.)
    """


_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


if yaml.__with_libyaml__:

    class _FastLoader(yaml.CSafeLoader):
        """The same reading with libyaml's parser: about 5x faster, for our own files only.

        libyaml recurses in C on nested brackets and crashes the process on a few hundred
        thousand of them, where the Python parser raises RecursionError; so files from
        users (and the server's clients) always go through :class:`_Loader`.
        """

    _FastLoader.yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers
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
        raise SceneError(f"file too large: over {MAX_BYTES // (1024 * 1024)} MiB", file)
    _refuse_deep_brackets(text, file)
    try:
        loader = (_FastLoader if trusted_source else _Loader)(text)
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
