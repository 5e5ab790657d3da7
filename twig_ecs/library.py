"""Finding and reading content: built-in and user body templates and scenes.

Built-in content ships inside the package (``twig_ecs.content``: ``bodies/`` and
``scenes/``). Extra folders (``--content DIR``) add their own templates and scenes;
a YAML file with a top-level ``template:`` key is a body template, any other is a
scene. Later folders override earlier ones by name.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from twig_ecs.errors import SceneError
from twig_ecs.files import read_bounded
from twig_ecs.templates import BodyTemplate, compile_template
from twig_ecs.validate import fail, join, read, suggest, text
from twig_ecs.yamldoc import MAX_BYTES, YDict, merge, parse_yaml

#: The schema version this release reads (the ``twig:`` key of every file).
SCHEMA_VERSION = 1


def builtin_dir() -> Path:
    """The folder holding the built-in ``bodies/`` and ``scenes/``."""
    return Path(str(resources.files("twig_ecs.content")))


def _builtin(path: Path) -> bool:
    """Is ``path`` one of the package's own content files?"""
    global _BUILTIN
    if _BUILTIN is None:
        _BUILTIN = builtin_dir().resolve()
    return Path(path).resolve().is_relative_to(_BUILTIN)


_BUILTIN: Path | None = None


def read_document(path: Path) -> YDict:
    """Parse a YAML file into a YDict, checking it is a mapping with ``twig: 1``."""
    data = read_bounded(path, MAX_BYTES, "YAML file", SceneError)
    try:
        source = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError("not a UTF-8 text file", str(path)) from None
    doc = parse_yaml(source, str(path), trusted_source=_builtin(path))
    if not isinstance(doc, YDict):
        raise SceneError(
            "expected a mapping at the top of the file (keys like 'twig: 1')",
            str(path),
            getattr(doc, "line", 1) or 1,
        )
    check_version(doc)
    return doc


#: The package's own content files as parsed, by path: ((size, mtime), document). Every scene a
#: process loads makes a library, which read and parsed every built-in body file again (8 ms
#: a library, most of a small scene's load); a file is parsed again only when it changed. The
#: documents are shared, never changed in place (as a library's copies share them already).
_PARSED_BUILTINS: dict[Path, tuple[tuple[int, int], YDict]] = {}


def _read_builtin(path: Path) -> YDict:
    """:func:`read_document` of one of the package's own files, parsed once while it is unchanged."""
    stat = path.stat()
    key = (stat.st_size, stat.st_mtime_ns)
    known = _PARSED_BUILTINS.get(path)
    if known is None or known[0] != key:
        known = _PARSED_BUILTINS[path] = (key, read_document(path))
    return known[1]


def check_version(doc: YDict) -> None:
    """Fail unless the document declares the schema version this release reads."""
    if "twig" not in doc:
        fail(doc, None, "twig", f"missing required key (add 'twig: {SCHEMA_VERSION}' at the top)")
    if doc["twig"] != SCHEMA_VERSION or isinstance(doc["twig"], bool):
        fail(
            doc,
            "twig",
            "twig",
            f"unsupported version {doc['twig']!r} (this twig-ecs reads version {SCHEMA_VERSION})",
        )


class ContentLibrary:
    """Named body templates and scenes from the built-in folder and user folders."""

    def __init__(self, content_dirs: tuple[str | Path, ...] | list[str | Path] = ()) -> None:
        self._template_docs: dict[str, YDict] = {}
        self._paths: dict[str, str] = {}
        self._compiled: dict[str, BodyTemplate] = {}
        self.scenes: dict[str, Path] = {}
        self._add_dir(builtin_dir(), builtin=True)
        for d in content_dirs:
            path = Path(d)
            if not path.is_dir():
                raise SceneError(f"content folder not found: {path}")
            self._add_dir(path)

    def _add_dir(self, folder: Path, builtin: bool = False) -> None:
        files = sorted(folder.glob("*.yaml")) + sorted(folder.glob("*/*.yaml"))
        for path in files:
            if path.parent.name == "scenes":
                self.scenes[path.stem] = path
                continue
            doc = _read_builtin(path) if builtin else read_document(path)
            if "template" in doc:
                self.add_template(read(doc, "template", "template", text), doc)
            else:
                self.scenes[path.stem] = path

    def add_template(self, name: str, doc: YDict, path: str = "") -> None:
        """Register (or replace) the template document called ``name``.

        ``path`` is where the document sits inside its file (``templates.stick`` for a
        scene's own template), so errors can point inside it.
        """
        self._template_docs[name] = doc
        self._paths[name] = path
        self._compiled.pop(name, None)

    def copy(self) -> ContentLibrary:
        """A library with the same content, to which a scene may add its own templates."""
        other = ContentLibrary.__new__(ContentLibrary)
        other._template_docs = dict(self._template_docs)
        other._paths = dict(self._paths)
        other._compiled = dict(self._compiled)
        other.scenes = dict(self.scenes)
        return other

    @property
    def template_names(self) -> list[str]:
        """Names of all known templates, sorted."""
        return sorted(self._template_docs)

    def has_template(self, name: str) -> bool:
        """Is a template of this name known?"""
        return name in self._template_docs

    def template(self, name: str) -> BodyTemplate:
        """The compiled template ``name`` (``extends`` resolved); KeyError if unknown."""
        if name not in self._compiled:
            if name not in self._template_docs:
                raise KeyError(f"unknown template '{name}'" + suggest(name, self._template_docs))
            self._compiled[name] = compile_template(name, self._resolve(name, ()), self._paths[name])
        return self._compiled[name]

    def _resolve(self, name: str, chain: tuple[str, ...]) -> YDict:
        doc = self._template_docs[name]
        if "extends" not in doc:
            return _strip(doc)
        where = join(self._paths[name], "extends")
        parent = read(doc, "extends", self._paths[name], text)
        if parent in chain + (name,):
            cycle = " -> ".join(chain + (name, parent))
            fail(doc, "extends", where, f"templates extend each other in a cycle: {cycle}")
        if parent not in self._template_docs:
            fail(doc, "extends", where, f"unknown template '{parent}'" + suggest(parent, self._template_docs))
        return merge(self._resolve(parent, chain + (name,)), _strip(doc))

    def scene_path(self, name_or_path: str | Path) -> Path:
        """A scene file by path, or by built-in/user scene name (``schoolyard``)."""
        path = Path(name_or_path)
        if path.suffix in (".yaml", ".yml") or path.exists():
            if path.exists() and not path.is_file():  # a folder, or a link to /dev/zero
                raise SceneError(f"not a regular file: {path} (give a scene .yaml file)")
            if not path.is_file():
                raise SceneError(f"scene file not found: {path}")
            return path
        name = str(name_or_path)
        if name in self.scenes:
            return self.scenes[name]
        raise SceneError(
            f"unknown scene '{name}'"
            + suggest(name, self.scenes)
            + " (give a .yaml path or a built-in scene name)"
        )


def _strip(doc: YDict) -> YDict:
    """The template document without its file-level keys."""
    out = YDict()
    out.file, out.line = doc.file, doc.line
    out.key_lines = dict(getattr(doc, "key_lines", {}))
    for key, value in doc.items():
        if key not in ("twig", "template", "extends"):
            out[key] = value
    return out
