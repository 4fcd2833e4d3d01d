"""A study's seeds: one draw (`seed`) or an ensemble (`seeds`), each seed its own preparation and release.

A study file may give `seeds:` as a count (that many seeds from its `seed` on: 3 with seed 2009 is
2009, 2010, 2011) or as a list. Each seed is a member study of its own (`seed` set, `seeds` unset),
content-addressed like any study, so a member already run is reused and adding a seed runs only
that seed (campaign.ensemble runs the members as the points of a campaign).
"""

from __future__ import annotations

from typing import Annotated, Any, Union

from pydantic import PlainValidator, WithJsonSchema

MAX_SEED = 2**31 - 1
MAX_MEMBERS = 1000

ALLOWED = f"allowed: a count 1–{MAX_MEMBERS} or a list of 1–{MAX_MEMBERS} distinct whole numbers 1–{MAX_SEED}"


def _parse(value: Any) -> int | list[int] | None:
    """The `seeds` field: a count or a list of distinct seeds, checked in one message."""
    def whole(item: Any) -> bool:
        return isinstance(item, int) and not isinstance(item, bool)

    if value is None:
        return None
    if whole(value):
        if not 1 <= value <= MAX_MEMBERS:
            raise ValueError(f"{value} seeds; {ALLOWED}")
        return int(value)
    if isinstance(value, (list, tuple)):
        if not 1 <= len(value) <= MAX_MEMBERS or not all(whole(item) and 1 <= item <= MAX_SEED for item in value):
            raise ValueError(f"{list(value)[:10]!r} is not a list of 1–{MAX_MEMBERS} seeds; {ALLOWED}")
        repeated = sorted({item for item in value if list(value).count(item) > 1})
        if repeated:
            raise ValueError(f"{repeated} given more than once; {ALLOWED}")
        return [int(item) for item in value]
    raise ValueError(f"{value!r:.60} is neither a count nor a list; {ALLOWED}")


# The field both study kinds carry (None: the study is one draw, its `seed`).
Seeds = Annotated[
    Union[int, list[int], None],
    PlainValidator(_parse),
    WithJsonSchema({"anyOf": [{"type": "integer", "minimum": 1, "maximum": MAX_MEMBERS},
                              {"type": "array", "items": {"type": "integer", "minimum": 1, "maximum": MAX_SEED},
                               "minItems": 1, "maxItems": MAX_MEMBERS, "uniqueItems": True},
                              {"type": "null"}],
                    "description": "a count of seeds from `seed` on, or a list of seeds"}),
]


def member_seeds(seed: int, seeds: int | list[int] | None) -> list[int]:
    """The seeds of a study's members: [seed] for one draw, `seeds` as listed, or a count of them
    from `seed` on. ValueError when a count runs past the largest seed (2³¹ − 1)."""
    if seeds is None:
        return [seed]
    if isinstance(seeds, list):
        return list(seeds)
    if seed + seeds - 1 > MAX_SEED:
        raise ValueError(f"seeds: {seeds} seeds from seed {seed} run past {MAX_SEED}; allowed: seed + seeds - 1 ≤ {MAX_SEED}")
    return list(range(seed, seed + seeds))


def is_ensemble(study: Any) -> bool:
    """Whether a study (a validated model or its mapping) asks for several seeds or a list of them."""
    seeds = study.get("seeds") if isinstance(study, dict) else getattr(study, "seeds", None)
    return seeds is not None


def members(data: dict[str, Any]) -> list[tuple[int, dict[str, Any]]]:
    """(seed, member study mapping) for each seed of a study mapping: `seed` set, `seeds` dropped."""
    seeds = member_seeds(int(data.get("seed", 1)), data.get("seeds"))
    return [(seed, {**{k: v for k, v in data.items() if k != "seeds"}, "seed": seed}) for seed in seeds]
