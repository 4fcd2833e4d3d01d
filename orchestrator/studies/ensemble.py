"""A study over seeds, in numbers: each metric's mean, spread, range and per-seed values, and a report
whose numbers are the members' means (for comparisons with references: the avalanche table reads it as
it reads one run's report). The members run as a campaign's points (campaign/ensemble.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def summarize(metrics: dict[int, dict[str, float]]) -> dict[str, dict[str, Any]]:
    """Per metric over the seeds (seed → flat metrics): n, mean, std (sample, ddof 1; 0 for one seed),
    min, max and the value of each seed. Seeds without a finite value are left out of that metric."""
    names = sorted({name for values in metrics.values() for name in values})
    out: dict[str, dict[str, Any]] = {}
    for name in names:
        by_seed = {seed: float(values[name]) for seed, values in metrics.items() if name in values and math.isfinite(float(values[name]))}
        if not by_seed:
            continue
        array = np.array(list(by_seed.values()))
        out[name] = {"n": len(array), "mean": float(array.mean()), "std": float(array.std(ddof=1)) if len(array) > 1 else 0.0,
                     "min": float(array.min()), "max": float(array.max()), "by_seed": {str(seed): v for seed, v in by_seed.items()}}
    return out


def mean_report(reports: list[dict[str, Any]]) -> dict[str, Any]:
    """A report whose numbers are the means of the members' (NaN-free members only): numbers averaged
    where every member has a number, flags true only when true for all, anything else (lists, text)
    the first member's."""

    def merge(values: list[Any]) -> Any:
        first = values[0]
        if isinstance(first, dict):
            return {key: merge([v[key] for v in values if isinstance(v, dict) and key in v]) for key in first}
        if isinstance(first, bool):
            return all(bool(v) for v in values)
        if all(v == first for v in values):  # the same in every member (the study's set-up): kept exactly
            return first
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            finite = [float(v) for v in values if math.isfinite(float(v))]
            return float(np.mean(finite)) if finite else float("nan")
        return first

    return merge(reports)
