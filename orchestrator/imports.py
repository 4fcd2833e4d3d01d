"""The package's own modules and the imports between them, read from the source with `ast` (nothing is imported).

Two readers: the run identity hashes the modules an engine adapter imports (engines.build), and the
architecture test checks the layers. A module imported lazily, inside a function, counts like one
imported at the top: it is part of what runs.
"""

from __future__ import annotations

import ast
from functools import lru_cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
PACKAGE_NAME = PACKAGE.name


def module_name(path: Path) -> str:
    """orchestrator/engines/base.py → orchestrator.engines.base; a package's __init__ → the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@lru_cache(maxsize=1)
def package_modules() -> dict[str, Path]:
    """Every module of the package: dotted name → source file."""
    return {module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}


def package_imports(path: Path) -> set[str]:
    """Modules of the package that the source at `path` imports, at any depth of the file.

    `from orchestrator.x import y` counts as orchestrator.x.y when y is a module, else as
    orchestrator.x. Relative imports are not used in the package and are not followed.
    """
    modules = package_modules()
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and node.module.split(".")[0] == PACKAGE_NAME:
            for alias in node.names:
                candidate = f"{node.module}.{alias.name}"
                found.add(candidate if candidate in modules else node.module)
        elif isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.split(".")[0] == PACKAGE_NAME}
    return found


def import_closure(roots: list[str]) -> list[str]:
    """The modules `roots` import, directly or through others (the roots included), sorted.

    A module brings in the packages above it too (importing orchestrator.engines.base runs
    orchestrator/engines/__init__.py first).
    """
    modules = package_modules()
    seen: set[str] = set()
    todo = list(roots)
    while todo:
        name = todo.pop()
        if name in seen or name not in modules:
            continue
        seen.add(name)
        parents = [".".join(name.split(".")[:k]) for k in range(1, name.count(".") + 1)]
        todo += parents + sorted(package_imports(modules[name]))
    return sorted(seen)
