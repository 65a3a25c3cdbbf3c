"""The layout shows the flow: a thin ``gcs/`` root, small modules, and no import cycle.

- The ``gcs/`` root holds the command line (``cli.py``, ``cli_commands.py``, ``cli_errors.py``) only;
  everything else is in a package named for its role (the daemon's composition root is
  ``gcs/daemon/app.py``).
- No module of ``gcs``, ``sim_vehicles`` or ``protocols`` exceeds :data:`MAX_LINES`.
- The modules' imports form no cycle, counting the imports inside functions as well as those at
  the top. So no function-level import can be there to dodge a cycle: moved to the top, it would
  still close none. Imports under ``if TYPE_CHECKING:`` never run and are not counted.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("gcs", "sim_vehicles", "protocols")
GCS_ROOT_MODULES = {"__init__.py", "cli.py", "cli_commands.py", "cli_errors.py"}
MAX_LINES = 400


def module_files(root: Path, packages: Iterable[str]) -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` under the packages (a package is its ``__init__``)."""
    found: dict[str, Path] = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imported_modules(source: str, known: Mapping[str, Path]) -> set[str]:
    """The known modules one module's source imports, anywhere in it but under ``if TYPE_CHECKING``."""

    def resolve(name: str) -> str | None:
        while name and name not in known:
            name = name.rpartition(".")[0]
        return name or None

    found: set[str] = set()

    class Imports(ast.NodeVisitor):
        def visit_If(self, node: ast.If) -> None:
            if _is_type_checking(node.test):
                for statement in node.orelse:
                    self.visit(statement)
            else:
                self.generic_visit(node)

        def visit_Import(self, node: ast.Import) -> None:
            found.update(filter(None, (resolve(alias.name) for alias in node.names)))

        def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
            if node.level == 0 and node.module:
                found.update(filter(None, (resolve(f"{node.module}.{alias.name}") for alias in node.names)))

    Imports().visit(ast.parse(source))
    return found


def import_graph(modules: Mapping[str, Path]) -> dict[str, set[str]]:
    """Module -> the modules it imports (itself left out)."""
    return {name: imported_modules(path.read_text(), modules) - {name} for name, path in modules.items()}


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan 1972), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
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
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_gcs_root_holds_the_command_line_and_the_composition_root_only():
    modules = {path.name for path in (ROOT / "gcs").glob("*.py")}
    assert modules - GCS_ROOT_MODULES == set()


def test_no_module_exceeds_the_line_limit():
    long = {name: n for name, path in module_files(ROOT, PACKAGES).items()
            if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert long == {}


def test_no_import_cycle_even_through_function_level_imports():
    assert cycles(import_graph(module_files(ROOT, PACKAGES))) == []


def test_a_cycle_through_a_function_level_import_is_found(tmp_path):
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from pkg.b import g\n\ndef f():\n    return g()\n")
    (package / "b.py").write_text("def g():\n    from pkg.a import f\n    return f\n")
    (package / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import f\n")
    graph = import_graph(module_files(tmp_path, ["pkg"]))
    assert graph["pkg.c"] == set()
    assert cycles(graph) == [["pkg.a", "pkg.b"]]
