"""Validation errors as one line a user can act on: the field's path, the problem, the allowed range."""

from __future__ import annotations

import errno
import os
import reprlib
import stat
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
    constraints = list(info.metadata)
    vector = info.annotation
    if get_origin(vector) is tuple and location and isinstance(location[-1], int):  # an element of a vector field
        element = get_args(vector)[min(location[-1], len(get_args(vector)) - 1)]
        constraints += [c for meta in get_args(element)[1:] for c in getattr(meta, "metadata", [meta])]
    low = high = None
    low_open = high_open = True
    for constraint in constraints:
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
        if location and item["type"] != "missing" and "(got " not in message:  # a validator's message may name the value already
            text += f" (got {_SHORT.repr(item.get('input'))})"
        lines.append(bounded(text))
    shown = "; ".join(lines[:MAX_PROBLEMS])
    return shown + (f"; and {len(lines) - MAX_PROBLEMS} more problems" if len(lines) > MAX_PROBLEMS else "")


MAX_PROBLEMS = 5
MAX_MESSAGE = 300
# A value is shown cut short without ever being formatted whole (a huge list costs nothing here).
_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 60
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 4
_SHORT.maxlevel = 2


def bounded(text: str, limit: int = MAX_MESSAGE) -> str:
    """`text` on one line, at most `limit` characters."""
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


ModelT = TypeVar("ModelT", bound=BaseModel)


def parse_model(model: type[ModelT], data: object, source: str) -> ModelT:
    """Validate a mapping into `model` (a case, a study, a campaign), raising CaseError with one line."""
    if not isinstance(data, dict):
        raise CaseError(f"{source}: must be a mapping of fields, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as error:
        raise CaseError(f"{source}: {format_error(error, model)}") from None


MAX_FILE_BYTES = 16 * 1024 * 1024  # a case of 10 000 bricks is about 2 MB


class _StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """YAML's safe loader (libyaml's when present: 5 × faster), minus what lets a small file mislead or
    exhaust the reader: a key given twice (YAML keeps the last silently) and aliases (`*ref`, which
    a kilobyte of nested ones turns into gigabytes once expanded)."""

    def construct_document(self, node: yaml.Node) -> object:
        seen: set[int] = set()
        pending = [node]
        while pending:  # an alias is a node reached twice
            current = pending.pop()
            if id(current) in seen:
                raise yaml.constructor.ConstructorError(None, None, "aliases (*name) are not allowed; write the value out", current.start_mark)
            seen.add(id(current))
            if isinstance(current, yaml.SequenceNode):
                pending.extend(current.value)
            elif isinstance(current, yaml.MappingNode):
                pending.extend(part for pair in current.value for part in pair)
        return super().construct_document(node)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set[object] = set()
        for key_node, _ in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else id(key_node)
            if key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {str(key)[:40]!r}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _StrictLoader.construct_mapping)


def read_capped(path: str | Path, what: str, limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of the regular file `path`, at most `limit` of them, or CaseError naming the file.

    Bounded whatever `path` is: a FIFO or a device (/dev/zero) is refused before a byte is read (it
    is opened without blocking and checked with fstat), a symlink loop is an error, and the read
    stops at limit + 1 bytes, so a file that grows, or reports size 0, cannot exhaust memory."""
    path = Path(path)
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as error:
        reason = "a symlink loop" if error.errno == errno.ELOOP else error.strerror
        raise CaseError(f"{path}: cannot read the {what} ({reason})") from None
    mode = os.fstat(descriptor).st_mode
    if not stat.S_ISREG(mode):
        os.close(descriptor)
        kind = "a directory" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode) else "a device or socket"
        raise CaseError(f"{path}: cannot read the {what} (it is {kind}, not a regular file)")
    with os.fdopen(descriptor, "rb") as handle:
        try:
            data = handle.read(limit + 1)
        except OSError as error:
            raise CaseError(f"{path}: cannot read the {what} ({error.strerror})") from None
    if len(data) > limit:
        raise CaseError(f"{path}: the {what} is over {limit // 2**20} MB; allowed: at most {limit // 2**20} MB")
    return data


def read_yaml(path: str | Path, what: str = "case file") -> object:
    """The YAML document in `path` (strict safe loader: no duplicate keys, no aliases, a regular file
    of at most 16 MB), or CaseError naming the file and the problem."""
    path = Path(path)
    try:
        text = read_capped(path, what).decode("utf-8")
    except UnicodeDecodeError:
        raise CaseError(f"{path}: the {what} is not UTF-8 text") from None
    try:
        return yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as error:
        raise CaseError(f"{path}: not valid YAML ({bounded(str(error).splitlines()[0] if str(error) else type(error).__name__)})") from None
    except RecursionError:
        raise CaseError(f"{path}: not valid YAML (nested too deeply)") from None


def with_engine(model: ModelT, engine: str | None, source: str = "case") -> ModelT:
    """A case or study on another engine (`-e`), validated again (the engine may not run it);
    None keeps its own. Raises CaseError naming the field the engine cannot take."""
    if engine is None:
        return model
    try:
        return type(model).model_validate({**model.model_dump(mode="json"), "engine": engine})
    except ValidationError as error:
        raise CaseError(f"{source} on {engine}: {format_error(error, type(model))}") from None
