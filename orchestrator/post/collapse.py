"""Metrics of a column collapse: pure functions of grain positions, velocities and sizes.

Frame as in `collapse`: x down the channel from the gate, z normal to the bed from its base plane.

Thickness. The deposit profile is an *equivalent thickness*: the grain volume per unit channel
length in a slice of the channel, divided by the channel width and the solid fraction,
h(x) = Σ V_i / (Δx · W · φ). In 2D (grains in one plane) V_i is the area of the grain's central
disc and W = 1. It is what a uniform layer of the prepared packing would be, which a few scattered
grains cannot fake: a lone grain of diameter d adds π d²/4 / (Δx φ) ≈ 0.4 d over the 3 d window
used for the front (2D; ≈ 0.05 d in 3D), while a continuous monolayer gives ≈ π d / (4 φ) ≈ 1 d.

Front. The front is the downstream end of the flowing mass. Slices of one d from the gate carry
the thickness *added* since the release, h(x, t) - h(x, 0) (which discounts the erodible bed already
there), averaged over 3 d. Slices where it reaches FRONT_THRESHOLD = 0.6 d are grouped into clusters
(gaps of up to FRONT_MAX_GAP = 6 d below the threshold join them); the front is the downstream end
of the farthest cluster holding at least FRONT_MIN_GRAINS grains' worth of added material, or 1 %
of the column, except a cluster detached from the mass behind it and lying against the channel's
end wall (grains that rolled there one by one and piled up). So a single grain, or a handful,
thrown ahead of the flow never moves the front, and a bed scoured behind the flow (added
thickness < 0) does not cut it short.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import savgol_filter

FRONT_THRESHOLD = 0.6  # × d: thickness added since the release that marks the flowing mass
FRONT_WINDOW = 3  # slices of one d averaged: the window the threshold applies to
FRONT_MAX_GAP = 6  # slices of one d below the threshold that separate two clusters
FRONT_MIN_GRAINS = 5  # a cluster needs this many grains' worth of added material (or 1 % of the column)
REST_SPEED = 0.02  # m/s: a front slower than this has stopped


def grain_measure(radii: np.ndarray, planar: bool) -> np.ndarray:
    """Volume of each grain (3D) or area of its central disc (2D, grains in one plane)."""
    return math.pi * radii**2 if planar else 4.0 / 3.0 * math.pi * radii**3


def thickness_profile(x: np.ndarray, measure: np.ndarray, edges: np.ndarray, width: float, fraction: float) -> np.ndarray:
    """Equivalent thickness h per slice [edges[k], edges[k+1]) (see the module docstring)."""
    volume, _ = np.histogram(x, bins=edges, weights=measure)
    return volume / (np.diff(edges) * width * fraction)


def front_from_profile(edges: np.ndarray, added: np.ndarray, diameter: float, min_amount: float) -> float:
    """The front (m from the gate) from the added thickness per slice of width d (module docstring).

    `min_amount`: the added thickness × length (m²) a cluster needs to count. Slices start at the
    gate (edges[0] = 0). Returns 0 when nothing has moved past the gate.
    """
    smooth = uniform_filter1d(added, size=FRONT_WINDOW, mode="constant")
    qualifying = np.flatnonzero(smooth >= FRONT_THRESHOLD * diameter)
    if qualifying.size == 0:
        return 0.0
    breaks = np.flatnonzero(np.diff(qualifying) > FRONT_MAX_GAP + 1)
    widths = np.diff(edges)

    def amount(cluster: np.ndarray) -> float:
        span = slice(cluster[0], cluster[-1] + 1)
        return float(np.sum(np.clip(added[span], 0.0, None) * widths[span]))

    clusters = [cluster for cluster in np.split(qualifying, breaks + 1) if amount(cluster) >= min_amount]
    if len(clusters) > 1 and clusters[-1][-1] >= len(added) - FRONT_WINDOW:
        # Detached and against the end wall: grains that rolled away one by one and piled up there
        # (an open channel would have let them spread); the front is the mass behind.
        clusters.pop()
    return float(edges[clusters[-1][-1] + 1]) if clusters else 0.0


@dataclass(frozen=True)
class ProfileGrid:
    """Slices of one mean diameter from the back wall to the channel end, and the normalisation."""

    edges: np.ndarray  # edges[gate] = 0: the gate is a slice edge
    diameter: float
    width: float  # W in 3D, 1 in 2D
    fraction: float  # solid fraction of the prepared column
    planar: bool
    min_amount: float  # added thickness × length a front cluster needs (front_from_profile)
    gate: int = 0  # index of the edge at x = 0


def profile_grid(channel_length: float, diameter: float, width: float, fraction: float, planar: bool, column_measure: float,
                 column_length: float = 0.0) -> ProfileGrid:
    """Slices of one d from the back wall (-column_length) to the channel end, one edge at the gate;
    `column_measure`: the column's total grain measure (volume or area)."""
    behind = int(math.ceil(column_length / diameter - 1e-9))
    ahead = max(1, int(round(channel_length / diameter)))
    grain = float(grain_measure(np.array([diameter / 2]), planar)[0])
    amount = max(FRONT_MIN_GRAINS * grain, 0.01 * column_measure) / (width * fraction)
    edges = diameter * np.arange(-behind, ahead + 1, dtype=float)
    return ProfileGrid(edges, diameter, width, fraction, planar, amount, gate=behind)


def column_fraction(radii: np.ndarray, length: float, height: float, width: float, planar: bool) -> float:
    """Solid fraction of the column at release: its grains' measure over R0 × H0 (× W; 1 in 2D)."""
    return float(grain_measure(radii, planar).sum() / (length * height * (1.0 if planar else width)))


def profiles(positions: np.ndarray, radii: np.ndarray, mobile: np.ndarray, grid: ProfileGrid) -> np.ndarray:
    """(frames, slices) thickness of the mobile grains: the deposit profile h(x, t)."""
    measure = grain_measure(radii[mobile], grid.planar)
    return np.array([thickness_profile(frame[mobile, 0], measure, grid.edges, grid.width, grid.fraction) for frame in positions])


def front_positions(thickness: np.ndarray, grid: ProfileGrid) -> np.ndarray:
    """(frames,) front position r_f(t) from h(x, t) (added thickness since frame 0), from the gate on."""
    edges = grid.edges[grid.gate :]
    return np.array([front_from_profile(edges, (row - thickness[0])[grid.gate :], grid.diameter, grid.min_amount) for row in thickness])


def front_velocity(times: np.ndarray, front: np.ndarray, window_s: float = 0.1) -> np.ndarray:
    """Smoothed dr_f/dt: a quadratic Savitzky-Golay derivative over `window_s` (odd frame count ≥ 5).

    The front moves by whole slices (one d): differences of raw positions are spiky; the window
    spans several slices at the slow-phase speeds.
    """
    if len(times) < 5:
        return np.gradient(front, times) if len(times) > 1 else np.zeros_like(front)
    dt = float(np.median(np.diff(times)))
    frames = max(5, int(round(window_s / dt)) | 1)
    frames = min(frames, len(times) if len(times) % 2 else len(times) - 1)
    return savgol_filter(front, frames, 2, deriv=1, delta=dt, mode="interp")


def front_phases(times: np.ndarray, velocity: np.ndarray, front: np.ndarray, rest_speed: float = REST_SPEED) -> dict[str, float | bool]:
    """The three phases of the front: acceleration, deceleration, slow propagation (then rest).

    - acceleration ends at the velocity maximum (t_max);
    - the front is at rest from the first time after t_max its speed stays below `rest_speed`
      (t_stop; the end of the record if it never does);
    - between them a two-segment line fit of v(t) (best break point) separates the deceleration
      from the slow propagation. The slow phase is reported when its deceleration is less than a
      quarter of the first segment's, it lasts at least 15 % of t_stop - t_max, and its mean speed
      is above `rest_speed`. Otherwise the deceleration lasts until rest.
    """
    peak = int(np.argmax(velocity))
    below = velocity < rest_speed
    stop = len(times) - 1
    for k in range(peak, len(times)):
        if below[k:].all():
            stop = k
            break
    result: dict[str, float | bool] = {
        "t_max": float(times[peak]), "x_max": float(front[peak]), "v_max": float(velocity[peak]),
        "t_stop": float(times[stop]), "x_stop": float(front[stop]), "at_rest": bool(below[stop:].all() and stop < len(times) - 1),
        "slow_phase": False, "t_slow": math.nan, "x_slow": math.nan, "v_slow": math.nan,
    }
    if stop - peak < 6:
        return result
    t, v = times[peak : stop + 1], velocity[peak : stop + 1]
    best = None
    for k in range(2, len(t) - 2):
        first = np.polyfit(t[: k + 1], v[: k + 1], 1)
        second = np.polyfit(t[k:], v[k:], 1)
        error = np.sum((np.polyval(first, t[: k + 1]) - v[: k + 1]) ** 2) + np.sum((np.polyval(second, t[k:]) - v[k:]) ** 2)
        if best is None or error < best[0]:
            best = (error, k, first[0], second[0])
    _, k, slope_fast, slope_slow = best  # type: ignore[misc]
    duration = t[-1] - t[k]
    mean_slow = float(np.mean(v[k:]))
    if slope_fast < 0 and abs(slope_slow) < 0.25 * abs(slope_fast) and duration >= 0.15 * (t[-1] - t[0]) and mean_slow > rest_speed:
        result.update(slow_phase=True, t_slow=float(t[k]), x_slow=float(front[peak + k]), v_slow=mean_slow)
    return result


def static_flowing_interface(z: np.ndarray, ux: np.ndarray, x: np.ndarray, radii: np.ndarray, at: float, diameter: float,
                             threshold: float = 0.01) -> float:
    """h_sf at x = `at`: the height below which the grains are static (u_x < threshold, 1 cm/s).

    Grains within one d of `at` are layered by height (layers of one d); scanning down from the free
    surface, the first layer whose mean u_x is below the threshold is the top of the static part:
    h_sf is its upper edge (the free surface when nothing flows, the base when everything does).
    This is the study's "lowest z inside the bed where u_x < 1 cm/s", read as the interface of a
    static layer under a flowing one. NaN when no grain is there.
    """
    near = np.abs(x - at) <= diameter
    if not near.any():
        return math.nan
    heights, speeds = z[near], ux[near]
    top = float((heights + radii[near]).max())
    edges = np.arange(0.0, top + diameter, diameter)
    for upper, lower in zip(edges[::-1][:-1], edges[::-1][1:]):
        layer = (heights >= lower) & (heights < upper)
        if layer.any() and float(speeds[layer].mean()) < threshold:
            return min(float(upper), top)
    return 0.0


def bed_energy_ratio(z: np.ndarray, velocity: np.ndarray, masses: np.ndarray, bed: np.ndarray, g_normal: float) -> float:
    """e_k = E_k(bed) / E_p(bed): kinetic energy of the erodible bed's grains over their potential
    energy m g cos α z above the base plane (so e_k = 0 for a bed at rest). NaN without a bed."""
    if not bed.any():
        return math.nan
    kinetic = 0.5 * float(np.sum(masses[bed] * np.sum(velocity[bed] ** 2, axis=1)))
    potential = g_normal * float(np.sum(masses[bed] * z[bed]))
    return kinetic / potential


def entrained_mass(positions: np.ndarray, initial: np.ndarray, masses: np.ndarray, bed: np.ndarray, diameter: float) -> float:
    """Mass of erodible-bed grains that have moved more than one mean diameter from where they lay."""
    moved = np.linalg.norm(positions[bed] - initial[bed], axis=1) > diameter
    return float(masses[bed][moved].sum())
