"""Response surfaces of campaign metrics."""

from __future__ import annotations

from pathlib import Path

from orchestrator.figures import subplots
import numpy as np
import pandas as pd


def response_surface(table: pd.DataFrame, x_name: str, y_name: str, metric: str, path: Path) -> None:
    """Filled contours of `metric` over (x, y) from completed runs (triangulated: grids and designs alike)."""
    x_col, y_col, z_col = f"param.{x_name}", f"param.{y_name}", f"metric.{metric}"
    done = table[table["status"] == "completed"]
    x, y, z = (done[c].to_numpy(dtype=float) for c in (x_col, y_col, z_col))
    fig, ax = subplots(figsize=(6, 5), constrained_layout=True)
    if len(np.unique(x)) > 1 and len(np.unique(y)) > 1 and len(x) >= 3:
        filled = ax.tricontourf(x, y, z, levels=12, cmap="viridis")
        ax.tricontour(x, y, z, levels=12, colors="k", linewidths=0.4)
        fig.colorbar(filled, ax=ax, label=metric)
    ax.scatter(x, y, c="w", edgecolors="k", s=25, zorder=3, label="runs", clip_on=False)
    ax.margins(0.04)
    ax.set_xlabel(x_name)
    ax.set_ylabel(y_name)
    ax.set_title(f"{metric} over ({x_name}, {y_name})")
    fig.savefig(path, dpi=120)
