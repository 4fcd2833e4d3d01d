"""Validation errors as one line a user can act on: the field's path, the problem, the allowed range."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, ValidationError


class CaseError(ValueError):
    """A case, study or campaign that cannot be run; the message names the field and the allowed range."""


_BOUND_ERRORS = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def allowed_range(root: type[BaseModel], location: tuple[object, ...]) -> str | None:
    """'(0, 1e12]'-style range of the numeric field of `root` at `location`, from its Field constraints."""
    annotation: object = root
    info = None
    for part in location:
        while get_origin(annotation) in (list, tuple, Union) or str(get_origin(annotation)) == "typing.Annotated":
            if get_origin(annotation) in (list, tuple):
                annotation = get_args(annotation)[0]
            elif get_origin(annotation) is Union:
                annotation = next((a for a in get_args(annotation) if isinstance(a, type) and issubclass(a, BaseModel)), annotation)
                break
            else:
                annotation = get_args(annotation)[0]
        if isinstance(part, int):
            continue
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)) or part not in annotation.model_fields:
            return None
        info = annotation.model_fields[part]
        annotation = info.annotation
    if info is None:
        return None
    low = high = None
    low_open = high_open = True
    for constraint in info.metadata:
        for name, closed in (("gt", False), ("ge", True)):
            if getattr(constraint, name, None) is not None:
                low, low_open = getattr(constraint, name), not closed
        for name, closed in (("lt", False), ("le", True)):
            if getattr(constraint, name, None) is not None:
                high, high_open = getattr(constraint, name), not closed
    if low is None and high is None:
        return None
    left = "(" if low_open or low is None else "["
    right = ")" if high_open or high is None else "]"
    return f"{left}{'-inf' if low is None else low:.10g}, {'inf' if high is None else high:.10g}{right}"


def format_error(error: ValidationError, root: type[BaseModel] | None = None) -> str:
    """One line: `field.path: message (got value)` for each problem, joined by '; '; a bound names the
    allowed range when `root` (the validated model) is given."""
    lines = []
    for item in error.errors():
        location = tuple(part for part in item["loc"] if isinstance(part, int) or ("[" not in part and "(" not in part))
        message = item["msg"].removeprefix("Value error, ")
        if item["type"] == "string_pattern_mismatch":
            message = "must start with a letter and hold only letters, digits and '_' (1 to 40 characters)"
        if item["type"] in _BOUND_ERRORS:
            allowed = allowed_range(root, location) if root is not None else None
            message = f"{message}; allowed range: {allowed}" if allowed else message
        text = f"{'.'.join(str(p) for p in location)}: {message}" if location else message
        if location and item["type"] != "missing":
            shown = repr(item.get("input"))
            text += f" (got {shown[:57] + '...' if len(shown) > 60 else shown})"
        lines.append(text)
    return "; ".join(lines)


ModelT = TypeVar("ModelT", bound=BaseModel)


def parse_model(model: type[ModelT], data: object, source: str) -> ModelT:
    """Validate a mapping into `model` (a case, a study, a campaign), raising CaseError with one line."""
    if not isinstance(data, dict):
        raise CaseError(f"{source}: must be a mapping of fields, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as error:
        raise CaseError(f"{source}: {format_error(error, model)}") from None


def read_yaml(path: str | Path, what: str = "case file") -> object:
    """The YAML document in `path` (safe loader), or CaseError naming the file and the problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise CaseError(f"{path}: cannot read the {what} ({error.strerror})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise CaseError(f"{path}: not valid YAML ({str(error).splitlines()[0]})") from None
