"""Jinja2 rendering with one rule per engine about what may reach the generated text.

YADE scripts are Python, so every value must arrive as a Python literal made by `py_literal`:
the environment's `finalize` hook refuses anything else, which makes template injection from a
case file impossible even if a template forgets a filter. LIGGGHTS decks accept numbers and
names that match the case's strict name pattern only.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
from functools import lru_cache
from pathlib import Path
from typing import Any

import jinja2

PACKAGED_TEMPLATES = Path(__file__).resolve().parents[2] / "templates"


def template_root() -> Path:
    """$DEMORCH_TEMPLATES (a user's own copy of the deck templates), else the project's templates/."""
    return Path(os.environ.get("DEMORCH_TEMPLATES", PACKAGED_TEMPLATES))

_SAFE_DECK_WORD = re.compile(r"^[A-Za-z0-9_./+\- :]*$")  # no newline, $, #, &, quotes


class PyLiteral(str):
    """Text known to be a Python literal produced by `py_literal`."""


def py_literal(value: Any) -> PyLiteral:
    """Render data as a Python literal (numbers round-trip exactly via repr)."""
    if isinstance(value, PyLiteral):
        return value
    if value is None or isinstance(value, bool):
        return PyLiteral(repr(value))
    if isinstance(value, int):
        return PyLiteral(repr(value))
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"refusing to render a non-finite number {value!r}")
        return PyLiteral(repr(value))
    if isinstance(value, str):
        return PyLiteral(repr(value))
    if isinstance(value, (list, tuple)):
        items = ", ".join(py_literal(v) for v in value)
        return PyLiteral(f"[{items}]" if isinstance(value, list) else f"({items}{',' if len(value) == 1 else ''})")
    if isinstance(value, dict):
        items = ", ".join(f"{py_literal(k)}: {py_literal(v)}" for k, v in value.items())
        return PyLiteral("{" + items + "}")
    if hasattr(value, "item"):  # numpy scalar
        return py_literal(value.item())
    raise TypeError(f"cannot render {type(value).__name__} into a YADE script")


def _yade_finalize(value: Any) -> str:
    if isinstance(value, PyLiteral):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return py_literal(value)
    raise jinja2.TemplateError(f"YADE template emitted a raw value {value!r}: pass it through |py")


def deck_number(value: Any) -> str:
    """A number for a LIGGGHTS deck, with full precision."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"expected a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"refusing to render a non-finite number {value!r}")
    return repr(value) if isinstance(value, float) else str(value)


def _liggghts_finalize(value: Any) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return deck_number(value)
    text = str(value)
    if isinstance(value, str) and not _SAFE_DECK_WORD.match(text):
        raise jinja2.TemplateError(f"LIGGGHTS template emitted unsafe text {text!r}")
    return text


def environment(engine: str) -> jinja2.Environment:
    return _environment(engine, template_root())


@lru_cache(maxsize=None)
def _environment(engine: str, root: Path) -> jinja2.Environment:
    finalize = _yade_finalize if engine == "yade" else _liggghts_finalize
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root / engine)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
        finalize=finalize,
    )
    env.filters["py"] = py_literal
    env.filters["num"] = deck_number
    return env


def render(engine: str, template: str, context: dict[str, Any]) -> str:
    return environment(engine).get_template(template).render(**context)


def template_hash(engine: str) -> str:
    """sha256 over every template file of an engine: recorded in run.json to tie results to decks."""
    digest = hashlib.sha256()
    # cocd has no template: its deck is data, and what turns it into steps is the package's solver
    folder = Path(__file__).resolve().parent / "cocd" if engine == "cocd" else template_root() / engine
    for path in sorted(folder.rglob("*.py") if engine == "cocd" else folder.rglob("*")):
        if path.is_file():
            digest.update(path.relative_to(folder.parent).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()
