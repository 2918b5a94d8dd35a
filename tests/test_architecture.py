"""The package's import graph: no cycles, and dependencies flow one way.

Layers, lowest first: the base modules (``rollsim.log``, ``compat``, ``files``, ``mpi``, ``units``,
``render``, ``presets``) < ``rollsim.geometry`` < ``rollsim.solver`` < the input layer (``rollsim.scene``) <
``rollsim.studies`` < ``rollsim.cli``.  A module may import its own layer and the layers below.
Every ``import`` statement counts, including those inside functions.
"""
from __future__ import annotations

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PARTS = {"rollsim": "rollsim", "rollsim.geometry": "geometry", "rollsim.solver": "solver",
         "rollsim.studies": "studies"}
BASE = {"rollsim", "rollsim.log", "rollsim.compat", "rollsim.files", "rollsim.mpi",
        "rollsim.units", "rollsim.render", "rollsim.presets"}
LAYERS = ["base", "geometry", "solver", "input", "studies", "cli"]


def _modules() -> dict[str, pathlib.Path]:
    """``{dotted name: file}`` of every module of the package (folders as installed)."""
    found = {}
    for package, folder in PARTS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT / folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            name = ".".join([package, *parts])
            if package == "rollsim" and len(parts) > 1:
                continue
            found[name] = path
    return found


def _layer(name: str) -> str:
    if name in BASE:
        return "base"
    if name == "rollsim.scene":
        return "input"
    if name in ("rollsim.cli", "rollsim.__main__"):
        return "cli"
    return name.split(".")[1]


def _imports(name: str, path: pathlib.Path, modules) -> set[str]:
    """The package modules that ``name`` imports anywhere in its file."""
    is_package = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")[: len(name.split(".")) - node.level + (1 if is_package else 0)]
                base = ".".join(base + ([node.module] if node.module else []))
            else:
                base = node.module
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in modules:       # "rollsim.solver.run.x" -> its module
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _cycle(graph) -> list[str] | None:
    """One import cycle of ``graph`` (a list of modules, first == last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_the_walk_sees_the_package(graph):
    assert {"rollsim.cli", "rollsim.scene", "rollsim.solver.run", "rollsim.solver.problem",
            "rollsim.geometry.soil", "rollsim.studies.study"} <= set(graph)
    assert "rollsim.solver.problem" in graph["rollsim.solver.indentation"]
    assert "rollsim.solver.options" in graph["rollsim.scene"]


def test_no_import_cycles(graph):
    cycle = _cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_cycle_finder_finds_a_planted_cycle(graph):
    planted = {k: set(v) for k, v in graph.items()}
    planted["rollsim.solver.options"].add("rollsim.solver.run")
    assert _cycle(planted) is not None


def test_dependencies_flow_one_way(graph):
    wrong = [f"{a} -> {b}" for a, targets in graph.items() for b in sorted(targets)
             if LAYERS.index(_layer(b)) > LAYERS.index(_layer(a))]
    assert not wrong, "imports from a higher layer: " + "; ".join(wrong)


def test_no_solver_function_is_longer_than_80_lines():
    """A long function in ``solver/`` is split into named steps (``_init_*`` methods, helpers)."""
    long = []
    for path in sorted((ROOT / "solver").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno >= 80:
                long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} "
                            f"({node.end_lineno - node.lineno + 1} lines)")
    assert not long, long
