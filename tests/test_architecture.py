"""The package's shape: imports flow one way, from the CLI down to the robots and the YAML reader;
no file over 500 lines, no function over 60; every module named in docs/architecture.md;
the generic layers know no specific strategy or policy, and the report no shipped scenario.

Every import counts (module level, function-local and `TYPE_CHECKING` ones): a deferred import is a
design dependency all the same.
"""

from __future__ import annotations

import ast
import bisect
import io
import re
import tokenize
from functools import cache
from pathlib import Path

import pytest
from ruamel.yaml import YAML

PACKAGE = Path(__file__).resolve().parents[1] / "fallbench"
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"
MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 60  # of a body: the lines after the signature (`def ...:`, however many lines it takes)
# Files over MAX_FILE_LINES, each with the reason at its top (none today); a test fails once one is
# under the limit again.
LONG_FILES: set[str] = set()
SCENARIOS = PACKAGE.parent / "scenarios"

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
    {"bench"},  # `fallbench bench`: times the environment, the runner and the store
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


def line_count(path: Path) -> int:
    return len(path.read_text().splitlines())


def test_no_file_over_the_line_limit():
    long = {
        path.relative_to(PACKAGE).as_posix(): line_count(path)
        for path in sorted(PACKAGE.rglob("*.py"))
        if line_count(path) > MAX_FILE_LINES
    }
    over = {name: lines for name, lines in long.items() if name not in LONG_FILES}
    assert over == {}, f"files over {MAX_FILE_LINES} lines (split them): {over}"


def test_long_file_exemptions_are_still_needed():
    done = sorted(
        name
        for name in LONG_FILES
        if not (PACKAGE / name).exists() or line_count(PACKAGE / name) <= MAX_FILE_LINES
    )
    assert done == [], f"under {MAX_FILE_LINES} lines or gone: remove them from LONG_FILES: {done}"


def body_lengths(source: str) -> list[tuple[int, str, int]]:
    """(line, name, body lines) of every function and method: the lines from the one after its
    signature's closing colon to its last line."""
    tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    starts = [token.start for token in tokens]
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        depth = 0
        for token in tokens[bisect.bisect_left(starts, (node.lineno, node.col_offset)) :]:
            if token.type != tokenize.OP:
                continue
            if token.string in "([{":
                depth += 1
            elif token.string in ")]}":
                depth -= 1
            elif token.string == ":" and depth == 0:  # the end of the signature
                found.append((node.lineno, node.name, node.end_lineno - token.start[0]))
                break
    return found


def test_body_lengths_count_after_the_signature():
    source = "def f(\n    a: int,\n    b: int = 1,\n) -> dict[str, int]:\n    x = {'a': a}\n    return x\n"
    assert body_lengths(source) == [(1, "f", 2)]


def test_no_function_over_the_line_limit():
    long = [
        f"{path.relative_to(PACKAGE.parent)}:{line} {name}: {lines} lines"
        for path in sorted(PACKAGE.rglob("*.py"))
        for line, name, lines in body_lengths(path.read_text())
        if lines > MAX_FUNCTION_LINES
    ]
    assert long == [], f"functions over {MAX_FUNCTION_LINES} lines below their signature: {long}"


def documented_modules() -> set[str]:
    """Paths docs/architecture.md names: `fallbench/...` anywhere; in a table row, bare `x.py` names
    in the folder of the row's first path; in a heading, bare `package/` names under fallbench/."""
    named = set()
    for line in ARCHITECTURE.read_text().splitlines():
        paths = re.findall(r"`(fallbench/[\w/]*(?:\.py)?)`", line)
        named.update(paths)
        if line.startswith("#"):
            named.update(f"fallbench/{name}" for name in re.findall(r"`(\w+/)`", line))
        elif line.startswith("|") and paths:
            folder = paths[0] if paths[0].endswith("/") else paths[0].rpartition("/")[0] + "/"
            named.update(folder + name for name in re.findall(r"`([\w/]+\.py)`", line) if "/" not in name)
    return named


def test_every_module_is_named_in_the_architecture_page():
    named = documented_modules()
    missing = [
        path.relative_to(PACKAGE.parent).as_posix()
        for path in sorted(PACKAGE.rglob("*.py"))
        if path.relative_to(PACKAGE.parent).as_posix() not in named
        and not (
            path.name == "__init__.py" and f"{path.parent.relative_to(PACKAGE.parent).as_posix()}/" in named
        )
    ]
    assert missing == [], f"modules docs/architecture.md does not name: {missing}"


# Layers that serve every strategy and policy alike: they may use the interfaces (`base`), never a
# specific strategy or policy package (`preimpact.reshape`, `postimpact.adaptive_qp`, ...).
GENERIC = ("analysis", "sim", "results")
INTERFACES = {
    "fallbench.preimpact",
    "fallbench.postimpact",
    "fallbench.preimpact.base",
    "fallbench.postimpact.base",
}


def specific_controllers(imported: set[str]) -> list[str]:
    """The imported modules that belong to a specific strategy or policy."""
    return sorted(
        name
        for name in imported
        if name.split(".")[1:2] in (["preimpact"], ["postimpact"]) and name not in INTERFACES
    )


def test_specific_controllers_are_told_apart_from_interfaces():
    imported = {"fallbench.preimpact.base", "fallbench.postimpact.adaptive_qp.policy", "fallbench.sim.world"}
    assert specific_controllers(imported) == ["fallbench.postimpact.adaptive_qp.policy"]


@pytest.mark.parametrize(
    "module", sorted(m for m in import_graph() if m.split(".")[1:2] and m.split(".")[1] in GENERIC)
)
def test_generic_layers_know_no_specific_controller(module):
    specific = specific_controllers(import_graph()[module])
    assert specific == [], f"{module} imports a specific strategy or policy: {specific}"


# The report selects runs by what the store holds, never by a scenario's name (report/selection.py).
SELECTING_CALLS = {"isin", "startswith", "endswith", "contains", "match", "fullmatch", "query"}


@cache
def shipped_scenario_names() -> frozenset[str]:
    """The `name` of every document of the shipped scenario files (scenarios/*.yaml)."""
    yaml = YAML(typ="safe", pure=True)
    return frozenset(
        str(document["name"])
        for path in sorted(SCENARIOS.glob("*.yaml"))
        for document in yaml.load_all(path.read_text())
        if isinstance(document, dict) and "name" in document
    )


def _strings(node: ast.AST) -> list[ast.Constant]:
    """The string constants of an expression, inside lists, tuples and sets too."""
    if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
        return [s for element in node.elts for s in _strings(element)]
    return [node] if isinstance(node, ast.Constant) and isinstance(node.value, str) else []


def scenario_names_in(source: str, names: frozenset[str]) -> list[tuple[int, str]]:
    """(line, name) of each shipped scenario `source` names: a string (docstrings aside) holding a
    name that is no plain word (it has an underscore or a digit), or the start of one (`"dir_fig"`,
    `"ci_"`); and any name at all, plain words too (`drop`), where a string is compared or selects
    (`==`, `.isin`, `.str.startswith`, ...)."""
    tree = ast.parse(source)
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    selecting: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            selecting |= {id(s) for operand in [node.left, *node.comparators] for s in _strings(operand)}
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", None) in SELECTING_CALLS:
            selecting |= {id(s) for argument in node.args for s in _strings(argument)}
    identifiers = [n for n in names if "_" in n or any(c.isdigit() for c in n)]
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Constant) and isinstance(node.value, str)) or id(node) in docstrings:
            continue
        tokens = re.findall(r"[A-Za-z0-9_]+", node.value)
        for token in tokens:
            hits = [n for n in identifiers if _names(token, n)]
            if id(node) in selecting:
                hits += [n for n in names if token == n]
            found += [(node.lineno, n) for n in sorted(set(hits))]
    return found


def _names(token: str, name: str) -> bool:
    """Whether a token of a string is this scenario name, or (with an underscore) its start."""
    if token == name:
        return True
    if "_" not in token or not name.startswith(token):
        return False
    return token.endswith("_") or name[len(token)] == "_" or name[len(token)].isdigit()


def test_the_scenario_name_finder_sees_names():
    names = frozenset({"dir_fig1", "dir_fig10", "drop", "ci_push"})
    source = '''"""About dir_fig1 (a docstring)."""
MIRRORS = "dir_fig"
A = "dir_fig10"
B = runs[runs.scenario == "drop"]
C = runs[runs.point.str.startswith("ci_")]
D = "(no drop runs)"
E = rows.drop(columns="x")
'''
    assert scenario_names_in(source, names) == [
        (2, "dir_fig1"),
        (2, "dir_fig10"),
        (3, "dir_fig10"),
        (4, "drop"),
        (5, "ci_push"),
    ]


def test_shipped_scenario_names_are_read():
    assert {"drop", "dir_fig1", "ci_push"} <= shipped_scenario_names()


@pytest.mark.parametrize("path", sorted(PACKAGE.joinpath("report").rglob("*.py")), ids=lambda p: p.name)
def test_the_report_names_no_shipped_scenario(path):
    found = scenario_names_in(path.read_text(), shipped_scenario_names())
    assert found == [], f"{path.relative_to(PACKAGE.parent)} names shipped scenarios (line, name): {found}"
