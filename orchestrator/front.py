"""Mass front of a granular flow: position and velocity versus time, robust to stray bodies.

Criterion (density, not the single farthest body): the front is the largest x such that the bodies
whose centres lie in [x - window, x] carry at least `min_fraction` of the total mass. A lone brick
thrown ahead holds far less than that and is ignored; the window (default 2 body diameters) sets the
spatial resolution. Velocity: Savitzky-Golay derivative of the front position (quadratic fits over a
`smooth_window`-frame window), which smooths the steps that a discrete front takes.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter


def front_position(x: np.ndarray, mass: np.ndarray, window: float, min_fraction: float = 0.01) -> float:
    """Front of one frame from body positions x (B,) along the flow and masses (B,); NaN bodies are ignored."""
    present = np.isfinite(x)
    x, mass = x[present], mass[present]
    order = np.argsort(x)
    x, mass = x[order], mass[order]
    cumulative = np.concatenate([[0.0], np.cumsum(mass)])
    # Mass in [x_i - window, x_i] for each body i taken as the window's leading edge.
    start = np.searchsorted(x, x - window, side="left")
    in_window = cumulative[np.arange(1, len(x) + 1)] - cumulative[start]
    dense = np.flatnonzero(in_window >= min_fraction * mass.sum())
    return float(x[dense[-1]]) if dense.size else float("nan")


def front_curve(
    time: np.ndarray,
    x: np.ndarray,
    mass: np.ndarray,
    window: float,
    min_fraction: float = 0.01,
    smooth_window: int = 7,
) -> tuple[np.ndarray, np.ndarray]:
    """Front position (F,) and smoothed velocity (F,) for positions x (F, B) along the flow."""
    position = np.array([front_position(frame, mass, window, min_fraction) for frame in x])
    frames = len(time)
    length = min(smooth_window, frames if frames % 2 else frames - 1)
    if length < 3:
        return position, np.gradient(position, time) if frames > 1 else np.zeros(frames)
    step = float(np.median(np.diff(time)))
    velocity = savgol_filter(position, length, polyorder=2, deriv=1, delta=step, mode="interp")
    return position, velocity
