"""What an engine build is, for the run identity: the code that makes its deck, its templates, its version.

A run id (orchestrator.rundir) covers the build that turned the inputs into results. Nothing here
is a list someone keeps: the code is the import closure of the engine's package inside this
package (orchestrator.imports), so a module the deck depends on, however indirectly (the brick's
spheres in shapes/clump.py, the wall triangles in geometry.py), is in it the day it is imported. Each
module counts by its syntax tree without docstrings, so comments, docstrings and formatting change
no id; any change to code does. The engine's version is asked of the engine itself, once per
executable file (cached by path, size and modification time).
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import subprocess
from functools import lru_cache
from pathlib import Path

from orchestrator.imports import import_closure, package_modules

ENGINES_PACKAGE = "orchestrator.engines"


def _without_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                node.body = node.body[1:] or [ast.Pass()]
    return tree


def code_digest(path: Path) -> str:
    """sha256 of a module's code: its syntax tree, docstrings left out (comments never reach it)."""
    tree = _without_docstrings(ast.parse(path.read_text()))
    return hashlib.sha256(ast.dump(tree, annotate_fields=False, include_attributes=False).encode()).hexdigest()


def deck_modules(engine: str) -> list[str]:
    """Every module of the package that writes, runs or reads an engine's deck: the engine's own
    package (its adapter, runner program, deck writer) and all they import."""
    prefix = f"{ENGINES_PACKAGE}.{engine}"
    roots = [name for name in package_modules() if name == prefix or name.startswith(prefix + ".")]
    return import_closure(roots)


@lru_cache(maxsize=None)
def _code_hash(engine: str) -> str:
    modules = package_modules()
    digest = hashlib.sha256()
    for name in deck_modules(engine):
        digest.update(f"{name}\0{code_digest(modules[name])}\n".encode())
    return digest.hexdigest()


def deck_hash(engine: str, template_dir: Path | None) -> str:
    """sha256 over the deck modules' code (by module name; read once per process) and the templates
    in `template_dir` (their bytes, read each time: a user's own templates may change between runs)."""
    digest = hashlib.sha256(_code_hash(engine).encode())
    if template_dir is not None:
        for path in sorted(p for p in template_dir.rglob("*") if p.is_file()):
            digest.update(f"{path.relative_to(template_dir)}\0".encode())
            digest.update(hashlib.sha256(path.read_bytes()).hexdigest().encode())
    return digest.hexdigest()


def _cache_file() -> Path:
    root = Path(os.environ.get("DEMORCH_CACHE", Path.home() / ".cache" / "dem-orchestrator"))
    return root / "engine-versions.json"


@lru_cache(maxsize=None)
def engine_version(executable: str | None, arguments: tuple[str, ...], pattern: str) -> str | None:
    """The version an engine prints of itself (`executable` with `arguments`, the first group of
    `pattern` in its output), or None when it is missing or says nothing that matches. Asked once
    per executable file: the answer is cached by the file's path, size and modification time."""
    if executable is None:
        return None
    try:
        stat = Path(executable).resolve().stat()
    except OSError:
        return None
    key = f"{Path(executable).resolve()}|{stat.st_size}|{stat.st_mtime_ns}|{' '.join(arguments)}|{pattern}"
    cache = _cache_file()
    try:
        known = json.loads(cache.read_text())
    except (OSError, ValueError):
        known = {}
    if isinstance(known, dict) and key in known:
        return known[key]
    try:
        result = subprocess.run([executable, *arguments], capture_output=True, text=True, errors="replace", timeout=60,
                                stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired):
        return None
    match = re.search(pattern, result.stdout + result.stderr)
    version = match.group(1).strip() if match else None
    if version is not None:
        try:
            cache.parent.mkdir(parents=True, exist_ok=True)
            temporary = cache.with_name(f"{cache.name}.{os.getpid()}.tmp")
            temporary.write_text(json.dumps({**(known if isinstance(known, dict) else {}), key: version}, indent=1))
            os.replace(temporary, cache)
        except OSError:
            pass  # a read-only cache: ask again next time
    return version
