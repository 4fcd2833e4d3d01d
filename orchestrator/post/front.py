"""Mass front of a granular flow: position and velocity versus time, robust to stray bodies.

Criterion (density, not the single farthest body): the front is the largest x such that the bodies
whose centres lie in [x - window, x] carry at least `min_fraction` of the total mass. A lone brick
thrown ahead holds far less than that and is ignored; the window (default 2 body diameters) sets the
spatial resolution. Velocity: Savitzky-Golay derivative of the front position (quadratic fits over a
`smooth_window`-frame window), which smooths the steps that a discrete front takes.

Whose front: given `members`, only those bodies make it. The avalanche study passes the bodies that
end in the deposit (deposit.deposit_members): a group that runs ahead and later leaves the deposit
then never holds the front, so the front does not jump back when the group detaches (it did, by
0.22 m, on the demo), the phase fit reads the main mass, and the final front is the deposit's
distal end R less at most one window.
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
    members: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Front position (F,) and smoothed velocity (F,) for positions x (F, B) along the flow, made by
    the bodies of `members` (B,) bool (default: all); min_fraction is a share of their mass."""
    if members is not None:
        x, mass = x[:, members], mass[members]
    position = np.array([front_position(frame, mass, window, min_fraction) for frame in x])
    frames = len(time)
    length = min(smooth_window, frames if frames % 2 else frames - 1)
    if length < 3:
        return position, np.gradient(position, time) if frames > 1 else np.zeros(frames)
    step = float(np.median(np.diff(time)))
    velocity = savgol_filter(position, length, polyorder=2, deriv=1, delta=step, mode="interp")
    return position, velocity


def flat_phases(position: np.ndarray, velocity: np.ndarray, min_points: int = 3) -> dict[str, float | bool] | None:
    """The front's phases on the flat board, as the 2012 study reads its Figs 12c/14c: v against x.

    From the first frame with the front on the flat (x ≥ 0) to the frame where it first reaches its
    farthest x, v(x) is fitted with three straight segments (the pair of break points with the least
    squared error, each segment at least `min_points` frames). Returned: the break points x_1, x_2,
    the slopes dv/dx of the three segments (negative: deceleration), the farthest x, and whether the
    pattern is strong / slow / strong (the middle slope smaller in magnitude than both others). None
    when the front spends fewer than 3 × min_points frames on the flat.
    """
    finite = np.isfinite(position) & np.isfinite(velocity)
    on_flat = np.flatnonzero(finite & (position >= 0.0))
    if on_flat.size == 0:
        return None
    first = int(on_flat[0])
    last = first + int(np.nanargmax(np.where(finite[first:], position[first:], -np.inf)))
    x, v = position[first : last + 1], velocity[first : last + 1]
    keep = np.isfinite(x) & np.isfinite(v)
    x, v = x[keep], v[keep]
    if len(x) < 3 * min_points:
        return None

    def line(i: int, j: int) -> tuple[float, float]:
        """Slope of the least-squares line through points i..j-1 and its squared error."""
        # A front that moves less than a micron over the stretch is standing: no slope to fit (and
        # polyfit would warn that the fit is poorly conditioned).
        slope, intercept = np.polyfit(x[i:j], v[i:j], 1) if np.ptp(x[i:j]) > 1e-6 else (0.0, float(np.mean(v[i:j])))
        return float(slope), float(np.sum((slope * x[i:j] + intercept - v[i:j]) ** 2))

    best = None
    n = len(x)
    for a in range(min_points, n - 2 * min_points + 1):
        for b in range(a + min_points, n - min_points + 1):
            (s1, e1), (s2, e2), (s3, e3) = line(0, a), line(a, b), line(b, n)
            if best is None or e1 + e2 + e3 < best[0]:
                best = (e1 + e2 + e3, a, b, s1, s2, s3)
    _, a, b, s1, s2, s3 = best  # type: ignore[misc]
    return {
        "x_1": float((x[a - 1] + x[a]) / 2), "x_2": float((x[b - 1] + x[b]) / 2), "x_stop": float(x[-1]),
        "slope_1": s1, "slope_2": s2, "slope_3": s3,
        "strong_slow_strong": bool(abs(s2) < abs(s1) and abs(s2) < abs(s3)),
    }
