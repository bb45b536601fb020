"""The dependency rules of docs/architecture.md, read from the imports of every module.

Every ``import`` and ``from … import`` statement counts, also those inside functions (a lazy import is
still a dependency). Rules:

* geometry imports none of meshing, solver, optimizer;
* meshing imports geometry only;
* solver imports none of geometry, meshing, optimizer (it knows meshes and fields, never blades);
* the solver core does not import ``solver.validation`` (the validation cases use the core, not the
  other way round);
* no import cycle between modules of the project.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("geometry", "meshing", "solver", "optimizer")
#: What each package may import of the others.
ALLOWED = {
    "geometry": set(),
    "meshing": {"geometry"},
    "solver": set(),
    "optimizer": {"geometry", "meshing", "solver"},
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """Project modules that ``name`` imports (resolved to the longest existing module name)."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            submodules = [f"{module}.{a.name}" for a in node.names]
            # ``from pkg import submodule`` depends on that submodule; any other name on pkg itself
            targets = submodules + ([module] if any(t not in MODULES for t in submodules) else [])
        for target in targets:
            resolved = _resolve(target)
            if resolved is not None and resolved != name:
                found.add(resolved)
    return found


def _resolve(target: str) -> str | None:
    parts = target.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in MODULES:
            return candidate
        parts.pop()
    return None


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def test_modules_found():
    assert {m.split(".")[0] for m in MODULES} == set(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_package_dependencies_point_one_way(package):
    bad = sorted(
        f"{mod} imports {dep}"
        for mod, deps in GRAPH.items() if mod.split(".")[0] == package
        for dep in deps
        if dep.split(".")[0] != package and dep.split(".")[0] not in ALLOWED[package]
    )
    assert not bad, "\n".join(bad)


def test_solver_core_does_not_import_validation():
    bad = sorted(
        f"{mod} imports {dep}"
        for mod, deps in GRAPH.items()
        if mod.startswith("solver") and not mod.startswith("solver.validation")
        for dep in deps if dep.startswith("solver.validation")
    )
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    """Tarjan's strongly connected components; a package's ``__init__`` importing its own submodules is
    not a cycle unless a submodule imports the package back (``from solver import X`` inside solver/)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
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
                cycles.append(sorted(component))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)
