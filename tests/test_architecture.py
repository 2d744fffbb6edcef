"""The package's shape: imports flow one way, from the CLI down to the robots and the YAML reader.

Every import counts (module level, function-local and `TYPE_CHECKING` ones): a deferred import is a
design dependency all the same.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fallbench"

# Lowest first: a package may import only from packages before it (or itself).
LAYERS: list[set[str]] = [
    {"yamlfile"},  # YAML input files with file:line errors: scenario files and robot cards
    {"robots"},
    {"scenario"},
    {"dynamics"},
    {"sim"},
    {"analysis"},  # measures of a recorded fall, generic: they know no strategy or policy
    {"preimpact", "postimpact"},
    {"registry", "checks", "assembly"},  # the plug-in registry, the checks that need it, a run put together
    {"environment"},  # the Gymnasium environment: drives the registry's worlds through sim's episode
    {"results"},
    {"report"},
    {"cli"},
]


def module_names() -> dict[str, Path]:
    """Dotted module name -> file, packages named by their `__init__.py`."""
    names = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join(parts)] = path
    return names


def imported_names(module: str, path: Path) -> set[str]:
    """Every `fallbench...` name that `module` imports, anywhere in its file."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = module.split(".")[: len(module.split(".")) - node.level + is_package]
                base = ".".join(anchor + ([node.module] if node.module else []))
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return {name for name in found if name.split(".")[0] == "fallbench"}


@cache
def import_graph() -> dict[str, set[str]]:
    """Module -> the modules it imports (a `from package import name` resolves to the deepest module)."""
    names = module_names()

    def resolve(name: str) -> str:
        while name not in names:
            name = name.rpartition(".")[0]
        return name

    return {
        module: {resolve(name) for name in imported_names(module, path)} - {module}
        for module, path in names.items()
    }


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        components.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in stack:
                low[node] = min(low[node], index[child])
    return components


def layer_of(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return -1  # the root package holds only the version
    return next(i for i, layer in enumerate(LAYERS) if parts[1] in layer)


def test_cycle_finder_sees_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_relative_and_deferred_imports_are_counted(tmp_path):
    source = "from ..sim import world\ndef f():\n    from fallbench.results import store\n"
    path = tmp_path / "x.py"
    path.write_text(source)
    assert imported_names("fallbench.report.x", path) >= {"fallbench.sim.world", "fallbench.results.store"}


def test_no_import_cycle():
    assert cycles(import_graph()) == []


def test_every_module_sits_in_a_layer():
    placed = set().union(*LAYERS)
    outside = sorted(m for m in import_graph() if "." in m and m.split(".")[1] not in placed)
    assert outside == [], f"modules of packages in no layer (add them to LAYERS): {outside}"


@pytest.mark.parametrize("module", sorted(import_graph()))
def test_imports_flow_down_the_layers(module):
    upward = [name for name in sorted(import_graph()[module]) if layer_of(name) > layer_of(module)]
    assert upward == [], f"{module} imports from a higher layer: {upward}"
