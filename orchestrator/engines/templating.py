"""One rendering path for every engine's deck: Jinja2 templates whose values arrive as data.

A rendered deck is a file to read, edit and run by hand (`liggghts -in in.liggghts`,
`yade -x -n script.py`). Every value printed into it passes one `finalize`: a number as its exact
repr (a non-finite one is refused), text only when it is a safe deck word (the case's strict names,
file names: no newline, quote, `$`, `#` or `&`); anything else is a template error. Structured data
enters through the `data` filter: one JSON document written as a Python string literal, which a
YADE script parses with json.loads. So a value from a case file is data in every deck, never code,
and no engine has safe-rendering code of its own.
"""

from __future__ import annotations

import json
import math
import os
import re
from functools import lru_cache
from pathlib import Path
from typing import Any

import jinja2
import numpy as np

PACKAGED_TEMPLATES = Path(__file__).resolve().parents[2] / "templates"

_SAFE_DECK_WORD = re.compile(r"^[A-Za-z0-9_./+\- :]*$")  # no newline, $, #, &, quotes


def template_root() -> Path:
    """$DEMORCH_TEMPLATES (a user's own copy of the deck templates), else the project's templates/."""
    return Path(os.environ.get("DEMORCH_TEMPLATES", PACKAGED_TEMPLATES))


def deck_number(value: Any) -> str:
    """A number for a deck, with full precision."""
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()  # numpy 2 writes repr(np.float64(0.5)) as 'np.float64(0.5)'
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"expected a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"refusing to render a non-finite number {value!r}")
    return repr(value) if isinstance(value, float) else str(value)


class DataLiteral(str):
    """A Python string literal holding a JSON document, made by `data_literal`."""


def data_literal(value: Any) -> DataLiteral:
    """`value` as JSON (exact floats; NaN and infinity refused) inside a Python string literal."""
    try:
        text = json.dumps(value, allow_nan=False, sort_keys=True, separators=(",", ":"), default=_plain)
    except ValueError as error:
        raise ValueError(f"refusing to render deck data: {error}") from None
    return DataLiteral(repr(text))


def _plain(value: Any) -> Any:
    if hasattr(value, "item"):  # numpy scalar
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot render {type(value).__name__} into a deck")


def _finalize(value: Any) -> str:
    if isinstance(value, DataLiteral):
        return value
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return deck_number(value)
    text = str(value)
    if isinstance(value, str) and not _SAFE_DECK_WORD.match(text):
        raise jinja2.TemplateError(f"a template emitted unsafe text {text!r}: pass data through |data")
    return text


def environment(engine: str) -> jinja2.Environment:
    return _environment(engine, template_root())


@lru_cache(maxsize=None)
def _environment(engine: str, root: Path) -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root / engine)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
        finalize=_finalize,
    )
    env.filters["num"] = deck_number
    env.filters["data"] = data_literal
    return env


def render(engine: str, template: str, context: dict[str, Any]) -> str:
    return environment(engine).get_template(template).render(**context)


def template_hash(engine: str) -> str:
    """sha256 over what turns a case into an engine's deck, recorded in every run id: the code that
    writes, runs and reads it (engines.build: the import closure of the engine's package) and the
    engine's templates. cocd has no template: its deck is data, its runner program is code."""
    from orchestrator.engines.build import deck_hash

    directory = template_root() / engine
    return deck_hash(engine, directory if directory.is_dir() else None)
