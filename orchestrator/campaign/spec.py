"""A campaign file: a base case plus what varies, expanded into a list of validated cases.

Parameters are dotted paths into the case (`contacts.1.mu`, `bodies.spheres.0.velocity.2`).
Designs: `grid` (every combination), `zip` (lists taken together), `lhs` and `sobol` (scipy.stats.qmc
over ranges). Each design block multiplies the others (a grid × a Sobol design, say); `replicates`
repeats every point with several seeds (as a study's own `seeds` do: each seed a point); `derived` sets parameters from others with arithmetic
expressions (`contacts.0.kn: "contacts.1.kn * 2"`), evaluated by a small AST walker, never `eval`.
"""

from __future__ import annotations

import ast
import copy
import itertools
import math
import re
import operator
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import Field, model_validator
from scipy.stats import qmc

from orchestrator.case import CaseError, Name, Strict, parse_model, read_yaml
from orchestrator.engines import Engine
from orchestrator.studies.registry import LAUNCH_KINDS, detect, launch_kind
from orchestrator.studies.seeds import is_ensemble, members

ParameterPath = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\.([A-Za-z_][A-Za-z0-9_]*|[0-9]+))*$")]


class GridDesign(Strict):
    kind: Literal["grid"]
    parameters: dict[ParameterPath, Annotated[list[Any], Field(min_length=1)]]


class ZipDesign(Strict):
    kind: Literal["zip"]
    parameters: dict[ParameterPath, Annotated[list[Any], Field(min_length=1)]]

    @model_validator(mode="after")
    def _same_lengths(self) -> "ZipDesign":
        if len({len(v) for v in self.parameters.values()}) > 1:
            raise ValueError("every list of a zip design must have the same length")
        return self


class SampledDesign(Strict):
    """Latin hypercube or Sobol points over [low, high] ranges (Sobol: n is rounded up to a power of 2)."""

    kind: Literal["lhs", "sobol"]
    samples: Annotated[int, Field(ge=1, le=100_000)]
    seed: Annotated[int, Field(ge=0)] = 0
    ranges: dict[ParameterPath, tuple[float, float]]

    @model_validator(mode="after")
    def _ordered(self) -> "SampledDesign":
        for name, (low, high) in self.ranges.items():
            if not low < high:
                raise ValueError(f"ranges.{name}: low must be below high")
        return self


Design = Annotated[Union[GridDesign, ZipDesign, SampledDesign], Field(discriminator="kind")]


class CampaignSpec(Strict):
    name: Name
    base: str  # a case file, an avalanche study or a collapse study, relative to the campaign file
    # What `base` is: a case, an avalanche study (packing + release + measures; its runs share
    # packings) or a collapse study (its runs share preparations). `auto`: a collapse study when the
    # file has `column`, `channel` or `grains`; an avalanche study when it has `packing`, `release`,
    # `geometry` or `brick`; either only without `bodies`.
    kind: Literal[("auto", *LAUNCH_KINDS)] = "auto"  # type: ignore[valid-type]
    engine: Engine | None = None
    designs: list[Design] = []
    replicates: Annotated[int, Field(ge=1, le=10_000)] = 1
    derived: dict[ParameterPath, str] = {}
    timeout_s: Annotated[float, Field(gt=0, json_schema_extra={"unit": "s"})] | None = None


def base_kind(spec: CampaignSpec, base: dict[str, Any]) -> str:
    """`case`, or the study kind (studies.registry) each point of the campaign runs."""
    return spec.kind if spec.kind != "auto" else detect(base)


def validate_point(kind: str, data: dict[str, Any], source: str) -> Any:
    """A validated case, or study of that kind, from a mapping."""
    return launch_kind(kind).parse(data, source)


@dataclass(frozen=True)
class Campaign:
    """A campaign as launched: its spec, its base case or study (a mapping) and where the base lives
    (files the base names are read beside it). From a campaign file (load_campaign) or made in memory
    (a study's seeds: campaign.ensemble)."""

    spec: CampaignSpec
    base: dict[str, Any]
    base_path: Path


def open_campaign(path: Path) -> Campaign:
    """The campaign file at `path` with its base, both validated (CaseError in one line)."""
    spec = parse_model(CampaignSpec, read_yaml(path, "campaign"), str(path))
    base_path = (path.parent / spec.base).resolve()
    try:
        base = read_yaml(base_path, "base case")
    except CaseError as error:
        raise CaseError(f"{path}: base: {error}") from None
    kind = base_kind(spec, base)
    looks = [name for name, launch in LAUNCH_KINDS.items() if name != "case" and launch.detect(base)]
    if spec.kind != "auto" and looks and spec.kind not in looks:  # a study of another kind: say so, not the other schema's errors
        raise CaseError(f"{path}: kind: {spec.kind!r}, but its base {base_path.name} is {_article(looks[0])}; "
                        f"allowed: {looks[0]!r} or auto (or a base of kind {spec.kind!r})")
    validate_point(kind, base, str(base_path))  # the base must be valid on its own
    return Campaign(spec, base, base_path)


def _article(kind: str) -> str:
    return "a case" if kind == "case" else f"{'an' if kind[0] in 'aeiou' else 'a'} {kind} study"


def load_campaign(path: Path) -> tuple[CampaignSpec, dict[str, Any]]:
    """The campaign and its base case or study (as a mapping), both validated."""
    campaign = open_campaign(path)
    return campaign.spec, campaign.base


MAX_POINTS = 100_000  # runs in one campaign


def _design_size(design: GridDesign | ZipDesign | SampledDesign) -> int:
    """The number of points a design gives, without making them."""
    if isinstance(design, GridDesign):
        return math.prod(len(values) for values in design.parameters.values())
    if isinstance(design, ZipDesign):
        return len(next(iter(design.parameters.values()), []))
    return design.samples if design.kind == "lhs" else 2 ** int(np.ceil(np.log2(design.samples)))


def design_points(design: GridDesign | ZipDesign | SampledDesign) -> list[dict[str, Any]]:
    if isinstance(design, GridDesign):
        names = list(design.parameters)
        return [dict(zip(names, values)) for values in itertools.product(*design.parameters.values())]
    if isinstance(design, ZipDesign):
        names = list(design.parameters)
        return [dict(zip(names, values)) for values in zip(*design.parameters.values())]
    names = list(design.ranges)
    if design.kind == "lhs":
        unit = qmc.LatinHypercube(d=len(names), seed=design.seed).random(design.samples)
    else:
        exponent = int(np.ceil(np.log2(design.samples)))
        unit = qmc.Sobol(d=len(names), scramble=True, seed=design.seed).random_base2(exponent)
    low = np.array([design.ranges[n][0] for n in names])
    high = np.array([design.ranges[n][1] for n in names])
    scaled = qmc.scale(unit, low, high)
    return [{n: float(v) for n, v in zip(names, row)} for row in scaled]


def set_path(data: dict[str, Any], path: str, value: Any) -> None:
    """Set a dotted path in nested dicts/lists; the path must exist (typos are errors, not new keys)."""
    parts = path.split(".")
    node: Any = data
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        key: Any = int(part) if part.isdigit() else part
        try:
            if last:
                if isinstance(node, dict) and key not in node and not _optional_key(parts):
                    raise KeyError(key)
                node[key] = value
            else:
                node = node[key]
        except (KeyError, IndexError, TypeError):
            raise CaseError(f"campaign parameter {path!r}: the base case has no {'.'.join(parts[: depth + 1])!r}") from None


def _optional_key(parts: list[str]) -> bool:
    """Leaves a campaign may add although the base omits them (they have defaults in the case model)."""
    return parts[-1] in {"law", "seed", "velocity", "contacts", "apparent_density", "brick_brick_mu", "angular_velocity", "step", "safety_factor", "engine", "fixed_rotation", "domain", "orientation"}


def get_path(data: dict[str, Any], path: str) -> Any:
    node: Any = data
    for part in path.split("."):
        node = node[int(part)] if part.isdigit() else node[part]
    return node


_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv, ast.Pow: operator.pow}


def evaluate(expression: str, data: dict[str, Any]) -> float:
    """Arithmetic over numbers and dotted case paths: + - * / ** and parentheses, nothing else."""

    def walk(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -walk(node.operand)
        if isinstance(node, (ast.Name, ast.Attribute, ast.Subscript)):
            return float(get_path(data, _dotted(node)))
        raise CaseError(f"derived expression {expression!r}: only numbers, case paths and + - * / ** are allowed")

    try:
        # Case paths index lists with dots (contacts.0.kn); Python wants contacts[0].kn.
        return walk(ast.parse(re.sub(r"(?<=[A-Za-z_\]])\.(\d+)", r"[\1]", expression), mode="eval"))
    except CaseError:
        raise
    except (SyntaxError, RecursionError, ValueError):
        raise CaseError(f"derived expression {expression[:80]!r} is not valid arithmetic") from None
    except ZeroDivisionError:
        raise CaseError(f"derived expression {expression[:80]!r} divides by zero") from None
    except OverflowError:
        raise CaseError(f"derived expression {expression[:80]!r} overflows (its value is beyond 1e308)") from None
    except (KeyError, IndexError, TypeError):
        raise CaseError(f"derived expression {expression!r} names a path the case does not have") from None


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
        return f"{_dotted(node.value)}.{node.slice.value}"
    raise CaseError("derived expressions may only name case paths like contacts.0.kn")


def expand(spec: CampaignSpec, base: dict[str, Any]) -> list[tuple[dict[str, Any], Any]]:
    """(varied parameters, validated case or study) for every point × replicate, in a stable order."""
    kind = base_kind(spec, base)
    if launch_kind(kind).fill_defaults:  # a study: every field present (defaults filled in), so any study path can vary
        base = validate_point(kind, base, spec.base).model_dump(mode="json")
    size = math.prod([_design_size(design) for design in spec.designs]) * spec.replicates
    if size > MAX_POINTS:
        raise CaseError(f"designs: {size:.3g} runs (the product of the designs' sizes × replicates); allowed: at most {MAX_POINTS}")
    blocks = [design_points(design) for design in spec.designs] or [[{}]]
    points = [dict(itertools.chain.from_iterable(p.items() for p in combo)) for combo in itertools.product(*blocks)]
    expanded = []
    for index, point in enumerate(points):
        for replicate in range(spec.replicates):
            data = copy.deepcopy(base)
            if spec.engine:
                data["engine"] = spec.engine.value
            parameters = dict(point)
            if spec.replicates > 1:
                data["seed"] = int(base.get("seed", 12345)) + replicate
                parameters["seed"] = data["seed"]
            for path, value in point.items():
                set_path(data, path, value)
            for path, expression in spec.derived.items():
                value = evaluate(expression, data)
                set_path(data, path, value)
                parameters[path] = value
            source = f"{spec.name} point {index}" + (f" replicate {replicate}" if spec.replicates > 1 else "")
            expanded.extend(_members(kind, spec, parameters, data, source))
    return expanded


def _members(kind: str, spec: CampaignSpec, parameters: dict[str, Any], data: dict[str, Any], source: str) -> list[tuple[dict[str, Any], Any]]:
    """A point as its runs: itself, or one run per seed of a study with `seeds` (studies/seeds.py),
    each its own point with `seed` among its parameters."""
    if not is_ensemble(data):
        return [(parameters, validate_point(kind, data, source))]
    if spec.replicates > 1:
        raise CaseError(f"{spec.base}: seeds: the study has seeds and the campaign replicates {spec.replicates}; give one of them")
    validate_point(kind, data, source)  # the study as written (its seeds checked), before its members
    return [({**parameters, "seed": seed}, validate_point(kind, member, f"{source} seed {seed}")) for seed, member in members(data)]
