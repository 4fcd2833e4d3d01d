"""Figures without pyplot: no global backend switch at import time, no global figure registry.

A `matplotlib.figure.Figure` made directly renders with the Agg canvas when saved, headless and
safe in campaign worker processes, and is freed with the last reference (nothing to close).
"""

from __future__ import annotations

from typing import Any

from matplotlib.figure import Figure


def subplots(*grid: int, figsize: tuple[float, float], **options: Any) -> tuple[Figure, Any]:
    """Like pyplot.subplots(nrows, ncols, figsize=…, constrained_layout=…, sharey=…, squeeze=…)."""
    layout = options.pop("constrained_layout", False)
    figure = Figure(figsize=figsize, layout="constrained" if layout else None)
    return figure, figure.subplots(*grid, **options)
