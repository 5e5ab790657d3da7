"""The package's layers: no import cycles, and pyproject's import-linter contracts hold.

The import graph is read from the source files the package is built from - the folders
``[tool.setuptools.package-dir]`` maps into ``twig_ecs`` (``twig_ecs/``, ``systems/``,
``components/``, ``content/``) - with every import statement, function-level ones
included (a function-level import is still a dependency; it only runs later), and those
under ``if TYPE_CHECKING:`` too: a loop made only of type hints still ties the modules
together. Stock ``lint-imports`` reads the same package through the checkout's
``twig_ecs/systems`` and ``twig_ecs/components`` links, and passes too.
"""

from __future__ import annotations

import ast
import functools
import io
import subprocess
import sys
import tomllib
from contextlib import redirect_stdout
from pathlib import Path

import grimp
from importlinter import configuration
from importlinter.application.app_config import settings
from importlinter.application.ports.building import GraphBuilder
from importlinter.application.use_cases import SUCCESS, lint_imports

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = ROOT / "pyproject.toml"


def package_modules(root: Path = ROOT) -> dict[str, Path]:
    """Module name -> source file, for every module pyproject's package-dir maps into the package."""
    mapping = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    modules: dict[str, Path] = {}
    for package, folder in mapping.items():
        mapped_below = [p for p in mapping if p.startswith(package + ".")]
        for path in sorted((root / folder).rglob("*.py")):
            parts = list(path.relative_to(root / folder).with_suffix("").parts)
            if "__pycache__" in parts:
                continue
            if parts[-1] == "__init__":
                parts.pop()
            name = ".".join([package, *parts])
            if not any(name == p or name.startswith(p + ".") for p in mapped_below):
                modules[name] = path
    return modules


def module_imports(name: str, path: Path, known: set[str]) -> list[tuple[str, int, str]]:
    """(imported module, line, line text) for each import of a package module in ``path``.

    ``from a.b import c`` imports ``a.b.c`` when that is a module, else ``a.b``.
    """
    source = path.read_text()
    lines = source.splitlines()
    is_package = path.name == "__init__.py"
    found: list[tuple[str, int, str]] = []

    def resolve(dotted: str) -> str | None:
        while dotted and dotted not in known:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            visit_one(child)

    def visit_one(child: ast.AST) -> None:
        targets: list[str] = []
        if isinstance(child, ast.Import):
            targets = [alias.name for alias in child.names]
        elif isinstance(child, ast.ImportFrom):
            base = child.module or ""
            if child.level:
                package = name if is_package else name.rpartition(".")[0]
                for _ in range(child.level - 1):
                    package = package.rpartition(".")[0]
                base = f"{package}.{base}" if base else package
            targets = [f"{base}.{alias.name}" for alias in child.names]
        else:
            visit(child)
            return
        for target in targets:
            module = resolve(target)
            if module is not None and module != name:
                found.append((module, child.lineno, lines[child.lineno - 1].strip()))

    visit(ast.parse(source, str(path)))
    return found


@functools.cache
def _package_imports(root: Path) -> tuple[tuple[str, ...], tuple[tuple[str, str, int, str], ...]]:
    """Every module of the package and every import between them, read from the sources once
    per run (the sources do not change under the tests; several tests read the graph)."""
    modules = package_modules(root)
    imports = tuple(
        (name, imported, line, text)
        for name, path in modules.items()
        for imported, line, text in module_imports(name, path, set(modules))
    )
    return tuple(modules), imports


def package_graph(root: Path = ROOT) -> grimp.ImportGraph:
    """The package's import graph (a grimp graph, as import-linter checks): a new one each
    call, which the caller may change."""
    modules, imports = _package_imports(root)
    graph = grimp.ImportGraph()
    for name in modules:
        graph.add_module(name)
    for name, imported, line, text in imports:
        graph.add_import(importer=name, imported=imported, line_number=line, line_contents=text)
    return graph


def import_cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each as a cycle path."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.find_modules_directly_imported_by(v)):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for module in sorted(graph.modules):
        if module not in index:
            connect(module)
    cycles = []
    for component in components:  # the shortest cycle through each component's first module, to read
        start, inside = component[0], set(component)
        loops = [(start, *graph.find_shortest_chain(importer=nxt, imported=start))
                 for nxt in sorted(graph.find_modules_directly_imported_by(start) & inside)]  # fmt: skip
        cycles.append(list(min(loops, key=len)))
    return cycles


class _PackageGraphBuilder(GraphBuilder):
    """Hands import-linter the graph of the whole package (grimp alone would miss systems/)."""

    def build(self, root_package_names, cache_dir, include_external_packages=False,
              exclude_type_checking_imports=False) -> grimp.ImportGraph:  # fmt: skip
        assert root_package_names == ["twig_ecs"], root_package_names
        assert not exclude_type_checking_imports, "the contracts count type-only imports too"
        return package_graph()


def test_the_graph_holds_every_module_of_the_package():
    graph = package_graph()
    for name in ("twig_ecs.scene", "twig_ecs.systems.physics.integrate", "twig_ecs.components.physics",
                 "twig_ecs.server.core", "twig_ecs.graphics.app"):  # fmt: skip
        assert name in graph.modules
    assert "twig_ecs.store" in graph.find_modules_directly_imported_by("twig_ecs.systems.physics.integrate")
    assert len(graph.modules) > 80


def test_stock_lint_imports_passes_on_the_checkout():
    # the links twig_ecs/systems -> ../systems (and components) let grimp walk the package
    code = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "Contracts: 2 kept, 0 broken." in done.stdout


def test_the_package_has_no_import_cycle():
    cycles = import_cycles(package_graph())
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_the_cycle_finder_finds_a_cycle():
    graph = grimp.ImportGraph()
    for a, b in (("p.a", "p.b"), ("p.b", "p.c"), ("p.c", "p.a"), ("p.c", "p.d")):
        graph.add_import(importer=a, imported=b)
    assert import_cycles(graph) == [["p.a", "p.b", "p.c", "p.a"]]


def _lint(builder: GraphBuilder) -> tuple[bool, str]:
    """Run import-linter on pyproject's contracts over ``builder``'s graph: (passed, its report)."""
    configuration.configure()
    settings.configure(GRAPH_BUILDER=builder)
    try:
        with redirect_stdout(io.StringIO()) as out:
            passed = lint_imports(str(PYPROJECT), cache_dir=None, no_logo=True, is_debug_mode=True) == SUCCESS
    finally:
        configuration.configure()  # the stock graph builder again
    return passed, out.getvalue()


def test_the_import_contracts_in_pyproject_hold():
    passed, report = _lint(_PackageGraphBuilder())
    assert passed, "import-linter contracts broken:\n" + report
    assert "2 kept, 0 broken" in report


def test_a_lower_layer_importing_a_higher_one_breaks_the_layers_contract():
    configuration.configure()

    class WithBadImport(_PackageGraphBuilder):
        def build(self, *args, **kwargs) -> grimp.ImportGraph:
            graph = super().build(*args, **kwargs)
            graph.add_import(importer="twig_ecs.store", imported="twig_ecs.scene", line_number=1,
                             line_contents="from twig_ecs.scene import Scene")  # fmt: skip
            return graph

    passed, report = _lint(WithBadImport())
    assert not passed and "twig_ecs.store -> twig_ecs.scene" in report
    assert "0 kept, 2 broken" in report  # a layer broken, and a cycle made (store <-> scene)


def test_every_module_has_a_layer():
    """A new module must be placed in a layer, or the layers contract would not check it."""
    config = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))["tool"]["importlinter"]["contracts"]
    layers = next(c["layers"] for c in config if c["type"] == "layers")
    placed = {name.strip() for layer in layers for name in layer.split(":")}
    unplaced = sorted(
        module
        for module in package_graph().modules
        if module.count(".") >= 1  # the package itself and subpackages' __init__ sit above the layers
        and not any(module == p or module.startswith(p + ".") for p in placed)
        and module not in ("twig_ecs.systems", "twig_ecs.components", "twig_ecs.content")
    )
    assert not unplaced, f"modules in no layer of pyproject's import-linter contract: {unplaced}"


#: A named tuple's public API begins with an underscore (``_replace``, ``_fields``, ``_asdict``,
#: ``_make``): that is not reaching into another module's privates.
NAMED_TUPLE_API = {"_replace", "_fields", "_asdict", "_make", "_field_defaults"}


def private_reads(source: str) -> list[tuple[int, str]]:
    """(line, code) of every read of another object's or module's private name in ``source``:
    ``x._name`` where x is not ``self`` or ``cls``, and ``from m import _name``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute):
            name, owner = node.attr, node.value
            own = isinstance(owner, ast.Name) and owner.id in ("self", "cls")
            if name.startswith("_") and not name.startswith("__") and name not in NAMED_TUPLE_API and not own:
                found.append((node.lineno, ast.unparse(node)))
        elif isinstance(node, ast.ImportFrom):
            found += [(node.lineno, f"from {node.module} import {a.name}") for a in node.names
                      if a.name.startswith("_") and not a.name.startswith("__")]  # fmt: skip
    return found


def test_no_system_reads_a_private_attribute_of_the_scene_esper_or_another_module():
    # issue 32: systems once read scene._names, patched esper's _components and imported
    # approach.py's private helpers
    reads = {
        str(path.relative_to(ROOT)): hits
        for path in sorted((ROOT / "systems").rglob("*.py"))
        if (hits := private_reads(path.read_text(encoding="utf-8")))
    }
    assert not reads, reads


def test_the_private_read_finder_finds_one():
    code = "from twig_ecs.systems.behaviours.approach import _grid\nn = scene._names\nt = row._replace(a=1)\n"
    assert private_reads(code) == [(1, "from twig_ecs.systems.behaviours.approach import _grid"),
                                   (2, "scene._names")]  # fmt: skip
