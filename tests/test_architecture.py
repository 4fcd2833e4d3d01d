"""The house plan, checked on the source (standard `ast`, no engine): layers, engine names, sizes.

Layers, lowest first; a module may import from its own layer and the ones below, never above. The
order is the one docs/development.md describes.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from orchestrator.capabilities import ENGINE_NAMES
from orchestrator.imports import package_imports, package_modules

PACKAGE = Path(__file__).resolve().parent.parent / "orchestrator"

LAYERS: list[tuple[str, ...]] = [
    # foundations: no import from the package, or only from each other
    ("orchestrator", "orchestrator.capabilities", "orchestrator.engine_sections", "orchestrator.imports", "orchestrator.results",
     "orchestrator.validation",
     "orchestrator.figures",
     "orchestrator.shapes", "orchestrator.fields", "orchestrator.contact.law", "orchestrator.contact"),
    ("orchestrator.bodies",),
    ("orchestrator.case",),
    ("orchestrator.rundir",),
    ("orchestrator.physics", "orchestrator.geometry", "orchestrator.post", "orchestrator.estimate", "orchestrator.preflight", "orchestrator.preflight_shapes",
     "orchestrator.plan"),
    ("orchestrator.engines",),
    ("orchestrator.runner",),
    ("orchestrator.studies", "orchestrator.parity"),
    ("orchestrator.campaign", "orchestrator.slurm"),
    ("orchestrator.cli",),
]


MODULES = package_modules()


def layer_of(module: str) -> int:
    """The layer of the longest entry that is `module` or a package holding it (the bare package
    `orchestrator` stands for its __init__ only)."""
    matches = [(name.count("."), index) for index, names in enumerate(LAYERS) for name in names
               if module == name or (name != "orchestrator" and module.startswith(name + "."))]
    assert matches, f"{module} is in no layer: add it to LAYERS (and to the tree in docs/development.md)"
    return max(matches)[1]


def test_the_package_imports_absolutely() -> None:
    """The import reader (orchestrator.imports) follows absolute imports only: a relative one would hide an edge."""
    relative = [f"{name}:{node.lineno}" for name, path in MODULES.items() for node in ast.walk(ast.parse(path.read_text()))
                if isinstance(node, ast.ImportFrom) and node.level]
    assert not relative, f"relative imports: {relative}"


def test_every_module_has_a_layer() -> None:
    for module in MODULES:
        layer_of(module)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_import_from_a_higher_layer(module: str) -> None:
    own = layer_of(module)
    for imported in package_imports(MODULES[module]):
        assert layer_of(imported) <= own, f"{module} (layer {own}) imports {imported} (layer {layer_of(imported)})"


def test_the_case_model_loads_no_engine_code() -> None:
    """`import orchestrator.case` (and physics, pre-flight) loads nothing from engines/: the case model sits below the engines."""
    import subprocess
    import sys

    probe = ("import sys, orchestrator.case, orchestrator.physics, orchestrator.preflight, orchestrator.geometry; "
             "print(sorted(m for m in sys.modules if m.startswith('orchestrator.engines')))")
    loaded = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.strip()
    assert loaded == "[]", f"importing the case model loads engine modules: {loaded}"


def test_no_import_cycle() -> None:
    graph = {module: {i for i in package_imports(path) if i in MODULES and i != module} for module, path in MODULES.items()}
    state: dict[str, int] = {}

    def visit(module: str, trail: list[str]) -> None:
        state[module] = 1
        for target in graph[module]:
            if state.get(target) == 1:
                raise AssertionError("import cycle: " + " → ".join(trail[trail.index(target):] + [target]) if target in trail else target)
            if target not in state:
                visit(target, trail + [target])
        state[module] = 2

    for module in graph:
        if module not in state:
            visit(module, [module])


ENGINE_WORD = re.compile(r"(?i)(?:^|_)(" + "|".join(ENGINE_NAMES) + r")(?:_|$)")


def engine_names_in_code(path: Path) -> list[str]:
    """Engine names used as code: identifiers (whole words between underscores), import paths and
    string literals equal to a name. Docstrings, comments and prose in messages are documentation."""
    tree = ast.parse(path.read_text())
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    hits = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Name):
            names = [node.id]
        elif isinstance(node, ast.Attribute):
            names = [node.attr]
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
            names = [node.name]
        elif isinstance(node, ast.arg):
            names = [node.arg]
        elif isinstance(node, ast.keyword) and node.arg:
            names = [node.arg]
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [a.name for a in node.names] + ([node.module] if isinstance(node, ast.ImportFrom) and node.module else [])
            names = [part for name in names for part in name.split(".")]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            if node.value.strip().lower() in ENGINE_NAMES:
                hits.append(f"line {node.lineno}: string {node.value!r}")
        hits += [f"line {node.lineno}: {name}" for name in names if ENGINE_WORD.search(name)]
    return hits


# The engine table and the engine-only case sections: leaves below the case model, so they stand outside
# engines/ (importing anything inside it runs engines/__init__), and they are where engines are named.
ENGINE_TABLE = ("orchestrator.capabilities", "orchestrator.engine_sections")


def test_no_engine_name_outside_engines() -> None:
    """Callers ask the engine table for a capability; only engines/ and the table name engines."""
    offenders = {module: hits for module, path in MODULES.items()
                 if not module.startswith("orchestrator.engines") and module not in ENGINE_TABLE and (hits := engine_names_in_code(path))}
    assert not offenders, f"engine names outside engines/: {offenders}"


def test_the_engine_name_check_sees_what_it_must(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text('"""Runs on LIGGGHTS."""\nimport orchestrator.engines.yade.adapter\nif case.engine == "cocd":\n    liggghts_grid()\n')
    assert len(engine_names_in_code(probe)) == 3  # the import, the string, the identifier; not the docstring


MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 60


@pytest.mark.parametrize("module", sorted(MODULES))
def test_modules_and_functions_stay_small(module: str) -> None:
    path = MODULES[module]
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_MODULE_LINES, f"{module}: {lines} lines (limit {MAX_MODULE_LINES})"
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            length = node.end_lineno - node.lineno + 1
            assert length <= MAX_FUNCTION_LINES, f"{module}.{node.name}: {length} lines (limit {MAX_FUNCTION_LINES})"


@pytest.mark.parametrize("script", sorted((PACKAGE.parent / "benchmarks").glob("*.py")), ids=lambda p: p.name)
def test_benchmark_scripts_import_what_exists(script: Path) -> None:
    """Benchmarks run on demand, not in the suite: a name they import that a refactor moved fails here."""
    import importlib

    for node in ast.walk(ast.parse(script.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "orchestrator":
            module = importlib.import_module(node.module)
            for alias in node.names:
                assert hasattr(module, alias.name) or f"{node.module}.{alias.name}" in MODULES, f"{script.name}: {node.module}.{alias.name}"
